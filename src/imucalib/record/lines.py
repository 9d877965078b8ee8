"""The lines of a live stream: cut into bounded lines, the table's layout, and the rows a session keeps.

* :class:`LineSplitter` cuts the bytes read into lines of at most
  :data:`MAX_LINE` bytes; a longer line is left out whole (a :class:`TooLong`
  in its place), so a stream that never sends a newline cannot grow the
  memory without bound.
* :class:`LineFormat` is the layout of the table (the CSV reader's,
  :func:`imucalib.io.read`, decided on the first lines) and parses a data line.
* :class:`RowCheck` decides, row by row, whether a data row belongs in the
  session: a reading that is not a finite number within the sensor's
  plausible range, or a stamp that does not move forward, is left out (with
  its reason), and a stamp far ahead of its neighbours is told from a gap in
  the samples by the row after it.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..constants import STANDARD_GRAVITY

__all__ = ["MAX_LINE", "LineFormat", "LineSplitter", "RowCheck", "TooLong", "clean_head_line", "garbled"]

#: the longest line kept [bytes]; a longer one is left out whole
MAX_LINE = 65536

#: the largest magnitude a reading can have in each unit (beyond any MEMS sensor's range: ±2000 g,
#: ±100 000 °/s; raw counts within a 32-bit integer); larger is a corrupted line
PLAUSIBLE = {"g": 2000.0, "m/s^2": 2000.0 * STANDARD_GRAVITY, "counts": 2.0**31, "deg/s": 1e5, "rad/s": np.radians(1e5)}


@dataclass(frozen=True)
class TooLong:
    """A line longer than :data:`MAX_LINE` bytes, left out: how many bytes it had (or more, when cut at the end)."""

    size: int


class LineSplitter:
    """Bytes as read → complete lines (newline included) of at most ``limit`` bytes; longer ones as :class:`TooLong`."""

    def __init__(self, limit: int = MAX_LINE) -> None:
        self.limit = int(limit)
        self._buf = bytearray()
        self._skipped = 0  # bytes of an over-long line dropped so far (0: not inside one)

    def push(self, chunk: bytes) -> list:
        """The lines completed by ``chunk``, in order."""
        out: list = []
        start = 0
        while True:
            k = chunk.find(b"\n", start)
            if k < 0:
                break
            self._line(chunk[start:k + 1], out)
            start = k + 1
        rest = chunk[start:]
        if rest:
            if self._skipped:
                self._skipped += len(rest)
            else:
                self._buf += rest
                if len(self._buf) > self.limit:
                    self._skipped = len(self._buf)
                    self._buf = bytearray()
        return out

    def _line(self, piece: bytes, out: list) -> None:
        if self._skipped:
            out.append(TooLong(self._skipped + len(piece)))
            self._skipped = 0
            return
        if self._buf:
            piece = bytes(self._buf) + piece
            self._buf = bytearray()
        if len(piece) > self.limit:
            out.append(TooLong(len(piece)))
        else:
            out.append(piece)

    def close(self) -> list:
        """The last line when the stream ended without a newline."""
        if self._skipped:
            self._skipped, size = 0, self._skipped
            return [TooLong(size)]
        if self._buf:
            line, self._buf = bytes(self._buf), bytearray()
            return [line]
        return []


_CONTROL = bytes(range(32)).replace(b"\t", b"").replace(b"\r", b"").replace(b"\n", b"")


def garbled(line: bytes) -> bool:
    """Whether a line holds bytes no text table has: a NUL or another control character, or bytes not UTF-8."""
    if any(c in line for c in _CONTROL) or b"\x7f" in line:
        return True
    try:
        line.decode("utf-8")
    except UnicodeDecodeError:
        return True
    return False


def clean_head_line(line: bytes) -> bytes | None:
    """A line of the stream's head with the garbage bytes a serial connection starts with removed.

    A port opened mid-transmission gives a few bytes of noise (NUL, 0xFF, a
    broken character) before the first complete line: the bytes before the
    last garbled one are dropped when what follows is clean text; None when
    nothing clean is left.
    """
    if not garbled(line):
        return line
    text = line.decode("utf-8", "replace")
    bad = [k for k, c in enumerate(text) if c == "\ufffd" or c == "\x7f" or (ord(c) < 32 and c not in "\t\r\n")]
    rest = text[bad[-1] + 1:].encode("utf-8")
    return rest if rest.strip() and not garbled(rest) else None


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
    head_rate: float = float("nan")  # the rate of the first lines [Hz]

    @classmethod
    def from_head(cls, lines: list[bytes], *, columns=None, acc_unit=None, gyro_unit=None, time_unit=None,
                  rate=None, directory: Path | None = None) -> tuple[LineFormat, list[str]]:
        """The layout of a stream from its first lines, as the CSV reader (:func:`imucalib.io.read`) takes them.

        Returns the format and the reader's notes. Raises ``ValueError`` (the
        reader's message) when the lines are not a table the reader takes.
        """
        from ..io.readers import TIME_UNITS, read  # imucalib.io.readers costs 35 ms at start-up

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
                  acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit, head_rate=float(rec.rate))
        # the rows the reader read must parse to the same numbers here
        rows = [r for r in (fmt.parse(ln) for ln in lines) if r is not None][-len(rec):]
        if len(rows) != len(rec) or not (np.array_equal(np.array([r[1:4] for r in rows]), rec.acc)
                                         and np.array_equal(np.array([r[4:] for r in rows]), rec.gyro)):
            raise ValueError("the stream's first lines are a table the reader takes, but not one that can be "
                             "followed line by line (pass --columns, or record to a file and calibrate it)")
        return fmt, [str(w.message) for w in caught]

    def parse(self, line: bytes) -> tuple[float, ...] | None:
        """``(t_raw, ax, ay, az, gx, gy, gz)`` of a data line (maybe not finite), or None when it is not one."""
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
            return tuple(float(cells[j].replace(",", ".") if self.decimal_comma else cells[j]) if j is not None
                         else np.nan for j in self.indices)
        except ValueError:
            return None


class RowCheck:
    """Which rows of a stream belong in its session, in order: see the module docstring.

    :meth:`push` takes a line (bytes or :class:`TooLong`) and its number in
    the stream, and returns what is decided with it: ``("row", line, values,
    number)`` for a row kept, ``("gap", seconds)`` before a row that follows a
    gap in the stamps, ``("bad", line, reason, number)`` for a line left out.
    A row whose stamp jumps ahead by more than ``gap`` seconds is held until
    the next row: when that one comes after it, the jump was a gap (samples
    lost); when it comes between, the stamp was corrupted and that row is
    left out.
    """

    def __init__(self, fmt: LineFormat, *, gap: float) -> None:
        self.fmt = fmt
        self.gap = float(gap)
        self.limits = np.array([PLAUSIBLE.get(fmt.acc_unit, np.inf)] * 3 + [PLAUSIBLE.get(fmt.gyro_unit, np.inf)] * 3)
        self.last: float | None = None  # the last stamp kept (raw unit)
        self._held: tuple[bytes, tuple, int] | None = None

    def push(self, line, number: int) -> list[tuple]:
        if isinstance(line, TooLong):
            return [("bad", line, f"a line of {line.size} bytes, longer than any row ({MAX_LINE} bytes at most)",
                     number)]
        if garbled(line):
            return [("bad", line, "bytes that are not text (NUL, 0xFF or other control bytes: a glitch of the "
                                  "connection)", number)]
        row = self.fmt.parse(line)
        if row is None:
            return [("bad", line, "not a row of the table", number)]
        values = np.asarray(row[1:])
        if not np.all(np.isfinite(values)):
            return [("bad", line, "a reading that is not a finite number", number)]
        if np.any(np.abs(values) > self.limits):
            return [("bad", line, "a reading beyond any sensor's range", number)]
        if self.fmt.time_scale is None:
            return [("row", line, row, number)]
        t = row[0]
        if not np.isfinite(t):
            return [("bad", line, "a time stamp that is not a finite number", number)]
        out: list[tuple] = []
        if self._held is not None:
            held_line, held, held_number = self._held
            if t > held[0]:  # the held row's jump was a gap: both kept
                self._held = None
                out += self._keep(held_line, held, held_number)
            elif self.last is None or t > self.last:  # the held row's stamp was corrupted
                self._held = None
                out.append(("bad", held_line, "a time stamp far ahead of the rows around it", held_number))
            else:
                return [("bad", line, self._backwards(t), number)]
        if self.last is not None and t <= self.last:
            return [*out, ("bad", line, self._backwards(t), number)]
        if self.last is not None and (t - self.last) * self.fmt.time_scale > self.gap:
            self._held = (line, row, number)
            return out
        return [*out, *self._keep(line, row, number)]

    def _backwards(self, t: float) -> str:
        return "a time stamp repeated" if t == self.last else "a time stamp going backwards"

    def _keep(self, line: bytes, row: tuple, number: int) -> list[tuple]:
        out: list[tuple] = []
        if self.last is not None and (row[0] - self.last) * self.fmt.time_scale > self.gap:
            out.append(("gap", (row[0] - self.last) * self.fmt.time_scale))
        self.last = row[0]
        out.append(("row", line, row, number))
        return out

    def close(self) -> list[tuple]:
        """The row still held at the end of the stream (its gap is taken as one)."""
        if self._held is None:
            return []
        line, row, number = self._held
        self._held = None
        return self._keep(line, row, number)
