"""Columns in thousandths of a unit (``[mg]``, ``_mdps``, ``(mrad/s)``), as vendors' logs write them, are read in the
unit with a note, and the calibration is the one of the same readings written in the unit."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import imucalib
from imucalib.scenarios import session


@pytest.fixture(scope="module")
def readings():
    """A simulated hand-held session's samples, taken as g and deg/s (a sensor's readings in those units)."""
    rec = session("handheld", rng=3).recording
    acc = rec.acc / np.median(np.linalg.norm(rec.acc, axis=1))  # about 1 at rest: readings in g
    gyro = rec.gyro * 0.01
    return rec.t, acc, gyro


def _write(path, header, t, acc, gyro, factor):
    data = np.column_stack([t, acc * factor, gyro * factor])
    np.savetxt(path, data, delimiter=",", header=",".join(header), comments="", fmt="%.10g")


@pytest.mark.parametrize("acc_name, gyro_name, gyro_unit", [
    ("a{}_mg", "g{}_mdps", "deg/s"),
    ("acc_{} [mg]", "gyro_{} (mdeg/s)", "deg/s"),
    ("acc_{} (mg)", "gyro_{} [mrad/s]", "rad/s"),
])
def test_thousandths_are_read_in_the_unit_with_a_note(tmp_path, readings, acc_name, gyro_name, gyro_unit):
    t, acc, gyro = readings
    header = ["time_s"] + [acc_name.format(a) for a in "xyz"] + [gyro_name.format(a) for a in "xyz"]
    _write(tmp_path / "milli.csv", header, t, acc, gyro, 1000.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = imucalib.read(tmp_path / "milli.csv")
    notes = [str(w.message) for w in caught]
    assert rec.acc_unit == "g" and rec.gyro_unit == gyro_unit
    np.testing.assert_allclose(rec.acc, acc, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(rec.gyro, gyro, rtol=1e-8, atol=1e-9)
    assert any("is in mg: its readings are taken in g" in n for n in notes), notes
    assert any(f"its readings are taken in {gyro_unit}" in n for n in notes), notes


def test_a_session_in_mg_calibrates_as_the_same_session_in_g(tmp_path, readings):
    t, acc, gyro = readings
    _write(tmp_path / "g.csv", ["time_s", "ax_g", "ay_g", "az_g", "gx_dps", "gy_dps", "gz_dps"], t, acc, gyro, 1.0)
    _write(tmp_path / "mg.csv", ["time_s", "ax_mg", "ay_mg", "az_mg", "gx_mdps", "gy_mdps", "gz_mdps"], t, acc,
           gyro, 1000.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        in_g = imucalib.calibrate(imucalib.read(tmp_path / "g.csv"))
        in_mg = imucalib.calibrate(imucalib.read(tmp_path / "mg.csv"))
    a, b = in_g.parameters(), in_mg.parameters()
    assert a.keys() == b.keys()
    for k in a:
        assert b[k] == pytest.approx(a[k], rel=1e-6, abs=1e-9), k
    assert in_mg.accelerometer.bias.shape == (3,)


def test_an_option_overrides_a_header_in_mg_with_a_warning(tmp_path, readings):
    t, acc, gyro = readings
    _write(tmp_path / "mg.csv", ["time_s", "ax_mg", "ay_mg", "az_mg", "gx_dps", "gy_dps", "gz_dps"], t, acc, gyro,
           1000.0)
    with pytest.warns(imucalib.ImucalibWarning, match="overrides the header"):
        rec = imucalib.read(tmp_path / "mg.csv", acc_unit="g")
    np.testing.assert_allclose(rec.acc, acc * 1000.0, rtol=1e-8)  # the option wins: the readings as written
