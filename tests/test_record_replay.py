"""Guided recording of a real session: one stream through standard input, TCP and a pseudo-terminal.

The MPU9250 session of Zhang 2021's first author (``mpu9250_gesture/caldata.mat``,
100 Hz, raw counts; its first 200 s: the rest and about 20 hand-held poses) as
a text stream: each transport must give the same events and the same session file,
the stream's header and rows unchanged, and the verdict ``calibrate`` gives.
"""

import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
CLI = [sys.executable, "-m", "imucalib.cli"]
DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(scope="module")
def stream(tmp_path_factory):
    mat = DATA / "public" / "mpu9250_gesture" / "caldata.mat"
    if not mat.exists():
        pytest.skip(f"{mat} not present (fresh clone): real-data test skipped")
    sio = pytest.importorskip("scipy.io")
    data = sio.loadmat(mat)["cal_data"][:20000]  # its rest and first 20 poses: complete at pose 13
    text = "t,ax,ay,az,gx,gy,gz\n" + "".join(",".join(f"{v:.9g}" for v in row[:7]) + "\n" for row in data)
    path = tmp_path_factory.mktemp("mpu") / "mpu9250.csv"
    path.write_text(text)
    return path


def _events(path):
    return [e for e in (json.loads(ln) for ln in path.read_text().splitlines()) if e["event"] != "silence"]


def _record(source, out, events, **kw):
    return subprocess.Popen([*CLI, "record", source, "-o", str(out), "--events", str(events)], env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


@pytest.mark.slow
def test_a_real_session_through_stdin_tcp_and_a_pty(tmp_path, stream):
    pty = pytest.importorskip("pty")
    import termios
    import tty

    data = stream.read_bytes()
    # standard input
    with open(stream, "rb") as fh:
        proc = _record("-", tmp_path / "stdin.csv", tmp_path / "stdin.jsonl", stdin=fh)
        out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()
    # TCP: the peer sends the stream in uneven pieces, then closes
    server = socket.create_server(("127.0.0.1", 0))

    def serve():
        conn, _ = server.accept()
        with conn:
            for k in range(0, len(data), 7001):
                conn.sendall(data[k:k + 7001])
        server.close()

    threading.Thread(target=serve, daemon=True).start()
    proc = _record(f"tcp://127.0.0.1:{server.getsockname()[1]}", tmp_path / "tcp.csv", tmp_path / "tcp.jsonl")
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err.decode()
    # a pseudo-terminal as standard input, raw (a serial line passes the bytes as they are); closed at the end
    master, slave = pty.openpty()
    tty.setraw(slave, termios.TCSANOW)
    proc = _record("-", tmp_path / "pty.csv", tmp_path / "pty.jsonl", stdin=slave)
    os.set_blocking(master, False)
    sent, deadline = 0, time.monotonic() + 300
    while sent < len(data) and time.monotonic() < deadline and proc.poll() is None:
        try:
            sent += os.write(master, data[sent:sent + 4096])
        except BlockingIOError:
            time.sleep(0.005)
    while time.monotonic() < deadline and (tmp_path / "pty.csv.partial").read_bytes().count(b"\n") < \
            data.count(b"\n") - 10:
        time.sleep(0.02)
    os.close(master)  # the line goes away: the session ends normally
    out, err = proc.communicate(timeout=300)
    os.close(slave)
    assert proc.returncode == 0, err.decode()
    events = _events(tmp_path / "stdin.jsonl")
    for name in ("tcp", "pty"):
        assert (tmp_path / f"{name}.csv").read_bytes() == data
        assert _events(tmp_path / f"{name}.jsonl") == events
    assert (tmp_path / "stdin.csv").read_bytes() == data
    poses = [e for e in events if e["event"] == "pose"]
    assert len(poses) >= 15 and events[-1]["verdict"] == "accepted"
    assert any(e["event"] == "complete" for e in events)
