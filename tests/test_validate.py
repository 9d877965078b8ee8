"""validate on short recordings: poses found without fitting, a verdict, exit 3 when the calibration no longer holds."""

import json
import re

import numpy as np
import pytest

from imucalib.cli import build_parser, main
from imucalib.io import write_csv
from imucalib.scenarios import pose_session
from imucalib.validation import validate
from imucalib.verdict import assess
from synth import linear_truth


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def gyro_off(cal, factor=1.5):
    """``cal`` with every gyroscope scale factor ``factor`` times too large."""
    return cal.with_(gyroscope=cal.gyroscope.with_(scale=cal.gyroscope.scale * factor))


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    """A rest of 5 s, one 90° turn about x, a pose held 2 s: two poses; the true and a 1.5×-off calibration."""
    truth = linear_truth()
    rec, _ = pose_session(truth, [([1.0, 0.0, 0.0], np.pi / 2)], rng=4, rest=5, hold=2)
    d = tmp_path_factory.mktemp("short")
    write_csv(d / "short.csv", rec)
    truth.save(d / "truth.json")
    gyro_off(truth).save(d / "off.json")
    return rec, truth, d


def test_short_recording_holds_with_the_true_calibration(capsys, short):
    rec, truth, d = short
    result = validate(truth, rec)
    assert result["verdict"] == "accepted", result["verdict_reasons"]
    assert result["static_intervals"] == 2 and len(result["intervals"]) == 2
    assert result["gyroscope_angle_error_mean_deg"] < 0.05
    assert result["gyroscope_error_to_noise"] < 3 and result["accelerometer_residual_to_noise"] < 3
    code, out, err = run(capsys, "validate", d / "truth.json", d / "short.csv")
    assert code == 0, err
    assert out.splitlines()[0] == "verdict: ACCEPTED — the calibration holds on this recording"
    assert "2 static poses" in out and "noise alone predicts" in out


def test_short_recording_rejects_a_gyroscope_scale_off_by_half(capsys, short):
    rec, truth, d = short
    result = validate(gyro_off(truth), rec)
    assert result["verdict"] == "rejected"
    # a 90° turn measured as 135°: 45° off, thousands of times what the noise predicts
    assert result["gyroscope_angle_error_mean_deg"] == pytest.approx(45, abs=1)
    assert result["gyroscope_error_to_noise"] > 1000
    assert any("gyroscope" in r for r in result["verdict_reasons"])
    code, out, err = run(capsys, "validate", d / "off.json", d / "short.csv")
    assert code == 3
    lines = out.splitlines()
    assert lines[0] == "verdict: REJECTED — the calibration does not hold on this recording"
    assert lines[1].startswith("  - the gyroscope's gravity-direction error")
    code, out, err = run(capsys, "validate", d / "off.json", d / "short.csv", "--json")
    assert code == 3
    doc = json.loads(out)
    assert doc["verdict"] == "rejected" and doc["verdict_reasons"] == result["verdict_reasons"]


def test_a_turn_about_the_vertical_gives_two_poses(short):
    """The accelerometer sees one long rest; the gyroscope gate, with the calibration's scale, cuts it in two."""
    truth = short[1]
    rec, _ = pose_session(truth, [([0.0, 0.0, 1.0], np.pi / 2)], rng=5, rest=5, hold=2)
    result = validate(truth, rec)
    assert result["static_intervals"] == 2
    assert result["verdict"] == "accepted", result["verdict_reasons"]


def test_a_calibration_made_from_a_session_holds_on_a_short_recording(capsys, short, tmp_path):
    from synth import tedaldi_session

    rec, truth, d = short
    session, _, _ = tedaldi_session(truth, seed=12, noise_acc=0.003, noise_gyro=0.002)
    write_csv(tmp_path / "session.csv", session)
    assert main(["calibrate", str(tmp_path / "session.csv"), "-o", str(tmp_path / "c.json"), "--json"]) == 0
    capsys.readouterr()
    code, out, err = run(capsys, "validate", tmp_path / "c.json", d / "short.csv", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["verdict"] == "accepted", doc["verdict_reasons"]
    then = doc["at_calibration"]
    assert then["static_intervals"] == 25
    assert doc["ratios"]["accelerometer_residual_rms"] == pytest.approx(
        doc["accelerometer_residual_rms"] / then["accelerometer_residual_rms"])


def test_too_few_poses_names_only_options_validate_has(capsys, short, tmp_path):
    truth = short[1]
    rec, _ = pose_session(truth, [], rng=6, rest=6)  # a rest and nothing else
    write_csv(tmp_path / "rest.csv", rec)
    truth.save(tmp_path / "truth.json")
    code, out, err = run(capsys, "validate", tmp_path / "truth.json", tmp_path / "rest.csv")
    assert code == 2 and out == ""
    assert "1 static pose(s) found" in err and "--init-static" in err
    sub = next(a for a in build_parser()._actions if a.dest == "command").choices["validate"]
    options = {o for a in sub._actions for o in a.option_strings}
    assert set(re.findall(r"--[a-z][a-z-]*", err)) <= options, err


def test_validate_reads_as_calibrate_does():
    parsers = next(a for a in build_parser()._actions if a.dest == "command").choices
    calibrate = {o for a in parsers["calibrate"]._actions for o in a.option_strings}
    validate_ = {o for a in parsers["validate"]._actions for o in a.option_strings}
    reading = {"--reader", "--topic", "--columns", "--acc-unit", "--gyro-unit", "--time-unit", "--rate",
               "--variable", "--init-static", "--gravity"}
    assert reading <= calibrate and reading <= validate_


def test_init_static(capsys, short):
    _, _, d = short
    code, out, err = run(capsys, "validate", d / "truth.json", d / "short.csv", "--init-static", 4, "--json")
    assert code == 0, err
    assert json.loads(out)["verdict"] == "accepted"
    code, out, err = run(capsys, "validate", d / "truth.json", d / "short.csv", "--init-static", 100)
    assert code == 2 and "--init-static 100" in err


def test_handheld_truth_holds(capsys, tmp_path):
    assert main(["simulate", "--scenario", "handheld", "--seed", "3", "-o", str(tmp_path / "s")]) == 0
    capsys.readouterr()
    code, out, err = run(capsys, "validate", tmp_path / "s" / "truth.json", tmp_path / "s", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["verdict"] == "accepted", doc["verdict_reasons"]
    assert doc["static_intervals"] >= 25
    assert doc["accelerometer_residual_to_noise"] < 3 and doc["gyroscope_error_to_noise"] < 10


def test_assess_for_validation_skips_the_checks_of_the_fit_itself():
    truth = linear_truth()
    rec, poses = pose_session(truth, [([1.0, 0.0, 0.0], np.pi / 2)], rng=4, rest=5, hold=2)
    from imucalib.metrics import fit_summary

    fit = fit_summary(truth, rec, poses)
    made = assess(truth.with_(fit=fit), rec, poses)  # as if it had been fitted to two poses
    assert made["verdict"] == "rejected" and any("poses for" in r for r in made["verdict_reasons"])
    checked = assess(truth.with_(fit=fit), rec, poses, purpose="validate")
    assert checked["verdict"] == "accepted", checked["verdict_reasons"]
    # the residual against the noise floor still counts
    high = assess(truth.with_(fit={**fit, "accelerometer_residual_to_noise": 100.0}), rec, poses, purpose="validate")
    assert high["verdict"] == "rejected" and any("white-noise floor" in r for r in high["verdict_reasons"])
    with pytest.raises(ValueError, match="purpose"):
        assess(truth, purpose="nope")


def test_headlines_say_what_the_verdict_says():
    """Each headline names its verdict and says the same thing in words: 'holds' only when accepted, 'does not
    hold' only when rejected."""
    from imucalib.cli.validation import HEADLINES

    for verdict, text in HEADLINES.items():
        assert text.startswith(f"verdict: {verdict.upper()} — ")
        assert ("does not hold" in text) == (verdict == "rejected")
        assert ("may not hold" in text) == (verdict == "suspect")
        assert (text.endswith("holds on this recording")) == (verdict == "accepted")
