"""Magnetometer columns read from files: names, units, and the same calibration as from the session itself."""

import warnings

import numpy as np
import pytest

from imucalib.cli import main
from imucalib.io import read
from imucalib.io.magnetometer import attach_magnetometer, magnetometer_columns
from imucalib.methods import calibrate
from imucalib.recording import ImucalibWarning, Recording
from imucalib.scenarios import handheld


@pytest.mark.parametrize("names, unit", [
    (["mx", "my", "mz"], None), (["mag_x [uT]", "mag_y [uT]", "mag_z [uT]"], "uT"),
    (["MagX (gauss)", "MagY (gauss)", "MagZ (gauss)"], "gauss"), (["magnetometer_x", "magnetometer_y",
                                                                  "magnetometer_z"], None),
    (["magneticField_x [µT]", "magneticField_y [µT]", "magneticField_z [µT]"], "uT")])
def test_column_names_and_units(names, unit):
    assert magnetometer_columns(["t", "ax", *names, "temp"]) == (names, unit)


def test_no_or_partial_columns():
    assert magnetometer_columns(["t", "ax", "mx", "my"]) is None
    with pytest.raises(ValueError, match="does not know"):
        magnetometer_columns(["mx [mG]", "my [mG]", "mz [mG]"])


def test_a_csv_with_magnetometer_columns_calibrates_like_the_session(tmp_path):
    d = handheld.generate(np.random.default_rng(12), magnetometer=True)
    rec = d["recording"]
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([rec.t, rec.acc, rec.gyro, rec.mag]), delimiter=",", fmt="%.17g",
               header="t,ax,ay,az,gx,gy,gz,mag_x,mag_y,mag_z", comments="")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        from_file = attach_magnetometer(read(path))
    assert from_file.mag_unit == "counts" and "mag_x" in from_file.extra  # kept: apply copies it as it was
    np.testing.assert_array_equal(from_file.mag, rec.mag)
    a = calibrate(from_file, method="tedaldi2014").magnetometer
    b = calibrate(rec, method="tedaldi2014").magnetometer
    np.testing.assert_allclose(a.matrix, b.matrix, rtol=1e-9)
    np.testing.assert_allclose(a.bias, b.bias, rtol=1e-9)
    # the command line: the unit given against the header's, and for data without a magnetometer
    uT = tmp_path / "ut.csv"
    uT.write_text(path.read_text().replace("mag_x,mag_y,mag_z", "mag_x [uT],mag_y [uT],mag_z [uT]", 1))
    assert main(["calibrate", str(uT), "--mag-unit", "gauss"]) == 2
    plain = tmp_path / "plain.csv"
    np.savetxt(plain, np.column_stack([rec.t, rec.acc, rec.gyro]), delimiter=",", fmt="%.17g",
               header="t,ax,ay,az,gx,gy,gz", comments="")
    assert main(["calibrate", str(plain), "--mag-unit", "uT"]) == 2


def test_gaps_in_the_magnetometer_columns_are_an_error():
    n = 5
    rec = Recording(np.arange(n) * 0.01, np.ones((n, 3)), np.ones((n, 3)),
                    extra={"mx": np.array([1.0, np.nan, 1, 1, 1]), "my": np.ones(n), "mz": np.ones(n)})
    with pytest.raises(ValueError, match="interpolated"):
        attach_magnetometer(rec)


def test_apply_adds_the_calibrated_field_and_copies_the_rest(tmp_path):
    d = handheld.generate(np.random.default_rng(13), magnetometer=True, temperature=30.0)
    rec = d["recording"]
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([rec.t, rec.acc, rec.gyro, rec.mag, rec.temperature]), delimiter=",",
               fmt="%.10g", header="t,ax,ay,az,gx,gy,gz,mx,my,mz,temperature", comments="")
    assert main(["calibrate", str(path), "-o", str(tmp_path / "c.json")]) == 0
    assert main(["apply", str(tmp_path / "c.json"), str(path), "-o", str(tmp_path / "out.csv")]) == 0
    lines_in = path.read_text().splitlines()
    lines_out = (tmp_path / "out.csv").read_text().splitlines()
    assert lines_out[0].startswith(lines_in[0] + ",acc_x_cal [m/s^2]")
    assert lines_out[0].endswith("mag_x_cal [normalised],mag_y_cal [normalised],mag_z_cal [normalised]")
    assert all(o.startswith(i + ",") for i, o in zip(lines_in[1:50], lines_out[1:50], strict=True))
    table = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)
    norms = np.linalg.norm(table[:, -3:], axis=1)  # per sample: 0.4 µT of noise in a 48 µT field
    assert abs(norms.mean() - 1.0) < 0.002 and norms.std() < 0.02
