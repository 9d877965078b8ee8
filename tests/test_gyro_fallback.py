"""A session whose rotations cannot calibrate the gyroscope: the accelerometer's calibration, and why.

Fast hands (no limit on the body rate, rotations of 0.15–0.25 s) saturate the gyroscope in every
rotation; those rotations are left out of the gyroscope fit as unreliable, and with none left the
methods that calibrate both sensors return the accelerometer's calibration with no gyroscope. With one
left the fit runs and its verdict rejects it (too few rotations to determine it). Other failures of the
gyroscope fit stay errors.
"""

import json
import warnings

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.io import write_csv
from imucalib.methods import calibrate
from imucalib.recording import ImucalibWarning, Interval, Recording
from imucalib.scenarios import handheld
from imucalib.segment import saturated

FAST = {"max_rate": None, "move": (0.15, 0.25), "n_poses": 20, "rest": 10.0, "hesitation": 0.0}


@pytest.fixture(scope="module")
def fast():
    """Seed 1: all 20 rotations saturate; seed 15: 19 of them. (Seed 2's one rotation left was a moment of
    tremor that cut one hold in two, which the gate now joins: all its 20 rotations saturate.)"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)  # the clipped readings, said by the simulator
        return {seed: handheld.generate(np.random.default_rng(seed), **FAST) for seed in (1, 2, 15)}


def _calibrate(rec, method):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        return calibrate(rec, method=method)


@pytest.mark.parametrize("method", ["tedaldi2014", "ellipsoid"])
def test_rotations_all_too_fast_give_the_accelerometer_alone(fast, method):
    d = fast[1]
    rec, truth = d["recording"], d["truth"]
    assert np.count_nonzero(saturated(rec.gyro)) > 100  # the hands were too fast for the gyroscope's range
    cal = _calibrate(rec, method)
    assert cal.gyroscope is None
    fit = cal.fit
    why = fit["gyroscope_not_calibrated"]
    left = fit["rotations_left_out"]
    assert len(left) == 20 and all("saturated gyroscope sample" in w for w in left.values())
    assert "all 20 rotations between poses were left out as unreliable" in why
    assert f"from pose 1 to 2: {left['0']}" in why, why
    assert any(why in n for n in fit["verdict_notes"])  # the verdict says why, and skips the gyroscope checks
    assert fit["verdict"] == "accepted", fit["verdict_reasons"]
    # the accelerometer is the one the same data give without their gyroscope columns (up to the poses' edges,
    # which the detector also finds with the gyroscope's rate: a few samples apart), and close to the truth
    alone = _calibrate(Recording(rec.t, rec.acc, None, acc_unit=rec.acc_unit), method)
    np.testing.assert_allclose(cal.accelerometer.scale, alone.accelerometer.scale, rtol=1e-4)
    np.testing.assert_allclose(cal.accelerometer.bias, alone.accelerometer.bias, atol=0.5)  # counts
    np.testing.assert_allclose(cal.accelerometer.scale, truth.accelerometer.scale, rtol=1e-3)
    np.testing.assert_allclose(cal.accelerometer.bias, truth.accelerometer.bias, atol=20)  # counts (1.2 mg)
    back = Calibration.from_dict(json.loads(cal.to_json()))  # the file reads it back
    assert back.gyroscope is None and back.fit["gyroscope_not_calibrated"] == why


@pytest.mark.parametrize("method", ["tedaldi2014", "ellipsoid"])
def test_a_tremor_inside_a_hold_is_no_rotation(fast, method):
    """Seed 2: one hold shaken for a moment is one pose, not two with a rotation of nothing between them."""
    cal = _calibrate(fast[2]["recording"], method)
    assert cal.gyroscope is None and len(cal.fit["rotations_left_out"]) == 20
    assert cal.fit["static_intervals"] == 21


@pytest.mark.parametrize("method", ["tedaldi2014", "ellipsoid"])
def test_one_rotation_left_is_fitted_and_rejected(fast, method):
    """19 of 20 rotations saturated: the fit runs on the one left, and the verdict says it cannot determine it."""
    cal = _calibrate(fast[15]["recording"], method)
    assert cal.gyroscope is not None and "gyroscope_not_calibrated" not in cal.fit
    assert len(cal.fit["rotations_left_out"]) == 19
    assert cal.fit["verdict"] == "rejected"
    assert any("the gyroscope rests on 1 of the 20 rotations" in r for r in cal.fit["verdict_reasons"])


def test_the_command_line_says_why_there_is_no_gyroscope(fast, tmp_path, capsys):
    rec = fast[1]["recording"]
    write_csv(tmp_path / "fast.csv", rec)
    code = main(["calibrate", str(tmp_path / "fast.csv"), "--method", "tedaldi2014", "-o", str(tmp_path / "c.json")])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "gyroscope: none (the gyroscope was not calibrated: all 20 rotations" in out, out
    assert Calibration.load(tmp_path / "c.json").gyroscope is None


def test_other_gyroscope_failures_stay_errors(fast):
    """A gyroscope that reads nothing is not a lack of rotations: the fit's error is raised, as before."""
    d = handheld.generate(np.random.default_rng(3), n_poses=20, rest=10.0)
    rec = d["recording"]
    dead = Recording(rec.t, rec.acc, np.zeros_like(rec.gyro), acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit)
    for method in ("tedaldi2014", "ellipsoid"):
        with pytest.raises(ValueError, match="the gyroscope does not move between the static poses"):
            _calibrate(dead, method)
    cal = _calibrate(rec, "tedaldi2014")  # the same session with its gyroscope: calibrated
    assert cal.gyroscope is not None and "gyroscope_not_calibrated" not in cal.fit


def test_what_leaves_nothing_to_fit():
    from imucalib.segment import no_usable_rotations

    poses = [Interval(10 * k, 10 * k + 5) for k in range(6)]
    assert no_usable_rotations(poses, {}) is None
    assert no_usable_rotations(poses, {k: "a gap" for k in range(4)}) is None  # one left: fitted, then judged
    why = no_usable_rotations(poses, {k: f"gap {k}" for k in (4, 1, 0, 3, 2)})
    assert "all 5 rotations between poses were left out as unreliable (the first, from pose 1 to 2: gap 0)" in why
    why = no_usable_rotations(poses[:3], {})
    assert "3 static poses found, and its calibration needs at least 4" in why
