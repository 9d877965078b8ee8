"""The command line: JSON contracts, the issue's real-data command, apply, errors."""

import json
from pathlib import Path

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.io import read, write_csv
from synth import tedaldi_session

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture
def session_csv(tmp_path):
    rec, truth, _ = tedaldi_session(seed=12, noise_acc=0.003, noise_gyro=0.002)
    path = tmp_path / "session.csv"
    write_csv(path, rec)
    return path, truth


def test_calibrate_json_and_apply(capsys, tmp_path, session_csv):
    path, truth = session_csv
    code, out, err = run(capsys, "calibrate", path, "--json", "-o", tmp_path / "c.json")
    assert code == 0, err
    doc = json.loads(out)  # stdout holds the JSON and nothing else
    assert doc["format"] == "imucalib.calibration" and doc["format_version"] == 2
    assert doc["fit"]["static_intervals"] == 25
    cal = Calibration.load(tmp_path / "c.json")
    np.testing.assert_allclose(cal.accelerometer.scale, truth.accelerometer.scale, rtol=2e-3)
    code, out, err = run(capsys, "apply", tmp_path / "c.json", path, "-o", tmp_path / "out.csv",
                         "--json")
    assert code == 0, err
    summary = json.loads(out)
    rec = read(path)
    assert summary["samples"] == len(rec)
    back = read(tmp_path / "out.csv")
    assert len(back) == len(rec)
    np.testing.assert_allclose(back.acc, rec.acc, rtol=1e-9)  # raw columns unchanged
    acc_cal = np.column_stack([back.extra[f"acc_{a}_cal [m/s^2]"] for a in "xyz"])
    np.testing.assert_allclose(acc_cal, cal.apply(rec).acc, rtol=1e-8)


def test_errors_go_to_stderr_with_nonzero_exit(capsys, tmp_path, session_csv):
    path, _ = session_csv
    code, out, err = run(capsys, "calibrate", tmp_path / "missing.csv", "--json")
    assert code == 2 and out == ""
    assert "missing.csv: file not found" in err
    code, out, err = run(capsys, "calibrate", path, "--method", "nope", "--json")
    assert code == 2 and "unknown method 'nope'" in err
    (tmp_path / "bad.json").write_text("{}")
    code, out, err = run(capsys, "apply", tmp_path / "bad.json", path, "-o", tmp_path / "o.csv")
    assert code == 2 and "not an imucalib calibration" in err
    (tmp_path / "bare.json").write_text('{"format": "imucalib.calibration", "format_version": 1}')
    code, out, err = run(capsys, "apply", tmp_path / "bare.json", path, "-o", tmp_path / "o.csv")
    assert code == 2 and "lacks the accelerometer and gyroscope section(s)" in err


def test_issue_command_on_xsens_matches_imu_tk(capsys):
    if not DATA.is_dir():
        pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): real-data test skipped")
    code, out, err = run(capsys, "calibrate", DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat",
                         "--reader", "imutk", "--method", "tedaldi2014", "--gravity", "9.81744",
                         "--json")
    assert code == 0, err
    doc = json.loads(out)
    fit = doc["fit"]
    assert 37 <= fit["static_intervals"] <= 39
    assert fit["accelerometer_residual_rms"] <= 0.00112
    assert fit["gyroscope_angle_error_mean_deg"] <= 0.481
    ta = np.array(doc["accelerometer"]["misalignment"])
    np.testing.assert_allclose(ta, [[1, -0.0033593, -0.00890639], [0, 1, -0.0213341], [0, 0, 1]],
                               atol=1e-3)
    np.testing.assert_allclose(doc["accelerometer"]["scale"], [0.00241278, 0.00242712, 0.00241168],
                               rtol=2e-3)
    np.testing.assert_allclose(doc["accelerometer"]["bias"], [33124.2, 33275.2, 32364.4], atol=10)
    np.testing.assert_allclose(doc["gyroscope"]["scale"], [2.09295e-4, 2.09899e-4, 2.09483e-4],
                               rtol=5e-3)
    np.testing.assert_allclose(
        doc["gyroscope"]["misalignment"],
        [[1, 0.00593634, 0.00111101], [0.00808812, 1, -0.0535569], [0.0253067, -0.0025513, 1]],
        atol=2e-3)


@pytest.mark.slow
def test_reproduce_zhang2021_simulate_detect_fall(capsys, tmp_path):
    code, out, err = run(capsys, "reproduce", "zhang2021", "--json")
    assert code == 0, err
    demo = json.loads(out)
    k = {r["name"]: r for r in demo["parameters"]}["accelerometer.scale.x"]
    assert abs(k["all"] - k["truth"]) < 1e-3 < abs(k["linear"] - k["truth"])
    assert demo["metrics"]["all_vs_tedaldi2014_eq34_reduction"] >= 0.6412
    assert demo["metrics"]["all_vs_tedaldi2014_eq35_reduction"] >= 0.4790
    code, out, err = run(capsys, "simulate", "--seed", "4", "-o", tmp_path / "s", "--json")
    assert code == 0 and json.loads(out)["weightless"] == 100
    code, out, err = run(capsys, "calibrate", tmp_path / "s", "--method", "zhang2021", "--model", "all",
                         "-o", tmp_path / "cal.json", "--json")
    assert code == 0, err
    cal = Calibration.load(tmp_path / "cal.json")
    np.testing.assert_allclose(cal.lever_arm, [0.07, 0.07, 0.07], atol=1e-4)
    # the first test toss of the session, as CSV, through detect-fall
    from imucalib.scenarios import read_session

    toss = read_session(tmp_path / "s").tests[0]
    write_csv(tmp_path / "toss.csv", toss.recording)
    code, out, err = run(capsys, "detect-fall", tmp_path / "cal.json", tmp_path / "toss.csv",
                         "--acc-unit", "g", "--json")
    assert code == 0, err
    falls = json.loads(out)["falls"]
    spin = next(s for s in toss.segments if s.kind == "weightless")
    assert len(falls) == 1
    assert abs(falls[0]["start"] - spin.start) <= 3 and abs(falls[0]["stop"] - spin.stop) <= 3


def test_plot_of_the_fit(capsys, tmp_path, session_csv):
    pytest.importorskip("matplotlib", reason="plots need matplotlib (the plot extra)")
    import matplotlib.image as mpimg

    path, _ = session_csv
    code, out, err = run(capsys, "calibrate", path, "--plot", tmp_path / "fit.png", "-o", tmp_path / "c.json")
    assert code == 0, err
    img = mpimg.imread(tmp_path / "fit.png")
    assert img.shape[0] > 600 and img.shape[1] > 800  # a three-panel figure
    cal = Calibration.load(tmp_path / "c.json")
    assert len(cal.fit["intervals"]) == cal.fit["static_intervals"] == 25


def test_noise_command_on_xsens(capsys):
    if not DATA.is_dir():
        pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): real-data test skipped")
    code, out, err = run(capsys, "noise", DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat", "--reader",
                         "imutk", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert 50 < doc["seconds"] < 53  # the ~51.5 s initial rest
    rec = read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk")
    std = rec.acc[: doc["samples"]].std(axis=0)
    # per-sample white noise from the Allan deviation ≈ the rest's standard deviation
    np.testing.assert_allclose(doc["accelerometer"]["white_noise_per_sample"], std, rtol=0.3)


def test_noise_plot(capsys, tmp_path, session_csv):
    pytest.importorskip("matplotlib", reason="plots need matplotlib (the plot extra)")
    import matplotlib.image as mpimg

    path, _ = session_csv
    code, out, err = run(capsys, "noise", path, "--plot", tmp_path / "allan.png")
    assert code == 0, err
    assert "plot written to" in out and "white noise" in out
    img = mpimg.imread(tmp_path / "allan.png")
    assert img.shape[1] > 1000  # two panels side by side


def test_every_method_accepts_a_progress_callback():
    from imucalib.methods import calibrate
    from imucalib.scenarios import qureshi_session

    rec, iv, truth = qureshi_session(1)
    seen = []
    for method in ("tedaldi2014", "ellipsoid", "qureshi2017"):
        cal = calibrate(rec, method=method, gravity=truth.gravity, progress=seen.append)
        assert cal.method == method
    assert "detecting static intervals" in seen  # tedaldi2014 reports its stages


def test_validate_on_a_second_recording(capsys, tmp_path, session_csv):
    path, truth = session_csv
    code, _, err = run(capsys, "calibrate", path, "-o", tmp_path / "c.json", "--json")
    assert code == 0, err
    rec2, _, _ = tedaldi_session(truth, seed=13, noise_acc=0.003, noise_gyro=0.002)  # same sensor, new poses
    write_csv(tmp_path / "second.csv", rec2)
    code, out, err = run(capsys, "validate", tmp_path / "c.json", tmp_path / "second.csv", "--json")
    assert code == 0, err
    good = json.loads(out)
    then = good["at_calibration"]
    assert good["static_intervals"] >= 20
    assert good["verdict"] == "accepted", good["verdict_reasons"]
    assert good["accelerometer_residual_rms"] < 2 * then["accelerometer_residual_rms"]
    assert good["gyroscope_angle_error_mean_deg"] < 2 * then["gyroscope_angle_error_mean_deg"]
    # a calibration 1 % off in one accelerometer scale shows on the new recording
    cal = Calibration.load(tmp_path / "c.json")
    bad = cal.with_(accelerometer=cal.accelerometer.with_(scale=cal.accelerometer.scale * [1.01, 1, 1]))
    bad.save(tmp_path / "bad.json")
    code, out, err = run(capsys, "validate", tmp_path / "bad.json", tmp_path / "second.csv")
    assert code == 3, err  # it no longer holds
    assert out.startswith("verdict: REJECTED — the calibration does not hold")
    assert "not refitted" in out and "at calibration" in out and "noise floor" in out
    code, out, err = run(capsys, "validate", tmp_path / "bad.json", tmp_path / "second.csv", "--json")
    assert code == 3 and json.loads(out)["verdict"] == "rejected"
    assert json.loads(out)["accelerometer_residual_rms"] > 10 * good["accelerometer_residual_rms"]
    # units must match
    rec2.acc_unit = "g"
    write_csv(tmp_path / "g.csv", rec2)
    code, out, err = run(capsys, "validate", tmp_path / "c.json", tmp_path / "g.csv")
    assert code == 2 and "maps accelerometer readings in 'counts'" in err


def test_html_report(capsys, tmp_path, session_csv):
    path, _ = session_csv
    code, out, err = run(capsys, "calibrate", path, "--report", tmp_path / "r.html")
    assert code == 0, err
    page = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert page.startswith("<!DOCTYPE html>") and "report written to" in out
    assert "accelerometer.scale.x" in page and "± 1σ" in page and "scale_cubic" not in page
    assert page.count("<tr>") >= 18 + 4
    if __import__("importlib").util.find_spec("matplotlib"):
        assert "data:image/png;base64," in page  # the fit figure, embedded


def test_pose_coverage_flags_a_missing_orientation():
    from imucalib.methods import calibrate

    rng = np.random.default_rng(4)
    d = rng.normal(size=(30, 3))
    d[:, 0] = np.abs(d[:, 0])  # the x axis never points down
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rec, truth, iv = tedaldi_session(seed=4, directions=d, noise_acc=0.02, noise_gyro=0.003)
    cal = calibrate(rec, method="tedaldi2014", gravity=truth.gravity, intervals=iv)
    flags = cal.fit["quality_flags"]
    assert len(flags) == 1 and "x axis within 60° of down" in flags[0]
    assert cal.fit["pose_coverage"]["x"][0] > -0.2
    rec, truth, iv = tedaldi_session(seed=5, noise_acc=0.02, noise_gyro=0.003, poses=30)
    cal = calibrate(rec, method="tedaldi2014", gravity=truth.gravity, intervals=iv)
    assert "quality_flags" not in cal.fit and cal.fit["pose_coverage"]["z"][1] > 0.5


def test_temperature_is_recorded_and_compared(capsys, tmp_path):
    rec, truth, _ = tedaldi_session(seed=12, noise_acc=0.003, noise_gyro=0.002)
    rec.temperature = np.linspace(24.0, 26.0, len(rec))
    write_csv(tmp_path / "warm.csv", rec)
    code, out, err = run(capsys, "calibrate", tmp_path / "warm.csv", "-o", tmp_path / "c.json", "--report",
                         tmp_path / "r.html")
    assert code == 0, err
    cal = Calibration.load(tmp_path / "c.json")
    np.testing.assert_allclose(cal.fit["temperature_c"], [24.0, 25.0, 26.0], atol=1e-6)
    assert "temperature min / mean / max" in (tmp_path / "r.html").read_text(encoding="utf-8")
    rec.temperature = rec.temperature + 15.0
    write_csv(tmp_path / "hot.csv", rec)
    code, out, err = run(capsys, "validate", tmp_path / "c.json", tmp_path / "hot.csv")
    assert code == 0, err
    assert "temperature 40.0 °C (at calibration 25.0 °C)" in out and "biases may have drifted" in out


def test_a_gap_inside_a_rotation_is_flagged():
    from imucalib.methods import calibrate
    from imucalib.recording import Interval, Recording

    rec, truth, iv = tedaldi_session(seed=6, noise_acc=0.02, noise_gyro=0.003, poses=30)
    a, b = iv[4].stop, iv[5].start  # the rotation from pose 5 to pose 6
    drop = np.arange(a + 20, a + 40)  # 0.2 s of samples lost mid-rotation
    keep = np.setdiff1d(np.arange(len(rec)), drop)
    gappy = Recording(rec.t[keep], rec.acc[keep], rec.gyro[keep], acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit)
    shift = np.searchsorted(keep, [[i.start, i.stop] for i in iv])
    iv2 = [Interval(int(s), int(e)) for s, e in shift]
    cal = calibrate(gappy, method="tedaldi2014", gravity=truth.gravity, intervals=iv2)
    flags = cal.fit["quality_flags"]
    assert len(flags) == 1 and "from pose 5 to 6 has 1 sampling gap" in flags[0] and "0.21 s" in flags[0]
    assert b > a
