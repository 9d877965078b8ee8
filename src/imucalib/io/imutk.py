"""imu_tk's two-file text format: the accelerometer's file and the gyroscope's, ``time x y z`` a line."""

from __future__ import annotations

import re
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..recording import Recording
from . import csvparse
from .columns import TIME as _TIME
from .columns import not_number as _not_number
from .errors import ReaderError
from .stamps import TIME_UNITS, repair_coarse, to_seconds
from .stamps import check_increasing as _check_time
from .tables import parse_block, parse_table, sensors_named, split_table

__all__ = ["imutk_table", "numeric_table", "read_imutk"]


def read_imutk(acc_path: Path, gyro_path: Path, acc_unit, gyro_unit, time_unit) -> Recording:
    (ta, acc), (tg, gyro) = (imutk_table(path) for path in (acc_path, gyro_path))
    meta: dict = {"source": [str(acc_path), str(gyro_path)]}
    unit = time_unit or "s"
    t_acc = to_seconds(ta, unit, meta)
    t_gyro = (tg - ta[0]) * TIME_UNITS[unit] if meta.get("time_relative") else tg * TIME_UNITS[unit]
    del ta, tg
    return Recording.from_streams(
        t_acc, acc, t_gyro, gyro,
        acc_unit=acc_unit or "counts", gyro_unit=gyro_unit or "counts", metadata=meta,
    )


def imutk_table(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """One imu_tk file's ``time x y z`` rows: the times (n,) and the values (n, 3), read a few megabytes at a time.

    The body is parsed in chunks by :func:`.csvparse.parse` into preallocated
    arrays, so memory is the arrays', not the text's (a 230 MB file of 3.6 M rows
    took 0.8 GB as one string). A file it does not take as it is (blank lines, a
    bad cell, another number of columns) is read again whole by
    :func:`numeric_table`, whose messages name the line.
    """
    names = ("time", "x", "y", "z")
    st = path.stat()
    with path.open("rb") as f:
        head = f.read(1 << 16)
        start = 3 if head.startswith(b"\xef\xbb\xbf") else 0
        end = st.st_size
        while end > start:  # the body ends at the last non-blank character, as the text was stripped
            f.seek(max(start, end - 4096))
            tail = f.read(end - max(start, end - 4096))
            stripped = tail.rstrip()
            end -= len(tail) - len(stripped)
            if stripped:
                break
    first = head[start:].split(b"\n", 1)[0].split()
    if _headed(head[start:]):  # a header, or cells parted by commas: the table reader's header logic
        return _headed_pair_table(path)
    if end > start and len(first) == 4:
        layout = csvparse.Layout(path, None, (start, end), 1, None, False, 4, st.st_size, st.st_mtime_ns)
        try:
            body = csvparse.plan(layout)
            if body.comments == 0:  # a '#' line is a bad line here, named by the whole-text reader
                t, xyz = np.empty(body.rows), np.empty((body.rows, 3))
                csvparse.parse(layout, ["float"] * 4, names, required=range(4),  # no text copy: no checksum
                               out={0: t, 1: xyz[:, 0], 2: xyz[:, 1], 3: xyz[:, 2]}, plan=body, checksum=False)
                rep = repair_coarse(path, t, [xyz], 1)
                return rep.t, (xyz if rep.keep is None else xyz[rep.keep])
        except ReaderError:
            pass
    data = numeric_table(path, path.read_bytes().decode("utf-8-sig", errors="replace"), 4, names)
    return data[:, 0].copy(), np.ascontiguousarray(data[:, 1:])


def _headed(head: bytes) -> bool:
    """Whether a file of a pair starts with a header or parts its cells with a separator other than blanks."""
    line = head.split(b"\n", 1)[0].decode("utf-8", errors="replace").strip()
    return bool(line) and (any(_not_number(c) for c in line.replace(",", " ").replace(";", " ").split())
                           or "," in line or ";" in line)


#: a column of one sensor's three axes, by the axis its name ends with (``x``, ``acc_x``, ``GyroX (rad/s)``)
_AXIS = re.compile(r"^(?:.*?[\s_.-]?)([xyz])(?:\s*[\[\(].*)?$", re.I)


def _headed_pair_table(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """One file of a pair written as a table (a header, commas): its time column and its x, y, z columns.

    The header's time column (:data:`.columns.TIME`) and the columns named by their axis (``x``, ``acc_x``,
    ``GyroZ (rad/s)``) are taken; a table of four columns without a header is ``time x y z``.
    """
    table = split_table(path)
    names = table.names
    if table.header is None:
        if table.ncols != 4:
            raise ReaderError(f"{path}: a file of an accelerometer/gyroscope pair holds time x y z; this one has "
                              f"{table.ncols} columns and no header naming them")
        picked = [0, 1, 2, 3]
    else:
        if sensors_named(names) == {"acc", "gyro"}:
            raise ReaderError(f"{path}: its header names the accelerometer's and the gyroscope's columns: it is a "
                              "recording of its own, not one file of an accelerometer/gyroscope pair (give it alone)")
        t = next((j for j, n in enumerate(names) if _TIME.match(n.strip())), None)
        axes = {}
        for j, n in enumerate(names):
            m = _AXIS.match(n.strip())
            if m and j != t:
                axes.setdefault(m.group(1).lower(), j)
        if t is None or len(axes) < 3:
            raise ReaderError(f"{path}: a file of an accelerometer/gyroscope pair needs a time column and x, y, z "
                              f"columns; its header names {', '.join(names)}")
        picked = [t, axes["x"], axes["y"], axes["z"]]
    cols = parse_table(path, table, picked, others=False)
    t = np.asarray(cols[picked[0]], dtype=np.float64)
    xyz = np.column_stack([np.asarray(cols[j], dtype=np.float64) for j in picked[1:]])
    if t.size < 2:
        raise ReaderError(f"{path}: {t.size} row(s): a file of an accelerometer/gyroscope pair holds many")
    _check_time(path, t, table.first_line)
    return t, xyz


def numeric_table(path: Path, text: str, ncols: int, names: Sequence[str]) -> np.ndarray:
    """A whitespace-separated numeric table with increasing first column.

    Fast path: one C-level parse of the whole text, accepted only when it gives
    exactly ``ncols`` finite values per non-empty line; anything else goes to
    the line-by-line parser that names the bad line.
    """
    stripped = text.rstrip()
    if not stripped:
        raise ReaderError(f"{path}: empty file; imu_tk files hold 'time x y z' per line")
    nlines = stripped.count("\n") + 1
    data = None
    if "\n\n" not in stripped:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # fromstring warns (older numpy) or raises on a bad cell
                flat = np.fromstring(stripped, dtype=np.float64, sep=" ")
        except ValueError:
            flat = np.empty(0)  # the line-by-line parser below names the line
        if flat.size == ncols * nlines:
            data = flat.reshape(nlines, ncols)
            if not np.all(np.isfinite(data)):
                data = None
    if data is None:
        lines = stripped.splitlines()
        blank = [i for i, ln in enumerate(lines) if not ln.strip()]
        if blank:
            raise ReaderError(f"{path}: line {blank[0] + 1} is empty; remove blank lines")
        data = parse_block(path, lines, 1, ncols, None, names)
    rep = repair_coarse(path, data[:, 0], [data[:, 1:]], 1)
    data = data if rep.keep is None else data[rep.keep]
    data[:, 0] = rep.t
    return data
