"""Safe writes: through a temporary file moved into place, never onto an input; strict JSON output."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.cli._common import print_json
from imucalib.io import write_csv
from imucalib.io.atomic import (
    OutputIsInputError,
    atomic_create,
    atomic_path,
    atomic_write,
    refuse_overwriting_inputs,
    temporary_prefix,
)
from imucalib.io.jsontext import dumps
from synth import tedaldi_session

SRC = Path(__file__).resolve().parents[1] / "src"


def strict_loads(text: str):
    """``json.loads`` that refuses NaN and Infinity, as strict parsers do."""
    def refuse(name):
        raise ValueError(f"not strict JSON: {name}")

    return json.loads(text, parse_constant=refuse)


def leftovers(directory: Path, name: str) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name.startswith(temporary_prefix(name)))


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    d = tmp_path_factory.mktemp("session")
    rec, _, _ = tedaldi_session(seed=12, noise_acc=0.003, noise_gyro=0.002)
    write_csv(d / "session.csv", rec)
    return d / "session.csv"


# ------------------------------------------------------------------ the helpers
@pytest.mark.parametrize("interrupt", [RuntimeError("disk on fire"), KeyboardInterrupt()])
def test_a_write_that_fails_half_way_leaves_the_old_file(tmp_path, interrupt):
    target = tmp_path / "out.txt"
    target.write_text("old contents\n")
    with pytest.raises(type(interrupt)), atomic_write(target) as fh:
        fh.write("new, but only half")
        fh.flush()
        assert leftovers(tmp_path, "out.txt")  # the temporary file is next to the target
        raise interrupt
    assert target.read_text() == "old contents\n"
    assert leftovers(tmp_path, "out.txt") == []
    # and with nothing there before, nothing is left
    with pytest.raises(type(interrupt)), atomic_write(tmp_path / "new.bin", "wb") as fh:
        fh.write(b"\x00" * 10)
        raise interrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_a_write_replaces_and_keeps_the_permissions(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    target.chmod(0o640)
    (tmp_path / f"{temporary_prefix(target)}stale.tmp").write_text("left by a killed run")
    with atomic_write(target) as fh:
        fh.write("new")
    assert target.read_text() == "new"
    assert target.stat().st_mode & 0o777 == 0o640
    with atomic_write(tmp_path / "fresh.txt") as fh:  # a new file: the umask's permissions, not 0600
        fh.write("x")
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "fresh.txt").stat().st_mode & 0o777 == 0o666 & ~mask
    assert leftovers(tmp_path, "out.txt") == [f"{temporary_prefix(target)}stale.tmp"]  # only the stale one


def test_atomic_path_keeps_the_suffix_and_cleans_up(tmp_path):
    target = tmp_path / "table.csv.gz"
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.name.endswith(".gz") and tmp.name.startswith(".table.csv.gz.")
        np.savetxt(tmp, np.eye(2))  # compressed, as the suffix says
    np.testing.assert_array_equal(np.loadtxt(target), np.eye(2))
    before = target.read_bytes()
    with pytest.raises(ValueError), atomic_path(target) as tmp:
        tmp.write_bytes(b"partial")
        raise ValueError("failed")
    assert target.read_bytes() == before and leftovers(tmp_path, target.name) == []


def test_atomic_create_never_replaces(tmp_path):
    target = tmp_path / "bag"
    with atomic_create(target) as inner:
        assert not inner.exists() and inner.name == "bag"
        inner.mkdir()
        (inner / "bag.db3").write_text("data")
    assert (target / "bag.db3").read_text() == "data"
    with pytest.raises(FileExistsError, match="never overwritten"), atomic_create(target):
        pass
    with pytest.raises(RuntimeError), atomic_create(tmp_path / "other") as inner:
        inner.mkdir()
        raise RuntimeError("killed half-way")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]


def test_refuse_overwriting_inputs(tmp_path):
    a = tmp_path / "a.csv"
    a.write_text("x")
    (tmp_path / "link.csv").symlink_to(a)
    os.link(a, tmp_path / "hard.csv")
    for same in (a, tmp_path / "link.csv", tmp_path / "hard.csv", tmp_path / "sub" / ".." / "a.csv"):
        with pytest.raises(OutputIsInputError, match="destroy the input"):
            refuse_overwriting_inputs([None, same], [a])
    with pytest.raises(OutputIsInputError, match="two outputs"):
        refuse_overwriting_inputs([tmp_path / "r.html", tmp_path / "r.html"], [a])
    refuse_overwriting_inputs([tmp_path / "b.csv", None], [a, None])  # different: fine


# ------------------------------------------------------------ the command line
def test_output_onto_an_input_is_refused_before_anything_happens(capsys, tmp_path, session):
    data = tmp_path / "rec.csv"
    data.write_bytes(session.read_bytes())
    original = data.read_bytes()
    cal = tmp_path / "cal.json"
    Calibration().save(cal)
    cal_text = cal.read_bytes()
    for args in (["calibrate", data, "-o", data], ["calibrate", data, "--report", data],
                 ["calibrate", data, "-o", tmp_path / "c.json", "--plot", tmp_path / "c.json"],
                 ["apply", cal, data, "-o", data], ["apply", cal, data, "-o", cal],
                 ["export", cal, "-o", cal], ["noise", data, "--kalibr", data],
                 ["noise", data, "--calibration", cal, "--plot", cal], ["validate", cal, data, "--plot", data]):
        code, out, err = run(capsys, *args)
        assert code == 2, args
        assert "choose" in err and "error" in err, err
        assert data.read_bytes() == original and cal.read_bytes() == cal_text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json", "rec.csv"]


def test_json_output_is_strict(capsys, tmp_path, session):
    text = dumps({"a": float("nan"), "b": [np.float64("inf"), 1.5], "c": np.array([np.nan, 2.0])})
    assert strict_loads(text) == {"a": None, "b": [None, 1.5], "c": [None, 2.0]}
    assert print_json({"x": -float("inf")}) == 0
    assert strict_loads(capsys.readouterr().out) == {"x": None}
    cal = Calibration(fit={"residual": float("nan"), "uncertainty": {"accelerometer.bias.x": np.inf}})
    assert strict_loads(cal.to_json())["fit"] == {"residual": None, "uncertainty": {"accelerometer.bias.x": None}}
    cal.save(tmp_path / "nan.json")
    assert strict_loads((tmp_path / "nan.json").read_text())["fit"]["residual"] is None
    for args in (["noise", session, "--json"], ["calibrate", session, "--json"],
                 ["compare", session, "--methods", "six_position,tedaldi2014", "--folds", "3", "--json"]):
        code, out, err = run(capsys, *args)
        assert code in (0, 3), err
        doc = strict_loads(out)
        if args[0] == "noise":  # a random walk not reached in a short rest: not available, not NaN
            assert None in doc["accelerometer"]["random_walk"]


def test_figures_go_through_a_temporary_file(capsys, tmp_path, session):
    pytest.importorskip("matplotlib", reason="plots need matplotlib (the plot extra)")
    from imucalib.io import read
    from imucalib.report import plot_allan

    rec = read(session)[:3000]
    for name in ("allan.png", "allan.svg", "allan"):  # no suffix: matplotlib's default format, as before
        plot_allan(rec, tmp_path / name)
    assert (tmp_path / "allan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "allan").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert b"<svg" in (tmp_path / "allan.svg").read_bytes()[:500]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["allan", "allan.png", "allan.svg"]


def test_an_interrupted_session_write_does_not_read_as_a_session(tmp_path, monkeypatch):
    import imucalib.io.sessionfiles as base
    from imucalib.scenarios import read_session, session, write_session

    sim = session("zhang2021", rng=0)
    write_session(sim, tmp_path / "s")
    assert read_session(tmp_path / "s").seed == 0
    original = base.write_recording

    def fail_at_the_tests(path, rec):
        if path.name.startswith("test_"):
            raise KeyboardInterrupt
        original(path, rec)

    monkeypatch.setattr(base, "write_recording", fail_at_the_tests)
    with pytest.raises(KeyboardInterrupt):
        write_session(session("zhang2021", rng=1), tmp_path / "s")
    assert not (tmp_path / "s" / "session.json").exists()  # new recordings, old index: no longer a session
    assert not [p for p in (tmp_path / "s").iterdir() if p.name.startswith(".")]
    monkeypatch.setattr(base, "write_recording", original)
    write_session(session("zhang2021", rng=1), tmp_path / "s")
    assert read_session(tmp_path / "s").seed == 1


# ---------------------------------------------------------------- SIGKILL
def _big_csv(path: Path, n: int) -> None:
    """``n`` rows of raw counts at 100 Hz, written quickly (the same readings on every row)."""
    with path.open("w") as fh:
        fh.write("t [s],ax,ay,az,gx,gy,gz\n")
        fh.write("".join(f"{k / 100:.2f},10,-20,1000,1,2,3\n" for k in range(n)))


@pytest.fixture(scope="module")
def big(tmp_path_factory):
    """A 1.5 M-row recording and an identity calibration of it."""
    d = tmp_path_factory.mktemp("big")
    _big_csv(d / "in.csv", 1_500_000)
    Calibration().save(d / "cal.json")
    return d


@pytest.mark.slow
@pytest.mark.parametrize("previous", [b"the previous output\n", None], ids=["over-a-file", "new-file"])
def test_sigkill_during_apply_leaves_the_previous_output(tmp_path, big, previous):
    d = tmp_path
    out = d / "out.csv"
    if previous is not None:
        out.write_bytes(previous)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, "-m", "imucalib.cli", "apply", str(big / "cal.json"), str(big / "in.csv"),
                             "-o", str(out)], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        tmp = []
        while time.monotonic() < deadline and proc.poll() is None:
            tmp = leftovers(d, out.name)
            if tmp and (d / tmp[0]).stat().st_size > 1_000_000:  # well into the writing
                break
            time.sleep(0.01)
        assert proc.poll() is None, f"apply ended before it could be killed: {proc.stderr.read().decode()}"
        assert tmp, "no temporary file appeared"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    if previous is None:
        assert not out.exists()
    else:
        assert out.read_bytes() == previous
    names = sorted(p.name for p in d.iterdir())
    assert names == sorted([*(["out.csv"] if previous else []), *tmp])  # and the hidden temporary file only
    # the leftover does not block the next write
    with atomic_write(out) as fh:
        fh.write("next run\n")
    assert out.read_text() == "next run\n"


# ---------------------------------------------------------------- ROS bags
def test_a_failed_bag_write_leaves_nothing_behind(tmp_path, monkeypatch, capsys):
    pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
    import imucalib.io.rosbag as rosbag
    from test_rosbag import write_bag

    rec, truth, _ = tedaldi_session(seed=3, poses=8)
    si = truth.apply(rec)
    src = write_bag(tmp_path / "in", "sqlite", {"/imu": (si.t[:200], si.acc[:200], si.gyro[:200]),
                                                "/other": (si.t[:5], si.acc[:5], si.gyro[:5])})
    cal = Calibration(units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
                             "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}})
    cal.save(tmp_path / "c.json")
    original = rosbag._add_connection_like
    calls = []

    def fail_on_the_second(*args):
        calls.append(1)
        if len(calls) == 2:
            raise OSError("no space left on device")
        return original(*args)

    monkeypatch.setattr(rosbag, "_add_connection_like", fail_on_the_second)
    argv = ["apply", tmp_path / "c.json", src, "-o", tmp_path / "out", "--topic", "/imu"]
    code, _, err = run(capsys, *argv)
    assert code == 2 and "no space left" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json", "in"]
    monkeypatch.setattr(rosbag, "_add_connection_like", original)
    code, _, err = run(capsys, *argv)  # the next run is not blocked
    assert code == 0, err
    assert (tmp_path / "out" / "metadata.yaml").is_file()
    assert main(["apply", str(tmp_path / "c.json"), str(src), "-o", str(src), "--topic", "/imu"]) == 2
    assert "destroy the input" in capsys.readouterr().err
