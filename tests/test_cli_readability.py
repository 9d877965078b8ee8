"""What the terminal shows a person: rounded directions, units on every matrix, and a validation that says
when it was run on the calibration's own recording."""

from __future__ import annotations

import json
import re

import pytest

from imucalib.cli import main


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    """Two simulated hand-held sessions of different sensors, and a calibration of the first."""
    folder = tmp_path_factory.mktemp("sessions")
    for seed in (2, 3):
        assert main(["simulate", "--scenario", "handheld", "--seed", str(seed), "-o", str(folder / f"s{seed}")]) == 0
    assert main(["calibrate", str(folder / "s2"), "-o", str(folder / "cal.json")]) in (0, 3)
    return folder


def test_validate_says_when_the_recording_is_the_calibrations_own(capsys, sessions):
    own = sessions / "s2" / "recording.csv"
    code, out, err = _run(capsys, "validate", sessions / "cal.json", own, "--json")
    assert json.loads(out)["own_recording"] is True
    code, out, err = _run(capsys, "validate", sessions / "cal.json", own)
    assert "the recording the calibration was made from" in out
    code, out, err = _run(capsys, "validate", sessions / "cal.json", sessions / "s3" / "recording.csv", "--json")
    assert json.loads(out)["own_recording"] is False  # another sensor's session, in the same time base


def test_calibrate_prints_g_sensitivity_with_units_and_next_poses_rounded(capsys, sessions):
    from imucalib.calibration import Calibration
    from imucalib.cli.calibration import print_calibration

    cal = Calibration.load(sessions / "cal.json")
    cal = cal.with_(fit={**cal.fit, "next_poses": [[0.7071067811865476, 0.0, -0.7071067811865476]]})
    print_calibration(cal)
    out = capsys.readouterr().out
    assert "g-sensitivity G [counts per m/s^2]:" in out
    line = next(x for x in out.splitlines() if "next_poses" in x)
    assert "[+0.71 +0.00 -0.71]" in line and not re.search(r"\d{5}", line)


def test_a_format_sample_too_short_to_calibrate_points_to_a_session_to_try(capsys):
    from pathlib import Path

    sample = Path(__file__).resolve().parents[1] / "docs" / "examples" / "session.csv"
    code, out, err = _run(capsys, "calibrate", sample)
    assert code == 2 and "s long: too short for an initial rest" in err
    assert "`imucalib simulate -o session` writes one" in err
