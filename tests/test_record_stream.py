"""Guided recording: nothing lost or destroyed, every transport ended cleanly, the same events whatever the batching.

The session file keeps the stream's header and rows; stray lines, garbage
bytes, readings that cannot be, stamps that repeat or go backwards are left
out with one note each; the outputs follow the rules every other command
follows; Ctrl-C and SIGTERM end a busy or silent stream on standard input, a
TCP socket and a serial port within a second; a peer or device that goes away
ends the session normally; a reader that fails ends it with its reason.
"""

import contextlib
import io
import json
import os
import signal
import socket
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from imucalib.io import read, write_csv
from imucalib.methods import calibrate
from imucalib.record import LineSplitter, Recorder, RecordError, Source, record
from imucalib.scenarios.handheld import generate

SRC = Path(__file__).resolve().parents[1] / "src"
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
CLI = [sys.executable, "-m", "imucalib.cli"]


@pytest.fixture(scope="module")
def short_session(tmp_path_factory):
    """A short hand-held session (14 poses, 8 s rest) written as imucalib writes CSV."""
    s = generate(np.random.default_rng(7), n_poses=14, rest=8.0)
    path = tmp_path_factory.mktemp("short") / "short.csv"
    write_csv(path, s["recording"])
    return path, 14


def _events(text: str) -> list[dict]:
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def _rows(path):
    return path.read_bytes().splitlines(keepends=True)


# ------------------------------------------------------------ bad lines
def test_bad_lines_are_left_out_with_one_note_each_and_the_session_goes_on(tmp_path, short_session):
    csv, n_poses = short_session
    data = _rows(csv)
    row = data[3000].decode().rstrip("\n").split(",")
    nan_row = ",".join([row[0] + "1", "nan", *row[2:]]) + "\n"  # a stamp between its neighbours, a NaN reading
    big_row = ",".join([row[0] + "2", row[1], "1e30", *row[3:]]) + "\n"
    injected = {  # after stream line k (1-based) comes the bad line
        1200: b"ERR i2c timeout\n",
        2000: b"\x00\xff\xfe\x00,1,2\n",
        3001: nan_row.encode(),
        3002: big_row.encode(),
        4000: data[3990],  # an earlier row again: its stamp goes backwards
        5000: data[4999],  # the row just read again: its stamp repeats
        6000: b"1e9,1,2,3,4,5,6\n",  # a stamp far ahead of its neighbours
    }
    sent, where = [], {}
    for k, line in enumerate(data, start=1):
        sent.append(line)
        if k in injected:
            sent.append(injected[k])
            where[len(sent)] = k
    events = []
    result = record(io.BytesIO(b"".join(sent)), tmp_path / "s.csv", Recorder(events.append))
    # the session is the stream without the bad lines: every row kept, in order, unchanged
    assert (tmp_path / "s.csv").read_bytes() == b"".join(data)
    notes = [e for e in events if e["event"] == "warning" and e["kind"] == "bad_line"]
    assert [e["line"] for e in notes] == sorted(where)  # one note each, at its line of the stream
    reasons = [e["reason"] for e in notes]
    assert "not a row" in reasons[0] and "not text" in reasons[1] and "finite" in reasons[2]
    assert "range" in reasons[3] and "backwards" in reasons[4] and "repeated" in reasons[5]
    assert "far ahead" in reasons[6]
    assert result.bad == len(injected) and abs(result.poses - n_poses) <= 1
    assert events[-1]["event"] == "end" and events[-1]["verdict"] == "accepted"
    # the file calibrates as the recorder's last word said
    assert calibrate(read(tmp_path / "s.csv")).fit["verdict"] == "accepted"


def test_garbage_bytes_before_the_header_are_removed(tmp_path, short_session):
    csv, _ = short_session
    data = _rows(csv)
    sent = [b"\x00\xff\xff\xfe" + data[0], b"\xff\x00\n", *data[1:]]  # a serial port's connect glitch
    events = []
    result = record(io.BytesIO(b"".join(sent)), tmp_path / "s.csv", Recorder(events.append))
    assert (tmp_path / "s.csv").read_bytes() == b"".join(data)
    assert events[0]["event"] == "format" and result.bad == 2
    assert read(tmp_path / "s.csv").acc.shape[0] == len(data) - 1


def test_a_gap_in_a_turn_is_a_gap_not_a_fast_turn(tmp_path, short_session):
    csv, _ = short_session
    data = _rows(csv)
    events = []
    record(io.BytesIO(b"".join(data)), tmp_path / "a.csv", Recorder(events.append))
    poses = [e for e in events if e["event"] == "pose"]
    assert not [e for e in events if e["event"] == "warning"]
    # 5 s of samples lost from the middle of the turn after pose 6 (the gyroscope's scale is known by then)
    a, b = poses[5]["stop"], poses[6]["start"]
    mid = (a + b) // 2
    lost = 500
    sent = [*data[:1 + mid], *data[1 + mid + lost:]]
    events = []
    result = record(io.BytesIO(b"".join(sent)), tmp_path / "s.csv", Recorder(events.append))
    warnings = [e for e in events if e["event"] == "warning"]
    assert [e["kind"] for e in warnings] == ["gap"]
    assert warnings[0]["seconds"] == pytest.approx(5.01, abs=0.02)
    assert result.bad == 0 and (tmp_path / "s.csv").read_bytes() == b"".join(sent)


def test_a_line_without_end_is_bounded_and_left_out(tmp_path, short_session):
    csv, _ = short_session
    split = LineSplitter()
    for _ in range(50):  # 50 MiB without a newline: never held
        assert split.push(b"x" * (1 << 20)) == []
        assert len(split._buf) <= split.limit
    out = split.push(b"tail\n1,2\n")
    assert out[0].size == 50 * (1 << 20) + 5 and out[1] == b"1,2\n"
    data = _rows(csv)
    sent = [*data[:3000], b"7" * 3_000_000 + b"\n", *data[3000:]]
    events = []
    result = record(io.BytesIO(b"".join(sent)), tmp_path / "s.csv", Recorder(events.append))
    assert result.bad == 1 and (tmp_path / "s.csv").read_bytes() == b"".join(data)
    note = [e for e in events if e["event"] == "warning"][0]
    assert note["line"] == 3001 and "3000001 bytes" in note["message"]


# -------------------------------------------------------- batching, COMPLETE
class Batches(Source):
    """The bytes of a stream, read in the batch sizes given (cycled)."""

    def __init__(self, data: bytes, sizes) -> None:
        self.data, self.sizes, self.pos, self.k = data, list(sizes), 0, 0

    def read(self, timeout):
        if self.pos >= len(self.data):
            return b""
        n = self.sizes[self.k % len(self.sizes)]
        self.k += 1
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out


def test_the_same_events_whatever_the_batching(tmp_path):
    with pytest.warns(UserWarning, match="clipped"):  # fast turns, a saturating gyroscope and wobbling poses
        s = generate(np.random.default_rng(11), n_poses=12, rest=8.0, max_rate=None, move=(0.3, 0.5), tremor=2.0)
    path = tmp_path / "fast.csv"
    write_csv(path, s["recording"])
    data = path.read_bytes()
    runs = []
    for k, sizes in enumerate(([len(data)], [37], [1, 2, 3, 500, 7, 65536, 11])):
        events = []
        record(Batches(data, sizes), tmp_path / f"s{k}.csv", Recorder(events.append))
        runs.append(json.dumps(events))
        assert (tmp_path / f"s{k}.csv").read_bytes() == data
    # the recorder itself, given the lines in batches of other sizes
    lines = data.splitlines(keepends=True)
    for sizes in ([1], [3, 1000, 17]):
        events, recorder, i, k = [], None, 0, 0
        recorder = Recorder(events.append)
        while i < len(lines):
            n = sizes[k % len(sizes)]
            recorder.feed(lines[i:i + n])
            i, k = i + n, k + 1
        recorder.close()
        runs.append(json.dumps(events))
    assert all(r == runs[0] for r in runs[1:])
    kinds = [e["kind"] for e in json.loads(runs[0]) if e["event"] == "warning"]
    assert "saturation" in kinds and "wobble" in kinds


def test_the_file_at_complete_is_what_calibrate_reads(tmp_path, short_session):
    csv, _ = short_session
    partial = tmp_path / "s.csv.partial"
    seen = {}

    def on_event(event):
        if event["event"] == "complete":
            seen["bytes"] = partial.read_bytes()
            seen["trial"] = recorder.trial
            seen["event"] = event

    recorder = Recorder(on_event)
    record(io.BytesIO(csv.read_bytes()), tmp_path / "s.csv", recorder)
    snapshot = tmp_path / "at_complete.csv"
    snapshot.write_bytes(seen["bytes"])
    rec = read(snapshot)
    assert len(rec) == seen["event"]["samples"]
    cal = calibrate(rec)
    assert cal.fit["verdict"] == "accepted"
    trial = seen["trial"]
    np.testing.assert_allclose(cal.accelerometer.scale, trial.accelerometer.scale, rtol=1e-9)
    np.testing.assert_allclose(cal.gyroscope.scale, trial.gyroscope.scale, rtol=1e-9)
    np.testing.assert_allclose(cal.accelerometer.bias, trial.accelerometer.bias, rtol=1e-9, atol=1e-9)


# ---------------------------------------------------------------- outputs
def _run(args, **kw):
    return subprocess.run([*CLI, "record", *args], capture_output=True, text=True, env=ENV, timeout=120, **kw)


def record_here(capsys, args, input=None) -> subprocess.CompletedProcess:
    """``imucalib record ARGS`` in this process, as :func:`_run` reports it, with ``input`` on a pipe that stands
    for standard input (the recorder reads its file descriptor); for the tests of what is written where, not of
    signals or transports (a child costs ~0.4 processor seconds before the command runs)."""
    from imucalib.cli import main

    read_end, write_end = os.pipe()

    def feed():
        with contextlib.suppress(BrokenPipeError), open(write_end, "wb") as pipe:
            pipe.write((input or "").encode())

    feeder = threading.Thread(target=feed, daemon=True)
    feeder.start()
    capsys.readouterr()
    saved = sys.stdin
    with open(read_end, "rb") as sys.stdin:
        try:
            code = main(["record", *map(str, args)])
        except SystemExit as exit_:  # argparse's refusals: the exit status a child would end with
            assert isinstance(exit_.code, int), exit_.code
            code = exit_.code
        finally:
            sys.stdin = saved
    feeder.join(timeout=60)  # a command that left its input unread: the pipe is closed, the writer stops
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(["imucalib", "record", *map(str, args)], code, out, err)


def test_an_existing_session_or_partial_is_never_destroyed(tmp_path, short_session, capsys):
    csv, _ = short_session
    out = tmp_path / "s.csv"
    out.write_text("a finished session\n")
    run = record_here(capsys, ["-", "-o", str(out)], input=csv.read_text()[:2000])
    assert run.returncode == 2 and "already there" in run.stderr and "--force" in run.stderr
    assert out.read_text() == "a finished session\n" and not (tmp_path / "s.csv.partial").exists()
    run = record_here(capsys, ["-", "-o", str(out), "--force"], input=csv.read_text())
    assert run.returncode == 0, run.stderr
    assert out.read_bytes() == csv.read_bytes()
    # the .partial an earlier, killed run left: never truncated, nor appended to
    (tmp_path / "t.csv.partial").write_text("an earlier session\n")
    for extra in ([], ["--force"]):
        run = record_here(capsys, ["-", "-o", str(tmp_path / "t.csv"), *extra], input=csv.read_text()[:2000])
        assert run.returncode == 2 and "unfinished session" in run.stderr
        assert (tmp_path / "t.csv.partial").read_text() == "an earlier session\n"
        assert not (tmp_path / "t.csv").exists()


def test_special_files_and_symbolic_links(tmp_path, short_session, capsys):
    csv, _ = short_session
    csv = tmp_path / "in.csv"  # the first 20 s of the session: its rest and a few poses
    csv.write_bytes(b"".join(_rows(short_session[0])[:2001]))
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    # in a child: a recorder that opened the FIFO to write would block there, failing on the timeout
    run = _run(["-", "-o", str(fifo)], input=csv.read_text()[:2000])
    assert run.returncode == 2 and "FIFO" in run.stderr and stat.S_ISFIFO(os.stat(fifo).st_mode)
    run = record_here(capsys, ["-", "-o", str(tmp_path / "s.csv"), "--events", "/dev/sda"], input="t\n")
    assert run.returncode == 2 and not (tmp_path / "s.csv").exists()
    # a .partial planted as a link to another file: that file is never written through it
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    os.symlink(victim, tmp_path / "v.csv.partial")
    run = record_here(capsys, ["-", "-o", str(tmp_path / "v.csv")], input=csv.read_text()[:2000])
    assert run.returncode == 2 and victim.read_text() == "precious\n"
    # -o a link: followed as the shell follows it, the link stays (and the file it names is a session kept)
    target = tmp_path / "real.csv"
    target.write_text("old\n")
    os.symlink(target, tmp_path / "link.csv")
    run = record_here(capsys, ["-", "-o", str(tmp_path / "link.csv")], input=csv.read_text()[:2000])
    assert run.returncode == 2 and target.read_text() == "old\n"
    run = record_here(capsys, ["-", "-o", str(tmp_path / "link.csv"), "--force"], input=csv.read_text())
    assert run.returncode == 0 and (tmp_path / "link.csv").is_symlink()
    assert target.read_bytes() == csv.read_bytes()
    # --events into a FIFO: written into as a stream, the FIFO stays
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()))
    reader.start()
    run = record_here(capsys, ["-", "-o", str(tmp_path / "e.csv"), "--events", str(fifo)], input=csv.read_text())
    reader.join(timeout=60)
    assert run.returncode == 0 and stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert _events(got[0])[-1]["event"] == "end"


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write read-only files")
def test_read_only_outputs_are_refused(tmp_path, short_session):
    csv, _ = short_session
    ro = tmp_path / "ro.csv"
    ro.write_text("x\n")
    ro.chmod(0o444)
    run = _run(["-", "-o", str(ro), "--force"], input=csv.read_text())
    assert run.returncode == 2 and "read-only" in run.stderr and ro.read_text() == "x\n"


# -------------------------------------------------------------- transports
def _wait_rows(partial: Path, count: int, proc, limit=120.0):
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline and proc.poll() is None:
        if partial.exists() and partial.read_bytes().count(b"\n") >= count:
            return
        time.sleep(0.02)
    raise AssertionError(f"{partial} did not reach {count} lines")


def _time_to_file(out: Path, proc, limit=30.0) -> float:
    start = time.monotonic()
    while not out.exists() and proc.poll() is None and time.monotonic() - start < limit:
        time.sleep(0.005)
    return time.monotonic() - start


@pytest.mark.slow
@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_and_sigterm_on_a_silent_stdin(tmp_path, short_session, how):
    csv, _ = short_session
    data = _rows(csv)
    out, cal = tmp_path / "s.csv", tmp_path / "cal.json"
    proc = subprocess.Popen([*CLI, "record", "-", "-o", str(out), "--calibrate", str(cal)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=ENV)
    proc.stdin.write(b"".join(data))
    proc.stdin.flush()  # … then nothing more: the stream stays open and silent
    _wait_rows(tmp_path / "s.csv.partial", len(data) - 10, proc)
    time.sleep(0.3)
    proc.send_signal(how)
    took = _time_to_file(out, proc)
    stdout, stderr = proc.communicate(timeout=120)
    proc.stdin.close()
    assert proc.returncode == 0, stderr.decode()
    assert took < 1.0, took
    assert out.read_bytes() == b"".join(data) and b"interrupted" in stdout
    assert json.loads(cal.read_text())["fit"]["verdict"] == "accepted"
    assert stdout.decode().splitlines()[-1].startswith("verdict: accepted")


@pytest.mark.slow
def test_sigterm_on_a_silent_tcp_peer_and_a_peer_that_goes_away(tmp_path, short_session):
    csv, _ = short_session
    data = csv.read_bytes()
    lines = data.splitlines(keepends=True)
    for ending in ("silent", "gone", "flowing"):
        server = socket.create_server(("127.0.0.1", 0))
        port = server.getsockname()[1]
        done = threading.Event()

        def serve(server=server, ending=ending, done=done):
            conn, _ = server.accept()
            if ending == "flowing":  # 1000 lines a second until the recorder is stopped
                with contextlib.suppress(OSError):
                    for k in range(0, len(lines), 20):
                        if done.is_set():
                            break
                        conn.sendall(b"".join(lines[k:k + 20]))
                        time.sleep(0.02)
            else:
                conn.sendall(data)
            if ending == "silent":
                done.wait(60)  # the peer stays connected and sends nothing more
            conn.close()
            server.close()

        threading.Thread(target=serve, daemon=True).start()
        out = tmp_path / f"{ending}.csv"
        proc = subprocess.Popen([*CLI, "record", f"tcp://127.0.0.1:{port}", "-o", str(out), "--calibrate",
                                 str(tmp_path / f"{ending}.json")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                env=ENV)
        if ending != "gone":
            _wait_rows(Path(str(out) + ".partial"), data.count(b"\n") - 10 if ending == "silent" else 3000, proc)
            proc.send_signal(signal.SIGTERM)
            took = _time_to_file(out, proc)
            assert took < 1.0, took
        stdout, stderr = proc.communicate(timeout=120)
        done.set()
        # 3: calibrate's exit code for a rejected calibration, of a session stopped early
        assert proc.returncode == 0 or (ending == "flowing" and proc.returncode == 3), stderr.decode()
        kept = out.read_bytes()
        assert kept == data if ending != "flowing" else (data.startswith(kept) and kept.count(b"\n") >= 3000)
        assert (tmp_path / f"{ending}.json").exists()


def has_open(pid: int, name: str) -> bool:
    """Whether process ``pid`` has the file ``name`` open (its descriptors come and go while it starts)."""
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return False
    for fd in fds:
        try:
            if os.path.realpath(f"/proc/{pid}/fd/{fd}", strict=True) == name:
                return True
        except OSError:  # closed since it was listed
            continue
    return False


def wait_port_open(proc, slave: int, baud: int = 115200, limit: float = 60.0) -> None:
    """Until the recorder ``proc`` has opened the pty ``slave`` as its serial port and set its speed: pyserial's
    open() then empties the port's input (what a device sent before the port was open is dropped, and so would
    the test's data be)."""
    import termios

    name, speed = os.ttyname(slave), getattr(termios, f"B{baud}")
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline and proc.poll() is None and not (
            has_open(proc.pid, name) and termios.tcgetattr(slave)[4] == speed):
        time.sleep(0.02)
    time.sleep(0.2)  # the emptying follows the speed within the same call


@pytest.mark.slow
def test_a_serial_port_silent_then_gone(tmp_path, short_session):
    pytest.importorskip("serial")
    pty = pytest.importorskip("pty")
    import termios
    import tty

    csv, _ = short_session
    data = csv.read_bytes()
    for ending in ("ctrl-c", "unplugged"):
        master, slave = pty.openpty()
        tty.setraw(slave, termios.TCSANOW)
        out = tmp_path / f"{ending}.csv"
        proc = subprocess.Popen([*CLI, "record", f"serial:{os.ttyname(slave)}?baud=115200", "-o", str(out),
                                 "--calibrate", str(tmp_path / f"{ending}.json")], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, env=ENV)
        wait_port_open(proc, slave)
        os.set_blocking(master, False)
        sent, deadline = 0, time.monotonic() + 120
        while sent < len(data) and time.monotonic() < deadline and proc.poll() is None:
            try:
                sent += os.write(master, data[sent:sent + 4096])
            except BlockingIOError:
                time.sleep(0.01)
        _wait_rows(Path(str(out) + ".partial"), data.count(b"\n") - 10, proc)
        if ending == "ctrl-c":
            time.sleep(0.3)  # silent
            proc.send_signal(signal.SIGINT)
            took = _time_to_file(out, proc)
            assert took < 1.0, took
        else:
            os.close(master)  # the device goes away
        stdout, stderr = proc.communicate(timeout=120)
        if ending == "ctrl-c":
            os.close(master)
        os.close(slave)
        assert proc.returncode == 0, stderr.decode()
        assert b"Traceback" not in stderr and out.read_bytes() == data
        assert (tmp_path / f"{ending}.json").exists()
        if ending == "unplugged":
            assert b"went away" in stdout


def test_a_phyphox_peer_answering_odd_json_ends_the_session_with_its_reason(tmp_path, capsys):
    import http.server

    answers = iter([b'{"result": true}', b"[" * 100_000 + b"]" * 100_000])

    class Phone(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args):
            pass

        def do_GET(self):
            body = next(answers, b'{"buffer": {"acc_time": 5}}')
            self.send_response(200)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

    server = http.server.HTTPServer(("127.0.0.1", 0), Phone)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        run = record_here(capsys, [f"phyphox://127.0.0.1:{server.server_port}", "-o", str(tmp_path / "s.csv")])
    finally:
        server.shutdown()
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert "nested deeper" in run.stderr


def test_a_reader_that_fails_ends_the_recorder_with_its_reason(tmp_path, short_session):
    csv, _ = short_session
    data = csv.read_bytes()

    class Broken(Source):
        name = "the test stream"

        def __init__(self):
            self.sent = False

        def read(self, timeout):
            if not self.sent:
                self.sent = True
                return data[:200_000]
            raise RuntimeError("the driver crashed")

    result = {}

    def run():
        try:
            record(Broken(), tmp_path / "s.csv", Recorder(lambda e: None))
        except RecordError as exc:
            result["error"] = str(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=60)
    assert not thread.is_alive(), "the recorder hangs when its reader fails"
    assert "the driver crashed" in result["error"] and str(tmp_path / "s.csv") in result["error"]
    kept = (tmp_path / "s.csv").read_bytes()
    assert kept and data.startswith(kept)


@pytest.mark.slow
def test_ctrl_c_on_a_silent_phyphox_phone(tmp_path):
    """A phone that has sent a session and then nothing more: Ctrl-C ends it within a second, calibrated."""
    import http.server
    from urllib.parse import parse_qs, urlsplit

    s = generate(np.random.default_rng(4), n_poses=12, rest=8.0, quantise=False)
    rec, truth = s["recording"], s["truth"]
    acc, gyro = truth.accelerometer_si(rec.acc), truth.gyroscope_si(rec.gyro, rec.acc)
    t = rec.t

    class Phone(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args):
            pass

        def do_GET(self):
            url = urlsplit(self.path)
            q = {k: v[0] for k, v in parse_qs(url.query).items()}
            if url.path == "/control":
                body = {"result": True}
            else:
                buf = {}
                for name, x in (("acc", acc), ("gyr", gyro)):
                    since = q[f"{name}_time"]
                    keep = t > (-1.0 if since == "full" else float(since))
                    buf[f"{name}_time"] = {"buffer": t[keep].tolist()}
                    for j, c in enumerate("XYZ"):
                        buf[f"{name}{c}"] = {"buffer": x[keep, j].tolist()}
                body = {"buffer": buf, "status": {"measuring": True}}
            data = json.dumps(body).encode()
            self.send_response(200)
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Phone)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    out = tmp_path / "s.csv"
    try:
        proc = subprocess.Popen([*CLI, "record", f"phyphox://127.0.0.1:{server.server_port}", "-o", str(out),
                                 "--calibrate", str(tmp_path / "cal.json")], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, env=ENV)
        _wait_rows(Path(str(out) + ".partial"), len(t) - 20, proc)  # every sample but the last block's
        time.sleep(0.3)
        proc.send_signal(signal.SIGINT)
        took = _time_to_file(out, proc)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        server.shutdown()
    assert proc.returncode == 0, stderr.decode()
    assert took < 1.0, took
    assert read(out).acc.shape[0] == len(t) and b"interrupted" in stdout
    verdict = json.loads((tmp_path / "cal.json").read_text())["fit"]["verdict"]
    assert stdout.decode().splitlines()[-1].startswith(f"verdict: {verdict} ")  # the last word is calibrate's


def test_a_killed_session_resumed(tmp_path, short_session, capsys):
    """A run killed mid-session leaves its .partial; --resume follows it again and appends the stream's rest."""
    csv, _ = short_session
    data = _rows(csv)
    out = tmp_path / "s.csv"
    proc = subprocess.Popen([*CLI, "record", "-", "-o", str(out)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=ENV)
    proc.stdin.write(b"".join(data[:5001]))
    proc.stdin.flush()
    _wait_rows(tmp_path / "s.csv.partial", 4991, proc)
    proc.kill()
    proc.wait(timeout=60)
    proc.stdin.close()
    proc.stdout.close()
    proc.stderr.close()
    kept = (tmp_path / "s.csv.partial").read_bytes().splitlines(keepends=True)
    assert kept == data[:len(kept)]
    # the logger's stream again from a few rows before where the file ends, with its header
    again = [data[0], *data[len(kept) - 5:]]
    run = record_here(capsys, ["-", "-o", str(out), "--resume", "--events", str(tmp_path / "e.jsonl")],
                      input=b"".join(again).decode())
    assert run.returncode == 0, run.stderr
    assert out.read_bytes() == b"".join(data) and not (tmp_path / "s.csv.partial").exists()
    events = _events((tmp_path / "e.jsonl").read_text())
    bad = [e for e in events if e["event"] == "warning" and e["kind"] == "bad_line"]
    # the stream's header and its five rows the file has already: left out, one note each, numbered after the file's
    assert [e["line"] for e in bad] == list(range(len(kept) + 1, len(kept) + 7))
    assert "not a row" in bad[0]["reason"] and all("backwards" in e["reason"] for e in bad[1:-1])
    assert "repeated" in bad[-1]["reason"]  # the last row the file holds, sent again
    assert events[-1]["verdict"] == "accepted"
