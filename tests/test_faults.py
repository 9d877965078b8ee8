"""Structural faults in every input: each is an error (exit 2) naming the file and the field or line."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.io import ReaderError, read, write_csv
from imucalib.recording import ImucalibWarning
from synth import tedaldi_session

SRC = str(Path(__file__).resolve().parents[1] / "src")


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def plain(err: str) -> bool:
    return "Traceback" not in err and "np." not in err and "numpy" not in err


@pytest.fixture(scope="module")
def si():
    rec, truth, _ = tedaldi_session(seed=5, poses=8)
    return truth.apply(rec)


@pytest.fixture
def bag(tmp_path, si):
    pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
    from test_rosbag import write_bag

    def make(kind, n=600):
        name = {"ros1": "b.bag", "sqlite": "b_sql", "mcap": "b_mcap"}[kind]
        return write_bag(tmp_path / name, kind, {"/imu": (si.t[:n], si.acc[:n], si.gyro[:n])})

    return make


def si_calibration(path):
    Calibration(units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
                       "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}}).save(path)
    return path


# ---------------------------------------------------------------- ROS bags
@pytest.mark.parametrize("kind", ["ros1", "mcap", "sqlite"])
def test_a_bag_with_flipped_bytes_is_an_error_naming_it(tmp_path, bag, kind, capsys):
    path = bag(kind)
    target = path if path.is_file() else next(p for p in path.iterdir() if p.suffix in (".mcap", ".db3"))
    clean = target.read_bytes()
    rng = np.random.default_rng(2)
    failures = 0
    for trial in range(12):
        data = bytearray(clean)
        for i in rng.integers(200, len(data), 1 + trial):
            data[i] ^= 0xFF
        target.write_bytes(bytes(data))
        try:
            with _quiet():
                read(path)
        except ReaderError as exc:
            failures += 1
            assert str(path) in str(exc) or str(target) in str(exc)
            assert plain(str(exc))
    target.write_bytes(clean)
    assert failures  # some of the damage is found (damage to a reading's value cannot be)
    # the worst case of all: the index names a message that is not there
    data = bytearray(clean)
    data[len(data) // 2:len(data) // 2 + 400] = b"\x5a" * 400
    target.write_bytes(bytes(data))
    cal = si_calibration(tmp_path / "c.json")
    code, out, err = run(capsys, "apply", cal, path, "-o", tmp_path / "o.csv")
    assert code in (0, 2) and plain(err), err  # (a hit inside readings only changes numbers)
    if code:
        assert str(path) in err or str(target) in err, err


class _quiet:
    def __enter__(self):
        import warnings

        self.ctx = warnings.catch_warnings()
        self.ctx.__enter__()
        warnings.simplefilter("ignore", ImucalibWarning)

    def __exit__(self, *exc):
        self.ctx.__exit__(*exc)


def test_apply_to_a_lone_mcap_writes_a_lone_mcap(tmp_path, bag, capsys):
    (mcap,) = bag("mcap").glob("*.mcap")
    cal = si_calibration(tmp_path / "c.json")
    code, out, err = run(capsys, "apply", cal, mcap, "-o", tmp_path / "out.mcap")
    assert code == 0, err
    assert (tmp_path / "out.mcap").is_file()
    np.testing.assert_array_equal(read(tmp_path / "out.mcap").acc, read(mcap).acc)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # nothing left behind


def test_a_killed_bag_write_leaves_nothing_that_blocks_the_next(tmp_path, bag, capsys):
    src = bag("sqlite")
    cal = si_calibration(tmp_path / "c.json")
    out = tmp_path / "out"
    child = textwrap.dedent(f"""
        import os, signal, sys
        import imucalib.io.rosbag as rosbag
        original = rosbag._add_connection_like
        def die(*args):
            original(*args)
            os.kill(os.getpid(), signal.SIGKILL)  # killed half-way through the write
        rosbag._add_connection_like = die
        from imucalib.cli import main
        sys.exit(main(["apply", {str(cal)!r}, {str(src)!r}, "-o", {str(out)!r}]))
    """)
    env = {**os.environ, "PYTHONPATH": SRC}
    proc = subprocess.run([sys.executable, "-c", child], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == -9
    assert not out.exists()
    assert any(p.name.startswith(".out.") for p in tmp_path.iterdir())  # the hidden leftover ...
    code, _, err = run(capsys, "apply", cal, src, "-o", out)  # ... does not block the next run
    assert code == 0, err
    assert len(read(out)) == 600


# ------------------------------------------------------ calibration files
@pytest.mark.parametrize(("text", "words"), [
    ("[]", "expected a JSON object (an imucalib calibration); got a list"),
    ("null", "got null"),
    ("42", "got a number"),
    ("{", "not valid JSON"),
    (lambda d: {**d, "units": {"accelerometer": d["units"]["accelerometer"]}}, "'units' has no 'gyroscope' entry"),
    (lambda d: {**d, "fit": [1, 2]}, "'fit': expected an object"),
    (lambda d: {**d, "gyroscope": {**d["gyroscope"], "bias": [1, 2]}}, "'gyroscope.bias': expected 3 numbers"),
    (lambda d: {**d, "accelerometer": {**d["accelerometer"], "scale": "1"}}, "'accelerometer.scale'"),
    (lambda d: {**d, "gravity": "9.8"}, "'gravity': expected a positive number"),
    (lambda d: {**d, "lever_arm": [0, 0]}, "'lever_arm': expected 3 numbers"),
])
def test_a_calibration_file_that_is_not_one(tmp_path, capsys, si, text, words):
    csv = tmp_path / "d.csv"
    write_csv(csv, si)
    path = tmp_path / "cal.json"
    good = Calibration(units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
                              "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}}).to_dict()
    path.write_text(text if isinstance(text, str) else json.dumps(text(good)))
    for command in (["apply", path, csv, "-o", tmp_path / "o.csv"], ["export", path], ["validate", path, csv]):
        code, out, err = run(capsys, *command)
        assert code == 2, (command, err)
        assert f"{path}: " in err and words in err and plain(err), err


# ------------------------------------------------------- session files
def test_a_session_without_units_or_with_bad_segments(tmp_path, capsys):
    code, _, err = run(capsys, "simulate", "--scenario", "handheld", "--seed", "1", "-o", tmp_path / "s")
    assert code == 0, err
    meta_path = tmp_path / "s" / "session.json"
    meta = json.loads(meta_path.read_text())
    for change, words in ((lambda m: m.pop("units"), "lacks 'units'"),
                          (lambda m: m["units"].update(gyroscope="furlongs"), "'units.gyroscope': expected one of"),
                          (lambda m: m["files"].update({"recording.csv": [{"start": 5}]}),
                           "'files.recording.csv', segment 1"),
                          (lambda m: m.update(files=[]), "'files': expected an object")):
        broken = json.loads(json.dumps(meta))
        change(broken)
        meta_path.write_text(json.dumps(broken))
        code, _, err = run(capsys, "calibrate", tmp_path / "s")
        assert code == 2 and str(meta_path) in err and words in err and plain(err), err
    meta_path.write_text("[1, 2]")
    code, _, err = run(capsys, "calibrate", tmp_path / "s")
    assert code == 2 and "expected a JSON object" in err
    for text, words in (("[" * 10_000 + "]" * 10_000, "nested more than 64 levels deep"),
                        ('{"format": ' * 10_000 + "1" + "}" * 10_000, "nested more than 64 levels deep"),
                        ('{"format": "imucalib.session", "x": Infinity}', "Infinity is not a JSON number")):
        meta_path.write_text(text)
        code, _, err = run(capsys, "calibrate", tmp_path / "s")
        assert code == 2 and str(meta_path) in err and words in err and plain(err), err


# --------------------------------------------------------- text and MAT
def _imutk(path, n=300, bad_line=None, bad="0.05x 1 2 3"):
    lines = [f"{k * 0.01:.3f} {1 + k % 3} 2 3" for k in range(n)]
    if bad_line:
        lines[bad_line - 1] = bad
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(("bad", "words"), [("0.05x 1 2 3", "line 6, time: '0.05x' is not a number"),
                                            ("0.05 1 2", "line 6: expected 4 values, found 3"),
                                            ("0.05,1,2,3", "line 6: expected 4 values, found 1"),
                                            ("0.05 1 nan 3", "line 6, y: 'nan' is not finite"),
                                            ("0.04 1 2 3", "line 6, time: timestamp duplicated (0.04 then 0.04)")])
def test_imutk_text_that_does_not_parse_names_file_and_line(tmp_path, capsys, bad, words):
    acc = _imutk(tmp_path / "acc.txt")
    gyro = _imutk(tmp_path / "gyro.txt", bad_line=6, bad=bad)
    code, _, err = run(capsys, "calibrate", acc, gyro, "--reader", "imutk")
    assert code == 2 and f"{gyro}: {words}" in err and plain(err), err


@pytest.mark.parametrize("name", ["d.csv", "acc.txt"])
def test_utf16_text_is_refused_and_the_advice_works(tmp_path, capsys, si, name):
    path = tmp_path / name
    if name.endswith(".csv"):
        write_csv(tmp_path / "u8.csv", si)
        text = (tmp_path / "u8.csv").read_text()
        argv = [path]
    else:
        text = _imutk(tmp_path / "u8.txt").read_text()
        argv = [path, _imutk(tmp_path / "gyro.txt")]
    path.write_text(text, encoding="utf-16")
    code, _, err = run(capsys, "calibrate", *argv)
    assert code == 2 and f"{path}: the text is UTF-16 encoded" in err and plain(err), err
    if shutil.which("iconv") is None:
        pytest.skip("iconv is not installed: the suggested command cannot be run here")
    command = err.split("or ")[-1].rstrip(")\n")
    assert command.startswith("iconv")
    subprocess.run(command, shell=True, check=True, cwd=tmp_path)
    fixed = tmp_path / f"{path.stem}-utf8{path.suffix}"
    assert read([fixed, *argv[1:]]).acc.shape[0] > 0


def test_a_matlab_v73_file_is_refused_with_the_way_to_save_it(tmp_path, capsys):
    path = tmp_path / "d.mat"
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    path.write_bytes(header.ljust(512, b" ") + b"\x89HDF\r\n\x1a\n" + bytes(100))
    code, _, err = run(capsys, "calibrate", path, "--variable", "imu")
    assert code == 2 and f"{path}: a MATLAB v7.3 file" in err and "'-v7'" in err and plain(err), err
    savemat(tmp_path / "ok.mat", {"imu": np.ones((5, 7))})  # a v5 file still reads
    assert read(tmp_path / "ok.mat", variable="imu", columns=["-", "1", "2", "3", "4", "5", "6"], rate=10.0)


def test_no_overflow_warning_reaches_the_terminal(tmp_path):
    path = tmp_path / "huge.csv"
    t = np.arange(400) * 0.01
    rows = [f"{x:.2f},{1e200 if k > 100 else 1.0},2,3,4,5,6" for k, x in enumerate(t)]
    path.write_text("t,ax,ay,az,gx,gy,gz\n" + "\n".join(rows) + "\n")
    env = {**os.environ, "PYTHONPATH": SRC}
    proc = subprocess.run([sys.executable, "-m", "imucalib.cli", "calibrate", str(path)], env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    err = proc.stderr.replace(str(path), "FILE")
    assert "RuntimeWarning" not in err and "overflow" not in err and plain(err), err
    assert "FILE: sample 102: an accelerometer reading of 1e+200 is beyond any sensor's range" in err


# ------------------------------------------------------ small files read whole
def test_small_files_are_read_by_one_bounded_reader(tmp_path):
    """A calibration, a sections file and a noise file are each read at most to their limit (/dev/zero is
    refused, not read), and each fault is told in the same words, behind the file's name or option."""
    import time

    from imucalib.calibration import CalibrationFileError
    from imucalib.cli._common import CliError
    from imucalib.cli.calibration import _sections
    from imucalib.export import ExportError, read_noise
    from imucalib.io.jsontext import SmallFileError, read_json, read_small_text

    (tmp_path / "binary").write_bytes(b"\xff\xfe\x00\x81" * 10)
    (tmp_path / "broken.json").write_text('{"a": [1, 2}')
    readers = [(Calibration.load, CalibrationFileError, "{p}: "), (_sections, CliError, "--sections {p}: "),
               (read_noise, ExportError, "--noise {p}: ")]
    cases = [("/dev/zero", "larger than"), (str(tmp_path), "is a directory, not a"),
             (str(tmp_path / "none.json"), "file not found"), (str(tmp_path / "binary"), "not a text file")]
    for load, error, prefix in readers:
        for path, words in cases:
            if not Path(path).exists() and path == "/dev/zero":
                continue
            start = time.perf_counter()
            with pytest.raises(error) as info:
                load(path)
            assert str(info.value).startswith(prefix.format(p=path)) and words in str(info.value), str(info.value)
            assert time.perf_counter() - start < 5  # bounded: never /dev/zero read whole
    for load, error, _ in readers[:2]:  # the two JSON ones
        with pytest.raises(error, match=r"not valid JSON \(Expecting ',' delimiter at line 1, column 12\)"):
            load(str(tmp_path / "broken.json"))
    (tmp_path / "ok.json").write_bytes(b'\xef\xbb\xbf{"a": 1}')  # a byte-order mark is dropped
    assert read_json(tmp_path / "ok.json", 100, "test file") == {"a": 1}
    with pytest.raises(SmallFileError, match="^larger than 10 bytes, not a test file: tiny$"):
        read_small_text(tmp_path / "ok.json", 10, "test file", "tiny")
