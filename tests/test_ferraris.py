"""Ferraris: closed form, exact on noise-free data, sections found automatically."""

import numpy as np
import pytest

from imucalib.methods import calibrate
from imucalib.metrics import interval_means
from imucalib.scenarios import ferraris_session
from imucalib.segment import find_faces, find_turns
from synth import linear_truth


@pytest.fixture
def truth():
    t = linear_truth()
    g = np.array([[0.02, -0.01, 0.03], [0.01, 0.02, -0.02], [0.0, 0.01, 0.015]])  # raw per m/s²
    return t.with_(gyroscope=t.gyroscope.with_(g_sensitivity=g))


def _matrix(m):
    return m.misalignment * m.scale[None, :]


def test_noise_free_recovery(truth):
    rec, iv, _ = ferraris_session(truth, 1, noise=0)
    cal = calibrate(rec, method="ferraris", gravity=truth.gravity, intervals=iv)
    np.testing.assert_allclose(_matrix(cal.accelerometer), _matrix(truth.accelerometer), rtol=1e-6,
                               atol=1e-6 * np.abs(_matrix(truth.accelerometer)).max())
    np.testing.assert_allclose(cal.accelerometer.bias, truth.accelerometer.bias, rtol=1e-6)
    np.testing.assert_allclose(_matrix(cal.gyroscope), _matrix(truth.gyroscope), rtol=1e-6,
                               atol=1e-6 * np.abs(_matrix(truth.gyroscope)).max())
    np.testing.assert_allclose(cal.gyroscope.bias, truth.gyroscope.bias, rtol=1e-6)
    # the truth has a zero entry: relative to the largest, as for the matrices above (rtol alone would ask 0 exactly)
    np.testing.assert_allclose(cal.gyroscope.g_sensitivity, truth.gyroscope.g_sensitivity, rtol=1e-6,
                               atol=1e-6 * np.abs(truth.gyroscope.g_sensitivity).max())


def test_sections_found_automatically_match_the_layout(truth):
    rec, iv, layout = ferraris_session(truth, 2)  # with default noise
    faces = find_faces(interval_means(rec.acc, iv), truth.gravity)
    names = ("+x", "+y", "+z", "-x", "-y", "-z")
    for name, k in zip(names, faces, strict=True):
        expected = layout["faces"][name]
        # +x and the pose after the turn about x are the same face: either is right
        assert k in (expected, expected + 1 if name[0] == "+" else expected)
    turns = find_turns(rec, iv, rec.gyro[iv[0].slice].mean(axis=0), float(np.mean(truth.gyroscope.scale)))
    starts = {iv_.start: k for k, iv_ in enumerate(iv)}
    for axis, name in enumerate("xyz"):
        assert len(turns[axis]) == 1
        turn = turns[axis][0]
        assert starts[turn.stop] == layout["turns"][name] and turn.sign == 1
        assert turn.matches and abs(turn.angle_deg - 360) < 18  # by one scale for all three axes
    cal = calibrate(rec, method="ferraris", gravity=truth.gravity)
    assert cal.fit["turns"] == {"x": 1, "y": 1, "z": 1}
    np.testing.assert_allclose(cal.gyroscope.scale, truth.gyroscope.scale, rtol=2e-3)


def test_missing_turn_is_named(truth):
    rec, iv, layout = ferraris_session(truth, 3)
    keep = [k for k in range(len(iv)) if k != layout["turns"]["y"]]
    with pytest.raises(ValueError, match="no turn about the y axis found"):
        calibrate(rec, method="ferraris", gravity=truth.gravity, intervals=[iv[k] for k in keep])


def test_bias_from_each_axis_pair_beats_the_mean_of_six_faces_on_hand_placed_faces():
    """Why Ferraris takes each axis's bias from its own two faces: hand-placed faces tilt by a few degrees."""
    from imucalib.fit.accelerometer import faces_full
    from imucalib.methods.ferraris import sections_from_ranges
    from imucalib.scenarios import session

    errors = {"axis": [], "mean": []}
    for seed in range(6):
        sim = session("handheld", rng=seed, procedure="ferraris", tremor=0)
        faces, _ = sections_from_ranges(sim.recording, sim.options["sections"])
        means = interval_means(sim.recording.acc, faces)
        for how, out in errors.items():
            model = faces_full(means, sim.truth.gravity, bias=how)
            out.append((model.bias - sim.truth.accelerometer.bias) * sim.truth.accelerometer.scale)  # m/s²
    rms = {how: float(np.sqrt(np.mean(np.square(e)))) for how, e in errors.items()}
    assert rms["axis"] < 0.006 and rms["mean"] > 5 * rms["axis"], rms  # measured: 0.0026 vs 0.041 m/s²
