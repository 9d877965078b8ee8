"""Time stamps as files have them: checked, their unit guessed, stamps coarser than the sampling repaired.

* :func:`check_increasing` refuses stamps that repeat or go back, naming the line.
* :func:`guess_unit` takes the unit of a time column from its values: the unit in which the median step
  gives a rate IMUs record at (:data:`IMU_RATES`), the first stamp's size breaking a tie (an epoch in
  nanoseconds, ``1.6e18``, is a date of the 2020s only in nanoseconds).
* :func:`repair_coarse` reads stamps printed with a resolution coarser than the sampling interval (0.01 s
  at 200 Hz: every other step is zero): exactly repeated rows are dropped, and the times are put on the
  straight line the stamps follow, sample by sample, within the stamps' resolution; real gaps stay gaps.

Each repair or guess that is not plain is said in an :class:`~imucalib.recording.ImucalibWarning`.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..recording import ImucalibWarning, require_pandas
from .errors import ReaderError

__all__ = ["IMU_RATES", "TIME_UNITS", "Repair", "check_increasing", "datetime_cells", "guess_unit", "read_dated",
           "repair_coarse", "to_seconds"]

#: the length of each time unit a time column can be written in [s]
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
_NAMES = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}
#: sampling rates IMUs record at [Hz] (the verdict refuses a recording outside them: imucalib.verdict.check_rate)
IMU_RATES = (5.0, 50_000.0)
#: Unix times of the years 2000 and 2100 [s]: a first stamp between them is an epoch in that unit
_EPOCH = (9.46e8, 4.1e9)


def check_increasing(path: Path, t: np.ndarray, first_line: int, name: str = "time") -> None:
    """Raise a :class:`ReaderError` at the first stamp that repeats or goes back, naming its line."""
    d = np.diff(t)
    bad = np.nonzero(d <= 0)[0]
    if bad.size:
        i = int(bad[0])
        what = "duplicated" if d[i] == 0 else "goes backwards"
        raise ReaderError(
            f"{path}: line {first_line + i + 1}, {name}: timestamp {what} "
            f"({float(t[i]):.10g} then {float(t[i + 1]):.10g}); timestamps must increase strictly "
            "(sort the file or remove duplicated rows)"
        )


def _magnitude_unit(step: float) -> str:
    """The unit from the median step alone, assuming 1 Hz … 100 kHz: above 1e4 ns, above 10 µs, above 0.5 ms."""
    return "ns" if step > 1e4 else "us" if step > 10 else "ms" if step > 0.5 else "s"


def guess_unit(t: np.ndarray, path: Path | None = None, name: str = "time") -> str:
    """The unit of a time column from its values.

    The units whose rate (1 / median step) lies in :data:`IMU_RATES` are the candidates; of several, the one
    in which the first stamp is a date of 2000–2100 (epoch stamps). One candidate left is taken, with a note
    when the median step alone (1 Hz … 100 kHz) would have said another unit (``millis()`` stamps 16 ms apart
    are 62.5 Hz in ms, 62.5 kHz in µs, so ms); none or several left (a step of 100: 10 Hz in ms, 10 kHz in µs),
    the median step decides as before.
    """
    if t.size < 2:
        return "s"
    step = float(np.median(np.diff(t)))
    plain = _magnitude_unit(step)
    if not step > 0:
        return plain
    rates = {u: 1.0 / (step * s) for u, s in TIME_UNITS.items()}
    cands = [u for u, r in rates.items() if IMU_RATES[0] <= r <= IMU_RATES[1]]
    if len(cands) > 1:
        epoch = [u for u in cands if _EPOCH[0] <= abs(float(t[0])) * TIME_UNITS[u] <= _EPOCH[1]]
        cands = epoch if len(epoch) == 1 else cands
    if len(cands) != 1:
        return plain
    unit = cands[0]
    if unit != plain and path is not None:
        others = ", ".join(f"{rates[u]:.4g} Hz in {u}" for u in TIME_UNITS if u != unit)
        warnings.warn(f"{path}: the time column {name!r} was read in {_NAMES[unit]}: its median step, {step:.6g}, "
                      f"gives {rates[unit]:.4g} Hz in {unit}, the only unit in which the rate is one IMUs record at "
                      f"({others}); pass --time-unit to say otherwise", ImucalibWarning, stacklevel=6)
    return unit


def to_seconds(t: np.ndarray, unit: str, metadata: dict) -> np.ndarray:
    """``t`` in seconds; epoch-like stamps (beyond 1e6 s) relative to the first, which ``metadata`` keeps."""
    metadata["time_unit"] = unit
    metadata["t0"] = float(t[0])
    scale = TIME_UNITS[unit]
    seconds = t * scale
    if abs(seconds[0]) > 1e6:  # epoch-like stamps lose precision as float seconds: keep them relative to the start
        seconds = (t - t[0]) * scale
        metadata["time_relative"] = True
    return seconds


@dataclass(frozen=True)
class Repair:
    """What :func:`repair_coarse` did: the stamps to use, the rows kept (None: all), and the facts for notes."""

    t: np.ndarray
    keep: np.ndarray | None
    dropped: int = 0
    resolution: float | None = None
    interval: float | None = None
    gaps: int = 0


def _resolution(d: np.ndarray) -> float | None:
    """The stamps' resolution: the smallest positive step, when every step is a whole number of it, else None."""
    pos = d[d > 0]
    if pos.size == 0:
        return None
    r = float(pos.min())
    q = d / r
    if np.max(np.abs(q - np.round(q))) > 1e-3:
        return None
    return r


def repair_coarse(path: Path, t: np.ndarray, values: Sequence[np.ndarray], first_line: int,
                  name: str = "time") -> Repair:
    """Stamps checked, and repaired when they are printed coarser than the sampling interval.

    Rows that repeat the row before exactly (the same stamp and the same ``values``, each an (n,) or (n, k)
    array of the row's readings) are dropped. Stamps that still repeat are repaired when they are coarse:
    they never go back, every step is a whole number of one resolution ``r`` (the smallest step), and the
    sampling interval ``T`` (the stamps' span over the samples between them) is shorter than ``0.9 r``, and at least a
    tenth of the steps (and 3) are zero; a stamp repeated here and there is an error, not a resolution. Then
    consecutive stamps differ by 0 or ``r`` (``T < r``), so a step of two resolutions or more is a real gap:
    the stamps are cut there into runs, the interval ``T`` is the least-squares slope of stamp vs sample index
    pooled over the runs (one clock), and each run's times are ``a_k + T i`` with its own offset ``a_k`` (the
    run's mean residual), a straight line through quantised stamps: each time stays within ``r`` of its
    stamp, else the stamps are not a steady sampling and the repair is refused (a :class:`ReaderError`).
    Anything else that repeats or goes back is the error :func:`check_increasing` raises.
    """
    t = np.asarray(t, dtype=np.float64)
    d = np.diff(t)
    if t.size < 3 or np.all(d > 0):
        check_increasing(path, t, first_line, name)
        return Repair(t, None)
    keep = None
    dropped = 0
    same = d == 0
    for v in values:
        v = np.asarray(v)
        same &= np.all((v[1:] == v[:-1]).reshape(len(d), -1), axis=1)
    if np.any(same):
        keep = np.concatenate([[True], ~same])
        dropped = int(same.sum())
        t = t[keep]
        d = np.diff(t)
        warnings.warn(f"{path}: dropped {dropped} row{'s' if dropped > 1 else ''} that repeat the row before "
                      f"exactly (the same {name} and the same readings: a logger writing one sample twice)",
                      ImucalibWarning, stacklevel=5)
    if np.all(d > 0):
        return Repair(t, keep, dropped)
    lines = np.nonzero(keep)[0] if keep is not None else np.arange(t.size)
    r = _resolution(d)
    zeros = int(np.sum(d == 0))
    if r is None or np.any(d < 0) or zeros < max(3, 0.1 * d.size):  # a stamp repeated here and there: an error
        check_increasing(path, t, first_line, name)  # raises, naming the line (as the file numbers it)
    gap = d > 1.5 * r
    cuts = np.concatenate([[0], np.nonzero(gap)[0] + 1, [t.size]])
    runs = [(a, b) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    idx = np.arange(t.size, dtype=np.float64)
    sxy = sxx = 0.0
    for a, b in runs:
        if b - a >= 2:
            i, s = idx[a:b] - idx[a:b].mean(), t[a:b] - t[a:b].mean()
            sxy, sxx = sxy + float(i @ s), sxx + float(i @ i)
    interval = sxy / sxx if sxx > 0 else 0.0
    if not 0 < interval < 0.9 * r:
        check_increasing(path, t, first_line, name)
    out = np.empty_like(t)
    for a, b in runs:
        line = interval * (idx[a:b] - idx[a])
        out[a:b] = line + float(np.mean(t[a:b] - line))
    off = np.abs(out - t)
    if off.max() > r:
        k = int(np.argmax(off))
        raise ReaderError(f"{path}: line {first_line + int(lines[k])}, {name}: the stamps repeat (they are printed "
                          f"with a resolution of {r:.6g}, coarser than the sampling) but do not follow a steady "
                          f"rate: the time a steady rate puts there is {off[k]:.3g} from the stamp; write the stamps "
                          "with more digits, or give --columns with '-' for t and --rate")
    if np.any(np.diff(out) <= 0):
        check_increasing(path, out, first_line, name)
    warnings.warn(f"{path}: the {name} stamps are printed with a resolution of {r:.6g}, coarser than the sampling "
                  f"interval ({interval:.6g}, {zeros} steps of zero): the times were put on the "
                  f"stamps' straight line at that interval, within the resolution of each stamp"
                  + (f"; {len(runs) - 1} gap{'s' if len(runs) > 2 else ''} between them kept" if len(runs) > 1
                     else ""), ImucalibWarning, stacklevel=5)
    return Repair(out, keep, dropped, r, interval, len(runs) - 1)


def note_held_samples(path, acc: np.ndarray, gyro: np.ndarray | None, rate: float) -> None:
    """A note when most rows repeat the row before exactly: a sensor read faster than it updates.

    Such a log (an FXOS8700 updating at 100 Hz, read at 400 Hz) holds each reading for ``k`` rows: the
    sensor's own rate is ``rate / k``, and a noise taken from sample-to-sample differences comes out low.
    Nothing is changed; the note says what the rows are.
    """
    if len(acc) < 100:
        return
    same = np.all(acc[1:] == acc[:-1], axis=1)
    if gyro is not None:
        same &= np.all(gyro[1:] == gyro[:-1], axis=1)
    if same.mean() <= 0.5:
        return
    starts = np.r_[0, np.nonzero(~same)[0] + 1, len(acc)]
    hold = float(np.median(np.diff(starts)))
    warnings.warn(f"{path}: {100 * same.mean():.0f}% of the rows repeat the row before exactly: each reading is "
                  f"held for about {hold:g} rows, so the sensor updates at about {rate / hold:.4g} Hz, not "
                  f"{rate:.4g} Hz (read faster than it updates); the rows are kept as they are, but noise figures "
                  "from sample-to-sample differences come out low", ImucalibWarning, stacklevel=5)


#: a calendar date and time of day as loggers print them: ISO 8601 (``2024-05-01T12:00:00.010Z``) or with a
#: blank for the ``T`` (``2024-05-01 12:00:00.010``), optionally quoted, with a UTC offset
_DATETIME = re.compile(r'^"?\d{4}-\d{2}-\d{2}[T ]\d{1,2}:\d{2}(?::\d{2}(?:\.\d+)?)?(?:Z|[+-]\d{2}:?\d{2})?"?$')


def datetime_cells(cells: Sequence[str]) -> list[int]:
    """The indices of the cells of a row that are a calendar date and time (:data:`_DATETIME`)."""
    return [j for j, c in enumerate(cells) if _DATETIME.match(c.strip())]


def read_dated(path: Path, *, skiprows: int, sep: str | None, dated: Sequence[int], has_header: bool):
    """A delimited file whose rows carry date-time stamps, as a DataFrame with those columns as datetimes.

    The readers read such a file as a DataFrame (its stamps become nanoseconds, as a DataFrame's datetimes
    do); that needs pandas, and the rows need a header to name their columns.
    """
    if not has_header:
        raise ReaderError(f"{path}: the rows begin with a date and time but have no header naming the columns: "
                          "add one, or pass --columns -,AX,AY,AZ,GX,GY,GZ (0-based indices) and --rate HZ to "
                          "leave the stamps out")
    try:
        pd = require_pandas(f"{path}: date-time stamps")
    except ValueError as exc:
        raise ReaderError(f"{exc}; or pass --columns without the time column and --rate HZ") from None
    frame = pd.read_csv(path, skiprows=skiprows, sep=sep if sep not in (None, " ") else r"\s+", header=0,
                        engine="python" if sep in (None, " ") else "c")
    frame.columns = [str(c).strip() for c in frame.columns]
    for j in dated:
        name = frame.columns[j]
        try:
            stamps = pd.to_datetime(frame[name], utc=True, format="ISO8601")
        except (ValueError, TypeError) as exc:
            raise ReaderError(f"{path}: the column {name!r} holds dates and times that cannot be read: {exc}") from None
        frame[name] = stamps.dt.tz_localize(None)
    warnings.warn(f"{path}: the column {frame.columns[dated[0]]!r} holds dates and times: they were read as time "
                  "stamps (to the nanosecond, UTC where an offset is given)", ImucalibWarning, stacklevel=5)
    return frame
