"""``imucalib demo`` tells the main job's story on a simulated sensor and writes its files where asked;
``imucalib reproduce zhang2021`` holds the paper's comparison."""

from __future__ import annotations

import json

from imucalib.calibration import Calibration
from imucalib.cli import main


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_demo_calibrates_applies_and_checks_against_the_truth(capsys, tmp_path):
    folder = tmp_path / "here"
    code, out, err = _run(capsys, "demo", "-o", folder)
    assert code == 0, err
    lines = out.splitlines()
    assert len(lines) <= 25, out
    assert "ACCEPTED" in out and "tedaldi2014" in out
    assert lines[-3:] == ["  imucalib calibrate my_session.csv -o calib.json --report report.html",
                          "  imucalib apply calib.json my_session.csv -o my_session_calibrated.csv",
                          "  imucalib validate calib.json another_session.csv"]
    assert "eq. (34)" not in out and "paper" not in out
    for name in ("session/recording.csv", "session/truth.json", "calib.json", "calibrated.csv", "report.html"):
        assert (folder / name).is_file(), name
        assert str(folder / name.split("/")[0]) in out
    cal = Calibration.load(folder / "calib.json")
    assert cal.fit["verdict"] == "accepted"
    header = (folder / "calibrated.csv").read_text().splitlines()[0]
    assert "acc_x_cal [m/s^2]" in header and "gyro_z_cal [rad/s]" in header
    # the figures, against the truth the session was simulated from
    code, out, err = _run(capsys, "demo", "-o", folder, "--json")
    assert code == 2 and "--force" in err and not out  # its files are there: refused, nothing replaced
    code, out, err = _run(capsys, "demo", "-o", folder, "--json", "--force")
    assert code == 0, err
    r = json.loads(out)
    before, after, truth = r["before"], r["after"], r["truth"]
    assert after["accelerometer_mg"] < 1.0 < 20 < before["accelerometer_mg"]  # MPU-6050 zero-g offsets: tens of mg
    assert after["gyroscope_dps"] < 0.05 < 0.3 < before["gyroscope_dps"]
    assert after["angle_deg"] <= 1.5 * truth["angle_deg"] < before["angle_deg"] / 10
    assert truth["accelerometer_mg"] == 0 and truth["gyroscope_dps"] == 0


def test_the_demo_help_explains_its_options(capsys):
    try:
        main(["demo", "--help"])
    except SystemExit as exc:
        assert exc.code == 0
    out = capsys.readouterr().out
    for option in ("--seed", "-o FOLDER, --output FOLDER", "--force", "--json"):
        assert option in out
    assert "calib.json" in out and "report.html" in out and "truth" in out


def test_reproduce_zhang2021_says_why_its_figures_differ_from_the_papers(capsys):
    code, out, err = _run(capsys, "reproduce", "zhang2021")
    assert code == 0, err
    assert "paper: 64.12 %, 47.90 %" in out
    assert "differ from the paper's because" in out
    assert "linear: the linear model's estimate" in out
