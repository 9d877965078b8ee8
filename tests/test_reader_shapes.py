"""Files as people have them, synthesized: coarse stamps, repeated rows, '# ' headers, trailing separators,
CRLF, banner and prompt lines, packet-interleaved vendor logs, millis() and nanosecond stamps, --columns by
field (magnetometer, temperature, gyroscope first), MATLAB matrices of 10 columns, sample counters, and
imucal's sections lists."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.io import savemat

from imucalib import read as read_data
from imucalib.io import ReaderError, read
from imucalib.io.columns import parse_columns
from imucalib.io.stamps import guess_unit, repair_coarse
from imucalib.methods.ferraris import SECTION_NAMES, parse_sections
from imucalib.recording import ImucalibWarning

RATE = 200.0


def _session(n: int = 2000, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    acc = rng.normal(0, 0.01, (n, 3)) + [0.1, -0.2, 9.81]
    gyro = rng.normal(0, 0.001, (n, 3)) + [0.01, -0.02, 0.005]
    return t, acc, gyro


def _notes(caught) -> list[str]:
    return [str(w.message) for w in caught if issubclass(w.category, ImucalibWarning)]


def _read(*args, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = read(*args, **kw)
    return rec, _notes(caught)


# ------------------------------------------------------------------ 1. coarse stamps, repeated rows
def _coarse(t):
    """Stamps printed with two decimals (%.2f rounds): 0.01 s resolution at 200 Hz."""
    return np.array([float(f"{v:.2f}") for v in t])


def test_coarse_stamps_repaired_within_resolution_gap_kept_repeats_dropped(tmp_path):
    t, acc, gyro = _session()
    keep = np.r_[0:900, 1000:2000]  # 100 samples lost: a real gap of 0.5 s
    t, acc, gyro = t[keep], acc[keep], gyro[keep]
    rows = [f"{s:.2f},{a[0]:.6f},{a[1]:.6f},{a[2]:.6f},{g[0]:.6f},{g[1]:.6f},{g[2]:.6f}"
            for s, a, g in zip(t, acc, gyro, strict=True)]
    dup_at = [10, 500, 1500]
    lines = []
    for i, r in enumerate(rows):
        lines.append(r)
        if i in dup_at:
            lines.append(r)  # the logger wrote this sample twice
    path = tmp_path / "coarse.csv"
    path.write_text("t,ax,ay,az,gx,gy,gz\n" + "\n".join(lines) + "\n")
    rec, notes = _read(path, acc_unit="m/s^2", gyro_unit="rad/s")
    assert len(rec) == len(t)  # the three repeats dropped, nothing else
    assert np.allclose(rec.acc, np.round(acc, 6), atol=1e-12)
    said = [n for n in notes if "repeat the row before exactly" in n]
    assert len(said) == 1 and "dropped 3 rows" in said[0]
    repaired = [n for n in notes if "resolution of 0.01" in n]
    assert len(repaired) == 1 and "1 gap between them kept" in repaired[0]
    assert abs(rec.rate - RATE) / RATE < 1e-3
    stamps = _coarse(t)
    assert np.max(np.abs(rec.t - stamps)) <= 0.01 + 1e-12  # within the stamps' resolution
    assert np.all(np.diff(rec.t) > 0)
    assert np.max(np.abs(np.diff(rec.t) - np.diff(t))) < 1e-3  # the gap is the gap, the steps the interval
    assert abs((rec.t[900] - rec.t[899]) - 0.505) < 0.011


def test_coarse_stamps_imutk_pair(tmp_path):
    t, acc, gyro = _session(1500, seed=3)
    for name, v in (("acc.txt", acc), ("gyro.txt", gyro)):
        (tmp_path / name).write_text("".join(f"{s:.2f} {x:.7e} {y:.7e} {z:.7e}\n" for s, (x, y, z) in zip(t, v,
                                                                                                           strict=True)))
    rec, notes = _read([tmp_path / "acc.txt", tmp_path / "gyro.txt"], reader="imutk", acc_unit="m/s^2",
                       gyro_unit="rad/s")
    assert len(rec) == len(t)
    assert sum("resolution of 0.01" in n for n in notes) == 2  # one for each file
    assert abs(rec.rate - RATE) / RATE < 1e-3
    assert np.max(np.abs(rec.t - (_coarse(t) - _coarse(t)[0]))) <= 0.0105
    assert np.allclose(rec.gyro, np.array([[float(f"{x:.7e}") for x in r] for r in gyro]), atol=1e-12)


def test_repeated_stamp_here_and_there_stays_an_error(tmp_path):
    t = np.round(np.arange(50) / 100.0, 2)
    t[20] = t[19]
    with pytest.raises(ReaderError, match=r"line 21, time: timestamp duplicated"):
        repair_coarse(tmp_path / "x.csv", t, [np.random.default_rng(0).normal(size=(50, 3))], 1)


def test_coarse_stamps_without_a_steady_rate_refused(tmp_path):
    # the first half at 200 Hz, the second at 120 Hz, stamps with 0.01 resolution and no gap between
    t = np.r_[np.arange(400) / 200.0, 2.0 + np.arange(1, 400) / 120.0]
    v = np.random.default_rng(1).normal(size=(t.size, 3))
    with pytest.raises(ReaderError, match="do not follow a steady rate"):
        repair_coarse(tmp_path / "x.csv", _coarse(t), [v], 2)


# ------------------------------------------------------------------ 2. headers, separators, banners
def test_savetxt_hash_header_trailing_separators_crlf(tmp_path):
    t, acc, gyro = _session(300)
    data = np.column_stack([t, acc, gyro])
    np.savetxt(tmp_path / "h.csv", data, delimiter=",", header="t,ax,ay,az,gx,gy,gz", fmt="%.6f")
    body = ["\t".join(f"{v:.6f}" for v in r) for r in data]
    (tmp_path / "tab.tsv").write_text("t\tax\tay\taz\tgx\tgy\tgz\t\n" + "".join(ln + "\t\n" for ln in body))
    (tmp_path / "comma.csv").write_bytes(("t,ax,ay,az,gx,gy,gz,\r\n" + "".join(
        ln.replace("\t", ",") + ",\r\n" for ln in body)).encode())
    (tmp_path / "rows.csv").write_text("t,ax,ay,az,gx,gy,gz\n" + "".join(ln.replace("\t", ",") + ",\n" for ln in body))
    for name in ("h.csv", "tab.tsv", "comma.csv", "rows.csv"):
        rec, _ = _read(tmp_path / name, acc_unit="m/s^2", gyro_unit="rad/s")
        assert rec.metadata["columns"]["t"] == "t"
        assert rec.extra == {}, name  # no empty column after a trailing separator
        assert np.allclose(rec.acc, np.round(acc, 6), atol=1e-12) and np.allclose(rec.gyro, np.round(gyro, 6),
                                                                                   atol=1e-12)
        assert abs(rec.rate - RATE) < 1e-6


def test_serial_monitor_banner_and_prompt_blocks(tmp_path):
    rng = np.random.default_rng(2)
    faces = [[0, 0, 9.8], [0, 0, -9.8], [9.8, 0, 0], [-9.8, 0, 0], [0, 9.8, 0], [0, -9.8, 0]]
    text = ("--- Available filters and text transformations: colorize, debug, default, direct, hexlify, log2file, "
            "nocontrol, printable, send_on_enter, time\r\n--- More details at http://bit.ly/pio-monitor-filters\r\n")
    blocks = []
    for f in faces:
        v = rng.normal(0, 0.02, (200, 3)) + f
        blocks.append(np.round(v, 10))
        text += ">>> Gathering data for 10 seconds...\r\n" + "".join(
            f"{x:.10f}, {y:.10f}, {z:.10f}\r\n" for x, y, z in v)
        text += ">>> Type key when ready...\r\n"
    path = tmp_path / "monitor.csv"
    path.write_text(text, newline="")
    rec, notes = _read(path, rate=400, acc_unit="m/s^2")
    assert rec.gyro is None and len(rec) == 1200
    assert rec.metadata["blocks"] == [[200 * k, 200 * (k + 1)] for k in range(6)]
    assert np.allclose(rec.acc, np.concatenate(blocks), atol=1e-12)
    assert any("skipped 3 lines before the data" in n for n in notes)
    assert any("cut the rows into 6 blocks" in n for n in notes)


# ------------------------------------------------------------------ 3. packet-interleaved vendor logs
_MSCL = ["Time", "estFilterGpsTimeTow", "estFilterGpsTimeWeekNum", "estLinearAccelX", "estLinearAccelY",
         "estLinearAccelZ", "estFilterState", "scaledAccelX", "scaledAccelY", "scaledAccelZ", "scaledGyroX",
         "scaledGyroY", "scaledGyroZ", "scaledMagX", "scaledMagY", "scaledMagZ", "gpsCorrelTimestampTow"]
_BY_NAME = ("t=Time,ax=scaledAccelX,ay=scaledAccelY,az=scaledAccelZ,gx=scaledGyroX,gy=scaledGyroY,gz=scaledGyroZ,"
            "mx=scaledMagX,my=scaledMagY,mz=scaledMagZ")


def _mscl(path, n=600, broken_row=None):
    rng = np.random.default_rng(4)
    t0, step = 1_600_000_000_123_456_789, 2_500_000  # ns, 400 Hz
    imu = []
    lines = [",".join(_MSCL)]
    for i in range(n):
        stamp = t0 + i * step
        lines.append(f"{stamp - 1000},{345600 + i * 0.0025:.4f},2100,0.01,0.02,-0.03,4" + "," * 10)
        a, g, m = rng.normal(0, 1e-3, 3) + [0, 0, -1], rng.normal(0, 1e-3, 3), rng.normal(0, 1e-3, 3) + [.2, 0, .4]
        cells = [f"{x:.6f}" for x in (*a, *g, *m)]
        if i == broken_row:
            cells[4] = ""
        lines.append(f"{stamp},,,,,,," + ",".join(cells) + f",{345600 + i * 0.0025:.4f}")
        imu.append([float(c or "nan") for c in cells])
    path.write_text("\n".join(lines) + "\n")
    return np.array(imu), t0, step


def test_mscl_alternating_packets_by_name(tmp_path):
    imu, t0, step = _mscl(tmp_path / "mscl.csv")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = read_data(tmp_path / "mscl.csv", columns=_BY_NAME.split(","), acc_unit="g", gyro_unit="rad/s")
    notes = _notes(caught)
    skipped = [n for n in notes if "skipped" in n and "packet" in n]
    assert len(skipped) == 1 and "skipped 600 of 1200 rows" in skipped[0]
    assert len(rec) == 600 and rec.metadata["time_unit"] == "ns"
    assert abs(rec.rate - 400.0) < 1e-6
    assert rec.metadata["t0"] == t0  # the epoch stamp kept exactly
    assert np.array_equal(rec.acc, imu[:, 0:3]) and np.array_equal(rec.gyro, imu[:, 3:6])
    assert rec.mag is not None and np.array_equal(rec.mag, imu[:, 6:9])


def test_mscl_row_with_part_of_the_sensors_is_an_error(tmp_path):
    _mscl(tmp_path / "mscl.csv", n=50, broken_row=7)
    with pytest.raises(ReaderError, match=r"scaledGyroY empty while the other sensor columns are not"):
        read(tmp_path / "mscl.csv", columns=_BY_NAME.split(","))


# ------------------------------------------------------------------ 4. time units from values
def test_millis_stamps_read_as_ms_with_a_note(tmp_path):
    t, acc, gyro = _session(500)
    ms = 410 + np.cumsum(np.r_[0, np.where(np.arange(499) % 3 == 0, 17, 15)])  # millis(): 62.5 Hz-ish
    path = tmp_path / "m.csv"
    path.write_text("Timestamp,ax,ay,az,gx,gy,gz\n" + "".join(
        f"{s},{a[0]:.4f},{a[1]:.4f},{a[2]:.4f},{g[0]:.4f},{g[1]:.4f},{g[2]:.4f}\n"
        for s, a, g in zip(ms, acc, gyro, strict=True)))
    rec, notes = _read(path, acc_unit="m/s^2", gyro_unit="rad/s")
    assert rec.metadata["time_unit"] == "ms"
    assert np.allclose(rec.t, ms / 1000.0)
    assert sum("read in milliseconds" in n for n in notes) == 1


def test_unit_guess_rules():
    assert guess_unit(np.arange(10) * 16.0 + 410) == "ms"  # 62.5 Hz only in ms
    assert guess_unit(1.6e18 + np.arange(10) * 2.5e6) == "ns"  # 400 Hz only in ns
    assert guess_unit(np.arange(10) * 0.01) == "s"
    assert guess_unit(np.arange(10) * 1000.0) == "us"  # 1 kHz in us (1 Hz in ms is not an IMU's)
    # 100: 10 Hz in ms and 10 kHz in us are both IMU rates: the step alone decides (us), unless the first stamp
    # is an epoch in one of them only (1.6e12 ms is 2020; 1.6e12 us is 1970)
    assert guess_unit(np.arange(10) * 100.0) == "us"
    assert guess_unit(1.6e12 + np.arange(10) * 100.0) == "ms"


# ------------------------------------------------------------------ 5. --columns by field, .mat matrices
def _write_table(path, names, cols):
    path.write_text(",".join(names) + "\n" + "".join(",".join(f"{v:.6f}" for v in r) + "\n"
                                                     for r in np.column_stack(cols)))


def test_gyroscope_before_accelerometer_by_name_and_by_index(tmp_path):
    t, acc, gyro = _session(300)
    temp = 25 + 0.001 * np.arange(300)
    names = ["time", "wx", "wy", "wz", "fx", "fy", "fz", "temp_c"]
    _write_table(tmp_path / "g.csv", names, [t, gyro, acc, temp])
    by_name = "t=time,gx=wx,gy=wy,gz=wz,ax=fx,ay=fy,az=fz,temp=temp_c".split(",")
    by_index = "t=0,gx=1,gy=2,gz=3,ax=4,ay=5,az=6,temp=7".split(",")
    positional = "0,4,5,6,1,2,3".split(",")
    for columns in (by_name, by_index, positional):
        rec, _ = _read(tmp_path / "g.csv", columns=columns, acc_unit="m/s^2", gyro_unit="rad/s")
        assert np.allclose(rec.acc, np.round(acc, 6)) and np.allclose(rec.gyro, np.round(gyro, 6))
        if columns is not positional:
            assert np.allclose(rec.temperature, np.round(temp, 6))


def test_columns_magnetometer_positional_and_keyword(tmp_path):
    t, acc, gyro = _session(300)
    mag = np.random.default_rng(5).normal(0, 0.3, (300, 3)) + [20, -5, 40]
    names = ["T", "A1", "A2", "A3", "G1", "G2", "G3", "M1", "M2", "M3"]
    _write_table(tmp_path / "m.csv", names, [t, acc, gyro, mag])
    for columns in (names, ["t=T", "ax=A1", "ay=A2", "az=A3", "gx=G1", "gy=G2", "gz=G3", "mx=M1", "my=M2",
                            "mz=M3"]):
        rec = read_data(tmp_path / "m.csv", columns=columns, acc_unit="m/s^2", gyro_unit="rad/s", mag_unit="uT")
        assert rec.mag is not None and np.allclose(rec.mag, np.round(mag, 6)) and rec.mag_unit == "uT"


@pytest.mark.parametrize("columns,match", [
    (["t=0", "1", "2", "3"], "give every entry as FIELD=COLUMN"),
    (["t=0", "ax=1", "ay=2"], r"accelerometer's columns are needed .*az"),
    (["t=0", "ax=1", "ay=2", "az=3", "mx=4"], "all three magnetometer columns"),
    (["t=0", "ax=1", "ay=2", "az=3", "speed=4"], "unknown field 'speed'"),
    (["0", "1", "2", "3", "4"], "--columns needs 7 entries"),
])
def test_columns_errors(columns, match):
    with pytest.raises(ReaderError, match=match):
        parse_columns(columns)


def test_mat_ten_columns_taken_with_the_magnetometer(tmp_path):
    t, acc, gyro = _session(400)
    mag = np.random.default_rng(6).normal(0, 1, (400, 3)) + [100, -30, 200]
    savemat(tmp_path / "d.mat", {"cal_data": np.column_stack([t, acc, gyro, mag])})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = read_data(tmp_path / "d.mat")
    assert any("10 columns: taken as t,ax,ay,az,gx,gy,gz,mx,my,mz" in n for n in _notes(caught))
    assert np.array_equal(rec.mag, mag) and np.array_equal(rec.acc, acc)
    # the magnetometer first, named by index in the keyword form
    savemat(tmp_path / "e.mat", {"m": np.column_stack([mag, t, gyro, acc])})
    rec = read_data(tmp_path / "e.mat", columns="mx=0,my=1,mz=2,t=3,gx=4,gy=5,gz=6,ax=7,ay=8,az=9".split(","),
                    acc_unit="m/s^2", gyro_unit="rad/s")
    assert np.array_equal(rec.mag, mag) and np.array_equal(rec.gyro, gyro) and np.array_equal(rec.acc, acc)


# ------------------------------------------------------------------ 6. sample counters, sections lists
def test_sample_counter_needs_rate_and_keeps_gaps(tmp_path):
    t, acc, gyro = _session(300)
    n = np.r_[0:100, 110:310]  # ten samples lost
    _write_table(tmp_path / "n.csv", ["n_samples", "gyr_x", "gyr_y", "gyr_z", "acc_x", "acc_y", "acc_z"],
                 [n, gyro, acc])
    with pytest.raises(ReaderError, match=r"'n_samples' counts samples, it is not a time; pass --rate"):
        read(tmp_path / "n.csv", acc_unit="m/s^2", gyro_unit="deg/s")
    rec, notes = _read(tmp_path / "n.csv", rate=102.4, acc_unit="m/s^2", gyro_unit="deg/s")
    assert np.allclose(rec.t, n / 102.4)
    assert "n_samples" not in rec.extra
    assert any("skips 10 samples" in s for s in notes)


def test_sections_both_forms():
    pairs = {name: [100 * i, 100 * i + 50] for i, name in enumerate(SECTION_NAMES)}
    imucal = {name: {"start": a, "end": b} for name, (a, b) in pairs.items()}
    assert parse_sections(pairs) == parse_sections(imucal) == pairs
    with pytest.raises(ValueError, match=r"'x_p' must be \[start, stop\]"):
        parse_sections({**imucal, "x_p": {"start": 50, "end": 40}})
    with pytest.raises(ValueError, match="missing z_rot"):
        parse_sections({k: v for k, v in imucal.items() if k != "z_rot"})


def test_date_time_stamps_read_as_times_and_copied_as_written(tmp_path):
    """A logger's ``2024-05-01 12:00:00.010`` stamps: the same recording as
    numeric seconds give, and ``apply`` copies the rows' text, stamps included, as written."""
    pytest.importorskip("pandas")
    import json

    from imucalib.cli import main
    from imucalib.scenarios import session

    rec = session("handheld", rng=2).recording
    rows = np.column_stack([rec.acc, rec.gyro])
    epoch = np.datetime64("2024-05-01T12:00:00", "ns") + (rec.t * 1e9).round().astype("timedelta64[ns]")
    stamps = [str(s).replace("T", " ")[:26] for s in epoch]
    text = "".join(f"{s},{','.join(f'{v:.0f}' for v in r)}\n" for s, r in zip(stamps, rows, strict=True))
    (tmp_path / "dated.csv").write_text("time,ax,ay,az,gx,gy,gz\n" + text)
    numeric = "".join(f"{t:.6f},{','.join(f'{v:.0f}' for v in r)}\n" for t, r in zip(rec.t, rows, strict=True))
    (tmp_path / "plain.csv").write_text("t,ax,ay,az,gx,gy,gz\n" + numeric)
    with pytest.warns(ImucalibWarning, match="holds dates and times"):
        dated = read(str(tmp_path / "dated.csv"))
    plain = read(str(tmp_path / "plain.csv"))
    np.testing.assert_allclose(dated.t, plain.t, atol=1e-6)
    np.testing.assert_array_equal(dated.acc, plain.acc)
    np.testing.assert_array_equal(dated.gyro, plain.gyro)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["calibrate", str(tmp_path / "dated.csv"), "-o", str(tmp_path / "c.json")]) == 0
        assert main(["apply", str(tmp_path / "c.json"), str(tmp_path / "dated.csv"), "-o",
                     str(tmp_path / "out.csv")]) == 0
    out = (tmp_path / "out.csv").read_text().splitlines()
    assert out[1].startswith(stamps[0] + ",") and len(out) == len(rows) + 1
    assert json.loads((tmp_path / "c.json").read_text())["fit"]["verdict"] == "accepted"


def test_date_time_stamps_without_a_header_say_what_to_pass(tmp_path):
    pytest.importorskip("pandas")
    (tmp_path / "d.csv").write_text("".join(f"2024-05-01 12:00:00.{k:02d}0,0,0,1,0,0,0\n" for k in range(50)))
    with pytest.raises(ReaderError, match="no header naming the columns.*--rate"):
        read(str(tmp_path / "d.csv"))


def test_a_pair_of_tables_with_headers_is_read_as_imutks_pair(tmp_path):
    """An accelerometer file and a gyroscope file written as tables (a header, commas; a phone's or a camera
    module's export), at different rates, in either order: the same recording as imu_tk's headerless pair."""
    from imucalib.scenarios import session

    rec = session("handheld", rng=2).recording
    ta, acc = rec.t[::2], rec.acc[::2]
    np.savetxt(tmp_path / "a.txt", np.column_stack([ta, acc]))
    np.savetxt(tmp_path / "g.txt", np.column_stack([rec.t, rec.gyro]))
    np.savetxt(tmp_path / "accel.csv", np.column_stack([ta, acc]), delimiter=",", header="timestamp,x,y,z",
               comments="")
    np.savetxt(tmp_path / "gyro.csv", np.column_stack([rec.t, rec.gyro]), delimiter=",",
               header="time,gyro_x (counts),gyro_y (counts),gyro_z (counts)", comments="")
    np.savetxt(tmp_path / "acc_named.csv", np.column_stack([ta, acc]), delimiter=",", header="t,acc_x,acc_y,acc_z",
               comments="")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        plain = read([str(tmp_path / "a.txt"), str(tmp_path / "g.txt")])
        tables = read([str(tmp_path / "accel.csv"), str(tmp_path / "gyro.csv")])
    with pytest.warns(ImucalibWarning, match="names the gyroscope's axes"):
        swapped = read([str(tmp_path / "gyro.csv"), str(tmp_path / "acc_named.csv")])
    for got in (tables, swapped):
        np.testing.assert_allclose(got.t, plain.t, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got.acc, plain.acc, rtol=1e-15)
        np.testing.assert_allclose(got.gyro, plain.gyro, rtol=1e-12)


def test_a_line_of_units_under_the_header_gives_the_units(tmp_path):
    """A vendor's export: names, then a line of units, then the rows: the units are read (not a prompt line
    cutting the file into one block), and apply writes a coherent file anew."""
    from imucalib.cli import main
    from imucalib.scenarios import session

    sim = session("handheld", rng=2)
    rec = sim.truth.apply(sim.recording)  # readings of a perfect sensor, in m/s^2 and rad/s
    rows = [",".join(f"{v:.9g}" for v in (t, *a, *g)) for t, a, g in zip(rec.t, rec.acc, rec.gyro, strict=True)]
    head = ["Time,AccX,AccY,AccZ,GyroX,GyroY,GyroZ", "s,m/s^2,m/s^2,m/s^2,rad/s,rad/s,rad/s"]
    (tmp_path / "units.csv").write_text("\n".join(head + rows) + "\n")
    (tmp_path / "plain.csv").write_text("\n".join(head[:1] + rows) + "\n")
    with pytest.warns(ImucalibWarning, match=r"line 2 gives the columns' units \(s, m/s\^2"):
        got = read(str(tmp_path / "units.csv"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        plain = read(str(tmp_path / "plain.csv"), acc_unit="m/s^2", gyro_unit="rad/s")
        assert (got.acc_unit, got.gyro_unit) == ("m/s^2", "rad/s") and len(got) == len(plain)
        np.testing.assert_array_equal(got.acc, plain.acc)
        assert main(["calibrate", str(tmp_path / "units.csv"), "-o", str(tmp_path / "c.json")]) == 0
        assert main(["apply", str(tmp_path / "c.json"), str(tmp_path / "units.csv"), "-o",
                     str(tmp_path / "out.csv")]) == 0
    out = read(str(tmp_path / "out.csv"))
    assert len(out) == len(plain)


@pytest.mark.parametrize("layout", ["struct", "variables", "time_first", "rates", "no_time"])
def test_a_mat_file_with_each_sensor_in_a_variable_of_its_own(tmp_path, layout):
    """MATLAB lab scripts' layouts: ``imu.time/acc/gyro`` (a struct), ``t, acc, gyro``, ``Acc``/``Gyr`` with the
    time first (at one rate or two), ``acc, gyro`` without a time (with --rate): the same samples as one matrix."""
    from imucalib.scenarios import session

    rec = session("handheld", rng=2).recording
    t, acc, gyro = rec.t, rec.acc, rec.gyro
    content = {"struct": {"imu": {"time": t, "acc": acc, "gyro": gyro}},
               "variables": {"t": t[:, None], "acc": acc, "gyro": gyro, "note": np.array([1.0])},
               "time_first": {"Acc": np.column_stack([t, acc]), "Gyr": np.column_stack([t, gyro])},
               "rates": {"Acc": np.column_stack([t, acc]), "Gyr": np.column_stack([t[::2], gyro[::2]])},
               "no_time": {"acc": acc.T, "gyro": gyro.T}}[layout]
    savemat(tmp_path / "s.mat", content)
    with pytest.warns(ImucalibWarning, match="no matrix of every column"):
        got = read(str(tmp_path / "s.mat"), rate=100.0 if layout == "no_time" else None)
    if layout == "rates":  # the gyroscope interpolated onto the accelerometer's stamps, within its own span
        assert len(got) == len(rec) - 1
        np.testing.assert_array_equal(got.acc, acc[:-1])
        np.testing.assert_allclose(got.gyro[::2], gyro[::2][:len(got.gyro[::2])], rtol=1e-12)
    else:
        np.testing.assert_array_equal(got.acc, acc)
        np.testing.assert_array_equal(got.gyro, gyro)
    if layout not in ("no_time", "rates"):
        np.testing.assert_allclose(got.t, t - t[0] if got.t[0] == 0 else t, atol=1e-12)
