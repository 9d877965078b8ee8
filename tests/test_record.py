"""Guided recording: the incremental detector against the offline one, and sessions replayed live.

Simulated hand-held sessions (``imucalib simulate --scenario handheld``) are
sent through standard input, a pseudo-terminal at real time ×N and a TCP
socket; the events must find the poses simulated, suggest the next pose before
the session is complete, say ``complete``, and the file written must be the
bytes sent.
"""

import contextlib
import io
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from imucalib import segment as sg
from imucalib.io import read, write_csv
from imucalib.record import Recorder, record
from imucalib.scenarios.handheld import generate
from test_record_stream import record_here, wait_port_open

SRC = Path(__file__).resolve().parents[1] / "src"
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
CLI = [sys.executable, "-m", "imucalib.cli"]


@pytest.fixture(scope="module")
def handheld(tmp_path_factory):
    """The default hand-held session (30 poses) as ``imucalib simulate`` writes it."""
    from imucalib.cli import main

    d = tmp_path_factory.mktemp("hh")
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["simulate", "--scenario", "handheld", "--seed", "3", "-o", str(d / "sim")])
    assert code == 0, err.getvalue()
    session = json.loads((d / "sim" / "session.json").read_text())
    return d / "sim" / "recording.csv", session["options"]["n_poses"]


@pytest.fixture(scope="module")
def short_session(tmp_path_factory):
    """A shorter hand-held session (14 poses, 8 s rest) for the real-time replays."""
    s = generate(np.random.default_rng(7), n_poses=14, rest=8.0)
    path = tmp_path_factory.mktemp("short") / "short.csv"
    write_csv(path, s["recording"])
    return path, 14


def _events(text: str) -> list[dict]:
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def _check_session(events, n_poses):
    kinds = [e["event"] for e in events]
    poses = [e for e in events if e["event"] == "pose"]
    assert abs(len(poses) - n_poses) <= 1, len(poses)
    assert "complete" in kinds
    first_complete = kinds.index("complete")
    assert "next_pose" in kinds[:first_complete]  # the next pose was suggested before the session was complete
    # … and before the poses covered every axis up and down (within 60°, as pose_coverage asks)
    covered = [k for k, e in enumerate(events) if e["event"] == "pose"
               and all(lo <= -0.5 and hi >= 0.5 for lo, hi in e["coverage"].values())]
    assert covered and "next_pose" in kinds[:covered[0]]
    assert kinds.count("complete") == 1
    nxt = [e for e in events if e["event"] == "next_pose"]
    assert all(np.linalg.norm(e["up"]) == pytest.approx(1.0) and e["words"] for e in nxt)
    starts = [p["start"] for p in poses]
    assert starts == sorted(starts) and all(p["stop"] - p["start"] >= 100 for p in poses)  # ≥ 1 s at 100 Hz
    end = events[-1]
    assert end["event"] == "end" and end["bad_lines"] == 0 and end["complete"] and end["verdict"] == "accepted"


# -------------------------------------------------------------- the detector
def test_stream_statistic_is_the_offline_one_bit_for_bit():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(150_000, 3)) * 0.01 + [0.1, 0.2, 9.8]  # more than two blocks
    whole = sg.variance_norm(x, 101)
    # the offline statistic is what it was: the norm of the moving variance, block by block
    var = sg.moving_variance(x, 101)
    assert np.array_equal(whole, np.sqrt(np.einsum("ij,ij->i", var, var)))
    for seed in range(3):
        stream = sg.VarianceNormStream(101, x.mean(axis=0))
        i, r = 0, np.random.default_rng(seed)
        while i < len(x):
            k = int(r.integers(1, 5000))
            stream.push(x[i:i + k])
            assert stream.final == max(min(i + k, len(x)) - 50, 0)
            i += k
        stream.close()
        assert np.array_equal(stream.statistic, whole)


def test_still_detector_finds_the_offline_intervals():
    s = generate(np.random.default_rng(5), n_poses=12, rest=10.0)
    rec = s["recording"]
    rest = sg.find_initial_rest(rec)
    offline = sg.static_at(rec, rest, 6.0)
    det = sg.StillDetector(rec.acc[rest.slice], rec.rate, multiplier=6.0)
    online, i, r = [], 0, np.random.default_rng(1)
    while i < len(rec):
        k = int(r.integers(1, 300))
        online += det.push(rec.acc[i:i + k])
        assert all(iv.stop < det.stream.final for iv in online)  # reported once ended
        i += k
    online += det.close()
    assert [(iv.start, iv.stop) for iv in online] == [(iv.start, iv.stop) for iv in offline]
    assert len(online) == 13  # the rest and 12 poses


# ------------------------------------------------------------------ replays
@pytest.mark.slow
def test_replay_through_stdin_then_calibrate(tmp_path, handheld):
    csv, n_poses = handheld
    out = tmp_path / "session.csv"
    run = subprocess.run([*CLI, "record", "-", "-o", str(out), "--events", "-", "--calibrate",
                          str(tmp_path / "cal.json")], input=csv.read_bytes(), capture_output=True, env=ENV,
                         timeout=600)
    assert run.returncode == 0, run.stderr.decode()
    lines = run.stdout.decode().splitlines()
    events = _events("\n".join(ln for ln in lines if ln.startswith('{"event"')))
    _check_session(events, n_poses)
    assert out.read_bytes() == csv.read_bytes()  # every line, in order, unchanged
    assert not (tmp_path / "session.csv.partial").exists()
    cal = json.loads((tmp_path / "cal.json").read_text())
    assert cal["fit"]["verdict"] == "accepted"
    assert "pose 1 done" in run.stderr.decode()  # the view goes to stderr when the events go to stdout
    # the last line says the verdict, the one calibrate gave
    assert run.stderr.decode().splitlines()[-1] == "verdict: accepted — the session calibrates; nothing to redo"


@pytest.mark.slow
def test_replay_through_a_pty_in_real_time(tmp_path, short_session):
    pty = pytest.importorskip("pty")
    csv, n_poses = short_session
    data = csv.read_bytes().splitlines(keepends=True)
    t = read(csv).t
    speed = 25.0
    master, slave = pty.openpty()
    import termios

    attrs = termios.tcgetattr(slave)
    attrs[3] &= ~termios.ECHO  # the terminal does not echo what is typed into it
    termios.tcsetattr(slave, termios.TCSANOW, attrs)
    out, events = tmp_path / "live.csv", tmp_path / "events.jsonl"
    proc = subprocess.Popen([*CLI, "record", "-", "-o", str(out), "--events", str(events)], stdin=slave,
                            stdout=slave, stderr=slave, env=ENV)
    os.close(slave)
    screen = bytearray()

    def drain():
        while True:
            try:
                chunk = os.read(master, 65536)
            except BlockingIOError:
                time.sleep(0.01)
                continue
            except OSError:  # the recorder closed the terminal
                return
            if not chunk:
                return
            screen.extend(chunk)

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    start = time.monotonic()
    os.set_blocking(master, False)  # a recorder that stopped reading fails the test instead of hanging it

    def send(chunk):
        while chunk and proc.poll() is None and time.monotonic() - start < 300:
            try:
                chunk = chunk[os.write(master, chunk):]
            except BlockingIOError:
                time.sleep(0.01)
        assert not chunk, "the recorder stopped reading"

    send(data[0])  # the header
    for k, line in enumerate(data[1:]):
        lag = t[k] / speed - (time.monotonic() - start)
        if lag > 0:
            time.sleep(lag)
        send(line)
    send(b"\x04")  # Ctrl-D: the end of the input
    assert proc.wait(timeout=300) == 0, screen.decode(errors="replace")[-2000:]
    os.close(master)
    assert out.read_bytes() == csv.read_bytes()
    _check_session(_events(events.read_text()), n_poses)
    assert b"pose 1" in screen or b"poses held" in screen  # the live view was drawn on the terminal


@pytest.mark.slow
def test_replay_through_tcp(tmp_path, short_session):
    csv, n_poses = short_session
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def serve():
        conn, _ = server.accept()
        with conn:
            conn.sendall(csv.read_bytes())
        server.close()

    threading.Thread(target=serve, daemon=True).start()
    run = subprocess.run([*CLI, "record", f"tcp://127.0.0.1:{port}", "-o", str(tmp_path / "s.csv"), "--events",
                          str(tmp_path / "e.jsonl")], capture_output=True, env=ENV, timeout=300)
    assert run.returncode == 0, run.stderr.decode()
    assert (tmp_path / "s.csv").read_bytes() == csv.read_bytes()
    _check_session(_events((tmp_path / "e.jsonl").read_text()), n_poses)


def _start(tmp_path, csv, lines_first):
    out = tmp_path / "s.csv"
    proc = subprocess.Popen([*CLI, "record", "-", "-o", str(out)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=ENV)
    data = csv.read_bytes().splitlines(keepends=True)
    proc.stdin.write(b"".join(data[:lines_first]))
    proc.stdin.flush()
    partial = tmp_path / "s.csv.partial"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if partial.exists() and partial.read_bytes().count(b"\n") == lines_first:
            break
        time.sleep(0.05)
    return proc, out, partial, data


def test_a_killed_recorder_leaves_a_readable_partial_file(tmp_path, short_session):
    csv, _ = short_session
    proc, out, partial, data = _start(tmp_path, csv, 3001)
    proc.kill()
    proc.wait(timeout=60)
    assert not out.exists()
    assert partial.read_bytes() == b"".join(data[:3001])
    rec = read(partial)
    assert len(rec) == 3000
    np.testing.assert_array_equal(rec.acc, read(csv).acc[:3000])


def test_ctrl_c_finishes_cleanly(tmp_path, short_session):
    csv, _ = short_session
    proc, out, partial, data = _start(tmp_path, csv, 2001)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 0, stderr.decode()
    assert out.read_bytes() == b"".join(data[:2001]) and not partial.exists()
    assert b"interrupted" in stdout


def test_a_line_that_does_not_parse_is_left_out_with_a_note(tmp_path, short_session):
    csv, n_poses = short_session
    data = csv.read_bytes().splitlines(keepends=True)
    sent = [*data[:5000], b"#### logger restarted ####\n", b"1.0,2.0\n", *data[5000:]]
    events = []
    result = record(io.BytesIO(b"".join(sent)), tmp_path / "s.csv", Recorder(events.append))
    assert (tmp_path / "s.csv").read_bytes() == b"".join(data)  # the session: the rows, not the stray lines
    assert result.bad == 2 and result.lines == len(sent)
    bad = [e for e in events if e["event"] == "warning" and e["kind"] == "bad_line"]
    assert [e["line"] for e in bad] == [5001, 5002]  # 1-based lines of the stream
    assert events[-1]["bad_lines"] == 2
    assert abs(result.poses - n_poses) <= 1


def test_a_boot_message_among_the_first_lines_is_left_out_not_fatal(tmp_path, short_session):
    csv, _ = short_session
    data = csv.read_bytes().splitlines(keepends=True)
    sent = [b"MPU6050 ready\n", *data[:20], b"ERR i2c timeout\n", *data[20:]]
    events = []
    result = record(io.BytesIO(b"".join(sent)), tmp_path / "s.csv", Recorder(events.append))
    # the banner before the header is a preamble the reader takes; the message among the rows is left out
    assert (tmp_path / "s.csv").read_bytes() == b"".join([b"MPU6050 ready\n", *data])
    bad = [e["line"] for e in events if e["event"] == "warning" and e["kind"] == "bad_line"]
    assert bad == [22] and result.bad == 1
    assert events[-1]["samples"] == len(data) - 1


def test_fast_turns_and_wobbling_poses_are_warned(tmp_path):
    with pytest.warns(UserWarning, match="clipped"):  # the simulated gyroscope saturates, as intended
        s = generate(np.random.default_rng(11), n_poses=12, rest=8.0, max_rate=None, move=(0.3, 0.5), tremor=2.0)
    path = tmp_path / "fast.csv"
    write_csv(path, s["recording"])
    events = []
    with open(path, "rb") as fh:
        record(fh, tmp_path / "s.csv", Recorder(events.append))
    kinds = {e["kind"] for e in events if e["event"] == "warning"}
    assert "saturation" in kinds
    assert "wobble" in kinds
    # at 25 Hz a hand's 220 °/s is 8.8° per sample: too fast for the attitude integration to follow
    slow = generate(np.random.default_rng(2), rate=25.0, n_poses=12, rest=8.0)
    write_csv(path, slow["recording"])
    events = []
    with open(path, "rb") as fh:
        record(fh, tmp_path / "s1.csv", Recorder(events.append))
    fast = [e for e in events if e["event"] == "warning" and e["kind"] == "fast"]
    assert fast and all(float(e["message"].split("rotation of ")[1].split("°")[0]) > 5 for e in fast)
    # a calm session warns of nothing
    calm = generate(np.random.default_rng(11), n_poses=12, rest=8.0, tremor=0.05)
    write_csv(path, calm["recording"])
    events = []
    with open(path, "rb") as fh:
        record(fh, tmp_path / "s2.csv", Recorder(events.append))
    assert not [e for e in events if e["event"] == "warning"]


def test_stream_without_a_time_column_and_in_si_units(tmp_path):
    s = generate(np.random.default_rng(4), n_poses=12, rest=8.0, quantise=False)
    rec = s["recording"]
    truth = s["truth"]
    acc, gyro = truth.accelerometer_si(rec.acc), truth.gyroscope_si(rec.gyro, rec.acc)
    rows = np.hstack([acc, gyro])
    text = "ax,ay,az,gx,gy,gz\n" + "\n".join(",".join(f"{v:.7g}" for v in row) for row in rows)
    events = []
    record(io.BytesIO(text.encode()), tmp_path / "s.csv",
           Recorder(events.append, rate=rec.rate, acc_unit="m/s^2", gyro_unit="rad/s"))
    fmt = events[0]
    assert fmt["event"] == "format" and fmt["acc_unit"] == "m/s^2" and fmt["time"] == "100 Hz"
    assert abs(sum(e["event"] == "pose" for e in events) - 12) <= 1


def test_bad_sources_are_refused_with_exit_2(tmp_path, capsys):
    for source, text in (("ftp://x", "unknown source"), ("tcp://127.0.0.1", "give the host and port"),
                         ("tcp://127.0.0.1:9", "cannot connect")):
        run = record_here(capsys, [source, "-o", str(tmp_path / "s.csv")])
        assert run.returncode == 2 and text in run.stderr and "Traceback" not in run.stderr
    run = record_here(capsys, ["-", "-o", str(tmp_path / "s.csv"), "--method", "nope"], input="t,ax\n")
    assert run.returncode == 2 and "unknown method" in run.stderr


def test_phyphox_source_against_a_local_rest_server():
    """phyphox's remote interface (``/control?cmd=start``, ``/get`` with ``T|time`` thresholds), served locally."""
    import http.server
    from urllib.parse import parse_qs, urlsplit

    from imucalib.record import open_source

    t_acc = np.arange(0, 2.0, 0.01)
    t_gyr = np.arange(0.003, 2.05, 0.01)
    acc = np.column_stack([np.sin(t_acc), np.cos(t_acc), 9.8 + 0 * t_acc])
    gyr = np.column_stack([t_gyr, -t_gyr, 2 * t_gyr])
    served = {"started": False, "upto": 0.0}

    class Phone(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args):
            pass

        def do_GET(self):
            url = urlsplit(self.path)
            q = {k: v[0] for k, v in parse_qs(url.query).items()}
            if url.path == "/control":
                served["started"] = q.get("cmd") == "start"
                body = {"result": True}
            else:
                served["upto"] += 0.5  # the phone records half a second between polls
                buf = {}
                for name, (t, x, cols) in {"acc": (t_acc, acc, "XYZ"), "gyr": (t_gyr, gyr, "XYZ")}.items():
                    since = q[f"{name}_time"]
                    keep = (t <= served["upto"]) & (t > (-1.0 if since == "full" else float(since)))
                    buf[f"{name}_time"] = {"buffer": t[keep].tolist()}
                    for j, c in enumerate(cols):
                        assert q[f"{name}{c}"] == ("full" if since == "full" else f"{since}|{name}_time")
                        buf[f"{name}{c}"] = {"buffer": x[keep, j].tolist()}
                body = {"buffer": buf, "status": {"measuring": True}}
            data = json.dumps(body).encode()
            self.send_response(200)
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

    server = http.server.HTTPServer(("127.0.0.1", 0), Phone)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        with open_source(f"phyphox://127.0.0.1:{server.server_port}") as stream:
            lines = [stream.readline() for _ in range(1 + 150)]
    finally:
        server.shutdown()
    assert served["started"]
    assert lines[0].startswith(b"t,ax [m/s^2]")
    rows = np.array([[float(c) for c in ln.decode().split(",")] for ln in lines[1:]])
    # every sample from the gyroscope's first on (0.003 s), in order
    np.testing.assert_allclose(rows[:, 0], t_acc[1:151], rtol=0, atol=1e-12)
    np.testing.assert_allclose(rows[:, 1:4], acc[1:151], rtol=1e-8)
    np.testing.assert_allclose(rows[:, 4:], np.column_stack([rows[:, 0], -rows[:, 0], 2 * rows[:, 0]]),
                               rtol=1e-8, atol=1e-9)  # the linear gyroscope interpolated exactly


def test_a_stream_the_reader_cannot_take_is_an_error_that_keeps_the_lines(tmp_path):
    run = subprocess.run([*CLI, "record", "-", "-o", str(tmp_path / "s.csv")], input="hello\nworld\n" * 30,
                         capture_output=True, text=True, env=ENV, timeout=60)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert "60 lines read so far" in run.stderr and not (tmp_path / "s.csv").exists()
    assert "not a table the reader takes" in run.stderr and ".csv: line" not in run.stderr
    assert (tmp_path / "s.csv.partial").read_text() == "hello\nworld\n" * 30


def test_face_methods_are_told_the_faces_they_lack():
    from imucalib.plans import describe_direction

    events = []
    rec = Recorder(events.append, method="six_position")
    rec.directions = np.array([[0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0.02]])
    rec.format = type("F", (), {"time_scale": 1.0, "rate": None})()
    rec._raw[:2, 0] = [0.0, 0.01]
    rec.n = 2
    rec._next(1, rec.directions[-1])
    said = [events[-1]["words"], *events[-1]["then"]]
    assert sorted(said) == ["x down", "y down", "z down"]
    assert describe_direction(events[-1]["up"]) == events[-1]["words"]


def test_a_serial_port_recorded_until_ctrl_c(tmp_path, short_session):
    pytest.importorskip("serial")
    pty = pytest.importorskip("pty")
    import termios
    import tty

    csv, _ = short_session
    data = csv.read_bytes().splitlines(keepends=True)[:3001]
    master, slave = pty.openpty()
    tty.setraw(slave, termios.TCSANOW)  # a serial line passes the bytes as they are
    port = os.ttyname(slave)
    proc = subprocess.Popen([*CLI, "record", f"serial:{port}?baud=115200", "-o", str(tmp_path / "s.csv"),
                             "--events", str(tmp_path / "e.jsonl")], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=ENV)
    partial = tmp_path / "s.csv.partial"
    wait_port_open(proc, slave)
    deadline = time.monotonic() + 120
    os.set_blocking(master, False)  # a recorder that stopped reading fails the test instead of hanging it
    buf, sent = b"".join(data), 0
    while sent < len(buf) and time.monotonic() < deadline and proc.poll() is None:
        try:
            sent += os.write(master, buf[sent:sent + 4096])
        except BlockingIOError:
            time.sleep(0.01)
    assert sent == len(buf)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (partial.exists() and partial.read_bytes() == b"".join(data)):
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    os.close(master)
    os.close(slave)
    assert proc.returncode == 0, err.decode()
    assert (tmp_path / "s.csv").read_bytes() == b"".join(data)
    events = _events((tmp_path / "e.jsonl").read_text())
    assert events[0]["event"] == "format" and events[-1]["event"] == "end" and events[-1]["samples"] == 3000
