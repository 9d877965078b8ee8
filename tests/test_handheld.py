"""The hand-held scenario: exact geometry when clean, the nuisances where they are said to be, files."""

import math

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.kinematics import angle_between
from imucalib.metrics import gravity_direction_errors, gravity_residuals
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import SCENARIOS, read_session, session, table1_truth, write_session
from imucalib.scenarios.handheld import CLEAN, COUNTS_RANGE, consumer_truth, datasheet_noise

G = 9.80665


def _static(sim):
    return [s for s in sim.segments if s.kind == "static"]


def _turned(w, t, start, stop):
    """Trapezoidal integral [deg] of the rate (N, 3) [rad/s] over samples start…stop−1."""
    return np.degrees(np.sum(0.5 * (w[start + 1:stop] + w[start:stop - 1]) * np.diff(t[start:stop])[:, None], axis=0))


@pytest.fixture(scope="module")
def default():
    return {seed: session("handheld", rng=seed) for seed in (1, 2, 3)}


@pytest.fixture(scope="module")
def ferraris():
    return session("handheld", rng=4, procedure="ferraris", nudge_deg=13.0)


def test_registered_and_deterministic():
    assert "handheld" in SCENARIOS
    a = session("handheld", rng=11, n_poses=5)
    b = session("handheld", rng=11, n_poses=5)
    c = session("handheld", rng=12, n_poses=5)
    np.testing.assert_array_equal(a.recording.t, b.recording.t)
    np.testing.assert_array_equal(a.recording.acc, b.recording.acc)
    np.testing.assert_array_equal(a.recording.gyro, b.recording.gyro)
    assert a.segments == b.segments and a.options == b.options
    assert a.truth.parameters() == b.truth.parameters()
    assert len(a.recording) != len(c.recording) or not np.array_equal(a.recording.acc, c.recording.acc)


@pytest.mark.parametrize("procedure", ["poses", "ferraris"])
def test_clean_session_is_exact(procedure):
    sim = session("handheld", rng=5, noise=0, procedure=procedure, **CLEAN)
    rec, truth, static = sim.recording, sim.truth, _static(sim)
    assert sim.options["dropped"] == 0 and not sim.options["creep_sections"]
    a = truth.accelerometer_si(rec.acc)
    for iv in static:  # every sample of every hold, not only the means
        np.testing.assert_allclose(np.linalg.norm(a[iv.slice], axis=1), truth.gravity, rtol=0, atol=1e-9)
    assert np.max(np.abs(gravity_residuals(truth, rec, static))) < 1e-9
    err = np.degrees(gravity_direction_errors(truth, rec, static))
    assert len(err) == len(static) - 1 and np.max(err) < 0.01
    np.testing.assert_allclose(np.diff(rec.t), 1 / 100, rtol=0, atol=1e-12)  # no jitter, no drops


def test_layout_alternates_and_covers_the_recording(default):
    for sim in default.values():
        segs = sim.segments
        assert segs[0].start == 0 and segs[-1].stop == len(sim.recording)
        assert all(p.stop == n.start for p, n in zip(segs[:-1], segs[1:], strict=True))
        assert all(p.kind != n.kind for p, n in zip(segs[:-1], segs[1:], strict=True))
        static = _static(sim)
        assert len(static) == sim.options["n_poses"] + 1 == sim.options["static_poses"]
        assert len(static[0]) > 0.95 * 30 * 100  # the initial rest, less dropped samples
        for c in sim.options["creep_sections"]:  # creep lies at the start of its hold
            iv = static[c["static"]]
            assert iv.start <= c["range"][0] < c["range"][1] <= iv.stop and c["range"][0] - iv.start < 3


def test_default_noise_floor_of_the_true_calibration(default):
    """Tremor, drift and noise leave < 0.3° between poses; the ~1° creep shows where it is."""
    for sim in default.values():
        err = np.degrees(gravity_direction_errors(sim.truth, sim.recording, _static(sim)))
        creep = {c["static"] for c in sim.options["creep_sections"]}
        assert len(creep) == 2
        into = np.array([k in creep for k in range(1, len(err) + 1)])
        after = np.array([k - 1 in creep for k in range(1, len(err) + 1)])
        assert np.mean(err) < 0.3
        assert np.max(err[~into & ~after]) < 0.3
        assert np.min(err[into]) > 0.5  # the hold's mean is the settled pose, not where the motion ended


def test_default_noise_is_the_datasheet_density():
    sim = session("handheld", rng=1, n_poses=2, rate=200.0)
    assert sim.noise["accelerometer"] == pytest.approx(400e-6 * G * math.sqrt(100.0), rel=1e-12)
    assert sim.noise["gyroscope"] == pytest.approx(math.radians(0.005) * math.sqrt(100.0), rel=1e-12)
    assert datasheet_noise(200.0) == sim.noise


def test_readings_are_integer_counts_and_timestamps_milliseconds(default):
    rec = default[1].recording
    for arr in (rec.acc, rec.gyro):
        np.testing.assert_array_equal(arr, np.round(arr))
        assert COUNTS_RANGE[0] <= arr.min() and arr.max() <= COUNTS_RANGE[1]
    np.testing.assert_allclose(rec.t * 1000, np.round(rec.t * 1000), rtol=0, atol=1e-6)
    dt = np.diff(rec.t)
    assert np.all(dt > 0) and np.any(np.abs(dt - 0.01) > 5e-4)  # jittered
    raw = session("handheld", rng=1, n_poses=2, quantise=False).recording
    assert np.mean(raw.acc != np.round(raw.acc)) > 0.9


def test_saturation_clips_at_full_scale():
    with pytest.warns(ImucalibWarning, match="gyroscope values beyond"):
        sim = session("handheld", rng=6, n_poses=8, max_rate=None, move=(0.3, 0.5))
    gyro = sim.recording.gyro
    assert sim.options["clipped"]["gyroscope"] > 0 and sim.options["clipped"]["accelerometer"] == 0
    assert gyro.max() == COUNTS_RANGE[1] or gyro.min() == COUNTS_RANGE[0]
    assert COUNTS_RANGE[0] <= gyro.min() and gyro.max() <= COUNTS_RANGE[1]
    assert sim.options["rate_max_deg_s"] > 260


def test_a_truth_in_other_units_runs_without_counts():
    sim = session("handheld", rng=2, n_poses=3, truth=table1_truth(), quantise=False, full_scale=None)
    assert sim.recording.acc_unit == "g" and sim.options["truth"] == "given"
    assert sim.truth.accelerometer.parameters("a") == table1_truth().accelerometer.parameters("a")


def test_dropped_samples_match_the_options():
    sim = session("handheld", rng=8, n_poses=10, drop=0.02, gap=0.5, jitter=0.0, resolution=0.0)
    o, t = sim.options, sim.recording.t
    assert o["dropped"] == o["samples_simulated"] - len(t) == round(0.02 * o["samples_simulated"]) + 50
    missing = np.round(np.diff(t) * 100).astype(int) - 1  # no jitter: each missing sample is a 10 ms hole
    assert missing.sum() == o["dropped"]
    assert missing.max() >= 50  # the gap
    gap0 = np.argmax(missing)
    assert t[gap0] < o["gap_s"][0] and t[gap0 + 1] > o["gap_s"][1]


def test_turn_about_the_vertical_is_invisible_to_the_accelerometer(default):
    checked = 0
    for sim in default.values():
        rec, truth, static = sim.recording, sim.truth, _static(sim)
        creep = {c["static"] for c in sim.options["creep_sections"]}
        a = truth.accelerometer_si(rec.acc)
        w = truth.gyroscope_si(rec.gyro, rec.acc)
        for v in sim.options["vertical_turns"]:
            before, after = v["static_before"], v["static_after"]
            if before in creep or after in creep:
                continue
            moved = np.degrees(angle_between(a[static[before].slice].mean(0), a[static[after].slice].mean(0)))
            m0, m1 = v["motion"]
            turned = np.linalg.norm(_turned(w, rec.t, m0 - 1, m1 + 1))
            assert moved < 0.5 and turned > 30
            assert turned == pytest.approx(abs(v["angle_deg"]), abs=1.0)
            checked += 1
    assert checked >= 10


def test_ferraris_sections(ferraris):
    rec, truth, o = ferraris.recording, ferraris.truth, ferraris.options
    sec = o["sections"]
    assert set(sec) == {f"{a}_{s}" for a in "xyz" for s in ("p", "a", "rot")}
    assert o["face_order"][0] == "z_p" and sorted(o["face_order"]) == sorted(n for n in sec if "rot" not in n)
    static = {(s.start, s.stop) for s in _static(ferraris)}
    a = truth.accelerometer_si(rec.acc)
    w = truth.gyroscope_si(rec.gyro, rec.acc)
    for i, axis in enumerate("xyz"):
        for suffix, sign in (("p", 1.0), ("a", -1.0)):
            s0, s1 = sec[f"{axis}_{suffix}"]
            assert (s0, s1) in static and s1 - s0 > 4.5 * 100
            assert np.degrees(angle_between(a[s0:s1].mean(0), sign * np.eye(3)[i])) < 5
        phi = _turned(w, rec.t, *sec[f"{axis}_rot"])
        assert phi[i] * o["turn_signs"][axis] == pytest.approx(360.0, abs=1.0)
        assert np.linalg.norm(np.delete(phi, i)) < 2.0
    # four quarter-turns with three pauses between them, each turn in a motion segment
    for axis in "xyz":
        s0, s1 = sec[f"{axis}_rot"]
        inner = [p for p in o["pauses"] if s0 < p[0] and p[1] < s1]
        assert len(inner) == 3
        assert any(m.start <= s0 and s1 <= m.stop for m in ferraris.segments if m.kind == "motion")


def test_quarter_pause_knob_separates_quarter_turns():
    sim = session("handheld", rng=4, procedure="ferraris", quarter_pause=2.0, **{**CLEAN, "tremor": 0.15})
    sec = sim.options["sections"]
    for axis in "xyz":
        s0, s1 = sec[f"{axis}_rot"]
        inner = [p for p in sim.options["pauses"] if s0 < p[0] and p[1] < s1]
        assert [p[1] - p[0] for p in inner] == [200, 200, 200]


def test_files_round_trip(ferraris, tmp_path):
    write_session(ferraris, tmp_path)
    back = read_session(tmp_path)
    truth = Calibration.load(tmp_path / "truth.json")
    assert truth.parameters() == ferraris.truth.parameters()
    assert truth.units == ferraris.truth.units and truth.method == "truth"
    assert back.scenario == "handheld" and back.seed == 4
    assert back.segments == ferraris.segments and back.options == ferraris.options and back.noise == ferraris.noise
    np.testing.assert_array_equal(back.recording.t, ferraris.recording.t)
    np.testing.assert_array_equal(back.recording.acc, ferraris.recording.acc)
    np.testing.assert_array_equal(back.recording.gyro, ferraris.recording.gyro)


def test_turn_on_offset_and_drift_are_recorded():
    sim = session("handheld", rng=9, n_poses=4, gyro_drift=0.1)
    o = sim.options
    np.testing.assert_allclose(sim.truth.gyroscope.bias, np.add(o["gyro_bias_nominal"], o["gyro_turn_on_offset"]))
    minutes = o["duration_s"] / 60
    drift = np.subtract(o["gyro_bias_end"], sim.truth.gyroscope.bias)
    np.testing.assert_allclose(drift, np.multiply(o["gyro_drift_counts_per_min"], minutes), atol=2.0)
    off = session("handheld", rng=9, n_poses=4, turn_on=0.0)
    assert off.options["gyro_turn_on_offset"] == [0.0, 0.0, 0.0]


def test_consumer_truth_within_datasheet_tolerances():
    for seed in range(5):
        t = consumer_truth(seed)
        np.testing.assert_allclose(t.accelerometer.scale, G / 16384, rtol=0.03)
        np.testing.assert_allclose(t.gyroscope.scale, math.radians(1) / 131, rtol=0.03)
        assert np.all(np.abs(t.accelerometer.bias) <= 0.04 * 16384)
        assert np.all(np.abs(t.gyroscope.bias) <= 80)
        assert np.max(np.abs(t.gyroscope.g_sensitivity)) <= 0.1 * 131 / G
        assert t.accelerometer.is_linear and t.gyroscope.is_linear and t.model == "linear"
        assert t.units["accelerometer"]["raw"] == t.units["gyroscope"]["raw"] == "counts"
    assert consumer_truth().parameters() == consumer_truth().parameters()


@pytest.mark.parametrize(("knobs", "match"), [
    ({"procedure": "tedaldi"}, "procedure must be"),
    ({"jitter": 0.006}, "less than half a sample period"),
    ({"dwell": (5.0, 2.0)}, "dwell must be"),
    ({"hesitation": 1.5}, "hesitation is a probability"),
    ({"creep": -1}, "creep must be"),
    ({"truth": table1_truth()}, "quantise and full_scale work in integer counts"),
])
def test_bad_knobs_are_named(knobs, match):
    with pytest.raises(ValueError, match=match):
        session("handheld", rng=1, **knobs)
