"""Readers and writers: formats, header detection, units, and every error path."""

from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from imucalib.io import ReaderError, read, write_csv
from imucalib.recording import ImucalibWarning, Recording

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"


def _rows(n=20, t0=0.0, dt=0.01):
    rng = np.random.default_rng(0)
    t = t0 + np.arange(n) * dt
    return t, rng.normal(size=(n, 3)), rng.normal(size=(n, 3))


def _write(path, header, t, a, g, fmt="{:.9g}", sep=","):
    lines = [header] if header else []
    for i in range(len(t)):
        lines.append(sep.join(fmt.format(v) for v in (t[i], *a[i], *g[i])))
    path.write_text("\n".join(lines) + "\n")
    return path


# --------------------------------------------------------------------- CSV
@pytest.mark.parametrize("header,unit_a,unit_g", [
    ("t,ax,ay,az,gx,gy,gz", "counts", "counts"),
    ("time,acc_x,acc_y,acc_z,gyro_x,gyro_y,gyro_z", "counts", "counts"),
    ("timestamp,accel_x [g],accel_y [g],accel_z [g],gyr_x [deg/s],gyr_y [deg/s],gyr_z [deg/s]",
     "g", "deg/s"),
    ("Time,a_x,a_y,a_z,w_x,w_y,w_z", "counts", "counts"),
])
def test_csv_header_detection(tmp_path, header, unit_a, unit_g):
    t, a, g = _rows()
    rec = read(_write(tmp_path / "d.csv", header, t, a, g))
    np.testing.assert_allclose(rec.acc, a, rtol=1e-8)
    np.testing.assert_allclose(rec.gyro, g, rtol=1e-8)
    np.testing.assert_allclose(rec.t, t, atol=1e-12)
    assert (rec.acc_unit, rec.gyro_unit) == (unit_a, unit_g)
    assert rec.rate == pytest.approx(100.0)


def test_euroc_header_units_and_nanoseconds(tmp_path):
    t, a, g = _rows(t0=1403636579758555392 * 1e-9)
    header = ("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
              "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]")
    lines = [header]
    for i in range(len(t)):
        ns = 1403636579758555392 + i * 10_000_000
        lines.append(",".join([str(ns)] + [f"{v:.9g}" for v in (*g[i], *a[i])]))
    (tmp_path / "imu0.csv").write_text("\n".join(lines) + "\n")
    rec = read(tmp_path / "imu0.csv")
    assert rec.acc_unit == "m/s^2" and rec.gyro_unit == "rad/s"
    np.testing.assert_allclose(rec.acc, a, rtol=1e-8)
    np.testing.assert_allclose(np.diff(rec.t), 0.01, atol=1e-9)
    assert rec.metadata["time_unit"] == "ns"


def test_time_units_from_name_and_values(tmp_path):
    t, a, g = _rows()
    rec = read(_write(tmp_path / "a.csv", "time_ms,ax,ay,az,gx,gy,gz", t * 1000, a, g))
    np.testing.assert_allclose(np.diff(rec.t), 0.01, rtol=1e-9)
    rec = read(_write(tmp_path / "b.csv", "t,ax,ay,az,gx,gy,gz", t * 1e6, a, g))  # inferred µs
    assert rec.metadata["time_unit"] == "us"
    np.testing.assert_allclose(np.diff(rec.t), 0.01, rtol=1e-9)
    rec = read(_write(tmp_path / "c.csv", "t,ax,ay,az,gx,gy,gz", t * 1e6, a, g), time_unit="us")
    np.testing.assert_allclose(rec.t, t, atol=1e-12)


def test_csv_extra_columns_kept_and_units_forced(tmp_path):
    t, a, g = _rows()
    lines = ["t;ax;ay;az;gx;gy;gz;temp;label"]
    for i in range(len(t)):
        lines.append(";".join(f"{v:.9g}" for v in (t[i], *a[i], *g[i], 25.0 + i)) + f";L{i}")
    (tmp_path / "x.csv").write_text("\n".join(lines) + "\n")
    rec = read(tmp_path / "x.csv", acc_unit="g", gyro_unit="rad/s")
    assert rec.acc_unit == "g" and rec.gyro_unit == "rad/s"
    np.testing.assert_allclose(rec.temperature, 25.0 + np.arange(20))
    assert list(rec.extra["label"][:2]) == ["L0", "L1"]


def test_no_time_column_needs_rate(tmp_path):
    t, a, g = _rows()
    path = tmp_path / "n.csv"
    path.write_text("ax,ay,az,gx,gy,gz\n" + "\n".join(
        ",".join(f"{v:.9g}" for v in (*a[i], *g[i])) for i in range(20)) + "\n")
    with pytest.raises(ReaderError, match=r"n.csv: no time column found; pass --rate HZ"):
        read(path)
    rec = read(path, rate=200.0)
    np.testing.assert_allclose(np.diff(rec.t), 0.005)


def test_explicit_columns(tmp_path):
    t, a, g = _rows()
    path = _write(tmp_path / "c.csv", "stamp_x,q1,q2,q3,r1,r2,r3", t, a, g)
    with pytest.raises(ReaderError, match=r"missing columns ax, ay, az, gx, gy, gz .*--columns"):
        read(path)
    rec = read(path, columns=["stamp_x", "q1", "q2", "q3", "r1", "r2", "r3"])
    np.testing.assert_allclose(rec.gyro, g, rtol=1e-8)
    rec = read(path, columns=["0", "1", "2", "3", "4", "5", "6"])
    np.testing.assert_allclose(rec.acc, a, rtol=1e-8)
    with pytest.raises(ReaderError, match=r"--columns ax='nope': no such column"):
        read(path, columns=["stamp_x", "nope", "q2", "q3", "r1", "r2", "r3"])
    with pytest.raises(ReaderError, match="--columns needs 7 entries"):
        read(path, columns=["0", "1"])


def test_headerless_seven_columns_warns(tmp_path):
    t, a, g = _rows()
    path = _write(tmp_path / "h.csv", None, t, a, g)
    with pytest.warns(ImucalibWarning, match="no header: the columns were taken as t,ax"):
        rec = read(path)
    np.testing.assert_allclose(rec.acc, a, rtol=1e-8)


@pytest.mark.parametrize("bad,match", [
    ("abc", r"bad.csv: line 5, ay: 'abc' is not a number"),
    ("nan", r"bad.csv: line 5, ay: 'nan' is not finite \(NaN or inf\)"),
    ("inf", r"bad.csv: line 5, ay: 'inf' is not finite"),
])
def test_bad_cells(tmp_path, bad, match):
    t, a, g = _rows()
    path = _write(tmp_path / "bad.csv", "t,ax,ay,az,gx,gy,gz", t, a, g)
    lines = path.read_text().splitlines()
    cells = lines[4].split(",")
    cells[2] = bad
    lines[4] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ReaderError, match=match):
        read(path)


def test_ragged_row(tmp_path):
    t, a, g = _rows()
    path = _write(tmp_path / "r.csv", "t,ax,ay,az,gx,gy,gz", t, a, g)
    lines = path.read_text().splitlines()
    lines[3] = lines[3] + ",1.0"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ReaderError, match=r"r.csv: line 4: expected 7 values, found 8"):
        read(path)


@pytest.mark.parametrize("t_fix,match", [
    (lambda t: np.r_[t[:6], t[5], t[7:]], r"line 8, t: timestamp duplicated"),
    (lambda t: np.r_[t[:6], t[3], t[7:]], r"line 8, t: timestamp goes backwards"),
])
def test_non_monotonic_time(tmp_path, t_fix, match):
    t, a, g = _rows()
    path = _write(tmp_path / "m.csv", "t,ax,ay,az,gx,gy,gz", t_fix(t), a, g)
    with pytest.raises(ReaderError, match=match):
        read(path)


def test_empty_and_missing_files(tmp_path):
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(ReaderError, match=r"e.csv: empty file"):
        read(tmp_path / "e.csv")
    (tmp_path / "h.csv").write_text("t,ax,ay,az,gx,gy,gz\n")
    with pytest.raises(ReaderError, match=r"h.csv: no data rows after the header"):
        read(tmp_path / "h.csv")
    with pytest.raises(ReaderError, match=r"nothere.csv: file not found"):
        read(tmp_path / "nothere.csv")


def test_bad_options(tmp_path):
    t, a, g = _rows()
    path = _write(tmp_path / "o.csv", "t,ax,ay,az,gx,gy,gz", t, a, g)
    with pytest.raises(ReaderError, match="unknown reader 'xls'"):
        read(path, reader="xls")
    with pytest.raises(ReaderError, match="unknown accelerometer unit 'furlong'"):
        read(path, acc_unit="furlong")
    with pytest.raises(ReaderError, match="unknown gyroscope unit 'rpm'"):
        read(path, gyro_unit="rpm")
    with pytest.raises(ReaderError, match="has a time column .* and --rate was given"):
        read(path, rate=100.0)
    with pytest.raises(ReaderError, match="is given twice; several files are read as blocks"):
        read([path, path], reader="csv")
    with pytest.raises(ReaderError, match="the imutk reader takes two files"):
        read([path], reader="imutk")


# ------------------------------------------------------------------ imu_tk
def _imutk(path, t, x):
    path.write_text("\n".join(f"{t[i]:.7e} {x[i, 0]:.7e} {x[i, 1]:.7e} {x[i, 2]:.7e}"
                              for i in range(len(t))) + "\n")
    return path


def test_imutk_two_files_and_alignment(tmp_path):
    t, a, g = _rows()
    pa = _imutk(tmp_path / "acc.txt", t, a)
    pg = _imutk(tmp_path / "gyro.txt", t, g)
    rec = read([pa, pg])  # guessed: two text files
    assert rec.metadata["reader"] == "imutk"
    np.testing.assert_allclose(rec.gyro, g, rtol=1e-7)
    pg2 = _imutk(tmp_path / "gyro2.txt", t + 0.004, g)
    with pytest.warns(ImucalibWarning, match="gyroscope was linearly interpolated"):
        rec2 = read([pa, pg2], reader="imutk")
    assert len(rec2) == len(t) - 1  # the first accelerometer sample precedes the gyroscope


def test_imutk_errors(tmp_path):
    t, a, g = _rows()
    pa = _imutk(tmp_path / "acc.txt", t, a)
    bad = tmp_path / "gyro.txt"
    lines = _imutk(bad, t, g).read_text().splitlines()
    lines[2] = "0.02 1.0 2.0"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(ReaderError, match=r"gyro.txt: line 3: expected 4 values, found 3"):
        read([pa, bad], reader="imutk")
    (tmp_path / "empty.txt").write_text("\n")
    with pytest.raises(ReaderError, match=r"empty.txt: empty file"):
        read([pa, tmp_path / "empty.txt"], reader="imutk")


# ------------------------------------------------------------------ MATLAB
def test_mat_reader(tmp_path):
    t, a, g = _rows()
    savemat(tmp_path / "d.mat", {"imu": np.column_stack([t, a, g]), "other": np.ones(3)})
    rec = read(tmp_path / "d.mat")
    np.testing.assert_allclose(rec.acc, a)
    rec = read(tmp_path / "d.mat", variable="imu", columns=["0", "4", "5", "6", "1", "2", "3"])
    np.testing.assert_allclose(rec.acc, g)
    with pytest.raises(ReaderError, match=r"no variable 'x'; variables present: imu, other"):
        read(tmp_path / "d.mat", variable="x")
    savemat(tmp_path / "s.mat", {"imu": np.ones((5, 3))})
    with pytest.raises(ReaderError, match=r"variable 'imu' has 3 columns; pass --columns"):
        read(tmp_path / "s.mat", variable="imu")


# ------------------------------------------------------------------ writer
def test_write_keeps_rows_and_columns(tmp_path):
    t, a, g = _rows()
    lines = ["time_ms,ax,ay,az,gx,gy,gz,label"]
    for i in range(len(t)):
        lines.append(",".join(f"{v:.9g}" for v in (t[i] * 1000, *a[i], *g[i])) + f",L{i}")
    (tmp_path / "in.csv").write_text("\n".join(lines) + "\n")
    rec = read(tmp_path / "in.csv")
    write_csv(tmp_path / "out.csv", rec, calibrated_acc=a * 2, calibrated_gyro=g * 3)
    out_lines = (tmp_path / "out.csv").read_text().splitlines()
    assert out_lines[0].startswith("time_ms,ax,ay,az,gx,gy,gz,label,acc_x_cal [m/s^2]")
    assert len(out_lines) == len(t) + 1
    back = read(tmp_path / "out.csv")
    np.testing.assert_allclose(back.t, rec.t, atol=1e-12)
    np.testing.assert_allclose(back.acc, rec.acc, rtol=1e-12)
    np.testing.assert_allclose(back.extra["gyro_z_cal [rad/s]"], g[:, 2] * 3, rtol=1e-9)
    assert list(back.extra["label"][:1]) == ["L0"]


def test_recording_alignment_warns_and_interpolates():
    t = np.arange(100) * 0.01
    with pytest.warns(ImucalibWarning, match="interpolated onto the 99 accelerometer timestamps"):
        rec = Recording.from_streams(t, np.ones((100, 3)), t + 0.005, np.outer(t + 0.005, [1, 2, 3]))
    np.testing.assert_allclose(rec.gyro[:, 1], 2 * rec.t, atol=1e-12)


# --------------------------------------------------------------- real data
def test_xsens_files(tmp_path):
    if not DATA.is_dir():
        pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): real-data test skipped")
    rec = read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk")
    assert len(rec) == 51175
    assert rec.rate == pytest.approx(100.0, rel=5e-3)
    np.testing.assert_array_equal(rec.acc[0], [33108, 33329, 36429])
    assert rec.acc_unit == "counts" and rec.gyro_unit == "counts"


def test_written_units_are_read_back(tmp_path):
    from imucalib.io import write_csv
    from imucalib.recording import Recording

    rec = Recording(np.arange(5) * 0.01, np.ones((5, 3)), np.full((5, 3), 2.0), acc_unit="g", gyro_unit="deg/s")
    write_csv(tmp_path / "u.csv", rec)
    back = read(tmp_path / "u.csv")
    assert (back.acc_unit, back.gyro_unit) == ("g", "deg/s")
    np.testing.assert_array_equal(back.gyro, rec.gyro)


def test_an_empty_cell_is_an_error_even_when_the_counts_balance(tmp_path):
    p = tmp_path / "e.csv"
    p.write_text("t,ax,ay,az,gx,gy,gz\n0,1,2,,4,5,6\n0.01,1,2,3,4,5,6,7\n")
    with pytest.raises(ReaderError, match=r"line [23]"):  # rejected, never read shifted
        read(p)
