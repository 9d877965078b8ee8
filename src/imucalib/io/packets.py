"""Tables whose rows take turns between packet types, and what a table's other columns are.

A vendor's logger (MicroStrain's MSCL and SensorConnect, for example) writes one row per packet with
every channel as a column, so the accelerometer's and gyroscope's cells are filled on the rows of the IMU
packet only and empty on the others (a GNSS or filter packet)::

    Time,estFilterGpsTimeTow,…,scaledAccelX,scaledAccelY,scaledAccelZ,scaledGyroX,…
    1600000000000000000,345600.0,…,,,,,,
    1600000000002500000,,…,0.01,-0.02,1.0,0.001,…

:func:`sparse_rows` reads such a table: the rows where every sensor cell the reader needs is empty are
skipped, with one note saying how many; a row where some are empty and some are not is an error naming it.
:func:`counter_times` makes the times of a table whose first column counts samples (imucal's
``n_samples``), and :func:`mapped_others` the magnetometer and temperature ``--columns`` named.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..recording import ImucalibWarning
from . import csvparse
from .errors import ReaderError

__all__ = ["counter_times", "has_empty_cells", "mapped_others", "sparse_rows"]


def has_empty_cells(rows: Sequence[str], sep: str | None, needed: Sequence[int]) -> bool:
    """Whether some of ``rows`` (lines of text) leave a ``needed`` column's cell empty."""
    if sep is None:
        return False  # whitespace-separated cells cannot be empty
    for line in rows:
        cells = csvparse.split_cells(line, sep)
        if any(j < len(cells) and cells[j] == "" for j in needed):
            return True
    return False


def sparse_rows(path: Path, layout: csvparse.Layout, names: Sequence[str], needed: Sequence[int],
                sensors: Sequence[int]) -> tuple[int, dict[int, np.ndarray]]:
    """The rows of a packet-interleaved table that hold the sensors' cells: their count and the columns.

    ``needed`` are the columns read (sensor axes, time, counter); ``sensors`` those whose cells decide: a
    row with all of them empty is another packet's, skipped; with some empty, an error. The needed columns
    come back as float64 (int64 for long integer stamps, exact) over the rows kept.
    """
    kinds: list[str | None] = ["text" if j in needed else None for j in range(layout.ncols)]
    cols, _ = csvparse.parse(layout, kinds, names, checksum=False)
    empty = np.column_stack([cols[j] == "" for j in sensors])
    skip = np.all(empty, axis=1)
    part = empty.any(axis=1) & ~skip
    if np.any(part):
        i = int(np.nonzero(part)[0][0])
        gone = [names[j] for j, e in zip(sensors, empty[i], strict=True) if e]
        raise ReaderError(f"{path}: row {i + 1} of the table (line {layout.first_line + i}, if no comment lines): "
                          f"{', '.join(gone)} empty while the other sensor columns are not; a row holds a sample "
                          "of every sensor read, or of none (another packet's row)")
    keep = ~skip
    if not np.any(keep):
        raise ReaderError(f"{path}: no row holds the columns {', '.join(names[j] for j in sensors)}")
    out: dict[int, np.ndarray] = {}
    for j in needed:
        cells = cols[j][keep]
        if j not in sensors and np.any(cells == ""):
            i = int(np.nonzero(keep)[0][np.nonzero(cells == "")[0][0]])
            raise ReaderError(f"{path}: row {i + 1} of the table: {names[j]} is empty on a row of the sensors")
        try:
            long_ints = cells.size and all(c.lstrip("+-").isdigit() and len(c.lstrip("+-")) >= csvparse.INT_DIGITS
                                           for c in cells[:1])
            out[j] = cells.astype(np.int64) if long_ints else cells.astype(np.float64)
        except ValueError:
            bad = next(c for c in cells if csvparse.column_kinds([c], False)[0] == "text")
            raise ReaderError(f"{path}: {names[j]}: {bad!r} is not a number; fix or remove the row") from None
        if out[j].dtype.kind == "f" and not np.all(np.isfinite(out[j])):
            raise ReaderError(f"{path}: {names[j]}: a NaN or inf value on a row of the sensors; fix or remove the row")
    skipped = int(skip.sum())
    if skipped:
        warnings.warn(f"{path}: skipped {skipped} of {skip.size} rows that leave the columns "
                      f"{', '.join(names[j] for j in sensors)} empty (another packet's rows: the file's rows take "
                      f"turns between packet types); {int(keep.sum())} rows read, and only the columns named (the "
                      "others belong to the other packets)", ImucalibWarning, stacklevel=5)
    return int(keep.sum()), out


def counter_times(path: Path, counter: np.ndarray, name: str, rate: float | None) -> np.ndarray:
    """Times [s] of a table whose column ``name`` counts samples: ``(n − n₀) / rate``, a skipped count a gap.

    A counter is no time: ``rate`` is needed (a :class:`ReaderError` says so). One that does not increase
    by whole steps is not used (the samples are taken as evenly spaced, with a note).
    """
    if rate is None:
        raise ReaderError(f"{path}: no time column: {name!r} counts samples, it is not a time; pass --rate HZ (the "
                          "sampling rate)")
    d = np.diff(counter)
    if counter.size > 1 and np.all(d >= 1) and np.all(d == np.round(d)):
        lost = int(np.sum(d - 1))
        if lost:
            warnings.warn(f"{path}: the sample counter {name!r} skips {lost} samples: kept as gaps in the time",
                          ImucalibWarning, stacklevel=5)
        return (np.asarray(counter, dtype=np.float64) - float(counter[0])) / rate
    warnings.warn(f"{path}: the column {name!r} looks like a sample counter but does not count up by whole steps: "
                  "not used; the samples are taken as evenly spaced at --rate", ImucalibWarning, stacklevel=5)
    return np.arange(counter.size) / rate


def mapped_others(mapping: dict, names: Sequence[str], cols: dict[int, np.ndarray], meta: dict
                  ) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """The magnetometer (as the extra columns ``mag_x``, ``mag_y``, ``mag_z``, which
    :mod:`.magnetometer` takes) and the temperature that ``--columns`` named, and ``meta`` told which."""
    extra: dict[str, np.ndarray] = {}
    if mapping.get("mx") is not None:
        for axis in "xyz":
            extra[f"mag_{axis}"] = np.asarray(cols[mapping[f"m{axis}"]], dtype=np.float64)
        meta["magnetometer_from"] = [names[mapping[f"m{a}"]] for a in "xyz"]
    temperature = None
    if mapping.get("temp") is not None:
        temperature = np.asarray(cols[mapping["temp"]], dtype=np.float64)
        meta["temperature_column"] = names[mapping["temp"]]
    return extra, temperature
