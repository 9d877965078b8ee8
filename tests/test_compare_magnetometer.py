"""``compare`` on a session with a magnetometer: the folds leave it out; ``--no-magnetometer`` leaves it out of all."""

import json

import pytest

from imucalib.comparison import compare
from imucalib.scenarios import session as simulate
from imucalib.scenarios import write_session

METHODS = ["tedaldi2014", "ellipsoid"]


@pytest.fixture(scope="module")
def session():
    return simulate("handheld", rng=41, magnetometer=True)


@pytest.fixture
def counted(monkeypatch):
    """The number of magnetometer fits that run (the fit as the methods' registry calls it)."""
    import imucalib.fit.magnetometer as fm
    import imucalib.methods as registry

    calls = []
    real = fm.fit_magnetometer

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    assert registry.fit_magnetometer is real  # the one place a calibration's magnetometer is fitted
    monkeypatch.setattr(registry, "fit_magnetometer", counting)
    return calls


@pytest.mark.slow
def test_the_magnetometer_is_fitted_once_per_method_not_per_fold(session, counted):
    rec = session.recording
    out = compare(rec, gravity=session.truth.gravity, methods=METHODS, folds=4)
    assert all(r["ok"] for r in out["methods"]) and out["folds"] == 4
    assert len(counted) == len(METHODS)  # the calibrations on all poses; none of the 2 × 4 folds
    for row in out["methods"]:
        assert row["fit"]["magnetometer_dip_spread_deg"] < 0.5  # its figures are in the row (a uniform field)
    # the cross-validated figures do not depend on the magnetometer
    off = compare(rec, gravity=session.truth.gravity, methods=METHODS, folds=4, magnetometer=False)
    assert len(counted) == len(METHODS)
    for a, b in zip(out["methods"], off["methods"], strict=True):
        assert a["method"] == b["method"]
        assert a["cv_accelerometer_residual_rms"] == b["cv_accelerometer_residual_rms"]
        assert a["cv_gyroscope_angle_error_mean_deg"] == b["cv_gyroscope_angle_error_mean_deg"]
        assert "magnetometer_dip_spread_deg" not in b["fit"]


def test_cli_no_magnetometer(session, tmp_path, capsys, counted):
    from imucalib.cli import main

    write_session(session, tmp_path / "s")
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "s"), "--methods", "tedaldi2014", "--folds", "3", "--json",
                 "--no-magnetometer"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert not counted
    assert "magnetometer_norm_spread" not in out["methods"][0]["fit"]
