"""Guided recording: a live stream of samples, written as it comes, with what to do next.

:func:`record` reads a sensor's text stream line by line (standard input, a
serial port, a TCP socket, phyphox's remote-access interface: :func:`open_source`),
writes every line, unchanged and in order, to ``OUTPUT.partial`` as it
arrives (flushed: readable at any time, and after a killed process), and
renames it to ``OUTPUT`` on a clean finish (the end of the stream, or
Ctrl-C). Meanwhile a :class:`Recorder` follows the samples with the code the
offline calibration uses:

* the table of the stream is found by the CSV reader
  (:func:`imucalib.io.read` on the first lines: header, units, time column),
  every later line parsed into the same columns; a line that does not parse
  is counted and reported, and still written;
* the initial rest is timed (a countdown of ``rest`` seconds) and checked by
  :func:`imucalib.segment.find_initial_rest`;
* poses are found by the accelerometer detector of Tedaldi 2014 run as the
  samples arrive (:class:`imucalib.segment.StillDetector`: the statistic,
  window and threshold of the offline detector), each announced with its
  up-direction in words and the coverage of the directions so far
  (:func:`imucalib.metrics.pose_coverage`);
* the next pose to take (:func:`imucalib.plans.next_poses`), warnings when a
  rotation is too fast for the rate (the gyroscope near its range, or more
  than ``max_step_deg`` per sample, which the attitude integration of Zhang
  2021 eq. 23 cannot follow) or a pose wobbles
  (:func:`imucalib.segment.gyro_still`), and ``complete`` once a calibration
  of the poses so far by the chosen method is accepted
  (:func:`imucalib.methods.calibrate` and its verdict).

Every event is a dict ``{"event": kind, ...}`` with sample indices (0-based,
into the data rows) and times [s from the first sample]: ``format``,
``rest`` (countdown, then done), ``pose``, ``next_pose``, ``warning``,
``complete``, ``end``.
"""

from __future__ import annotations

import contextlib
import os
import queue
import signal
import socket
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

import numpy as np

from .constants import STANDARD_GRAVITY
from .methodinfo import DEFAULT_METHOD, declared, needing
from .recording import Interval, Recording

__all__ = ["Recorder", "LineFormat", "SessionWriter", "record", "open_source", "RecordResult", "MAX_STEP_DEG"]

#: the largest rotation per sample [deg] the attitude integration is trusted with
MAX_STEP_DEG = 5.0
#: methods that calibrate from the six faces (each axis up and down)
FACE_METHODS = needing("six faces")
#: lines read before the table's layout is decided (fewer when the stream ends sooner)
HEAD_LINES = 50


@dataclass
class LineFormat:
    """How one data line becomes a sample: the columns of t, ax…gz, the separator, the time unit."""

    indices: tuple[int | None, ...]  # t, ax, ay, az, gx, gy, gz
    separator: str | None  # None: blanks
    ncols: int
    time_scale: float | None  # seconds per unit of the time column; None: no time column
    rate: float | None  # the rate of a stream without a time column
    decimal_comma: bool
    acc_unit: str
    gyro_unit: str

    @classmethod
    def from_head(cls, lines: list[bytes], *, columns=None, acc_unit=None, gyro_unit=None, time_unit=None,
                  rate=None, directory: Path | None = None) -> tuple[LineFormat, list[str]]:
        """The layout of a stream from its first lines, as the CSV reader (:func:`imucalib.io.read`) takes them.

        Returns the format and the reader's notes. Raises ``ValueError`` (the
        reader's message) when the lines are not a table the reader takes.
        """
        from .io.readers import TIME_UNITS, read

        fd, name = tempfile.mkstemp(suffix=".csv", dir=directory)
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.writelines(ln if ln.endswith(b"\n") else ln + b"\n" for ln in lines)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                rec = read(name, reader="csv", columns=columns, acc_unit=acc_unit, gyro_unit=gyro_unit,
                           time_unit=time_unit, rate=rate)
        finally:
            with contextlib.suppress(OSError):
                os.unlink(name)
        meta = rec.metadata
        names = [n.lower() for n in meta["column_names"]]
        idx = tuple(None if meta["columns"][f] is None else names.index(meta["columns"][f].lower())
                    for f in ("t", "ax", "ay", "az", "gx", "gy", "gz"))
        sep = meta.get("separator")
        sep = None if sep in (None, " ") else sep
        unit = meta.get("time_unit")
        fmt = cls(indices=idx, separator=sep, ncols=len(names),
                  time_scale=None if idx[0] is None else TIME_UNITS[unit or "s"],
                  rate=None if idx[0] is not None else float(rec.rate), decimal_comma=sep in (";", "\t"),
                  acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit)
        # the rows the reader read must parse to the same numbers here
        rows = [r for r in (fmt.parse(ln) for ln in lines) if r is not None][-len(rec):]
        if len(rows) != len(rec) or not (np.array_equal(np.array([r[1:4] for r in rows]), rec.acc)
                                         and np.array_equal(np.array([r[4:] for r in rows]), rec.gyro)):
            raise ValueError("the stream's first lines are a table the reader takes, but not one that can be "
                             "followed line by line (pass --columns, or record to a file and calibrate it)")
        return fmt, [str(w.message) for w in caught]

    def parse(self, line: bytes) -> tuple[float, ...] | None:
        """``(t_raw, ax, ay, az, gx, gy, gz)`` of a data line, or None when it is not one."""
        try:
            text = line.decode("utf-8").strip()
        except UnicodeDecodeError:
            return None
        if not text:
            return None
        cells = [c.strip().strip('"') for c in (text.split(self.separator) if self.separator else text.split())]
        if len(cells) != self.ncols:
            return None
        try:
            out = tuple(float(cells[j].replace(",", ".") if self.decimal_comma else cells[j]) if j is not None
                        else np.nan for j in self.indices)
        except ValueError:
            return None
        if not all(np.isfinite(out[1:])):
            return None
        return out


class SessionWriter:
    """Lines written to ``OUTPUT.partial`` as they come, flushed; :meth:`finish` renames it to ``OUTPUT``.

    Thread-safe: the thread that reads the stream writes, another finishes.
    """

    def __init__(self, output: str | Path) -> None:
        self.output = Path(output)
        self.partial = self.output.with_name(self.output.name + ".partial")
        if not self.output.parent.is_dir():
            raise ValueError(f"{self.output}: its directory does not exist")
        self._fh = open(self.partial, "wb")  # noqa: SIM115 (closed by finish)
        self._lock = threading.Lock()
        self.lines = 0

    def write(self, line: bytes) -> bool:
        """Append one line (as read, newline included); False once finished."""
        with self._lock:
            if self._fh is None:
                return False
            self._fh.write(line)
            self._fh.flush()
            self.lines += 1
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
        from .io.atomic import move_into_place

        move_into_place(self.partial, self.output)
        return self.output


class Recorder:
    """Follows a live recording line by line and says what happens: see the module docstring.

    Parameters
    ----------
    on_event : callable
        Called with each event (a dict), in order.
    method : str
        The calibration method the session is for (``complete`` when it accepts the poses).
    gravity : float
        Local gravity [m/s²].
    rest : float
        Seconds of initial rest to count down.
    columns, acc_unit, gyro_unit, time_unit, rate
        As for :func:`imucalib.io.read`.
    multiplier : float
        Threshold of the pose detector, times the rest's variance norm (:class:`~imucalib.segment.StillDetector`).
    gyro_range : float, optional
        The gyroscope's full scale in its raw unit (default: 32768 for counts, else unknown).
    max_step_deg : float
        A rotation faster than this per sample is too fast for the rate.
    method_options : dict, optional
        Keyword options of the method (as for :func:`imucalib.methods.calibrate`).
    """

    def __init__(self, on_event: Callable[[dict], None], *, method: str = DEFAULT_METHOD,
                 gravity: float = STANDARD_GRAVITY, rest: float = 5.0, columns=None, acc_unit=None,
                 gyro_unit=None, time_unit=None, rate=None, multiplier: float = 6.0,
                 gyro_range: float | None = None, max_step_deg: float = MAX_STEP_DEG,
                 method_options: dict | None = None, directory: Path | None = None) -> None:
        if method not in declared():
            raise ValueError(f"unknown method {method!r}; use one of {', '.join(declared())}")
        if not (np.isfinite(rest) and rest > 0):
            raise ValueError(f"rest must be a positive number of seconds; got {rest!r}")
        self.emit = on_event
        self.method, self.gravity, self.rest_seconds = method, gravity, float(rest)
        self.reader_options = {"columns": columns, "acc_unit": acc_unit, "gyro_unit": gyro_unit,
                               "time_unit": time_unit, "rate": rate}
        self.multiplier, self.gyro_range, self.max_step = multiplier, gyro_range, np.radians(max_step_deg)
        self.method_options = dict(method_options or {})
        self.directory = directory
        self.format: LineFormat | None = None
        self._head: list[bytes] = []
        self.line_no = 0  # lines seen
        self.unparsed = 0
        self._t = np.empty(0)
        self._raw = np.empty((4096, 7))
        self.n = 0
        self.rest: Interval | None = None
        self.detector = None
        self.poses: list[Interval] = []
        self.directions: list[np.ndarray] = []
        self.complete = False
        self.trial = None  # the last calibration of the poses so far
        self.trial_error: str | None = None
        self.scale: float | None = None  # rad/s per raw gyroscope unit
        self._countdown = None
        self._last_warning: dict[str, float] = {}
        self._checked = 0  # samples checked against the gyroscope's range
        self._checked_speed = 0  # samples checked for fast rotations (once the gyroscope's scale is known)

    # ------------------------------------------------------------ input
    def feed(self, lines: list[bytes]) -> None:
        """Take the next lines of the stream (as read, newlines included)."""
        if self.format is None:
            self._head += lines
            if len(self._head) < HEAD_LINES:
                return
            lines, self._head = self._head, []
            self._start(lines)
            return
        self._add(lines)

    def close(self) -> None:
        """The stream has ended: finish the head, the last pose and say so (an ``end`` event)."""
        if self.format is None and self._head:
            lines, self._head = self._head, []
            self._start(lines)
        if self.detector is not None:
            for iv in self.detector.close():
                self._interval(iv)
        self.emit({"event": "end", "lines": self.line_no, "samples": self.n, "unparsed_lines": self.unparsed,
                   "poses": len(self.poses), "complete": self.complete, "t": self._time(self.n - 1)})

    def _start(self, lines: list[bytes]) -> None:
        fmt, notes = self._format(lines)
        self.format = fmt
        self.emit({"event": "format", "columns": list(fmt.indices), "acc_unit": fmt.acc_unit,
                   "gyro_unit": fmt.gyro_unit, "time": "column" if fmt.time_scale else f"{fmt.rate:g} Hz",
                   "notes": notes})
        self.scale = {"rad/s": 1.0, "deg/s": np.pi / 180}.get(fmt.gyro_unit)
        if self.gyro_range is None and fmt.gyro_unit == "counts":
            self.gyro_range = 32768.0
        data_seen = False
        for ln in lines:  # the header and preamble lines before the first row are not data
            if not data_seen and fmt.parse(ln) is not None:
                data_seen = True
            if data_seen:
                self._add([ln])
            else:
                self.line_no += 1

    def _format(self, lines: list[bytes]) -> tuple[LineFormat, list[str]]:
        """The stream's layout from its first lines; a row the reader names as bad is left out and tried again.

        A boot message or a garbled row among the first lines is then counted as
        a line that does not parse, as it would be later in the stream.
        """
        import re

        head = list(lines)
        for _ in range(5):
            try:
                return LineFormat.from_head(head, directory=self.directory, **self.reader_options)
            except ValueError as exc:
                m = re.search(r"\.csv: line (\d+)[:,]", str(exc))
                k = int(m.group(1)) - 1 if m else -1
                if not 0 < k < len(head) - 1:
                    raise ValueError(f"the stream's first {len(lines)} lines are not a table the reader takes: "
                                     + str(exc).split(".csv: ", 1)[-1]) from None
                del head[k]
        raise ValueError(f"the stream's first {len(lines)} lines hold more than five rows that do not parse")

    def _add(self, lines: list[bytes]) -> None:
        fmt = self.format
        start = self.n
        for ln in lines:
            self.line_no += 1
            row = fmt.parse(ln)
            if row is None:
                self.unparsed += 1
                if self.unparsed <= 5:
                    text = ln.decode("utf-8", "replace").rstrip("\r\n")[:80]
                    self.emit({"event": "warning", "kind": "unparsed_line", "line": self.line_no,
                               "message": f"line {self.line_no} does not parse ({text!r}); it is kept in the "
                                          "file and counted"})
                continue
            if self.n == self._raw.shape[0]:
                self._raw = np.concatenate([self._raw, np.empty_like(self._raw)])
            self._raw[self.n] = row
            self.n += 1
        if self.n > start:
            self._samples(start)

    # --------------------------------------------------------- samples
    @property
    def t(self) -> np.ndarray:
        """Times of the samples so far [s from the first]."""
        fmt = self.format
        if fmt.time_scale is None:
            return np.arange(self.n) / fmt.rate
        raw = self._raw[: self.n, 0]
        return (raw - raw[0]) * fmt.time_scale if self.n else raw

    def recording(self, stop: int | None = None) -> Recording:
        """The samples so far (or up to ``stop``) as a :class:`~imucalib.recording.Recording` in the stream's units."""
        stop = self.n if stop is None else stop
        raw = self._raw[:stop]
        return Recording(t=self.t[:stop], acc=raw[:, 1:4], gyro=raw[:, 4:7], acc_unit=self.format.acc_unit,
                         gyro_unit=self.format.gyro_unit)

    def _time(self, i: int) -> float:
        if self.n == 0:
            return 0.0
        fmt = self.format
        if fmt.time_scale is None:
            return i / fmt.rate
        return float((self._raw[min(max(i, 0), self.n - 1), 0] - self._raw[0, 0]) * fmt.time_scale)

    def _samples(self, start: int) -> None:
        if self.rest is None:
            self._rest()
            if self.rest is None:
                return
            start = 0
        self._fast(start)
        for iv in self.detector.push(self._raw[start:self.n, 1:4]):
            self._interval(iv)

    def _rate(self) -> float:
        if self.format.time_scale is None:
            return self.format.rate
        dt = np.diff(self.t[: min(self.n, 1000)])
        return float(1.0 / np.median(dt)) if dt.size else np.nan

    def _rest(self) -> None:
        """Count the rest down; once it is over, check it and start the pose detector."""
        from .segment import StillDetector, find_initial_rest

        if self.n < 10:
            return
        rate = self._rate()
        need = int(np.ceil(self.rest_seconds * rate))
        left = max(self.rest_seconds - self._time(self.n - 1), 0.0)
        whole = int(np.ceil(left))
        if whole != self._countdown and self.n < need and whole > 0:
            self._countdown = whole
            self.emit({"event": "rest", "remaining_s": whole, "sample": self.n - 1, "t": self._time(self.n - 1)})
        if self.n < need:
            return
        rec = self.recording()
        try:
            found = find_initial_rest(rec, min_seconds=min(self.rest_seconds, 0.5 * rec.duration))
            stop = min(found.stop, need)
            moved = None
        except ValueError as exc:
            stop, moved = need, str(exc)
        self.rest = Interval(0, stop, "static")
        if moved:
            self._warn("rest", self.n - 1, f"the sensor moved during the initial rest ({moved}); calibrating this "
                                           "session will need --init-static, or start the recording again")
        self.detector = StillDetector(self._raw[:stop, 1:4], rate, multiplier=self.multiplier)
        self.emit({"event": "rest", "remaining_s": 0, "start": 0, "stop": stop, "t": self._time(stop - 1),
                   "message": "initial rest recorded: take the first pose"})

    def _fast(self, start: int) -> None:
        """Warnings for rotations the rate or the gyroscope's range cannot follow, in samples ``[start, n)``.

        Each sample is checked once against the range and once for its rotation per sample; the latter waits
        until the gyroscope's scale is known (raw counts: from the first poses), so that what is found does
        not depend on how the stream's lines were batched.
        """
        bias = self._raw[: self.rest.stop, 4:7].mean(axis=0)
        first = max(start, self._checked, 1)
        if self.gyro_range and first < self.n:
            g = self._raw[first:self.n, 4:7]
            near = np.nonzero(np.max(np.abs(g), axis=1) >= 0.95 * self.gyro_range)[0]
            if near.size:
                i = first + int(near[0])
                self._warn("saturation", i, f"the gyroscope reaches {np.max(np.abs(g[near[0]])):.0f} of its "
                                            f"±{self.gyro_range:g} range at t = {self._time(i):.2f} s: turn more "
                                            "slowly (a clipped rate loses the rotation)")
        self._checked = self.n
        first = max(self._checked_speed, 1)
        if self.scale is None or first >= self.n:
            return
        g = self._raw[first:self.n, 4:7]
        fmt = self.format
        dt = (np.diff(self._raw[first - 1:self.n, 0]) * fmt.time_scale if fmt.time_scale is not None
              else np.full(self.n - first, 1.0 / fmt.rate))
        step = np.linalg.norm(g - bias, axis=1) * abs(self.scale) * dt
        over = np.nonzero(step > self.max_step)[0]
        if over.size:
            i = first + int(over[0])
            self._warn("fast", i, f"a rotation of {np.degrees(step[over[0]]):.1f}° in one sample at "
                                  f"t = {self._time(i):.2f} s (limit {np.degrees(self.max_step):g}°): too fast "
                                  "for this rate; turn more slowly")
        self._checked_speed = self.n

    def _warn(self, kind: str, sample: int, message: str, *, every: float = 2.0, **extra) -> None:
        t = self._time(sample)
        last = self._last_warning.get(kind)
        if last is not None and t - last < every:
            return
        self._last_warning[kind] = t
        self.emit({"event": "warning", "kind": kind, "sample": int(sample), "t": t, "message": message, **extra})

    # ----------------------------------------------------------- poses
    def _interval(self, iv: Interval) -> None:
        from .metrics import pose_coverage
        from .plans import describe_direction

        if iv.start == 0:  # the rest, still held when the detector started
            self.directions.append(self._direction(iv))
            return
        self.poses.append(iv)
        up = self._direction(iv)
        self.directions.append(up)
        coverage, _ = pose_coverage(np.array(self.directions))
        k = len(self.poses)
        self.emit({"event": "pose", "pose": k, "start": iv.start, "stop": iv.stop, "t_start": self._time(iv.start),
                   "t_stop": self._time(iv.stop - 1), "seconds": self._time(iv.stop - 1) - self._time(iv.start),
                   "up": up.tolist(), "words": describe_direction(up), "coverage": coverage})
        self._wobble(iv, k)
        if not self.complete:
            self._try_calibration(iv.stop)
        if not self.complete:
            self._next(iv.stop - 1)

    def _direction(self, iv: Interval) -> np.ndarray:
        raw = self._raw[iv.start:iv.stop, 1:4].mean(axis=0)
        a = raw if self.trial is None else self.trial.accelerometer_si(raw[None, :])[0]
        return a / np.linalg.norm(a)

    def _intervals(self) -> list[Interval]:
        return [self.rest, *self.poses]

    def _wobble(self, iv: Interval, k: int) -> None:
        from .fit.gyroscope import rough_scale
        from .models import TriadModel
        from .segment import gyro_still

        rec = self.recording(iv.stop)
        bias = rec.gyro[self.rest.slice].mean(axis=0)
        if self.scale is None and len(self.poses) >= 3:
            with contextlib.suppress(ValueError, FloatingPointError):
                s = rough_scale(rec, self._intervals(), TriadModel(), bias)
                if np.isfinite(s) and s > 0:
                    self.scale = float(s)
        if self.scale is None:
            return
        still = gyro_still(rec, self.rest, self.scale, [iv])[iv.slice]
        moving = 1.0 - float(np.mean(still))
        if moving > 0.25:
            self._warn("wobble", iv.stop - 1, f"pose {k} wobbles: the gyroscope moves during {100 * moving:.0f} % "
                                              "of it; hold the sensor steadier (or rest it on the table)",
                       every=0.0, pose=k)

    def _try_calibration(self, stop: int) -> None:
        from .methods import calibrate
        from .segment import MIN_INTERVALS

        if len(self.poses) + 1 < (7 if self.method in FACE_METHODS else MIN_INTERVALS):
            return
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                cal = calibrate(self.recording(stop), method=self.method, gravity=self.gravity,
                                **self.method_options)
        except ValueError as exc:
            self.trial_error = str(exc)
            return
        self.trial = cal
        self.scale = self.scale if self.format.gyro_unit != "counts" else float(np.mean(np.abs(cal.gyroscope.scale)))
        if cal.fit.get("verdict") == "accepted":
            self.complete = True
            self.emit({"event": "complete", "poses": len(self.poses), "sample": stop - 1,
                       "t": self._time(stop - 1), "method": self.method, "verdict": "accepted",
                       "message": f"enough poses for an accepted {self.method} calibration: stop the "
                                  "recording (Ctrl-C or end the stream) or add poses"})

    def _next(self, sample: int) -> None:
        from .plans import describe_direction, next_poses

        reasons = (self.trial.fit.get("verdict_reasons") or []) if self.trial is not None else []
        if self.method in FACE_METHODS:  # these take the six faces only: the next pose is one of them
            nxt = next_poses(np.array(self.directions), candidates=np.vstack([np.eye(3), -np.eye(3)]))
        elif self.trial is not None and self.trial.fit.get("next_poses"):
            nxt = np.asarray(self.trial.fit["next_poses"])
        else:
            nxt = next_poses(np.array(self.directions))
        self.emit({"event": "next_pose", "after_pose": len(self.poses), "up": nxt[0].tolist(),
                   "words": describe_direction(nxt[0]), "then": [describe_direction(u) for u in nxt[1:]],
                   "reasons": reasons[:3], "sample": int(sample), "t": self._time(sample)})


@dataclass
class RecordResult:
    """What :func:`record` did: the file written, lines, unparsed lines, poses, whether complete, interrupted."""

    path: Path
    lines: int
    unparsed: int
    poses: int
    complete: bool
    interrupted: bool


_END = object()


def _pump(stream, writer: SessionWriter, q: queue.Queue) -> None:
    """Read lines until the stream ends, each written first, then queued for the analysis."""
    try:
        for line in iter(stream.readline, b""):
            if not writer.write(line):
                break
            q.put(line)
    except (OSError, ValueError) as exc:
        q.put(exc)
    q.put(_END)


def record(stream, output: str | Path, recorder: Recorder, *, poll: float = 0.2) -> RecordResult:
    """Record ``stream`` (binary, with ``readline``) into ``output`` while ``recorder`` follows it.

    Every line is written to ``output + ".partial"`` as soon as it is read
    (flushed); at the end of the stream, or on Ctrl-C (KeyboardInterrupt),
    the analysis of the lines read so far is finished and the file renamed to
    ``output``. A process killed meanwhile leaves the ``.partial`` file with
    every line read up to then.
    """
    writer = SessionWriter(output)
    q: queue.Queue = queue.Queue()
    thread = threading.Thread(target=_pump, args=(stream, writer, q), daemon=True)
    # Ctrl-C sets a flag the loop looks at between batches, so that it never lands inside the analysis
    stop = threading.Event()
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGINT, lambda signum, frame: stop.set())
    thread.start()
    interrupted = False
    error = None
    try:
        pending = None
        while True:
            if stop.is_set():
                interrupted = True
                break
            if pending is None:
                try:
                    pending = q.get(timeout=poll)
                except queue.Empty:
                    continue
            if pending is _END or isinstance(pending, Exception):
                error = pending if pending is not _END else None
                break
            batch, pending = [pending], None
            while len(batch) < 20000:  # what has arrived meanwhile, analysed together
                try:
                    item = q.get_nowait()
                except queue.Empty:
                    break
                if item is _END or isinstance(item, Exception):
                    pending = item
                    break
                batch.append(item)
            recorder.feed(batch)
    except KeyboardInterrupt:
        interrupted = True
    except (ValueError, OSError) as exc:  # the stream cannot be followed: keep what was read, say where it is
        partial = writer.finish(rename=False)
        raise ValueError(f"{exc} (the {writer.lines} lines read so far are in {partial})") from None
    except BaseException:
        writer.finish(rename=False)
        raise
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    # Ctrl-C while the stream was ending (the handler runs as soon as it arrives, the loop sees it at its next
    # turn): the session was still interrupted by the user
    interrupted = interrupted or stop.is_set()
    try:
        recorder.close()
    finally:
        path = writer.finish()
    if error is not None:
        raise OSError(f"reading the stream failed after {writer.lines} lines ({error}); they are in {path}")
    return RecordResult(path, writer.lines, recorder.unparsed, len(recorder.poses), recorder.complete, interrupted)


# ------------------------------------------------------------------ sources
@contextlib.contextmanager
def open_source(spec: str, *, stdin=None) -> Iterator:
    """A binary line stream for ``spec``: ``-``, ``serial:PORT?baud=N``, ``tcp://HOST:PORT``, ``phyphox://HOST:PORT``."""
    if spec == "-":
        import sys

        yield stdin if stdin is not None else sys.stdin.buffer
        return
    if spec.startswith("serial:"):
        try:
            import serial  # pyserial
        except ImportError:
            raise ValueError("a serial port needs pyserial: pip install 'imucalib[serial]'") from None
        rest = spec[len("serial:"):]
        port, _, query = rest.partition("?")
        opts = parse_qs(query)
        try:
            baud = int(opts.get("baud", ["115200"])[0])
        except ValueError:
            raise ValueError(f"{spec}: baud must be a whole number of bits per second") from None
        if not port:
            raise ValueError(f"{spec}: name the port, e.g. serial:/dev/ttyUSB0?baud=115200")
        try:
            port_obj = serial.serial_for_url(port, baudrate=baud, timeout=None)
        except serial.SerialException as exc:
            raise ValueError(f"{spec}: cannot open the port ({exc})") from None
        with port_obj:
            yield port_obj
        return
    url = urlsplit(spec)
    if url.scheme == "tcp":
        if not url.hostname or not url.port:
            raise ValueError(f"{spec}: give the host and port, e.g. tcp://192.168.1.20:5000")
        try:
            sock = socket.create_connection((url.hostname, url.port), timeout=10)
        except OSError as exc:
            raise ValueError(f"{spec}: cannot connect ({exc})") from None
        sock.settimeout(None)
        with sock, sock.makefile("rb") as fh:
            yield fh
        return
    if url.scheme == "phyphox":
        if not url.hostname:
            raise ValueError(f"{spec}: give the phone's address, e.g. phyphox://192.168.1.20:8080")
        yield PhyphoxStream(url.hostname, url.port or 8080)
        return
    raise ValueError(f"unknown source {spec!r}: use -, serial:/dev/ttyUSB0?baud=115200, tcp://HOST:PORT or "
                     "phyphox://HOST:8080")


class PhyphoxStream:
    """phyphox's remote-access interface as a stream of CSV lines ``t,ax,ay,az,gx,gy,gz`` (m/s², rad/s).

    The experiment on the phone must record the accelerometer with gravity
    (buffers ``accX accY accZ acc_time``, as in phyphox's "Acceleration with g")
    and the gyroscope (``gyrX gyrY gyrZ gyr_time``, as in its "Gyroscope"): one
    experiment holding both, with "Allow remote access" on. Over phyphox's
    remote-interface REST API, ``/control?cmd=start`` starts it and
    ``/get?acc_time=T&accX=T|acc_time…`` returns the values recorded after
    ``T`` (``full`` the first time). The gyroscope is interpolated linearly onto
    the accelerometer's stamps, which are written only once the gyroscope has
    caught up with them (accelerometer samples from before the gyroscope's
    first are not written: they have no rate to go with them).
    """

    BUFFERS = ("accX", "accY", "accZ", "gyrX", "gyrY", "gyrZ")

    def __init__(self, host: str, port: int, *, poll: float = 0.1, timeout: float = 5.0) -> None:
        self.base = f"http://{host}:{port}"
        self.poll, self.timeout = poll, timeout
        self._lines: list[bytes] = [b"t,ax [m/s^2],ay [m/s^2],az [m/s^2],gx [rad/s],gy [rad/s],gz [rad/s]\n"]
        self._since = {"acc": None, "gyr": None}
        self._gyro = np.empty((0, 4))
        self._started = False

    def _get(self, path: str) -> dict:
        import json
        import urllib.request

        with urllib.request.urlopen(self.base + path, timeout=self.timeout) as r:  # noqa: S310 (a local device)
            return json.loads(r.read().decode("utf-8"))

    def _fetch(self) -> None:
        if not self._started:
            self._get("/control?cmd=start")
            self._started = True
        query = []
        for sensor, names in (("acc", self.BUFFERS[:3]), ("gyr", self.BUFFERS[3:])):
            since = self._since[sensor]
            sel = "full" if since is None else f"{since!r}|{sensor}_time"
            query += [f"{sensor}_time={'full' if since is None else repr(since)}"] + [f"{n}={sel}" for n in names]
        data = self._get("/get?" + "&".join(query))["buffer"]
        acc = [np.asarray(data[k]["buffer"], dtype=float) for k in ("acc_time", *self.BUFFERS[:3])]
        gyr = [np.asarray(data[k]["buffer"], dtype=float) for k in ("gyr_time", *self.BUFFERS[3:])]
        n_a, n_g = min(map(len, acc)), min(map(len, gyr))
        if n_g:
            self._gyro = np.concatenate([self._gyro, np.column_stack([g[:n_g] for g in gyr])])
            self._since["gyr"] = float(self._gyro[-1, 0])
        if n_a and self._gyro.shape[0] >= 2:
            a = np.column_stack([x[:n_a] for x in acc])
            a = a[(a[:, 0] >= self._gyro[0, 0]) & (a[:, 0] <= self._gyro[-1, 0])]  # where there is a gyroscope
            if a.shape[0]:
                g = np.column_stack([np.interp(a[:, 0], self._gyro[:, 0], self._gyro[:, j]) for j in (1, 2, 3)])
                self._lines += [(",".join(f"{v:.9g}" for v in (*row_a, *row_g)) + "\n").encode()
                                for row_a, row_g in zip(a, g, strict=True)]
                self._since["acc"] = float(a[-1, 0])
                self._gyro = self._gyro[self._gyro[:, 0] >= a[-1, 0] - 1.0]

    def readline(self) -> bytes:
        """The next line (blocking while the phone has nothing new)."""
        while not self._lines:
            try:
                self._fetch()
            except (OSError, ValueError, KeyError) as exc:
                raise OSError(f"phyphox at {self.base}: {exc}") from None
            if not self._lines:
                time.sleep(self.poll)
        return self._lines.pop(0)
