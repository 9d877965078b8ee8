"""Real recordings from other projects (shared/data/public), read as their authors left them.

Each test checks what the file holds against an independent reading of its text (numpy on the lines), so a
reader that shifts, drops or rescales a row fails.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib import read as read_data
from imucalib.io import ReaderError, read
from imucalib.methods.ferraris import SECTION_NAMES, parse_sections
from imucalib.recording import ImucalibWarning

PUBLIC = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "public"


def _need(*parts: str) -> Path:
    path = PUBLIC.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{path} not present (fresh clone): real-data test skipped")
    return path


def _read(*args, via=read, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = via(*args, **kw)
    return rec, [str(w.message) for w in caught if issubclass(w.category, ImucalibWarning)]


def test_fxos8700_serial_monitor_dump_reads_into_its_twenty_blocks():
    path = _need("fxos8700_blocks", "data_sample2.csv")
    rec, notes = _read(path, rate=400, acc_unit="m/s^2")
    lines = path.read_text().splitlines()
    rows = [ln for ln in lines if ln and (ln[0].isdigit() or ln[0] == "-") and not ln.startswith("---")]
    expect = np.array([[float(c) for c in ln.split(",")] for ln in rows])
    assert rec.gyro is None and rec.acc.shape == expect.shape == (80000, 3)
    np.testing.assert_array_equal(rec.acc, expect)
    assert rec.metadata["blocks"] == [[4000 * k, 4000 * (k + 1)] for k in range(20)]  # 20 blocks of 10 s at 400 Hz
    assert np.median(np.diff(rec.t)) == pytest.approx(1 / 400)
    assert rec.t[4000] - rec.t[3999] == pytest.approx(101 / 400)  # no time between blocks: 100 steps put there
    assert any("cut the rows into 20 blocks" in n for n in notes)
    held = [n for n in notes if "repeat the row before exactly" in n]
    assert len(held) == 1 and "updates at about 100 Hz" in held[0]  # an FXOS8700 at 100 Hz read at 400 Hz
    assert any("skipped 3 lines before the data" in n for n in notes)


def test_mpu6050_faces_millis_stamps_are_milliseconds():
    names = ["x_axis_pos", "x_axis_neg", "y_axis_pos", "y_axis_neg", "z_axis_pos", "z_axis_neg"]
    paths = [_need("mpu6050_faces", f"{n}.csv") for n in names]
    rec, notes = _read(paths, acc_unit="m/s^2")
    first = np.loadtxt(paths[0], delimiter=",", skiprows=1)
    assert rec.metadata["blocks"][0] == [0, len(first)]
    np.testing.assert_array_equal(rec.acc[:len(first)], first[:, 1:4])
    np.testing.assert_array_equal(rec.temperature[:len(first)], first[:, 4])
    step = np.median(np.diff(first[:, 0])) / 1000.0  # millis(): the step in seconds
    assert np.median(np.diff(rec.t)) == pytest.approx(step)
    assert 40 < rec.rate < 80
    ms = [n for n in notes if "read in milliseconds" in n]
    assert len(ms) == 1 and "(and in 5 more of the files)" in ms[0]
    gyro = [n for n in notes if "not whole numbers" in n]
    assert len(gyro) == 1 and "pass --gyro-unit rad/s" in gyro[0]


def test_ferraris_session_counter_sections_and_calibration(tmp_path):
    path = _need("ferraris_imucal", "example_ferraris_session.csv")
    sections = _need("ferraris_imucal", "example_ferraris_session_list.json")
    with pytest.raises(ReaderError, match=r"'n_samples' counts samples, it is not a time; pass --rate"):
        read(path, acc_unit="m/s^2", gyro_unit="deg/s")
    rec, _ = _read(path, rate=102.4, acc_unit="m/s^2", gyro_unit="deg/s")
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(rec.gyro, data[:, 1:4])
    np.testing.assert_array_equal(rec.acc, data[:, 4:7])
    assert np.allclose(rec.t, data[:, 0] / 102.4) and "n_samples" not in rec.extra
    doc = json.loads(sections.read_text())
    ranges = parse_sections(doc)
    assert ranges == {k: [doc[k]["start"], doc[k]["end"]] for k in SECTION_NAMES}
    from imucalib.methods.ferraris import calibrate

    cal = calibrate(rec, sections=ranges, gravity=9.80665)
    turns = {s["axis"]: s["measured_deg"] for s in cal.fit["turn_sections"]}
    assert all(abs(abs(turns[a]) - 360.0) < 20.0 for a in range(3))  # the rate makes the turns full turns


def test_mpu9250_caldata_ten_columns_take_the_magnetometer():
    path = _need("mpu9250_gesture", "caldata.mat")
    from scipy.io import loadmat

    m = loadmat(str(path))["cal_data"].astype(float)
    rec, notes = _read(path, via=read_data)
    np.testing.assert_array_equal(rec.mag, m[:, 7:10])
    np.testing.assert_array_equal(rec.gyro, m[:, 4:7])
    assert any("10 columns: taken as t,ax,ay,az,gx,gy,gz,mx,my,mz" in n for n in notes)
    by_field, _ = _read(path, via=read_data, columns="t=0,ax=1,ay=2,az=3,gx=4,gy=5,gz=6,mx=7,my=8,mz=9".split(","))
    np.testing.assert_array_equal(by_field.mag, rec.mag)


@pytest.mark.parametrize("session", ["data1", "data2", "data3", "data4"])
def test_imutk_sessions_read_unrepaired(session):
    acc = _need("imutk_sessions", session, "acc_data.txt")
    gyro = _need("imutk_sessions", session, "gyro_data.txt")
    rec, notes = _read([acc, gyro], reader="imutk", acc_unit="m/s^2", gyro_unit="rad/s")
    raw = np.loadtxt(acc)
    np.testing.assert_array_equal(rec.acc, raw[:, 1:])
    assert not [n for n in notes if "resolution" in n or "repeat" in n]
