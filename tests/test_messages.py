"""What the user reads: every error path in plain words (exit 2, no numpy text, no traceback), advice that
works when followed, inputs read alike by calibrate and apply, the Xsens export, units checked."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.io import read
from synth import tedaldi_session


def run(capsys, *args):
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:  # argparse's own errors (a bad option value): usage, then one error line
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def plain(err: str, *paths) -> bool:
    for p in paths:
        err = err.replace(str(p), "FILE")
    return "Traceback" not in err and "np." not in err and "numpy" not in err and "dtype" not in err


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One session written in every form the readers take."""
    d = tmp_path_factory.mktemp("inputs")
    raw, truth, _ = tedaldi_session(seed=7, noise_acc=0.003, noise_gyro=0.002, poses=16)
    si = truth.apply(raw)
    table = np.column_stack([si.t, si.acc, si.gyro])
    f = {"truth": truth, "si": si}
    f["csv"] = d / "plain.csv"
    np.savetxt(f["csv"], table, fmt="%.12g", delimiter=",", comments="",
               header="t [s],ax [m/s^2],ay [m/s^2],az [m/s^2],gx [rad/s],gy [rad/s],gz [rad/s]")
    f["bare"] = d / "bare.csv"  # no header, no units
    np.savetxt(f["bare"], table, fmt="%.12g", delimiter=",")
    f["serial"] = d / "serial.txt"  # six columns, no time
    np.savetxt(f["serial"], table[:, 1:], fmt="%.12g", delimiter=" ")
    for name, cols in (("acc", slice(1, 4)), ("gyro", slice(4, 7))):
        f[name] = d / f"imu_{name}.txt"
        np.savetxt(f[name], np.column_stack([table[:, 0], table[:, cols]]), fmt="%.12g", delimiter=" ")
    f["xsens"] = d / "MT_0120067F-000.txt"
    ticks = 1_234_567 + np.round(si.t * 1e4).astype(np.int64)
    with f["xsens"].open("w") as fh:
        fh.write("// General information:\n//  MT Manager version: 2022.2.0\n// Device information:\n"
                 "//  DeviceId: 00B42D4F\n// Coordinate system: ENU\n")
        fh.write("PacketCounter\tSampleTimeFine\tYear\tAcc_X\tAcc_Y\tAcc_Z\tGyr_X\tGyr_Y\tGyr_Z\tRoll\n")
        for k in range(len(si)):
            fh.write("\t".join([str(k), str(ticks[k]), "NaN", *(f"{v:.12g}" for v in table[k, 1:]), "0.1"]) + "\n")
    return f


@pytest.fixture(scope="module")
def cal_si(files, tmp_path_factory):
    path = tmp_path_factory.mktemp("cal") / "si.json"
    Calibration(units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
                       "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}}).save(path)
    return path


# ------------------------------------------------------------- the sweep
BAD = [  # (arguments, words the error holds); {csv} etc. are the fixture's files
    (["calibrate", "{missing}"], "file not found"),
    (["calibrate", "{csv}", "--method", "nope"], "unknown method 'nope'"),
    (["calibrate", "{csv}", "--columns", "t,ax,ay,az,gx"], "--columns needs 7 entries"),
    (["calibrate", "{csv}", "--columns", "t,ax,ay,az,ax,gy,gz"], "for both ax and gx"),
    (["calibrate", "{csv}", "--columns", "t,ax,ay,az,nope,gy,gz"], "no such column"),
    (["calibrate", "{csv}", "--rate", "100"], "has a time column"),
    (["calibrate", "{serial}"], "no time column found; pass --rate HZ"),
    (["calibrate", "{csv}", "--topic", "/imu"], "topic applies to ROS bags"),
    (["calibrate", "{acc}", "{gyro}", "{csv}"], "several files are read as blocks"),
    (["calibrate", "{csv}", "--reader", "imutk"], "takes two files"),
    (["calibrate", "{csv}", "--gravity", "-3"], "expected a positive number"),
    (["calibrate", "{csv}", "--gravity", "abc"], "expected a number"),
    (["calibrate", "{csv}", "--keep-terms"], "--keep-terms applies to --method zhang2021 only"),
    (["calibrate", "{xsens}", "--rate", "100"], "carries its own time"),
    (["apply", "{cal}", "{csv}", "-o", "{csv}"], "destroy the input"),
    (["apply", "{cal}", "{missing}", "-o", "{out}"], "file not found"),
    (["apply", "{cal}", "{acc}", "{gyro}", "{csv}", "-o", "{out}"], "several files are read as blocks"),
    (["apply", "{missing}", "{csv}", "-o", "{out}"], "calibration file not found"),
    (["apply", "{csv}", "{csv}", "-o", "{out}"], "not valid JSON"),
    (["apply", "{cal}", "{csv}", "-o", "{out}", "--columns", "0,1,2,3,1,5,6"], "for both ax and gx"),
    (["export", "{csv}"], "not valid JSON"),
    (["validate", "{cal}", "{serial}"], "pass --rate HZ"),
]


@pytest.mark.parametrize(("argv", "words"), BAD, ids=[" ".join(a) for a, _ in BAD])
def test_every_error_path_is_plain_words_and_exit_2(files, cal_si, tmp_path, capsys, argv, words):
    names = {**{k: v for k, v in files.items() if isinstance(v, Path)}, "cal": cal_si,
             "missing": tmp_path / "missing.csv", "out": tmp_path / "out.csv"}
    args = [a.format(**names) for a in argv]
    code, out, err = run(capsys, *args)
    assert code == 2, err
    assert out == ""
    assert words in err, err
    *before, last = err.splitlines()
    assert last.startswith(f"imucalib {argv[0]}: error: "), err  # one line, after any warnings
    assert all(line.startswith(("imucalib: warning: ", "usage: ", " ")) for line in before), err
    assert plain(err, *names.values()), err


# ------------------------------------------------------ advice that works
def test_the_columns_form_help_gives_works_with_a_space(files, cal_si, tmp_path, capsys):
    code, out, err = run(capsys, "apply", cal_si, files["serial"], "--columns", "-,0,1,2,3,4,5", "--rate", "100",
                         "--acc-unit", "m/s^2", "--gyro-unit", "rad/s", "-o", tmp_path / "o.csv")
    assert code == 0, err
    code, out, err = run(capsys, "calibrate", "--help")
    assert "--columns -,0,1,2,3,4,5" in re.sub(r"\s+", " ", out)


def _advised_flags(message: str) -> list[str]:
    """The options a message tells the user to pass ('pass --x A --y B')."""
    m = re.search(r"pass ((?:--[\w-]+ [^\s,;)]+\s?)+)", message)
    assert m, message
    return shlex.split(m.group(1))


def test_the_unit_note_says_what_the_data_look_like_and_its_flags_work(files, tmp_path, capsys):
    code, _, err = run(capsys, "calibrate", files["bare"], "-o", tmp_path / "a.json")
    assert code in (0, 3), err
    note = next(line for line in err.splitlines() if "look like physical units" in line)
    assert "accelerometer like m/s^2 (median norm 9.8" in note and "gyroscope like rad/s" in note
    flags = _advised_flags(note)
    assert flags == ["--acc-unit", "m/s^2", "--gyro-unit", "rad/s"]
    code, _, err = run(capsys, "calibrate", files["bare"], *flags, "-o", tmp_path / "b.json")
    assert code in (0, 3) and "look like" not in err, err
    assert Calibration.load(tmp_path / "b.json").units["accelerometer"]["raw"] == "m/s^2"
    # data in g and deg/s are told apart too
    si = files["si"]
    table = np.column_stack([si.t, si.acc / 9.80665, np.degrees(si.gyro)])
    np.savetxt(tmp_path / "gdeg.csv", table, fmt="%.12g", delimiter=",")
    code, _, err = run(capsys, "calibrate", tmp_path / "gdeg.csv", "-o", tmp_path / "c.json")
    note = next(line for line in err.splitlines() if "look like physical units" in line)
    assert _advised_flags(note) == ["--acc-unit", "g", "--gyro-unit", "deg/s"], err
    code, _, err = run(capsys, "calibrate", tmp_path / "gdeg.csv", "--acc-unit", "g", "--gyro-unit", "deg/s",
                       "-o", tmp_path / "d.json")
    assert code in (0, 3) and "look like" not in err, err


def test_advice_to_pass_rate_and_topic_works(files, tmp_path, capsys):
    code, _, err = run(capsys, "calibrate", files["serial"])
    flags = _advised_flags(err.splitlines()[-1])
    assert flags == ["--rate", "HZ"]
    code, _, err = run(capsys, "calibrate", files["serial"], "--rate", "100", "-o", tmp_path / "c.json")
    assert code in (0, 3), err


def test_gravity_outside_the_earths_range_is_a_warning_naming_it(files, tmp_path, capsys):
    code, _, err = run(capsys, "calibrate", files["csv"], "--gravity", "1", "-o", tmp_path / "c.json")
    assert "warning: --gravity 1: 1 m/s^2 is outside 9.74-9.87 m/s^2" in err
    code, _, err = run(capsys, "calibrate", files["csv"], "--gravity", "9.81", "-o", tmp_path / "d.json")
    assert "--gravity" not in err


# ----------------------------------------------------------- same inputs
def test_apply_takes_every_input_calibrate_takes(files, tmp_path, capsys):
    code, _, err = run(capsys, "calibrate", files["acc"], files["gyro"], "--reader", "imutk", "-o",
                       tmp_path / "tk.json")
    assert code in (0, 3), err
    code, _, err = run(capsys, "apply", tmp_path / "tk.json", files["acc"], files["gyro"], "--reader", "imutk",
                       "-o", tmp_path / "tk.csv")
    assert code == 0, err
    out = read(tmp_path / "tk.csv", acc_unit="counts", gyro_unit="counts")
    ref = Calibration.load(tmp_path / "tk.json").apply(read([files["acc"], files["gyro"]], reader="imutk"))
    np.testing.assert_allclose(out.extra["acc_x_cal [m/s^2]"], ref.acc[:, 0], rtol=1e-9, atol=1e-12)


def test_an_xsens_export_reads_with_no_flags_as_the_plain_csv(files, tmp_path, capsys):
    rec, ref = read(files["xsens"]), read(files["csv"])
    assert rec.metadata["format"] == "Xsens MT Manager"
    assert (rec.acc_unit, rec.gyro_unit) == ("m/s^2", "rad/s")
    np.testing.assert_allclose(rec.t, ref.t - ref.t[0], atol=1e-9)  # 10 kHz ticks, not microseconds
    np.testing.assert_array_equal(rec.acc, ref.acc)
    np.testing.assert_array_equal(rec.gyro, ref.gyro)
    a = json.loads(run(capsys, "calibrate", files["xsens"], "--json")[1])
    b = json.loads(run(capsys, "calibrate", files["csv"], "--json")[1])
    np.testing.assert_allclose(a["gyroscope"]["scale"], b["gyroscope"]["scale"], rtol=1e-9)
    np.testing.assert_allclose(a["accelerometer"]["bias"], b["accelerometer"]["bias"], rtol=1e-6, atol=1e-9)


def test_advice_to_name_the_columns_works(files, tmp_path, capsys):
    si = files["si"]
    path = tmp_path / "named.csv"
    np.savetxt(path, np.column_stack([si.t, si.acc, si.gyro]), fmt="%.12g", delimiter=",", comments="",
               header="time,a1,a2,a3,w1,w2,w3")
    code, _, err = run(capsys, "calibrate", path)
    assert code == 2 and "pass --columns with the names in the order t,ax,ay,az,gx,gy,gz" in err, err
    code, _, err = run(capsys, "calibrate", path, "--columns", "time,a1,a2,a3,w1,w2,w3", "--acc-unit", "m/s^2",
                       "--gyro-unit", "rad/s", "-o", tmp_path / "c.json")
    assert code in (0, 3), err


def test_apply_takes_a_phone_pair(files, cal_si, tmp_path, capsys):
    si = files["si"]
    for name, what, data in (("acc.csv", "Acceleration", si.acc), ("gyr.csv", "Gyroscope", si.gyro)):
        unit = "m/s^2" if what == "Acceleration" else "rad/s"
        header = ",".join(['"Time (s)"', *(f'"{what} {a} ({unit})"' for a in "xyz"), f'"Absolute ({unit})"'])
        np.savetxt(tmp_path / name, np.column_stack([si.t, data, np.linalg.norm(data, axis=1)]), fmt="%.12g",
                   delimiter=",", comments="", header=header)
    code, _, err = run(capsys, "apply", cal_si, tmp_path / "acc.csv", tmp_path / "gyr.csv", "-o", tmp_path / "o.csv")
    assert code == 0, err
    out = read(tmp_path / "o.csv")
    np.testing.assert_allclose(out.extra["acc_x_cal [m/s^2]"], si.acc[:, 0], rtol=1e-9)
    code, _, err = run(capsys, "apply", cal_si, tmp_path / "acc.csv", tmp_path / "gyr.csv", "--acc-unit", "g",
                       "-o", tmp_path / "p.csv")  # the option wins over the header, with a warning saying who is right
    assert code == 2 and "--acc-unit g overrides the header" in err and "the header looks right" in err, err
    assert "maps accelerometer readings in 'm/s^2'" in err, err
