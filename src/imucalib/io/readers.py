"""Readers: generic CSV, imu_tk's two-file text format, phone apps' two-file CSV (:mod:`.phone`), MATLAB
``.mat``, ROS bags (:mod:`.rosbag`).

Every reader returns a :class:`~imucalib.recording.Recording` and reports bad
input with a :class:`ReaderError` naming the file, the line (1-based, as an
editor shows it) and the column, and saying how to fix it. Nothing is silently
dropped: a bad row is an error, never skipped.
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..recording import ACC_UNITS, GYRO_UNITS, ImucalibWarning, Recording
from . import csvparse, expansion, inputs, packets
from .columns import FIELDS
from .columns import PATTERNS as _PATTERNS
from .columns import TEMP as _TEMP
from .columns import TIME as _TIME
from .columns import map_columns as _map_columns
from .columns import not_number as _not_number
from .errors import ReaderError
from .matvars import assemble as assemble_mat
from .stamps import TIME_UNITS, datetime_cells, note_held_samples, read_dated, repair_coarse, to_seconds
from .stamps import check_increasing as _check_time
from .stamps import guess_unit as _infer_time_unit

if TYPE_CHECKING:
    from .phone import PhoneFile

# ROS bags (.rosbag) and phone apps' files (.phone) are read by modules imported when such a file is met

__all__ = ["READERS", "ReaderError", "guess_reader", "is_frame", "read"]

READERS = ("csv", "imutk", "mat", "phone", "rosbag")


# ------------------------------------------------------------------ entry
def read(
    paths: str | Path | Sequence[str | Path],
    *,
    reader: str | None = None,
    columns: Sequence[str] | None = None,
    acc_unit: str | None = None,
    gyro_unit: str | None = None,
    rate: float | None = None,
    variable: str | None = None,
    time_unit: str | None = None,
    topic: str | None = None,
    progress=None,
) -> Recording:
    """Read a recording.

    Parameters
    ----------
    paths : path, sequence of paths, or pandas.DataFrame
        One CSV or MAT file, two imu_tk files (accelerometer, then gyroscope),
        a phone app's accelerometer and gyroscope files (phyphox, Sensor Logger:
        see :mod:`.phone`), or one ROS bag (a ROS 1 ``.bag``, a ROS 2 bag
        directory, an ``.mcap``); or a pandas DataFrame, read as a CSV file
        with its column names as the header (same names, units and options;
        a datetime64 time column is taken in nanoseconds).
    reader : {"csv", "imutk", "mat", "phone", "rosbag"}, optional
        The format; guessed from the file(s) when omitted (:func:`guess_reader`).
    columns : sequence of str, optional
        Column names (or 0-based indices as strings) in the order
        ``t, ax, ay, az, gx, gy, gz``; ``"-"`` for ``t`` means no time column.
    acc_unit : {"counts", "g", "m/s^2"}, optional
        Accelerometer unit (default: from the header, else counts).
    gyro_unit : {"counts", "deg/s", "rad/s"}, optional
        Gyroscope unit (default: from the header, else counts).
    rate : float, optional
        Sampling rate [Hz]; required when there is no time column, refused when
        there is one.
    variable : str, optional
        Name of the matrix in a MATLAB file.
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of the time column (default: from the header, else inferred from
        the median step: see :func:`_infer_time_unit`).
    topic : str, optional
        ROS bags: the ``sensor_msgs/Imu`` topic, when the bag has several.
    progress : callable, optional
        ``progress(done, total)`` while a long input is read (ROS bags: messages).

    Returns
    -------
    Recording
        Times [s], the accelerometer and gyroscope readings in the units taken, the temperature and any
        other columns (``extra``), and ``metadata`` (reader, units, source file).

    Raises
    ------
    ReaderError
        A file that cannot be read as this reader has it (no such file, no table, a column missing, a
        unit or option that does not apply), saying what is wrong and which option fixes it.

    Notes
    -----
    Xsens MT Manager text exports (``//`` comment lines, then ``PacketCounter
    SampleTimeFine … Acc_X … Gyr_Z``) are recognised from their header:
    ``SampleTimeFine`` counts 100 µs ticks, the readings are in m/s² and rad/s.
    A unit option that contradicts a unit written in the header wins over it,
    with a warning saying which of the two the accelerometer's magnitude
    supports; with no unit given or written, readings that look like m/s², g, rad/s or
    deg/s are still taken as counts, with a note saying so.
    """
    if is_frame(paths):
        return _read_frame(paths, reader, columns, acc_unit, gyro_unit, rate, variable, time_unit, topic)
    if isinstance(paths, str | Path):
        paths = [paths]
    paths = [Path(p) for p in paths]
    if not paths:
        raise ReaderError("no data file given")
    for p in paths:
        inputs.check_input_path(p)
        if p.is_dir() and not _is_rosbag(p):
            raise ReaderError(f"{p}: is a directory, not a data file (a ROS 2 bag directory holds metadata.yaml)")
    if acc_unit is not None and acc_unit not in ACC_UNITS:
        raise ReaderError(f"unknown accelerometer unit {acc_unit!r}; use one of {', '.join(ACC_UNITS)}")
    if gyro_unit is not None and gyro_unit not in GYRO_UNITS:
        raise ReaderError(f"unknown gyroscope unit {gyro_unit!r}; use one of {', '.join(GYRO_UNITS)}")
    if time_unit is not None and time_unit not in TIME_UNITS:
        raise ReaderError(f"unknown time unit {time_unit!r}; use one of {', '.join(TIME_UNITS)}")
    if rate is not None and not (np.isfinite(rate) and rate > 0):
        raise ReaderError(f"rate must be a positive number of Hz; got {rate!r}")
    if reader is None:
        reader = guess_reader(paths)
    if reader not in READERS:
        raise ReaderError(f"unknown reader {reader!r}; use one of {', '.join(READERS)}")
    if reader in ("csv", "mat") and len(paths) > 1:  # one file per pose (per face): blocks of one recording
        return _read_file_blocks(paths, reader, columns, acc_unit, gyro_unit, rate, variable, time_unit, topic)
    expected = 2 if reader in ("imutk", "phone") else 1
    if len(paths) != expected:
        what = ("two files: the accelerometer file, then the gyroscope file" if expected == 2
                else "one file")
        raise ReaderError(f"the {reader} reader takes {what}; got {len(paths)}")
    if reader in ("csv", "imutk", "phone"):
        for p in paths:
            inputs.check_text(p, gzip_ok=reader == "csv")
    inputs.check_distinct_columns(columns)
    if reader == "rosbag":
        ignored = [name for name, v in (("columns", columns), ("acc_unit", acc_unit), ("gyro_unit", gyro_unit),
                                        ("rate", rate), ("variable", variable), ("time_unit", time_unit))
                   if v is not None]
        if ignored:
            raise ReaderError(f"a ROS bag's sensor_msgs/Imu fixes the fields, units and time; "
                              f"{', '.join(ignored)} cannot be set")
        from .rosbag import read_rosbag  # imported when a bag is met (the note at the top): 12 ms at start-up

        rec = read_rosbag(paths[0], topic=topic, progress=progress)
    elif topic is not None:
        raise ReaderError(f"topic applies to ROS bags; the {reader} reader has none")
    elif reader == "phone":
        ignored = [name for name, v in (("columns", columns), ("rate", rate), ("variable", variable))
                   if v is not None]
        if ignored:
            raise ReaderError(f"a phone app's files name their columns and carry their own time; "
                              f"{', '.join(ignored)} cannot be set")
        rec = _read_phone(paths, acc_unit, gyro_unit, time_unit)
    elif reader == "imutk":
        if [_sensors_named(_head_names(p) or []) for p in paths] == [{"gyro"}, {"acc"}]:
            warnings.warn(f"{paths[0]} names the gyroscope's axes and {paths[1]} the accelerometer's: read as the "
                          "accelerometer's file, then the gyroscope's", ImucalibWarning, stacklevel=2)
            paths = [paths[1], paths[0]]
        rec = _read_imutk(paths[0], paths[1], acc_unit, gyro_unit, time_unit)
    elif reader == "mat":
        rec = _read_mat(paths[0], columns, acc_unit, gyro_unit, rate, variable, time_unit)
    elif columns is None and (xsens := inputs.xsens_header(paths[0])) is not None:
        rec = inputs.read_xsens(paths[0], xsens, acc_unit, gyro_unit, rate, time_unit, read_csv=_read_csv)
    else:
        rec = _read_csv(paths[0], columns, acc_unit, gyro_unit, rate, time_unit)
    acc_unit, gyro_unit, time_unit = _flags_over_header(paths, reader, rec, acc_unit, gyro_unit, time_unit)
    inputs.check_against_header(paths, reader, rec, acc_unit, gyro_unit, time_unit, unit_in=_unit_in,
                                phone_specs=_phone_specs)
    inputs.check_magnitudes(paths, rec)
    if reader in ("csv", "mat") and len(rec) > 1:
        note_held_samples(paths[0], rec.acc, rec.gyro, rec.rate)
    named = (rec.metadata.get("columns") or {}) if rec.metadata.get("header") else {}
    written = any(_unit_in(named.get(f) or "") for f in ("ax", "gx"))  # a header's "[counts]" is an answer
    if acc_unit is None and gyro_unit is None and reader in ("csv", "imutk", "mat") and not written:
        inputs.note_physical_units(paths, rec)
    elif gyro_unit is None and reader in ("csv", "imutk", "mat") and not _unit_in(named.get("gx") or ""):
        inputs.note_gyro_unit(paths, rec)
    rec.metadata.setdefault("source", [str(p) for p in paths])
    rec.metadata["reader"] = reader
    return rec


def _written_units(paths: Sequence[Path], reader: str, rec: Recording) -> dict[str, tuple[str, str]]:
    """Field (``ax``, ``gx``, ``t``) → (where, unit) for each unit the file's header writes."""
    written: dict[str, tuple[str, str]] = {}
    if reader == "csv" and rec.metadata.get("header"):
        for field, name in (rec.metadata.get("columns") or {}).items():
            if field in ("ax", "gx", "t") and name is not None and _unit_in(name) is not None:
                written[field] = (name, _unit_in(name))
    elif reader == "phone":
        for spec in _phone_specs(paths) or []:
            if spec.unit is not None:
                field = "ax" if spec.sensor == "acc" else "gx"
                written[field] = (f"{spec.app} {'accelerometer' if field == 'ax' else 'gyroscope'} file", spec.unit)
    return written


def _flags_over_header(paths: Sequence[Path], reader: str, rec: Recording, acc_unit, gyro_unit, time_unit):
    """A unit option that contradicts the header wins, with a warning; the options left to check against it.

    The readers already read the data in the option's unit. For the accelerometer the warning says which
    of the two units the readings' magnitude supports: the median norm of the static-ish samples is g in
    either unit, so about 9.8 in m/s² and about 1 in g.
    """
    given = {"ax": ("--acc-unit", acc_unit), "gx": ("--gyro-unit", gyro_unit), "t": ("--time-unit", time_unit)}
    where_file = ", ".join(map(str, paths)) if reader == "phone" else str(paths[0])
    overridden = set()
    for field, (where, unit) in _written_units(paths, reader, rec).items():
        flag, value = given[field]
        if value is None or value == unit:
            continue
        overridden.add(field)
        told = ""
        if field == "ax" and rec.acc is not None and len(rec):
            norm = float(np.median(np.linalg.norm(rec.acc, axis=1)))
            looks = {"m/s^2": 9.0 <= norm <= 10.6, "g": 0.9 <= norm <= 1.1}
            if looks.get(value):
                told = f"; the readings' median norm, {norm:.3g}, is gravity in {value}: the option is right"
            elif looks.get(unit):
                told = (f"; but the readings' median norm, {norm:.3g}, is gravity in {unit}: the header looks "
                        f"right, drop {flag}")
            elif value in looks:
                told = f"; the readings' median norm, {norm:.3g}, is gravity in neither unit: check the column"
        warnings.warn(f"{where_file}: {flag} {value} overrides the header ({where!r} says {unit}): the readings are "
                      f"taken in {value}{told}", ImucalibWarning, stacklevel=3)
    return tuple(None if f in overridden else given[f][1] for f in ("ax", "gx", "t"))


def _is_rosbag(path: Path) -> bool:
    """:func:`.rosbag.is_rosbag`, its module imported on first use."""
    from .rosbag import is_rosbag  # imported when a folder is met (the note at the top): 12 ms at start-up

    return is_rosbag(path)


def guess_reader(paths: Sequence[Path]) -> str:
    r"""The reader for ``paths``, from their content.

    ``"rosbag"`` for ROS bags, ``"mat"`` for MATLAB files; for two files,
    ``"phone"`` when both headers are a phone app's (phyphox, Sensor Logger:
    :mod:`.phone`), ``"imutk"`` unless both have headers naming sensor
    columns; else ``"csv"`` (several files are then blocks of one recording).

    Parameters
    ----------
    paths : sequence of Path
        The input files (the first one's first 128 bytes tell a MATLAB file; the headers of two tell a
        phone app's pair or imu_tk's).

    Returns
    -------
    str
        One of :data:`READERS`: ``"csv"``, ``"imutk"``, ``"mat"``, ``"phone"`` or ``"rosbag"``.

    Raises
    ------
    OSError
        The first file cannot be opened.
    """
    if _is_rosbag(paths[0]):
        return "rosbag"
    with paths[0].open("rb") as f:
        head = f.read(128)
    if head.startswith(b"MATLAB") or (head[:4] in (b"\x00\x00\x00\x00",) and paths[0].suffix == ".mat"):
        return "mat"
    if len(paths) == 2 and _phone_specs(paths) is not None:
        return "phone"
    if len(paths) == 2 and not all(_names_sensor_columns(_head_names(p) or []) for p in paths):
        return "imutk"  # two files without headers naming the sensors: imu_tk's accelerometer and gyroscope
    if len(paths) == 2 and [_sensors_named(_head_names(p) or []) for p in paths] in ([{"acc"}, {"gyro"}],
                                                                                  [{"gyro"}, {"acc"}]):
        return "imutk"  # a table of the accelerometer's axes and one of the gyroscope's: the same pair
    return "csv"


def _read_file_blocks(paths: Sequence[Path], reader: str, columns, acc_unit, gyro_unit, rate, variable, time_unit,
                      topic) -> Recording:
    """Several files of the same sensor, one per pose (MATLAB's ``accelcal(XUP, XDOWN, …)``), as one recording.

    Each file is read as one file is, with its own time base; the blocks follow each other in the order given,
    each :data:`BLOCK_GAP_STEPS` median sampling steps after the one before, and ``metadata["blocks"]`` holds
    their rows ``[start, stop)``. They must have the same sensors, units and columns. A note repeated by every
    file is shown once.
    """
    if topic is not None:
        raise ReaderError(f"topic applies to ROS bags; the {reader} reader has none")
    twice = [p for i, p in enumerate(paths) if p.resolve() in {q.resolve() for q in paths[:i]}]
    if twice:
        raise ReaderError(f"{twice[0]} is given twice; several files are read as blocks of one recording (one pose "
                          "each), each file once")
    recs = []
    notes: dict[str, list] = {}  # a note's text without the file and its figures → [first note, files it is in]
    for p in paths:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ImucalibWarning)
            recs.append(read(p, reader=reader, columns=columns, acc_unit=acc_unit, gyro_unit=gyro_unit, rate=rate,
                             variable=variable, time_unit=time_unit))
        for w in caught:
            key = re.sub(r"[-+]?\d[\d.]*(?:e[-+]?\d+)?", "#", str(w.message).replace(str(p), ""))
            notes.setdefault(key, [w, 0])[1] += 1
    for w, count in notes.values():
        warnings.warn(f"{w.message}" + (f" (and in {count - 1} more of the files)" if count > 1 else ""),
                      w.category, stacklevel=3)
    first = recs[0]
    for p, rec in zip(paths[1:], recs[1:], strict=True):
        has = ("a gyroscope" if first.gyro is not None else "no gyroscope",
               "a gyroscope" if rec.gyro is not None else "no gyroscope")
        for what, a, b in (("has", *has), ("has its accelerometer in", first.acc_unit, rec.acc_unit),
                           ("has its gyroscope in", first.gyro_unit if first.gyro is not None else None,
                            rec.gyro_unit if rec.gyro is not None else None),
                           ("has the columns", first.metadata.get("column_names"), rec.metadata.get("column_names"))):
            if a != b:
                a, b = (", ".join(v) if isinstance(v, list) else str(v) for v in (a, b))
                raise ReaderError(f"several files are read as blocks (one pose each) of one recording, so they must "
                                  f"match: {p} {what} {b}, {paths[0]} {what} {a}")
    steps = np.concatenate([np.diff(r.t) for r in recs])
    gap = BLOCK_GAP_STEPS * (float(np.median(steps)) if steps.size else 1.0)
    times, start, blocks, row = [], 0.0, [], 0
    for r in recs:
        times.append(r.t - r.t[0] + start)
        start = float(times[-1][-1]) + gap
        blocks.append([row, row + len(r)])
        row += len(r)
    keys = [k for k in first.extra if all(k in r.extra for r in recs)]
    left = sorted({k for r in recs for k in r.extra} - set(keys))
    if left:
        warnings.warn(f"the column(s) {', '.join(left)} are not in every file: left out", ImucalibWarning,
                      stacklevel=3)
    temps = [r.temperature for r in recs]
    meta = {**first.metadata, "source": [str(p) for p in paths], "reader": reader, "blocks": blocks,
            "block_files": len(paths)}
    meta.pop("source_layout", None)
    warnings.warn(f"read {len(paths)} files as blocks of one recording, one pose each, in the order given (each "
                  f"with its own time base); {len(paths)} files joined: the gaps between them are not used for "
                  "integration", ImucalibWarning, stacklevel=3)
    return Recording(
        t=np.concatenate(times), acc=np.concatenate([r.acc for r in recs]),
        gyro=None if first.gyro is None else np.concatenate([r.gyro for r in recs]),
        acc_unit=first.acc_unit, gyro_unit=first.gyro_unit,
        temperature=None if any(x is None for x in temps) else np.concatenate(temps),
        extra={k: np.concatenate([r.extra[k] for r in recs]) for k in keys}, metadata=meta,
    )


# ------------------------------------------------------------------ numbers
def _parse_block(path: Path, lines: list[str], first_line: int, ncols: int | None,
                 sep: str | None, names: Sequence[str] | None) -> np.ndarray:
    """Parse text rows into a float array; on failure find the first bad cell."""
    text = "\n".join(lines)
    separators_ok = True
    if sep not in (None, " "):
        # an empty cell would vanish in the whitespace parse: count the separators first
        separators_ok = ncols is not None and text.count(sep) == (ncols - 1) * len(lines)
        text = text.replace(sep, " ")
    try:
        if not separators_ok:
            raise ValueError("separator count")
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # numpy warns (not raises) when it stops at a bad cell
            flat = np.fromstring(text, dtype=np.float64, sep=" ")  # C parser; a bad cell → slow path
        if ncols is not None and flat.size == ncols * len(lines):
            data = flat.reshape(len(lines), ncols)
            if np.all(np.isfinite(data)):
                return data
    except (ValueError, DeprecationWarning):
        pass
    # slow path: locate the first problem precisely
    rows = []
    for i, line in enumerate(lines):
        cells = line.split(sep) if sep not in (None, " ") else line.split()
        cells = [c.strip() for c in cells]
        lineno = first_line + i
        if ncols is not None and len(cells) != ncols:
            raise ReaderError(
                f"{path}: line {lineno}: expected {ncols} values, found {len(cells)} "
                f"({line.strip()[:80]!r}); every row needs the same columns"
            )
        values = []
        for j, cell in enumerate(cells):
            col = names[j] if names is not None and j < len(names) else f"column {j + 1}"
            try:
                v = float(cell)
            except ValueError:
                raise ReaderError(
                    f"{path}: line {lineno}, {col}: {cell!r} is not a number; fix or remove "
                    "the row (imucalib never skips rows)"
                ) from None
            if not np.isfinite(v):
                raise ReaderError(
                    f"{path}: line {lineno}, {col}: {cell!r} is not finite (NaN or inf); "
                    "fix or remove the row (imucalib never skips rows)"
                )
            values.append(v)
        rows.append(values)
    return np.array(rows, dtype=np.float64)


# ------------------------------------------------------------------ imu_tk
def _read_imutk(acc_path: Path, gyro_path: Path, acc_unit, gyro_unit, time_unit) -> Recording:
    (ta, acc), (tg, gyro) = (_imutk_table(path) for path in (acc_path, gyro_path))
    meta: dict = {"source": [str(acc_path), str(gyro_path)]}
    unit = time_unit or "s"
    t_acc = to_seconds(ta, unit, meta)
    t_gyro = (tg - ta[0]) * TIME_UNITS[unit] if meta.get("time_relative") else tg * TIME_UNITS[unit]
    del ta, tg
    return Recording.from_streams(
        t_acc, acc, t_gyro, gyro,
        acc_unit=acc_unit or "counts", gyro_unit=gyro_unit or "counts", metadata=meta,
    )


def _imutk_table(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """One imu_tk file's ``time x y z`` rows: the times (n,) and the values (n, 3), read a few megabytes at a time.

    The body is parsed in chunks by :func:`.csvparse.parse` into preallocated
    arrays, so memory is the arrays', not the text's (a 230 MB file of 3.6 M rows
    took 0.8 GB as one string). A file it does not take as it is (blank lines, a
    bad cell, another number of columns) is read again whole by
    :func:`_numeric_table`, whose messages name the line.
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
    data = _numeric_table(path, path.read_bytes().decode("utf-8-sig", errors="replace"), 4, names)
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
    table = _split_table(path)
    names = table.names
    if table.header is None:
        if table.ncols != 4:
            raise ReaderError(f"{path}: a file of an accelerometer/gyroscope pair holds time x y z; this one has "
                              f"{table.ncols} columns and no header naming them")
        picked = [0, 1, 2, 3]
    else:
        if _sensors_named(names) == {"acc", "gyro"}:
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
    cols = _parse_table(path, table, picked, others=False)
    t = np.asarray(cols[picked[0]], dtype=np.float64)
    xyz = np.column_stack([np.asarray(cols[j], dtype=np.float64) for j in picked[1:]])
    if t.size < 2:
        raise ReaderError(f"{path}: {t.size} row(s): a file of an accelerometer/gyroscope pair holds many")
    _check_time(path, t, table.first_line)
    return t, xyz


def _numeric_table(path: Path, text: str, ncols: int, names: Sequence[str]) -> np.ndarray:
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
        data = _parse_block(path, lines, 1, ncols, None, names)
    rep = repair_coarse(path, data[:, 0], [data[:, 1:]], 1)
    data = data if rep.keep is None else data[rep.keep]
    data[:, 0] = rep.t
    return data


# --------------------------------------------------------------------- CSV
def _unit_in(name: str) -> str | None:
    """A unit written in a column name: ``[m/s^2]``, ``(dps)``, ``_ms`` …"""
    m = re.search(r"[\[\(]\s*([^\]\)]+?)\s*[\]\)]", name)
    tail = m.group(1) if m else re.split(r"[_\s]", name)[-1]
    u = tail.strip().lower().replace(" ", "").replace("²", "^2")
    table = {
        "s": "s", "sec": "s", "ms": "ms", "us": "us", "µs": "us", "ns": "ns",
        "g": "g", "m/s^2": "m/s^2", "m/s2": "m/s^2", "ms^-2": "m/s^2", "ms-2": "m/s^2",
        "deg/s": "deg/s", "dps": "deg/s", "°/s": "deg/s", "rad/s": "rad/s", "rads^-1": "rad/s",
        "rad/sec": "rad/s", "counts": "counts", "lsb": "counts", "raw": "counts",
    }
    return table.get(u)


def _sniff_separator(line: str) -> str | None:
    for sep in (";", "\t"):  # numbers with decimal commas, separated by semicolons or tabs (text cells too)
        if sep in line and "," in line:
            cells = line.split(sep)
            numbers = sum(not _not_number(c.strip().strip('"').replace(",", ".")) for c in cells)
            if numbers > len(cells) / 2 and any(_DECIMAL_COMMA.match(c.strip()) for c in cells):
                return sep
    for sep in (",", ";", "\t"):
        if sep in line:
            return sep
    return None  # whitespace


def _cells(line: str, sep: str | None) -> list[str]:
    return [c.strip() for c in (line.split(sep) if sep else line.split())]


_RATE = re.compile(
    r"(?:^|[,;:#%\t])\s*(?:fs|f_s|odr|rate|data[\s_]?rate|output[\s_]?data[\s_]?rate|"
    r"sampl(?:e|ing)[\s_]?(?:rate|frequency|freq)|samplerate|frequency)\s*(?:[\[\(]\s*(k?hz)\s*[\]\)])?"
    r"\s*[,;:=\t]\s*\"?\s*([0-9]+(?:\.[0-9]*)?(?:[eE][+-]?[0-9]+)?)\s*(k?hz)?",
    re.I,
)


def _preamble_rate(lines: Sequence[str]) -> float | None:
    """A sampling rate [Hz] written in preamble lines (``Fs,100``, ``sample rate [Hz],100``, ``ODR: 1 kHz`` …)."""
    for line in lines:
        m = _RATE.search(line.strip())
        if m:
            value = float(m.group(2))
            unit = (m.group(1) or m.group(3) or "hz").lower()
            value *= 1000.0 if unit == "khz" else 1.0
            if np.isfinite(value) and value > 0:
                return value
    return None


def _sensors_named(cells: Sequence[str]) -> set[str]:
    """The sensors (``acc``, ``gyro``) whose three axes a header names."""
    return {kind for kind, pat in _PATTERNS.items() if sum(bool(pat.match(c.strip())) for c in cells) >= 3}


def _names_sensor_columns(cells: Sequence[str]) -> bool:
    hits = sum(bool(_TIME.match(c) or any(p.match(c) for p in _PATTERNS.values())) for c in cells)
    return hits >= 3


def _table_start(lines: list[str]) -> int:
    """Index of the first line of the table (the header or the first row) after a preamble, 0 when none.

    The table's width is that of its last line. Leading lines of another width
    (``key,value`` pairs, free text, comments) are a preamble, provided they do
    not themselves look like a header naming sensor columns (a header of the
    wrong width stays an error) and the table starts in the first half of the file.
    """
    if len(lines) < 3:
        return 0
    last = next((ln for ln in reversed(lines) if not _is_prompt(ln, _sniff_separator(ln))), lines[-1])
    sep = _sniff_separator(last)  # the table's width: its last row's (a logger's prompt may come after it)
    width = len(_cells(last, sep))
    if width < 2 or len(_cells(lines[0], sep)) == width:
        return 0
    for k in range(1, len(lines) // 2 + 1):
        if len(_cells(lines[k], sep)) == width and len(_cells(lines[k + 1], sep)) == width:
            if any(_names_sensor_columns([c.strip('"\'') for c in _cells(ln, sep)]) for ln in lines[:k]):
                return 0
            return k
    return 0


@dataclass
class _Table:
    """A delimited file's parts (line numbers are 1-based) and where its rows lie in it (:class:`.csvparse.Layout`)."""

    header: list[str] | None
    first_line: int
    sep: str | None
    ncols: int
    layout: csvparse.Layout | None  # None for a DataFrame
    first_row: list[str]
    skipped: int = 0
    rate: float | None = None
    prompts: bool = False  # lines with no number inside the rows (a logger's prompts): block boundaries
    sample: list[str] = dataclasses.field(default_factory=list)  # the first rows, as text
    trailing: bool = False  # a separator ends every line: the last column is the empty cell after it
    units_row: bool = False  # a line of units under the header (read into the names; the file is written anew)

    @property
    def names(self) -> list[str]:
        return self.header or [f"column {j + 1}" for j in range(self.ncols)]

    def split(self, line: str) -> list[str]:
        return _cells(line, self.sep)


def _split_table(path: Path, columns: Sequence[str] | None = None) -> _Table:
    """Find ``path``'s preamble (skipped with a note), header and rows from its first lines and its last.

    Only the head of the file (1 MB) and its last line are read here; the rows
    are parsed by :func:`_parse_table`, a chunk at a time. A first line that
    is a logger's prompt rather than a header (:func:`_prompt_not_header`) is
    part of the preamble even when it has as many cells as the rows.
    """
    head = csvparse.read_head(path)
    if not head.lines:
        raise ReaderError(f"{path}: empty file")
    lines = head.lines if head.complete else [*head.lines, head.last]
    start = _table_start(lines)
    if start + 2 < len(lines) and _prompt_not_header(lines, start, columns):
        start += 1  # a logger's first prompt, as wide as the rows by chance: skipped as a preamble line
    preamble = lines[:start]
    sep = _sniff_separator(lines[start])
    first = _cells(lines[start], sep)
    has_header = any(_not_number(c) for c in first)
    header = [c.strip('"\'').strip() for c in first] if has_header else None
    if header and re.match(r"#\s", header[0]):  # numpy.savetxt's header="…" writes "# " before the names
        header[0] = header[0][1:].strip()
    row0 = start + 1 if has_header else start
    units = _units_row(head.lines, row0, sep, header) if header else None
    if units is not None:  # a line of units under the names (a vendor's export): read as the names' units
        header = [f"{h} [{u}]" if u else h for h, u in zip(header, units, strict=True)]
        row0 += 1
    first_line = row0 + 1
    if row0 >= len(head.lines):
        raise ReaderError(f"{path}: no data rows after the header" if head.complete
                          else f"{path}: no table in the first megabyte of the file")
    row = head.lines[row0]
    # semicolons or tabs between cells, commas as decimal marks
    decimal_comma = sep in (";", "\t") and any(_DECIMAL_COMMA.match(c) for c in _cells(row, sep))
    first_row = csvparse.split_cells(row.replace(",", ".") if decimal_comma else row, sep)
    if header and len(first_row) == len(header) + 1 and first_row[-1] == "":
        header.append("")  # the rows end with a separator, the header does not
    ncols = len(header) if header else len(first_row)
    hdr = None
    if has_header:
        hdr_end = head.offsets[start + 1] - 1
        hdr = (head.offsets[start], hdr_end)
    layout = csvparse.Layout(path, hdr, (head.offsets[row0], head.end), first_line, sep, decimal_comma, ncols,
                             head.size, head.mtime_ns)
    trailing = first_row[-1:] == [""] and (header is None or header[-1] == "") and sep not in (None, " ")
    table = _Table(header, first_line, sep, ncols, layout, first_row, skipped=start, rate=_preamble_rate(preamble),
                   units_row=units is not None,
                   sample=head.lines[row0:row0 + 1000], trailing=trailing,
                   prompts=any(_is_prompt(ln, sep) for ln in head.lines[row0:] + ([] if head.complete else
                                                                                  [head.last])))
    if units is not None:
        warnings.warn(f"{path}: line {first_line - 1} gives the columns' units ({', '.join(u for u in units if u)}): "
                      "read as the units of the names above it", ImucalibWarning, stacklevel=4)
    if start:
        what = "" if table.rate is None else f" (they give a sampling rate of {table.rate:g} Hz)"
        warnings.warn(f"{path}: skipped {start} line{'s' if start > 1 else ''} before the "
                      f"{'header' if has_header else 'data'}{what}", ImucalibWarning, stacklevel=4)
    return table


#: a cell of a units line: a short unit (``s``, ``ms``, ``g``, ``m/s^2``, ``m/s²``, ``deg/s``, ``°/s``, ``[counts]``)
_UNIT_CELL = re.compile(r"^[\[\(]?[A-Za-zµ°/^²0-9.\- ]{1,12}[\]\)]?$")


def _units_row(lines: Sequence[str], row: int, sep: str | None, header: list[str]) -> list[str] | None:
    """The cells of ``lines[row]`` when it is a line of units under the header (every cell a short unit or empty,
    as many as the names, rows of numbers after it), else None."""
    if row + 1 >= len(lines):
        return None
    cells = [c.strip('"\'').strip() for c in _cells(lines[row], sep)]
    after = [c for c in _cells(lines[row + 1], sep) if c.strip()]
    if (len(cells) != len(header) or not any(cells) or not after or any(_not_number(c) for c in after)
            or not all(_not_number(c) and _UNIT_CELL.match(c) for c in cells if c)):
        return None
    return [c.strip("[]()") for c in cells]


_DECIMAL_COMMA = re.compile(r'^"?[+-]?\d*,\d+(?:[eE][+-]?\d+)?"?$')
#: how a line of prose starts or ends: a run of marks (``>>>``, ``---``, ``***``), a sentence's last mark
_PROSE = re.compile(r"^[^\w\s\"'#\[\(]{2,}|[.!?:…]$")


def _prompt_not_header(lines: Sequence[str], start: int, columns: Sequence[str] | None) -> bool:
    """Whether the line ``lines[start]`` before rows of numbers is a logger's prompt, not the rows' header.

    A header names columns; a prompt (``>>> Pose 1: gathering data for 10s...``) is text that happens to split
    into as many cells as the rows have. It is a prompt when none of its cells is a column name this reader
    knows (time, accelerometer, gyroscope, temperature) or one ``--columns`` gives, the next line is a row
    (numbers), and it reads as prose (starts with a run of marks, ends like a sentence, or has a cell of three
    words or more) or begins with the word a prompt line inside the rows begins with (the logger's next
    prompts).
    """
    text = lines[start].strip()
    sep = _sniff_separator(lines[start + 1])
    cells = [c.strip('"\'').strip() for c in _cells(text, sep)]
    if not cells or not _not_number(cells[0]) or any(_not_number(c) for c in _cells(lines[start + 1], sep)):
        return False
    known = {c.strip().lower() for c in columns or ()}
    if any(_TIME.match(c) or _TEMP.match(c) or any(p.match(c) for p in _PATTERNS.values()) or c.lower() in known
           for c in cells):
        return False
    if _PROSE.search(text) or any(len(c.split()) >= 3 for c in cells):
        return True
    word = cells[0].split()[0]
    return any(ln.strip().startswith(word) for ln in lines[start + 1:] if _is_prompt(ln, sep))


def _is_prompt(line: str, sep: str | None) -> bool:
    """A line inside the rows that is not a row: a logger's prompt (``>>> Gathering data for 10 seconds...``,
    ``--- pose 2 ---``) or a repeated header — its first cell is not a number, whatever numbers follow (a row
    of numbers always starts with one); a comment (``#``) and a blank line are not prompts."""
    text = line.strip()
    if not text or text.startswith("#"):
        return False
    cells = [c for c in _cells(text, sep) if c]
    return not cells or _not_number(cells[0].strip('"\'').replace(",", "."))


def _prompt_blocks(path: Path, table: _Table) -> tuple[np.ndarray, list[list[int]]]:
    """The rows of a file whose rows are cut into blocks by prompt lines, and each block's rows ``[start, stop)``.

    A logger that pauses between poses ("place the sensor, press a key") writes a prompt before each block:
    every block is a pose. Blank lines beside the prompts are part of the boundary; comments are skipped as
    elsewhere. The rows are parsed line by line (such logs are short) and checked as every row is.
    """
    start, end = table.layout.body
    with csvparse.open_binary(path) as f:
        f.seek(start)
        text = f.read(end - start).decode("utf-8", errors="replace")
    lines = text.splitlines()
    blocks: list[list[int]] = []
    parts: list[np.ndarray] = []
    run: list[str] = []
    run_line = table.first_line
    prompts = 0
    rows = 0

    def close() -> None:
        nonlocal rows
        if run:
            body = [ln.replace(",", ".") for ln in run] if table.layout.decimal_comma else run
            parts.append(_parse_block(path, body, run_line, table.ncols, table.sep, table.names))
            blocks.append([rows, rows + len(run)])
            rows += len(run)

    for i, line in enumerate(lines):
        if _is_prompt(line, table.sep) or not line.strip():
            prompts += bool(line.strip())
            close()
            run = []
            continue
        if line.lstrip().startswith("#"):
            continue
        if not run:
            run_line = table.first_line + i
        run.append(line)
    close()
    if not parts:
        raise ReaderError(f"{path}: no data rows between the prompt lines")
    warnings.warn(f"{path}: {prompts} line{'s' if prompts > 1 else ''} inside the data that are not rows (a logger's "
                  f"prompts) cut the rows into {len(blocks)} blocks: each block is read as one pose",
                  ImucalibWarning, stacklevel=5)
    return np.concatenate(parts), blocks


#: the gap put between blocks whose times restart [median sampling steps]: a gap the integration never crosses
BLOCK_GAP_STEPS = 100


def _block_times(path: Path, t: np.ndarray, blocks: list[list[int]]) -> np.ndarray:
    """The time column of blocks, each block after one whose time it does not follow moved to start
    :data:`BLOCK_GAP_STEPS` median steps after it (each block keeps its own steps); with a note."""
    t = np.array(t, dtype=np.float64)
    steps = np.concatenate([np.diff(t[a:b]) for a, b in blocks])
    step = float(np.median(steps)) if steps.size else 1.0
    moved = 0
    for (_, prev_stop), (a, b) in zip(blocks[:-1], blocks[1:], strict=True):
        if t[a] <= t[prev_stop - 1]:
            t[a:b] += t[prev_stop - 1] + BLOCK_GAP_STEPS * step - t[a]
            moved += 1
    if moved:
        warnings.warn(f"{path}: the time restarts in {moved} of the {len(blocks)} blocks: each such block was put "
                      f"{BLOCK_GAP_STEPS} sampling steps after the one before (each keeps its own time base; the "
                      "gaps between blocks are not used for integration)",
                      ImucalibWarning, stacklevel=5)
    return t


def _parse_table(path: Path, table: _Table, required: Sequence[int], *, others: bool = True,
                 out: dict[int, np.ndarray] | None = None, plan: csvparse.Plan | None = None,
                 facts: dict | None = None) -> dict[int, np.ndarray]:
    """The rows' columns as arrays (:func:`.csvparse.parse`): ``required`` ones numbers, checked; the others
    (when ``others``) numbers or text as their cells are; int64 for long integers (ns stamps, IDs).
    ``facts``, when given, receives the parse's facts (its ``digest`` of the bytes parsed)."""
    kinds: list[str | None] = csvparse.column_kinds(table.first_row, False)
    if len(kinds) != table.ncols:  # the first row's width is wrong: the line-by-line parser says so
        kinds = (kinds + ["float"] * table.ncols)[:table.ncols]
    for j in range(table.ncols):
        if j in required and kinds[j] == "text":
            kinds[j] = "float"  # the parse names the bad cell
        elif (j not in required and not others) or (table.trailing and j == table.ncols - 1):
            kinds[j] = None
    cols, parsed = csvparse.parse(table.layout, kinds, table.names, required=required, out=out, plan=plan)
    if facts is not None:
        facts.update(parsed)
    if parsed["comment_lines"]:
        n = parsed["comment_lines"]
        warnings.warn(f"{path}: skipped {n} comment line{'s' if n > 1 else ''} (starting with #) between the rows",
                      ImucalibWarning, stacklevel=4)
    return cols


def _time_column(col: np.ndarray) -> tuple[np.ndarray, int]:
    """A time column as floats and an integer offset: long integer stamps (beyond float precision) are taken
    relative to the first one, exactly; other columns are returned as they are, with offset 0."""
    if col.dtype.kind == "i":
        return (col - col[0]).astype(np.float64), int(col[0])
    return col, 0


def _read_csv(path: Path, columns, acc_unit, gyro_unit, rate, time_unit, frame=None) -> Recording:
    table = _split_table(path, columns) if frame is None else _frame_table(frame)
    dated = datetime_cells(table.first_row) if frame is None else []
    source = table.layout  # where the file's rows lie: apply copies their text (io.writers)
    if dated:  # date-time stamps: read as a DataFrame's datetimes are
        frame = read_dated(path, skiprows=table.skipped, sep=table.sep, dated=dated,
                           has_header=table.header is not None and not datetime_cells(table.header))
        table = _frame_table(frame)
        dated_digest = None if csvparse.is_gzip(path) else csvparse.file_digest(source).hexdigest()
    has_header = table.header is not None
    first_line, names = table.first_line, table.names
    mapping = _map_columns(path, names, columns, has_header)
    numeric_cols = sorted({j for j in mapping.values() if j is not None})
    sensors = [mapping[f] for f in (*FIELDS[1:], "mx", "my", "mz") if mapping[f] is not None]
    # the samples go straight into the recording's arrays: no copy of the whole table
    blocks = _prompt_blocks(path, table) if frame is None and table.prompts else None
    sparse = (packets.sparse_rows(path, table.layout, names, numeric_cols, sensors) if frame is None and blocks is None
              and packets.has_empty_cells(table.sample, table.sep, sensors) else None)
    plan = csvparse.plan(table.layout) if frame is None and blocks is None and sparse is None else None
    rows = (plan.rows if plan is not None else len(frame) if frame is not None else sparse[0] if sparse is not None
            else blocks[0].shape[0])
    if rows == 0:
        raise ReaderError(f"{path}: no data rows after the header")
    has_gyro = mapping["gx"] is not None
    acc, gyro = np.empty((rows, 3)), (np.empty((rows, 3)) if has_gyro else None)
    targets = {f: (acc if f[0] == "a" else gyro)[:, "xyz".index(f[1])] for f in FIELDS[1:]
               if mapping[f] is not None}
    out: dict[int, np.ndarray] = {}
    for f, view in targets.items():
        out.setdefault(mapping[f], view)
    parsed: dict = {"digest": dated_digest} if dated else {}
    if blocks is not None:
        cols = {j: blocks[0][:, j] for j in range(table.ncols)}
    elif sparse is not None:
        cols = sparse[1]
    elif frame is None:
        cols = _parse_table(path, table, numeric_cols, out=out, plan=plan, facts=parsed)
    else:
        cols, stamps = _frame_columns(path, frame, numeric_cols, out)
        if mapping["t"] in stamps and time_unit is None:
            time_unit = "ns"
    for f, view in targets.items():
        if cols[mapping[f]] is not view:  # a column used for two fields
            view[:] = cols[mapping[f]]
    meta: dict = {"columns": {f: (names[j] if j is not None else None) for f, j in mapping.items()
                              if f in FIELDS or j is not None},
                  "column_names": list(names), "header": has_header, "separator": table.sep or " "}
    if table.skipped:
        meta["preamble_lines"] = table.skipped
    tcol = mapping["t"]
    if blocks is not None:
        meta["blocks"] = blocks[1]
        if tcol is not None:
            shifted = _block_times(path, cols[tcol], blocks[1])
            if not np.array_equal(shifted, cols[tcol]):
                meta["time_original"] = cols[tcol]  # what a writer writes back (imucalib.io.writers)
            cols[tcol] = shifted
    if tcol is None:
        if rate is None and table.rate is not None:
            rate = table.rate
            meta["rate_from"] = "preamble"
        if mapping["n"] is not None:
            t = packets.counter_times(path, cols[mapping["n"]], names[mapping["n"]], rate)
        elif rate is None:
            raise ReaderError(f"{path}: no time column found; pass --rate HZ (the sampling rate)")
        else:  # blocks of a logger that paused: BLOCK_GAP_STEPS steps between them, as between files
            t = (np.arange(rows) + (0 if blocks is None else BLOCK_GAP_STEPS * np.repeat(
                np.arange(len(blocks[1])), [b - a for a, b in blocks[1]]))) / rate
        meta["time_unit"] = None
    else:
        if rate is not None:
            raise ReaderError(
                f"{path}: the file has a time column ({names[tcol]!r}) and --rate was given; "
                "pass only one (use --columns with '-' for t to ignore the time column)"
            )
        raw_t, offset = _time_column(cols[tcol])
        rep = repair_coarse(path, raw_t, [acc] + ([gyro] if has_gyro else []), first_line, names[tcol])
        raw_t = rep.t
        if rep.keep is not None:  # repeated rows dropped: every column with them
            acc, gyro = acc[rep.keep], (gyro[rep.keep] if has_gyro else None)
            cols = {j: c[rep.keep] for j, c in cols.items()}
            parsed.pop("digest", None)  # the rows are no longer the file's: a writer writes them anew
        unit = time_unit or _unit_in(names[tcol]) if has_header else time_unit
        if unit not in TIME_UNITS:
            unit = time_unit or _infer_time_unit(raw_t, path, names[tcol])
        t = to_seconds(raw_t, unit, meta)
        if offset:
            meta["t0"] = offset
            meta["time_relative"] = True
    au = acc_unit or (_unit_in(names[mapping["ax"]]) if has_header else None) or "counts"
    gu = gyro_unit or (_unit_in(names[mapping["gx"]]) if has_header and has_gyro else None) or "counts"
    if au not in ACC_UNITS:
        au = "counts"
    if gu not in GYRO_UNITS:
        gu = "counts"
    used = {j for j in mapping.values() if j is not None}
    extra, temperature = packets.mapped_others(mapping, names, cols, meta)
    for j, name in enumerate(names):
        col = cols.get(j)
        if j in used or col is None or (table.trailing and j == table.ncols - 1):
            continue  # read as a field, not read (another packet's), or the empty cell after a trailing separator
        if temperature is None and has_header and _TEMP.match(name) and col.dtype.kind == "f":
            temperature = col
            meta["temperature_column"] = name
        extra[name if name not in extra else f"{name} (column {j + 1})"] = col
    rec = Recording(t=t, acc=acc, gyro=gyro, acc_unit=au, gyro_unit=gu, temperature=temperature,
                    extra=extra, metadata=meta)
    if parsed.get("digest") and not csvparse.is_gzip(path) and not table.units_row:  # what apply needs to copy the
        # file's own text (io.writers); a units line under the header: the file is written anew
        meta["source_layout"] = {**source.to_dict(), "rows": rows, "fingerprint": csvparse.fingerprint(rec),
                                 "digest": parsed["digest"]}
    return rec


# ------------------------------------------------------------- DataFrames
def is_frame(obj) -> bool:
    """Whether ``obj`` is a pandas DataFrame (without importing pandas)."""
    return type(obj).__module__.split(".")[0] == "pandas" and hasattr(obj, "columns") and hasattr(obj, "iloc")


def _read_frame(frame, reader, columns, acc_unit, gyro_unit, rate, variable, time_unit, topic) -> Recording:
    """A DataFrame read as a CSV file whose header is the frame's column names."""
    label = Path("DataFrame")
    for name, value, allowed in (("accelerometer", acc_unit, ACC_UNITS), ("gyroscope", gyro_unit, GYRO_UNITS),
                                 ("time", time_unit, tuple(TIME_UNITS))):
        if value is not None and value not in allowed:
            raise ReaderError(f"unknown {name} unit {value!r}; use one of {', '.join(allowed)}")
    if rate is not None and not (np.isfinite(rate) and rate > 0):
        raise ReaderError(f"rate must be a positive number of Hz; got {rate!r}")
    ignored = [n for n, v in (("variable", variable), ("topic", topic)) if v is not None]
    if reader not in (None, "csv") or ignored:
        raise ReaderError(f"a DataFrame is read as a table (the csv reader); {', '.join(ignored) or 'reader'} "
                          "cannot be set")
    rec = _read_csv(label, columns, acc_unit, gyro_unit, rate, time_unit, frame=frame)
    rec.metadata["reader"] = "dataframe"
    return rec


def _frame_table(frame) -> _Table:
    names = [str(c).strip() for c in frame.columns]
    return _Table(names, 1, ",", len(names), None, [])


def _frame_columns(label: Path, frame, required: Sequence[int], out: dict[int, np.ndarray]
                   ) -> tuple[dict[int, np.ndarray], set[int]]:
    """The frame's columns as arrays (numbers, int64 for integers and datetimes, or text) and the datetime ones.

    ``required`` columns must hold finite numbers (else a :class:`ReaderError` naming the row and column).
    """
    names = [str(c).strip() for c in frame.columns]
    cols: dict[int, np.ndarray] = {}
    stamps: set[int] = set()
    for j, name in enumerate(names):
        series = frame.iloc[:, j]
        kind = series.dtype.kind
        if kind in "Mm":  # datetimes and durations: integer nanoseconds
            values = series.to_numpy().astype("datetime64[ns]" if kind == "M" else "timedelta64[ns]")
            cols[j] = values.view(np.int64)
            stamps.add(j)
            if np.any(np.isnat(values)):
                i = int(np.nonzero(np.isnat(values))[0][0])
                raise ReaderError(f"{label}: row {i + 1}, {name}: a missing time (NaT); fix or remove the row")
            continue
        if kind in "iu" and j not in out:
            ints = series.to_numpy().astype(np.int64)
            if ints.size and np.abs(ints).max() >= 10 ** (csvparse.INT_DIGITS - 1):  # as for a CSV file's cells
                cols[j] = ints
                continue
        if kind in "fiub":
            values = series.to_numpy(dtype=np.float64)
        elif j in required:
            values = np.empty(len(series))
            for i, cell in enumerate(series.tolist()):
                try:
                    values[i] = float(cell)
                except (TypeError, ValueError):
                    raise ReaderError(f"{label}: row {i + 1}, {name}: {cell!r} is not a number; fix or remove "
                                      "the row (imucalib never skips rows)") from None
        else:
            cols[j] = series.to_numpy().astype(str)
            continue
        if j in required and not np.all(np.isfinite(values)):
            i = int(np.nonzero(~np.isfinite(values))[0][0])
            raise ReaderError(f"{label}: row {i + 1}, {name}: {values[i]} is not finite (NaN or inf); fix or "
                              "remove the row (imucalib never skips rows)")
        if j in out:
            out[j][:] = values
            values = out[j]
        cols[j] = values
    return cols, stamps


# ------------------------------------------------------------ phone apps
def _head_names(path: Path) -> list[str] | None:
    """The cells of the first line when they name columns (not all numbers), else None."""
    if path.is_dir():
        return None
    with csvparse.open_binary(path) as f:
        line = f.readline(1 << 16).decode("utf-8-sig", errors="replace")
    cells = [c.strip('"\'').strip() for c in _cells(line, _sniff_separator(line))]
    return cells if any(_not_number(c) for c in cells) else None


def _phone_specs(paths: Sequence[Path]) -> list[PhoneFile] | None:
    """The phone-app layout of each of two files, or None when either is not a phone app's file.

    Sensor Logger's files share one header; when a file's name does not say which
    sensor it holds, the order decides (accelerometer first, as for imu_tk).
    """
    from .phone import PhoneFile, identify, sensor_logger_header  # imported when a phone's file is met (top note)

    specs = []
    for i, path in enumerate(paths):
        names = _head_names(path)
        if names is None:
            return None
        spec = identify(path, names)
        if spec is None and sensor_logger_header(names):
            lower = [n.lower() for n in names]
            sensor = "acc" if i == 0 else "gyro"
            spec = PhoneFile("Sensor Logger", sensor, 0, "ns",
                             (lower.index("x"), lower.index("y"), lower.index("z")),
                             "m/s^2" if sensor == "acc" else "rad/s")
        if spec is None:
            return None
        specs.append(spec)
    return specs


def _read_phone(paths: Sequence[Path], acc_unit, gyro_unit, time_unit) -> Recording:
    """A phone app's accelerometer and gyroscope files, merged onto the accelerometer's time base."""
    from .phone import check_specific_force  # imported when a phone's file is met (the note at the top)

    specs = _phone_specs(paths)
    if specs is None:
        raise ReaderError(f"{paths[0]}, {paths[1]}: not a pair of phone-app files (phyphox's or Sensor "
                          "Logger's accelerometer and gyroscope CSV files); see the formats in the docs")
    if specs[0].app != specs[1].app:
        raise ReaderError(f"{paths[0]} is a {specs[0].app} file but {paths[1]} is a {specs[1].app} file; "
                          "their times cannot be matched: pass two files from the same app")
    sensors = sorted(s.sensor for s in specs)
    if sensors != ["acc", "gyro"]:
        what = "accelerometer" if sensors[0] == "acc" else "gyroscope"
        raise ReaderError(f"{paths[0]} and {paths[1]} are both {what} files; pass one accelerometer "
                          "file and one gyroscope file")
    streams = {}
    for path, spec in zip(paths, specs, strict=True):
        table = _split_table(path)
        cols = _parse_table(path, table, [spec.time, *spec.axes], others=False)
        raw_t, offset = _time_column(cols[spec.time])
        _check_time(path, raw_t, table.first_line, table.names[spec.time])
        streams[spec.sensor] = (path, spec, table, raw_t, offset, np.column_stack([cols[j] for j in spec.axes]))
    app = specs[0].app
    unit = time_unit or specs[0].time_unit
    # epoch stamps are kept as exact integers relative to the earliest start
    base = min(offset if offset else float(raw_t[0]) for *_, raw_t, offset, _ in streams.values())
    times = {sensor: (raw_t + (offset - base)) * TIME_UNITS[unit]
             for sensor, (*_, raw_t, offset, _) in streams.items()}
    acc_path, acc_spec, *_, acc = streams["acc"]
    gyro_path, gyro_spec, *_, gyro = streams["gyro"]
    au = check_specific_force(acc_path, acc_spec, acc)
    if acc_unit is not None:
        au = acc_unit
    gu = gyro_unit or gyro_spec.unit
    if gu not in GYRO_UNITS:
        raise ReaderError(f"{gyro_path}: unknown gyroscope unit {gu!r} in the header; pass --gyro-unit")
    orders = {kind: ",".join(streams[sensor][2].names[j] for j in sorted(spec.axes))
              for sensor, kind, spec in (("acc", "accelerometer", acc_spec), ("gyro", "gyroscope", gyro_spec))
              if list(spec.axes) != sorted(spec.axes)}
    if len(orders) == 2 and len(set(orders.values())) == 1:
        reordered = f"; the axes, written in the order {orders['accelerometer']} in both files, were put in x,y,z order"
    elif orders:
        reordered = "; the axes, written in the order " + " and ".join(
            f"{order} ({kind})" for kind, order in orders.items()) + ", were put in x,y,z order"
    else:
        reordered = ""
    warnings.warn(
        f"read {acc_path.name} and {gyro_path.name} as {app}'s accelerometer ({au}) and gyroscope ({gu}) "
        f"files, each with its own time stamps{reordered}", ImucalibWarning, stacklevel=3)
    meta: dict = {"source": [str(acc_path), str(gyro_path)], "app": app, "time_unit": unit,
                  "t0": float(base), "time_relative": bool(base)}
    return Recording.from_streams(times["acc"], acc, times["gyro"], gyro,
                                  acc_unit=au, gyro_unit=gu, metadata=meta)


# ----------------------------------------------------------------- MATLAB
def _read_mat(path: Path, columns, acc_unit, gyro_unit, rate, variable, time_unit) -> Recording:
    from scipy.io import loadmat  # scipy.io costs 233 ms at start-up

    with path.open("rb") as f:
        head = f.read(128)
    if head.startswith(b"MATLAB 7.3 MAT-file") or b"HDF5" in head[:128]:
        raise ReaderError(f"{path}: a MATLAB v7.3 file (HDF5 inside), which imucalib does not read; in MATLAB "
                          f"save the matrix again with save('{path.name}', 'VARIABLE', '-v7'), or write it "
                          "as CSV with writematrix")
    expansion.check_mat(path)  # compressed variables that expand past their budget: refused before scipy
    try:
        content = loadmat(str(path))
    except Exception as exc:  # scipy raises several types for non-MAT input
        raise ReaderError(f"{path}: not a readable MATLAB file ({exc}); for imu_tk's text "
                          "files use --reader imutk") from None
    found = {k: v for k, v in content.items() if not k.startswith("__")}
    if variable is None:
        cands = [k for k, v in found.items()
                 if isinstance(v, np.ndarray) and v.ndim == 2 and v.dtype.kind in "fiu"
                 and v.shape[1] >= 7]
        if not cands:  # an accelerometer-only matrix: 3 or 4 columns beside a magnetometer or temperature
            cands = [k for k, v in found.items()
                     if isinstance(v, np.ndarray) and v.ndim == 2 and v.dtype.kind in "fiu"
                     and min(v.shape) in (3, 4) and max(v.shape) > 4 and not _MAT_MAG.match(k)]
        assembled = assemble_mat(path, found) if len(cands) != 1 else None
        if assembled is not None:  # each sensor a variable (or a struct's field) of its own
            variable, matrix, taken = assembled
            found = {**{k: v for k, v in found.items() if k not in taken}, variable: matrix}
            if matrix.shape[1] == 6 and columns is None:
                columns = ["-", *map(str, range(6))]
        elif len(cands) != 1:
            raise ReaderError(f"{path}: pass --variable NAME; variables present: "
                              f"{', '.join(found) or 'none'}")
        else:
            variable = cands[0]
    if variable not in found:
        raise ReaderError(f"{path}: no variable {variable!r}; variables present: "
                          f"{', '.join(found) or 'none'}")
    m = np.asarray(found[variable])
    if m.ndim != 2 or m.dtype.kind not in "fiu":
        raise ReaderError(f"{path}: variable {variable!r} must be a numeric matrix; got shape "
                          f"{m.shape} of {m.dtype}")
    m = m.astype(np.float64)
    if m.shape[1] < 6 and m.shape[0] >= 6 and m.shape[1] not in (3, 4):
        m = m.T
    elif m.shape[0] in (3, 4) and m.shape[1] > m.shape[0]:  # an accelerometer-only matrix stored as rows
        m = m.T
    names = [str(j) for j in range(m.shape[1])]
    if columns is None:
        if m.shape[1] < 7:
            raise ReaderError(f"{path}: variable {variable!r} has {m.shape[1]} columns; pass "
                              "--columns (use '-' for t with --rate when there is no time; 4 entries "
                              "t,ax,ay,az for an accelerometer-only log)")
        columns = [str(j) for j in range(10 if m.shape[1] == 10 else 7)]
        if m.shape[1] == 10:  # t, accelerometer, gyroscope, magnetometer: the 9-axis layout loggers write
            warnings.warn(f"{path}: variable {variable!r} has 10 columns: taken as t,ax,ay,az,gx,gy,gz,mx,my,mz "
                          "(pass --columns to say otherwise)", ImucalibWarning, stacklevel=3)
    mapping = _map_columns(path, names, columns, True)
    bad = ~np.isfinite(m[:, [j for j in mapping.values() if j is not None]])
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ReaderError(f"{path}: variable {variable!r}, row {i + 1}: a NaN or inf value; "
                          "fix the data (imucalib never skips rows)")
    meta: dict = {"variable": variable}
    if mapping["t"] is None:
        if rate is None:
            raise ReaderError(f"{path}: no time column; pass --rate HZ")
        t = np.arange(m.shape[0]) / rate
    else:
        if rate is not None:
            raise ReaderError(f"{path}: a time column and --rate were given; pass only one")
        raw_t = m[:, mapping["t"]]
        _check_time(path, raw_t, 1, "time (row)")
        t = to_seconds(raw_t, time_unit or _infer_time_unit(raw_t, path, f"column {mapping['t']}"), meta)
    extra, temperature = _mat_others(path, found, variable, m, mapping)
    named, named_temp = packets.mapped_others(mapping, names, {j: m[:, j] for j in range(m.shape[1])}, meta)
    extra.update(named)
    temperature = named_temp if named_temp is not None else temperature
    return Recording(
        t=t, acc=m[:, [mapping["ax"], mapping["ay"], mapping["az"]]],
        gyro=None if mapping["gx"] is None else m[:, [mapping["gx"], mapping["gy"], mapping["gz"]]],
        acc_unit=acc_unit or "counts", gyro_unit=gyro_unit or "counts", metadata=meta,
        extra=extra, temperature=temperature,
    )


_MAT_MAG = re.compile(r"^(?:m|mag|magn|magnetometer|magneticfield|magnetic_field|compass)$", re.I)
_MAT_TEMP = re.compile(r"^(?:temp|temperature|t_?deg|thermometer)(?:_?c)?$", re.I)


def _mat_others(path: Path, found: dict, variable: str, m: np.ndarray, mapping: dict):
    """A MATLAB file's other data: a magnetometer or temperature variable used, the rest named in a note.

    A variable named like a magnetometer (``mag``, ``magnetometer`` …) with 3 columns and the matrix's rows
    becomes the extra columns ``mag_x``, ``mag_y``, ``mag_z`` (which :mod:`.magnetometer` takes as the
    recording's magnetometer); one named like a temperature (``temp``, ``temperature``) with one column the
    temperature [°C]. The matrix's columns no field reads, and the variables left unused, are named in an
    :class:`ImucalibWarning`: a matrix names no columns, so its extra columns cannot be told apart.
    """
    n = m.shape[0]
    extra: dict[str, np.ndarray] = {}
    temperature = None
    unused = []
    for name, value in found.items():
        if name == variable:
            continue
        arr = np.asarray(value) if isinstance(value, np.ndarray) else None
        if arr is None or arr.dtype.kind not in "fiu" or arr.size == 0:
            unused.append(name)
            continue
        arr = arr.astype(np.float64)
        if arr.ndim == 2 and arr.shape[0] != n and arr.shape[1] == n:
            arr = arr.T
        if _MAT_MAG.match(name) and arr.shape == (n, 3) and np.all(np.isfinite(arr)):
            extra.update({f"mag_{a}": arr[:, i] for i, a in enumerate("xyz")})
        elif _MAT_TEMP.match(name) and arr.reshape(-1).shape == (n,) and temperature is None:
            temperature = arr.reshape(-1)
            extra[name] = temperature
        else:
            unused.append(name)
    used = {j for j in mapping.values() if j is not None}
    spare = [j for j in range(m.shape[1]) if j not in used]
    parts = []
    if spare:
        parts.append(f"column{'s' if len(spare) > 1 else ''} {', '.join(str(j) for j in spare)} (0-based) of "
                     f"{variable!r}, which name{'s' if len(spare) == 1 else ''} no field (a matrix has no header: a "
                     "magnetometer or temperature kept as a variable of its own, 'mag' (N x 3) or 'temperature' "
                     "(N x 1), is used)")
    if unused:
        parts.append(f"the variable{'s' if len(unused) > 1 else ''} {', '.join(map(repr, unused))}")
    if parts:
        warnings.warn(f"{path}: not used: {'; and '.join(parts)}", ImucalibWarning, stacklevel=4)
    return extra, temperature
