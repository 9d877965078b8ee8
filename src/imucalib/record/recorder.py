"""The analysis of a live recording, line by line: :class:`Recorder`.

The lines are taken in whatever batches they arrive; the rows kept are
analysed in blocks of a fixed number of samples (a tenth of a second at the
stream's rate), counted from the first sample, so that every event — and
every line written to the session — is the same however the lines were
batched. A line left out, or a gap in the stamps, is said at the block of the
sample it comes before.
"""

from __future__ import annotations

import contextlib
import re
import warnings
from collections.abc import Callable

import numpy as np

from ..constants import STANDARD_GRAVITY
from ..methodinfo import DEFAULT_METHOD, declared, needing
from ..models import TriadModel
from ..recording import Interval, Recording
from .guidance import FACES, angle_deg, checklist, held_before, turn_vector, up_directions
from .lines import LineFormat, RowCheck, TooLong, clean_head_line, garbled

__all__ = ["Recorder", "MAX_STEP_DEG", "HEAD_LINES", "BLOCK_SECONDS"]

#: the largest rotation per sample [deg] the attitude integration is trusted with
MAX_STEP_DEG = 5.0
#: methods that calibrate from the six faces (each axis up and down)
FACE_METHODS = needing("six faces")
#: lines read before the table's layout is decided (fewer when the stream ends sooner)
HEAD_LINES = 50
#: the samples analysed together [s of the stream]
BLOCK_SECONDS = 0.1
#: a stretch without samples longer than this (and than 5 sample periods) is a gap [s]
GAP_SECONDS = 0.1
#: what a pose must be held for [s] (the detector's shortest interval) before the person may turn on
HOLD_SECONDS = 1.0


class Recorder:
    """Follows a live recording line by line and says what happens (see :mod:`imucalib.record`).

    Parameters
    ----------
    on_event : callable
        Called with each event (a dict), in order.
    method : str
        The calibration method the session is for (``complete`` when it accepts the poses).
    gravity : float
        Local gravity [m/s²].
    rest : float
        Seconds of initial rest to count down; it starts again when the sensor moves.
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
    sink : callable, optional
        Called with the lines the session keeps (a list of bytes), in order, once each block is analysed
        (the session file: :class:`~imucalib.record.session.SessionWriter`).

    Examples
    --------
    The first 12 s of a simulated stream, fed in one block: the format is found and the rest counted down:

    >>> import io, tempfile
    >>> from pathlib import Path
    >>> from imucalib.io import write_csv
    >>> from imucalib.record import Recorder
    >>> from imucalib.scenarios import session
    >>> path = Path(tempfile.mkdtemp()) / "stream.csv"
    >>> write_csv(path, session("handheld", rng=1, rest=8, n_poses=12).recording)
    >>> events = []
    >>> recorder = Recorder(events.append, rest=5)
    >>> recorder.feed(path.read_bytes().splitlines(keepends=True)[:1200])
    >>> events[0]["event"], events[0]["acc_unit"]
    ('format', 'counts')
    >>> [event["remaining_s"] for event in events if event["event"] == "rest"]
    [5, 4, 3, 2, 1, 0]
    """

    def __init__(self, on_event: Callable[[dict], None], *, method: str = DEFAULT_METHOD,
                 gravity: float = STANDARD_GRAVITY, rest: float = 5.0, columns=None, acc_unit=None,
                 gyro_unit=None, time_unit=None, rate=None, multiplier: float = 6.0,
                 gyro_range: float | None = None, max_step_deg: float = MAX_STEP_DEG,
                 method_options: dict | None = None, directory=None,
                 sink: Callable[[list[bytes]], None] | None = None) -> None:
        if method not in declared():
            raise ValueError(f"unknown method {method!r}; use one of {', '.join(declared())}")
        if not (np.isfinite(rest) and rest > 0):
            raise ValueError(f"rest must be a positive number of seconds; got {rest!r}")
        self.emit = on_event
        self.sink = sink
        self.method, self.gravity, self.rest_seconds = method, gravity, float(rest)
        self.reader_options = {"columns": columns, "acc_unit": acc_unit, "gyro_unit": gyro_unit,
                               "time_unit": time_unit, "rate": rate}
        self.multiplier, self.gyro_range, self.max_step = multiplier, gyro_range, np.radians(max_step_deg)
        self.method_options = dict(method_options or {})
        self.directory = directory
        self.format: LineFormat | None = None
        self.check: RowCheck | None = None
        self._head: list = []
        self.line_no = 0  # lines seen
        self.bad = 0  # lines left out of the session
        self.gaps = 0
        self.dropped_before_rest = 0  # samples of a rest that started again
        self.restarts = 0
        self._raw = np.empty((4096, 7))
        self._lines: list[bytes] = []  # the lines of the samples [written, n)
        self._written = 0  # samples whose lines went to the sink
        self._notes: list[tuple[int, dict]] = []  # events waiting for the block of their sample
        self.n = 0
        self._done = 0  # samples analysed
        self.block = 1
        self.rate = np.nan
        self.rest: Interval | None = None
        self.detector = None
        self.poses: list[Interval] = []
        self._means: list[np.ndarray] = []  # raw accelerometer means: the rest's, then each pose's
        self._turns_raw: list[np.ndarray] = []  # each motion's integrated raw gyroscope (bias removed)
        self.directions = np.empty((0, 3))
        self.source_of_directions = "raw"
        self.complete = False
        self.trial = None  # the last calibration of the poses so far
        self.trial_error: str | None = None
        self.final = None  # the calibration of the whole session, at close
        self.scale: float | None = None  # rad/s per raw gyroscope unit
        self.suggestion: np.ndarray | None = None
        self._countdown = None
        self._restarted = False
        self._closing = False
        self._held_said = -1.0
        self._last_warning: dict[str, float] = {}
        self._checked = 0  # samples checked against the gyroscope's range and for fast rotations

    # ------------------------------------------------------------ input
    def feed(self, lines: list) -> None:
        """Take the next lines of the stream (bytes as read, newlines included, or :class:`~.lines.TooLong`)."""
        for k, line in enumerate(lines):
            if self.format is None:
                self._head.append(line)
                if len(self._head) >= HEAD_LINES:
                    try:
                        self._start()
                    except ValueError:  # the lines stay with the head: the caller keeps them
                        self._head += lines[k + 1:]
                        raise
                continue
            self._line(line)
        self._analyse(final=False)

    def close(self) -> None:
        """The stream has ended: :meth:`end_stream`, then :meth:`conclude`."""
        self.end_stream()
        self.conclude()

    def mark_written(self) -> None:
        """Take every line so far as in the session file already (a session resumed from its ``.partial``)."""
        self._lines = []
        self._written = self.n

    def unread(self, more: list | None = None) -> list[bytes]:
        """The lines taken but not followed (the head, when the stream is not a table), ``more`` after them; cleared."""
        head = [ln for ln in [*self._head, *(more or [])] if not isinstance(ln, TooLong)]
        self._head = []
        return head

    def end_stream(self) -> None:
        """Finish the head, the last block and pose: every line the session keeps handed to the sink."""
        if self.format is None and self._head:
            self._start()
        if self.check is not None:
            for decision in self.check.close():
                self._decided(decision)
        self._analyse(final=True)
        if self.detector is not None:
            self._closing = True  # the last pose: no trial calibration, conclude() calibrates the whole session
            for iv in self.detector.close():
                self._interval(iv, self.n)
        elif self.n:  # the stream ended during the initial rest: keep what was recorded
            self._write(self.n)
        self._flush_notes(None)

    def conclude(self) -> None:
        """Calibrate the whole session (as ``calibrate`` will) and say so: the ``end`` event with the verdict."""
        verdict, reasons = None, []
        if self.poses and self.rest is not None:
            self.final = self._calibrate(self.n)
            if self.final is not None:
                verdict, reasons = self.final.fit.verdict.level, list(self.final.fit.verdict.reasons or [])
        self.emit({"event": "end", "lines": self.line_no, "samples": self.n, "bad_lines": self.bad,
                   "gaps": self.gaps, "rest_restarts": self.restarts, "left_out_before_rest": self.dropped_before_rest,
                   "poses": len(self.poses), "complete": self.complete, "t": self._time(self.n - 1),
                   "verdict": verdict, "reasons": reasons[:3], "redo": self._redo(verdict, reasons),
                   "error": self.trial_error if verdict is None and self.poses else None})

    def _start(self) -> None:
        """The layout from the head; its lines written (header), left out (garbage) or taken as rows."""
        head = list(self._head)
        clean: list[bytes | None] = [None if isinstance(ln, TooLong) else clean_head_line(ln) for ln in head]
        fmt, notes, refused = self._format([ln for ln in clean if ln is not None])
        kept = [k for k, ln in enumerate(clean) if ln is not None]
        refused = {kept[j] for j in refused}
        self._head = []
        self.format = fmt
        self.rate = float(fmt.rate if fmt.time_scale is None else fmt.head_rate)
        self.block = max(int(round(BLOCK_SECONDS * self.rate)), 1)
        self.check = RowCheck(fmt, gap=max(GAP_SECONDS, 5.0 / self.rate))
        self.emit({"event": "format", "columns": list(fmt.indices), "acc_unit": fmt.acc_unit,
                   "gyro_unit": fmt.gyro_unit, "time": "column" if fmt.time_scale else f"{fmt.rate:g} Hz",
                   "rate": self.rate, "notes": notes})
        self.scale = {"rad/s": 1.0, "deg/s": np.pi / 180}.get(fmt.gyro_unit)
        if self.gyro_range is None and fmt.gyro_unit == "counts":
            self.gyro_range = 32768.0
        data_seen = False
        for k, (raw, ln) in enumerate(zip(head, clean, strict=True)):
            if ln is None or k in refused:
                self.line_no += 1
                self._note_bad(raw, "a line the reader does not take at the start of the stream"
                               if ln is not None else "bytes that are not text (a glitch of the connection)")
                continue
            if not data_seen and fmt.parse(ln) is not None:
                data_seen = True
            if data_seen:
                self._line(raw if ln == raw else ln)
            else:  # the header and the lines before it: the session's first lines
                self.line_no += 1
                if ln != raw:
                    self._note_bad(raw, "garbage bytes before the text (removed; the rest of the line is kept)")
                if self.sink is not None:
                    self.sink([ln if ln.endswith(b"\n") else ln + b"\n"])

    def _format(self, lines: list[bytes]) -> tuple[LineFormat, list[str], list[int]]:
        """The stream's layout from its first lines; a row the reader names as bad is left out and tried again."""
        head = list(lines)
        index = list(range(len(lines)))
        refused: list[int] = []
        for _ in range(6):
            try:
                fmt, notes = LineFormat.from_head(head, directory=self.directory, **self.reader_options)
                return fmt, notes, refused
            except ValueError as exc:
                m = re.search(r"\.csv: line (\d+)[:,]", str(exc))
                k = int(m.group(1)) - 1 if m else -1
                if not 0 < k < len(head) - 1:
                    raise ValueError(f"the stream's first {len(lines)} lines are not a table the reader takes: "
                                     + str(exc).split(".csv: ", 1)[-1]) from None
                del head[k]
                refused.append(index.pop(k))
        raise ValueError(f"the stream's first {len(lines)} lines hold more than five rows that do not parse")

    def _line(self, line) -> None:
        self.line_no += 1
        for decision in self.check.push(line, self.line_no):
            self._decided(decision)

    def _decided(self, decision: tuple) -> None:
        kind = decision[0]
        if kind == "bad":
            _, line, reason, number = decision
            self._note_bad(line, reason, number)
        elif kind == "gap":
            seconds = decision[1]
            self.gaps += 1
            t0 = self._time(self.n - 1)
            self._notes.append((self.n, {
                "event": "warning", "kind": "gap", "sample": self.n, "t": t0, "seconds": seconds,
                "message": f"a gap of {seconds:.2f} s without samples after t = {t0:.2f} s: samples were lost "
                           "(a loose cable, a link too slow for the rate, a full buffer); the poses and turns "
                           "across it are not trusted, record again if it was inside a pose"}))
        else:
            _, line, row, _number = decision
            if self.n == self._raw.shape[0]:
                self._raw = np.concatenate([self._raw, np.empty_like(self._raw)])
            self._raw[self.n] = row
            self.n += 1
            self._lines.append(line)

    def _note_bad(self, line, reason: str, number: int | None = None) -> None:
        self.bad += 1
        number = self.line_no if number is None else number
        text = (f"{line.size} bytes" if isinstance(line, TooLong)
                else repr(line.decode("utf-8", "replace").rstrip("\r\n")[:60]) if not garbled(line)
                else repr(line[:40]))
        self._notes.append((self.n, {"event": "warning", "kind": "bad_line", "line": number, "reason": reason,
                                     "message": f"line {number} left out of the session ({text}): {reason}"}))

    def _flush_notes(self, before: int | None) -> None:
        """Emit the notes of samples before ``before`` (all when None)."""
        k = 0
        while k < len(self._notes) and (before is None or self._notes[k][0] < before):
            self.emit(self._notes[k][1])
            k += 1
        del self._notes[:k]

    def _write(self, stop: int) -> None:
        """Hand the lines of samples ``[written, stop)`` to the sink."""
        k = stop - self._written
        if k <= 0 or not self._lines:
            self._written = max(self._written, stop)
            return
        if self.sink is not None:
            self.sink(self._lines[:k])
        del self._lines[:k]
        self._written = stop

    # --------------------------------------------------------- samples
    @property
    def unparsed(self) -> int:
        """The lines left out of the session (the older name of :attr:`bad`)."""
        return self.bad

    @property
    def t(self) -> np.ndarray:
        """Times of the samples so far [s from the first]."""
        return self._times(0, self.n)

    def _times(self, a: int, b: int) -> np.ndarray:
        fmt = self.format
        if fmt.time_scale is None:
            return np.arange(a, b) / fmt.rate
        return (self._raw[a:b, 0] - self._raw[0, 0]) * fmt.time_scale

    def recording(self, stop: int | None = None) -> Recording:
        """The samples so far (or up to ``stop``) as a :class:`~imucalib.recording.Recording` in the stream's units."""
        stop = self.n if stop is None else stop
        raw = self._raw[:stop]
        return Recording(t=self._times(0, stop), acc=raw[:, 1:4], gyro=raw[:, 4:7], acc_unit=self.format.acc_unit,
                         gyro_unit=self.format.gyro_unit)

    def _time(self, i: int) -> float:
        if self.n == 0:
            return 0.0
        fmt = self.format
        if fmt.time_scale is None:
            return i / fmt.rate
        return float((self._raw[min(max(i, 0), self.n - 1), 0] - self._raw[0, 0]) * fmt.time_scale)

    def _analyse(self, final: bool) -> None:
        while self.n - self._done >= self.block or (final and self.n > self._done):
            m = min(self._done + self.block, self.n)
            self._flush_notes(m)
            self._block(self._done, m)
        if final:
            self._flush_notes(None)

    def _block(self, a: int, m: int) -> None:
        if self.rest is None:
            if not self._rest_block(a, m):
                return
            a = 0
        self._write(m)
        self._fast(m)
        for iv in self.detector.push(self._raw[a:m, 1:4]):
            self._interval(iv, m)
        self._done = m
        self._holding(m)

    # ------------------------------------------------------------ rest
    def _rest_block(self, a: int, m: int) -> bool:
        """Count the rest down over ``[a, m)``; True once it is complete (the detector started)."""
        from ..segment import StillDetector  # imucalib.segment costs 43 ms at start-up

        need = int(np.ceil(self.rest_seconds * self.rate))
        t = self._times(a, m)
        left = np.ceil(np.maximum(self.rest_seconds - t, 0.0)).astype(int)
        for k in np.nonzero(np.diff(np.concatenate([[self._countdown if self._countdown is not None else -1],
                                                     left])))[0]:
            if left[k] > 0 and a + k < need:
                self.emit({"event": "rest", "remaining_s": int(left[k]), "sample": int(a + k), "t": float(t[k])})
        self._countdown = int(left[-1]) if left.size else self._countdown
        self._done = m
        moved = self._moved(m)
        if moved is not None:
            self._restart(m, moved)
            return False
        if m < need:
            return False
        self.rest = Interval(0, need, "static")
        self._means.append(self._raw[:need, 1:4].mean(axis=0))
        self.detector = StillDetector(self._raw[:need, 1:4], self.rate, multiplier=self.multiplier)
        self._write(m)
        self.emit({"event": "rest", "remaining_s": 0, "start": 0, "stop": need, "t": self._time(need - 1),
                   "message": "initial rest recorded: take the first pose"})
        return True

    def _moved(self, m: int) -> float | None:
        """Where the sensor first moved in ``[0, m)`` [s], by the offline rest finder; None when still."""
        from ..segment import SHORTEST_REST, find_initial_rest  # imucalib.segment costs 43 ms at start-up

        if m < SHORTEST_REST * self.rate:
            return None
        rec = self.recording(m)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                found = find_initial_rest(rec, min_seconds=min(self.rest_seconds, 0.5 * rec.duration))
            except ValueError:
                return 0.0
        return None if found.stop >= m else self._time(found.stop)

    def _restart(self, m: int, moved: float | None) -> None:
        """Drop the samples ``[0, m)``: the rest starts again after them (said once while the sensor keeps moving)."""
        self.dropped_before_rest += m
        self.restarts += 1
        keep = self.n - m
        self._raw[:keep] = self._raw[m:self.n]
        del self._lines[:m]
        self._notes = [(max(i - m, 0), e) for i, e in self._notes]
        said = self._countdown is not None and self._countdown < int(np.ceil(self.rest_seconds))
        self.n, self._done, self._written = keep, 0, 0
        if self._restarted and not said:
            return
        self._restarted = True
        when = f"{moved:.1f} s into the initial rest" if moved else "during the initial rest"
        self.emit({"event": "rest", "restart": True, "moved_t": moved, "remaining_s": int(np.ceil(self.rest_seconds)),
                   "message": f"the sensor moved {when}: put it down and keep it still; the {self.rest_seconds:g} s "
                              "rest starts again once it is (the samples before are left out of the session)"})
        self._countdown = None

    # ----------------------------------------------------------- checks
    def _fast(self, m: int) -> None:
        """Warnings for rotations the rate or the gyroscope's range cannot follow, in samples ``[checked, m)``.

        A step across a gap (more than 2.5 sample periods) is no rotation per sample: it is not checked.
        """
        first = max(self._checked, 1)
        if first >= m:
            return
        g = self._raw[first:m, 4:7]
        if self.gyro_range:
            near = np.nonzero(np.max(np.abs(g), axis=1) >= 0.95 * self.gyro_range)[0]
            for j in self._spaced(first, near, "saturation"):
                self._warn("saturation", first + j, f"the gyroscope reaches {np.max(np.abs(g[j])):.0f} of its "
                                                     f"±{self.gyro_range:g} range at t = {self._time(first + j):.2f}"
                                                     " s: turn more slowly (a clipped rate loses the rotation)")
        self._checked = m
        if self.scale is None:
            return
        bias = self._means_gyro_bias()
        dt = np.diff(self._times(first - 1, m))
        step = np.linalg.norm(g - bias, axis=1) * abs(self.scale) * dt
        step[dt > 2.5 / self.rate] = 0.0
        for j in self._spaced(first, np.nonzero(step > self.max_step)[0], "fast"):
            self._warn("fast", first + j, f"a rotation of {np.degrees(step[j]):.1f}° in one sample at "
                                          f"t = {self._time(first + j):.2f} s (limit {np.degrees(self.max_step):g}°):"
                                          " too fast for this rate; turn more slowly")

    def _spaced(self, first: int, idx: np.ndarray, kind: str, every: float = 2.0) -> list[int]:
        """The indices of ``idx`` (from ``first``) that :meth:`_warn` says: at least ``every`` seconds apart."""
        if not idx.size:
            return []
        t = self._times(first, first + int(idx[-1]) + 1)[idx]
        out, last = [], self._last_warning.get(kind)
        k = 0
        while k < idx.size:
            if last is None or t[k] - last >= every:
                out.append(int(idx[k]))
                last = t[k]
                k += 1
            else:
                k = int(np.searchsorted(t, last + every, side="left"))
        return out

    def _means_gyro_bias(self) -> np.ndarray:
        return self._raw[: self.rest.stop, 4:7].mean(axis=0)

    def _warn(self, kind: str, sample: int, message: str, *, every: float = 2.0, **extra) -> None:
        t = self._time(sample)
        last = self._last_warning.get(kind)
        if last is not None and t - last < every:
            return
        self._last_warning[kind] = t
        self.emit({"event": "warning", "kind": kind, "sample": int(sample), "t": t, "message": message, **extra})

    # ----------------------------------------------------------- poses
    def _holding(self, m: int) -> None:
        """While a pose is held: how long, its direction, how far from the suggestion, whether already held."""
        from ..plans import describe_direction  # imucalib.plans costs 22 ms at start-up

        run = self._current_run()
        if run is None or run.start == 0 or run.stop - run.start < 2:
            self._held_said = -1.0
            return
        seconds = self._time(run.stop - 1) - self._time(run.start)
        step = 1.0 if seconds >= HOLD_SECONDS else 0.5 if seconds >= 0.5 else 0.0
        if step <= self._held_said or step == 0.0:  # said twice: at half a second, and once held long enough
            return
        self._held_said = step
        mean = self._raw[run.start:run.stop, 1:4].mean(axis=0)
        up = self._direction_of(mean)
        before = held_before(up, self.directions)
        event = {"event": "holding", "sample": m - 1, "t": self._time(m - 1), "seconds": float(seconds),
                 "up": up.tolist(), "words": describe_direction(up), "enough": bool(seconds >= HOLD_SECONDS),
                 "already_held": before}
        if self.suggestion is not None:
            event["to_suggestion_deg"] = angle_deg(up, self.suggestion)
        self.emit(event)

    def _current_run(self) -> Interval | None:
        """The static run the detector's final statistic ends in (None when moving), looked for after the last
        interval only: at a cost that does not grow with the session."""
        det = self.detector
        stat = det.stream.statistic
        if stat.size == 0 or stat[-1] >= det.threshold:
            return None
        start = det.intervals[-1].stop if det.intervals else 0
        above = np.nonzero(stat[start:] >= det.threshold)[0]
        return Interval(start + int(above[-1]) + 1 if above.size else start, stat.size, "static")

    def _direction_of(self, mean: np.ndarray) -> np.ndarray:
        dirs, _ = up_directions(np.vstack([*self._means, mean]), gravity=self._gravity_unit(), trial=self.trial)
        return dirs[-1]

    def _gravity_unit(self) -> float:
        """Gravity in the accelerometer's unit where it is known (the sphere fit's radius is not used beyond it)."""
        return {"g": 1.0, "m/s^2": self.gravity}.get(self.format.acc_unit, self.gravity)

    def _interval(self, iv: Interval, m: int) -> None:
        from ..metrics import pose_coverage  # imucalib.metrics costs 23 ms at start-up
        from ..plans import describe_direction  # imucalib.plans costs 22 ms at start-up

        if iv.start == 0:  # the rest, still held when the detector started
            return
        previous = self.poses[-1] if self.poses else self.rest
        self.poses.append(iv)
        self._means.append(self._raw[iv.start:iv.stop, 1:4].mean(axis=0))
        self._turns_raw.append(self._turn_raw(previous.stop, iv.start))
        self._wobble(iv, len(self.poses), m)
        self._update_directions()
        up = self.directions[-1]
        before = held_before(up, self.directions[:-1])
        coverage, _ = pose_coverage(self.directions)
        k = len(self.poses)
        self.emit({"event": "pose", "pose": k, "start": iv.start, "stop": iv.stop, "t_start": self._time(iv.start),
                   "t_stop": self._time(iv.stop - 1), "seconds": self._time(iv.stop - 1) - self._time(iv.start),
                   "up": up.tolist(), "words": describe_direction(up), "directions_from": self.source_of_directions,
                   "already_held": before, "coverage": coverage, "directions": self.directions.tolist(),
                   "checklist": self._checklist().as_event()})
        if self._closing:
            return
        if not self.complete:
            self._try_calibration(m)
        if not self.complete:
            self._next(m - 1, up)

    def _turn_raw(self, a: int, b: int) -> np.ndarray:
        dt = np.diff(self._times(max(a - 1, 0), b))
        if b - a <= 0 or dt.size != b - a:
            return np.zeros(3)
        dt = np.where(dt > 2.5 / self.rate, 0.0, dt)  # nothing is known of the turn across a gap
        return turn_vector(self._raw[a:b, 4:7], dt, self._means_gyro_bias(), 1.0)

    def _update_directions(self) -> None:
        self.directions, self.source_of_directions = up_directions(np.array(self._means), gravity=self._gravity_unit(),
                                                                   trial=self.trial)

    def _checklist(self):
        turns = None if self.scale is None else [t * abs(self.scale) for t in self._turns_raw]
        return checklist(self.directions, turns, corners=self.method not in FACE_METHODS)

    def _intervals(self) -> list[Interval]:
        return [self.rest, *self.poses]

    def _wobble(self, iv: Interval, k: int, m: int) -> None:
        from ..fit.gyroscope import rough_scale  # imucalib.fit.gyroscope costs 42 ms at start-up
        from ..segment import gyro_still  # imucalib.segment costs 43 ms at start-up

        bias = self._means_gyro_bias()
        if self.scale is None and len(self.poses) >= 3:
            with contextlib.suppress(ValueError, FloatingPointError):
                s = rough_scale(self.recording(m), self._intervals(), TriadModel(), bias)
                if np.isfinite(s) and s > 0:
                    self.scale = float(s)
        if self.scale is None:
            return
        # the rest and the pose with half a second around it: the windows of the pose's samples are the same,
        # and the cost does not grow with the session
        pad = int(np.ceil(0.5 * self.rate))
        lo, hi = max(iv.start - pad, self.rest.stop), min(iv.stop + pad, m)
        keep = np.r_[0:self.rest.stop, lo:hi]
        local = Recording(t=np.arange(keep.size) / self.rate, acc=self._raw[keep, 1:4], gyro=self._raw[keep, 4:7],
                          acc_unit=self.format.acc_unit, gyro_unit=self.format.gyro_unit)
        pose = Interval(self.rest.stop + iv.start - lo, self.rest.stop + iv.stop - lo, "static")
        still = gyro_still(local, self.rest, self.scale, [pose])[pose.slice]
        moving = 1.0 - float(np.mean(still))
        if moving > 0.25:
            self._warn("wobble", iv.stop - 1, f"pose {k} wobbles: the gyroscope moves during {100 * moving:.0f} % "
                                              "of it; hold the sensor steadier (or rest it on the table)",
                       every=0.0, pose=k)

    def _calibrate(self, stop: int):
        from ..methods import calibrate  # imucalib.methods costs 118 ms at start-up

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return calibrate(self.recording(stop), method=self.method, gravity=self.gravity,
                                 **self.method_options)
        except ValueError as exc:
            self.trial_error = str(exc)
            return None

    def _try_calibration(self, m: int) -> None:
        from ..segment import MIN_INTERVALS  # imucalib.segment costs 43 ms at start-up

        if len(self.poses) + 1 < (7 if self.method in FACE_METHODS else MIN_INTERVALS):
            return
        cal = self._calibrate(m)
        if cal is None:
            return
        self.trial = cal
        if self.format.gyro_unit == "counts":
            self.scale = float(np.mean(np.abs(cal.gyroscope.scale)))
        self._update_directions()
        if cal.fit.verdict.level == "accepted":
            self.complete = True
            self.emit({"event": "complete", "poses": len(self.poses), "sample": m - 1, "samples": m,
                       "t": self._time(m - 1), "method": self.method, "verdict": "accepted",
                       "message": f"enough poses for an accepted {self.method} calibration: stop the "
                                  "recording (Ctrl-C or end the stream) or add poses"})

    def _next(self, sample: int, up: np.ndarray) -> None:
        from ..plans import describe_direction, next_poses  # imucalib.plans costs 22 ms at start-up

        reasons = (self.trial.fit.verdict.reasons or []) if self.trial is not None else []
        if self.method in FACE_METHODS:  # these take the six faces only: the next pose is one of them
            nxt = next_poses(self.directions, candidates=np.vstack([np.eye(3), -np.eye(3)]))
        elif self.trial is not None and self.trial.fit.verdict.next_poses:
            nxt = np.asarray(self.trial.fit.verdict.next_poses)
        else:
            nxt = next_poses(self.directions)
        self.suggestion = nxt[0]
        self.emit({"event": "next_pose", "after_pose": len(self.poses), "up": nxt[0].tolist(),
                   "words": describe_direction(nxt[0]), "then": [describe_direction(u) for u in nxt[1:]],
                   "turn_deg": angle_deg(up, nxt[0]), "reasons": reasons[:3], "sample": int(sample),
                   "t": self._time(sample)})

    def _redo(self, verdict: str | None, reasons: list[str]) -> list[str]:
        """What to record again or add, in words, when the final calibration is not accepted."""
        if verdict == "accepted":
            return []
        out = list(reasons[:3])
        if self.dropped_before_rest and len(self.poses) < 4:
            out.append(f"keep the sensor still for the whole initial rest ({self.rest_seconds:g} s): it started again "
                       f"{self.restarts} time(s), and the {self.dropped_before_rest} samples before its last start "
                       "are not in the session (a recording with a shorter rest: --rest SECONDS)")
        if self.rest is None:
            return ["record the initial rest: the sensor still for "
                    f"{self.rest_seconds:g} s at the start", *out]
        missing = self._checklist().missing if self.poses else [name for name, _ in FACES]
        if missing:
            out.append("add poses: " + ", ".join(missing))
        return out
