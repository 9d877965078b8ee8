"""The command line for calibrations that follow temperature and for the magnetometer."""

import json
import warnings

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import handheld, session, write_session

STEADY = {"turn_on": 0.0, "gyro_drift": 0.0, "gyro_rw": 0.0}


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    d = tmp_path_factory.mktemp("thermal")
    rng = np.random.default_rng(0)
    sensor = handheld.consumer_truth(rng)
    coeffs = handheld.datasheet_thermal(rng, sensor)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        for i, temp in enumerate((10, 25, 40, 32)):
            write_session(session("handheld", rng=10 + i, truth=sensor, thermal=coeffs, temperature=temp, **STEADY),
                          d / f"s{temp}")
    return d


def test_thermal_command_combines_and_validate_follows_it(sessions, capsys):
    d = sessions
    for temp in (10, 25, 40):
        assert main(["calibrate", str(d / f"s{temp}"), "--method", "tedaldi2014", "-o", str(d / f"c{temp}.json"),
                     "--json"]) == 0
    capsys.readouterr()
    assert main(["thermal", *(str(d / f"c{t}.json") for t in (10, 25, 40)), "-o", str(d / "th.json"),
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["range_c"] == pytest.approx([10.0, 40.0], abs=0.05)
    assert out["decisions"]["gyroscope.bias.z"]["order"] == 1
    assert Calibration.load(d / "th.json").thermal is not None
    assert main(["validate", str(d / "th.json"), str(d / "s32"), "--json"]) == 0
    thermal = json.loads(capsys.readouterr().out)
    assert main(["validate", str(d / "c25.json"), str(d / "s32"), "--json"]) in (0, 3)
    single = json.loads(capsys.readouterr().out)
    assert thermal["verdict"] == "accepted"
    assert thermal["gyroscope_angle_error_mean_deg"] < 0.5 * single["gyroscope_angle_error_mean_deg"]
    # exports: the C header follows temperature; the others need one temperature
    assert main(["export", str(d / "th.json")]) == 0
    assert "double temperature_c" in capsys.readouterr().out
    kalibr = ["export", str(d / "th.json"), "--format", "kalibr", "--raw-scale", "1,1", "-o", str(d / "k.yaml")]
    assert main(kalibr) == 2
    assert "--temperature C" in capsys.readouterr().err
    assert main([*kalibr, "--temperature", "30"]) == 0
    assert main(["thermal", str(d / "c25.json"), "-o", str(d / "one.json")]) == 2
    assert "two or more" in capsys.readouterr().err
    assert main(["thermal", str(d / "c25.json"), str(d / "c40.json"), "-o", str(d / "c25.json")]) == 2


def test_simulate_with_a_magnetometer_and_the_report(tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="the report's figures need the plot extra")
    assert main(["simulate", "--scenario", "handheld", "--magnetometer", "--seed", "3", "-o", str(tmp_path / "m"),
                 "--json"]) == 0
    capsys.readouterr()
    assert main(["calibrate", str(tmp_path / "m"), "--method", "tedaldi2014", "-o", str(tmp_path / "m.json"),
                 "--report", str(tmp_path / "m.html")]) == 0
    cal = Calibration.load(tmp_path / "m.json")
    assert cal.magnetometer is not None and cal.fit["verdict"] == "accepted"
    page = (tmp_path / "m.html").read_text()
    assert "<h2>Magnetometer</h2>" in page and "magnetometer: dip spread" in page and "+y +x -z" in page
    assert main(["simulate", "--scenario", "zhang2021", "--magnetometer", "-o", str(tmp_path / "z")]) == 2
    assert "apply to --scenario handheld" in capsys.readouterr().err
