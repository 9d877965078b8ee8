"""The session file and the loop that records a stream into it: :class:`SessionWriter`, :func:`record`.

The session's lines go to ``OUTPUT.partial`` as they are kept (flushed:
readable at any time, and after a killed process), which is renamed to
``OUTPUT`` on a clean finish. What is at ``OUTPUT`` is never destroyed: the
rules of :mod:`imucalib.io.atomic` (a symbolic link followed to the file it
names, never replaced by a file; a block device, a socket, a directory and a
read-only file refused), and beyond them: a FIFO or a character device is
refused (a session is a file that ``calibrate`` reads back), an existing
session is kept unless ``force``, and an existing ``OUTPUT.partial`` — a
session an earlier run left unfinished — is never truncated or appended to.
"""

from __future__ import annotations

import os
import queue
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from ..io.atomic import move_into_place, output_target
from .lines import LineSplitter
from .recorder import HEAD_LINES, Recorder
from .sources import Source, SourceGone, as_source

__all__ = ["SessionWriter", "RecordResult", "record", "check_session_output"]


def check_session_output(output: str | Path, *, force: bool = False, resume: bool = False) -> tuple[Path, Path]:
    """The file a session goes to and its ``.partial``, or the reason they cannot be written (an exception).

    Raises ``FileExistsError`` for an existing session (without ``force``)
    and for an existing ``.partial`` (without ``resume``: then it must be a
    regular file, not a link, ending with a whole line); ``ValueError``,
    ``OSError`` for what :mod:`imucalib.io.atomic` refuses, and for a FIFO or
    device.
    """
    if str(output).endswith(".partial"):
        raise ValueError(f"-o {output}: name the finished file; {output}.partial is written while recording")
    target, stream = output_target(output)
    if stream:
        raise ValueError(f"{output}: is a FIFO or a device; a session is a file that calibrate reads back: "
                         "give a file name")
    if not target.parent.is_dir():
        raise ValueError(f"{target}: its directory does not exist")
    if (target.exists() or target.is_symlink()) and not force:
        raise FileExistsError(f"{output}: a session is already there; it is kept: give a new name "
                                            "(or --force to replace it at the end of this one)")
    partial = target.with_name(target.name + ".partial")
    if resume:
        if partial.is_symlink() or not partial.is_file():
            raise ValueError(f"--resume: {partial} is not a regular file (nothing to resume, or a link): give -o "
                             "the session to continue")
        with open(partial, "rb") as fh:
            fh.seek(max(partial.stat().st_size - 1, 0))
            if fh.read(1) not in (b"\n", b""):
                raise ValueError(f"--resume: {partial} ends inside a line (the run was killed while writing it); "
                                 "calibrate it as it is, or give -o another name")
    elif partial.exists() or partial.is_symlink():
        raise FileExistsError(f"{partial}: an unfinished session of an earlier run is there; it is never "
                              f"overwritten: continue it (--resume), calibrate or rename it (imucalib calibrate "
                              f"{partial}), or give -o another name")
    return target, partial


class SessionWriter:
    """Lines written to ``OUTPUT.partial`` as they come, flushed; :meth:`finish` renames it to ``OUTPUT``.

    Thread-safe. ``OUTPUT`` is checked by :func:`check_session_output`; the
    ``.partial`` is created new (never through a symbolic link, never over a
    file) — or, with ``resume``, an existing one is appended to (its lines in
    :attr:`resumed`, for the recorder to follow first).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.record import SessionWriter
    >>> output = Path(tempfile.mkdtemp()) / "session.csv"
    >>> writer = SessionWriter(output)
    >>> writer.write_lines([b"t,ax,ay,az" + bytes([10]), b"0.00,12,-40,16390" + bytes([10])])
    True
    >>> output.with_name("session.csv.partial").exists(), output.exists()
    (True, False)
    >>> writer.finish() == output, output.read_text().splitlines()
    (True, ['t,ax,ay,az', '0.00,12,-40,16390'])
    """

    def __init__(self, output: str | Path, *, force: bool = False, resume: bool = False) -> None:
        self.output, self.partial = check_session_output(output, force=force, resume=resume)
        nofollow = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
        self.resumed: list[bytes] = []
        if resume:
            fd = os.open(self.partial, os.O_RDWR | os.O_APPEND | nofollow)
            with open(fd, "rb", closefd=False) as fh:
                self.resumed = fh.read().splitlines(keepends=True)
        else:
            try:
                fd = os.open(self.partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL | nofollow, 0o666)
            except FileExistsError:
                raise FileExistsError(f"{self.partial}: appeared meanwhile; it is never overwritten: "
                                      "give -o another name") from None
        self._fh = os.fdopen(fd, "ab" if resume else "wb")
        self._lock = threading.Lock()
        self.lines = 0

    def write(self, line: bytes) -> bool:
        """Append one line (newline included); False once finished."""
        return self.write_lines([line])

    def write_lines(self, lines: list[bytes]) -> bool:
        """Append lines (newlines included) and flush; False once finished."""
        with self._lock:
            if self._fh is None:
                return False
            self._fh.writelines(lines)
            self._fh.flush()
            self.lines += len(lines)
            return True

    def finish(self, *, rename: bool = True) -> Path:
        """Close the file (synced to the disk) and move it onto ``OUTPUT``; returns the file's path."""
        with self._lock:
            if self._fh is not None:
                self._fh.flush()
                os.fsync(self._fh.fileno())
                self._fh.close()
                self._fh = None
        if not rename:
            return self.partial
        if not self.partial.exists():
            return self.output

        move_into_place(self.partial, self.output)
        return self.output


@dataclass
class RecordResult:
    """What :func:`record` did: the file, lines read, lines left out, poses, complete, interrupted, how it ended.

    Examples
    --------
    :func:`record` returns one; here a stream of two seconds of a sensor lying still:

    >>> import io, tempfile
    >>> from pathlib import Path
    >>> from imucalib.record import Recorder, record
    >>> rows = [b"t,ax,ay,az,gx,gy,gz"] + [b"%.2f,0,0,16384,0,0,0" % (k / 100) for k in range(200)]
    >>> result = record(io.BytesIO(bytes([10]).join(rows)), Path(tempfile.mkdtemp()) / "s.csv",
    ...                 Recorder(lambda event: None))
    >>> result.lines, result.bad, result.poses, result.complete, result.interrupted
    (201, 0, 0, False, False)
    """

    path: Path
    lines: int
    bad: int
    poses: int
    complete: bool
    interrupted: bool
    ended: str | None = None  # how the source ended when it went away (a device unplugged, a peer gone)

    @property
    def unparsed(self) -> int:
        """The lines left out (the older name)."""
        return self.bad


@dataclass
class _End:
    reason: str | None


@dataclass
class _Failed:
    error: BaseException


def _pump(source: Source, q: queue.Queue, stop: threading.Event, poll: float) -> None:
    """Read the source until it ends or ``stop`` is set, its lines queued in batches; a failure queued too."""
    split = LineSplitter()
    try:
        try:
            while not stop.is_set():
                chunk = source.read(poll)
                if chunk is None:
                    continue
                if not chunk:
                    break
                lines = split.push(chunk)
                if lines:
                    q.put(lines)
            else:
                return
        except SourceGone as exc:
            tail = split.close()
            if tail:
                q.put(tail)
            q.put(_End(str(exc)))
            return
        tail = split.close()
        if tail:
            q.put(tail)
        q.put(_End(None))
    except BaseException as exc:  # noqa: BLE001 (any failure of the reader ends the session with its reason)
        q.put(_Failed(exc))


class RecordError(OSError):
    """Reading the stream failed: the session so far is kept (the message says where).

    Examples
    --------
    A stream that fails after 300 rows, as a device unplugged in the middle of a read does:

    >>> import io, tempfile
    >>> from pathlib import Path
    >>> from imucalib.record import Recorder, RecordError, record
    >>> class Unplugged(io.RawIOBase):
    ...     rows = [b"t,ax,ay,az,gx,gy,gz"]
    ...     rows += [b"%.2f,0,0,16384,0,0,0" % (k / 100) for k in range(300)]
    ...     def readable(self):
    ...         return True
    ...     def readline(self, size=-1):
    ...         if self.rows:
    ...             return self.rows.pop(0) + bytes([10])
    ...         raise OSError("device disconnected")
    >>> try:
    ...     record(Unplugged(), Path(tempfile.mkdtemp()) / "s.csv", Recorder(lambda event: None))
    ... except RecordError as exc:
    ...     print(exc)
    reading the stream failed after 301 lines (OSError: device disconnected); the session so far
    is in /.../s.csv
    """


def _not_a_table(recorder: Recorder, writer: SessionWriter, exc: ValueError, more: list | None = None):
    """The stream is not a table that can be followed: its lines so far into the ``.partial``, and why."""
    writer.write_lines(recorder.unread(more))
    partial = writer.finish(rename=False)
    raise ValueError(f"{exc} (the {writer.lines} lines read so far are in {partial})") from None


def _resume(writer: SessionWriter, recorder: Recorder) -> None:
    """The recorder fed the unfinished session's lines again (already in the file: not written twice)."""

    if len(writer.resumed) < HEAD_LINES:
        writer.finish(rename=False)
        raise ValueError(f"--resume: {writer.partial} holds {len(writer.resumed)} lines, fewer than the "
                         f"{HEAD_LINES} the layout is read from: give -o another name")
    recorder.sink = None
    recorder.feed(writer.resumed)
    recorder.mark_written()


def _follow(q: queue.Queue, recorder: Recorder, writer: SessionWriter, stop: threading.Event,
            interrupted: threading.Event, poll: float, silence: float) -> tuple:
    """The lines the reading thread queues fed to the recorder until the stream ends, fails or is interrupted;
    ``(how it ended, the reading error)`` (:func:`record`)."""
    ended, error = None, None
    last, said = time.monotonic(), 0
    while not interrupted.is_set():
        try:
            item = q.get(timeout=poll)
        except queue.Empty:
            quiet = time.monotonic() - last
            if silence and quiet >= silence * (said + 1):
                said += 1
                recorder.emit({"event": "silence", "seconds": round(silence * said, 1),
                               "message": f"no data for {silence * said:g} s: is the sensor still sending? "
                                          "(check the cable or connection, the port, the baud rate)"})
            continue
        if isinstance(item, _End):
            ended = item.reason
            break
        if isinstance(item, _Failed):
            error = item.error
            break
        last, said = time.monotonic(), 0
        for k in range(0, len(item), 2000):  # Ctrl-C is looked at between slices of a long batch
            try:
                recorder.feed(item[k:k + 2000])
            except ValueError as exc:  # the stream cannot be followed: keep what was read, say where it is
                stop.set()
                more = list(item[k + 2000:])
                while not q.empty():
                    queued = q.get_nowait()
                    more += queued if isinstance(queued, list) else []
                _not_a_table(recorder, writer, exc, more)
            if interrupted.is_set():
                break
    return ended, error


def _end_stream(recorder: Recorder, writer: SessionWriter, source, error) -> None:
    """The recorder's end of the stream; a table it cannot follow, or a failed read, leaves the ``.partial`` file
    and raises (:func:`record`)."""
    try:
        recorder.end_stream()
    except ValueError as exc:
        if error is None:
            _not_a_table(recorder, writer, exc)
        head = recorder.unread()
        writer.write_lines(head)
        partial = writer.finish(rename=False)
        raise RecordError(f"reading {source.name} failed after {recorder.line_no + len(head)} lines "
                          f"({type(error).__name__}: {error}); the lines read so far are in {partial}") from None
    except BaseException:
        writer.finish(rename=False)
        raise


def record(stream, output: str | Path | SessionWriter, recorder: Recorder, *, poll: float = 0.1,
           force: bool = False, silence: float = 5.0) -> RecordResult:
    """Record ``stream`` into ``output`` while ``recorder`` follows it.

    The lines the recorder keeps are written to ``output + ".partial"`` as each block is analysed (flushed);
    at the end of the stream, when the device or peer goes away, on Ctrl-C or SIGTERM, the session is
    finished, renamed to ``output`` and calibrated by the recorder (its ``end`` event). A process killed
    meanwhile leaves the ``.partial`` file with every line kept up to then.

    Parameters
    ----------
    stream : Source or binary stream
        A :class:`~imucalib.record.sources.Source` (:func:`open_source`), or any binary stream with ``read1``
        or ``readline``.
    output : str, Path or SessionWriter
        The session file to write (a :class:`SessionWriter` to resume an unfinished one).
    recorder : Recorder
        What follows the stream: poses found, prompts, the calibration at the end.
    poll : float
        How often [s] the end of the stream and Ctrl-C/SIGTERM are looked at, data flowing or not.
    force : bool
        Replace an existing session at ``output`` at the end.
    silence : float
        After this many seconds [s] without a line, a ``silence`` event (then every as many).

    Returns
    -------
    RecordResult
        The file written, the lines read and left out, the poses held, whether the session is complete,
        whether it was interrupted, and how the source ended.

    Raises
    ------
    FileExistsError
        A session at ``output`` (without ``force``), or an unfinished ``output.partial`` of an earlier run.
    ValueError
        The stream is not a table that can be followed (its lines so far are in the ``.partial`` file).
    RecordError
        Reading the stream failed (the session so far is at ``output``).

    Examples
    --------
    A simulated session replayed as a stream (a serial port or ``imucalib record -`` would give the same
    lines), recorded to a file while the recorder follows it:

    >>> import io, tempfile
    >>> from pathlib import Path
    >>> from imucalib.io import write_csv
    >>> from imucalib.record import Recorder, record
    >>> from imucalib.scenarios import session
    >>> folder = Path(tempfile.mkdtemp())
    >>> write_csv(folder / "stream.csv", session("handheld", rng=1, rest=8, n_poses=14).recording)
    >>> events = []
    >>> result = record(io.BytesIO((folder / "stream.csv").read_bytes()), folder / "session.csv",
    ...                 Recorder(events.append))
    >>> result.path.name, result.poses, result.complete, events[-1]["verdict"]
    ('session.csv', 14, True, 'accepted')
    """
    writer = output if isinstance(output, SessionWriter) else SessionWriter(output, force=force)
    if writer.resumed:  # the session so far, followed again; its lines are in the file already
        _resume(writer, recorder)
    recorder.sink = writer.write_lines
    source = as_source(stream)
    q: queue.Queue = queue.Queue()
    stop, interrupted = threading.Event(), threading.Event()
    thread = threading.Thread(target=_pump, args=(source, q, stop, poll), daemon=True, name="imucalib-record")
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, lambda signum, frame: interrupted.set())
    thread.start()
    try:
        ended, error = _follow(q, recorder, writer, stop, interrupted, poll, silence)
    except BaseException:
        stop.set()
        writer.finish(rename=False)
        raise
    finally:
        stop.set()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    thread.join(timeout=1.0)
    _end_stream(recorder, writer, source, error)
    path = writer.finish()
    recorder.conclude()
    if error is not None:
        raise RecordError(f"reading {source.name} failed after {recorder.line_no} lines "
                          f"({type(error).__name__}: {error}); the session so far is in {path}")
    return RecordResult(path, recorder.line_no, recorder.bad, len(recorder.poses), recorder.complete,
                        interrupted.is_set(), ended)
