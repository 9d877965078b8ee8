"""Readers: generic CSV, imu_tk's two-file text format, MATLAB ``.mat``, ROS bags (:mod:`.rosbag`).

Every reader returns a :class:`~imucalib.recording.Recording` and reports bad
input with a :class:`ReaderError` naming the file, the line (1-based, as an
editor shows it) and the column, and saying how to fix it. Nothing is silently
dropped: a bad row is an error, never skipped.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..recording import ACC_UNITS, GYRO_UNITS, ImucalibWarning, Recording
from .errors import ReaderError
from .rosbag import is_rosbag, read_rosbag

__all__ = ["READERS", "ReaderError", "read", "guess_reader"]

READERS = ("csv", "imutk", "mat", "rosbag")
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
FIELDS = ("t", "ax", "ay", "az", "gx", "gy", "gz")


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
) -> Recording:
    """Read a recording.

    Parameters
    ----------
    paths : path or sequence of paths
        One CSV or MAT file, two imu_tk files (accelerometer, then gyroscope),
        or one ROS bag (a ROS 1 ``.bag``, a ROS 2 bag directory, an ``.mcap``).
    reader : {"csv", "imutk", "mat", "rosbag"}, optional
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
    """
    if isinstance(paths, str | Path):
        paths = [paths]
    paths = [Path(p) for p in paths]
    if not paths:
        raise ReaderError("no data file given")
    for p in paths:
        if not p.exists():
            raise ReaderError(f"{p}: file not found")
        if p.is_dir() and not is_rosbag(p):
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
    expected = 2 if reader == "imutk" else 1
    if len(paths) != expected:
        what = ("two files: the accelerometer file, then the gyroscope file" if expected == 2
                else "one file")
        raise ReaderError(f"the {reader} reader takes {what}; got {len(paths)}")
    if reader == "rosbag":
        ignored = [name for name, v in (("columns", columns), ("acc_unit", acc_unit), ("gyro_unit", gyro_unit),
                                        ("rate", rate), ("variable", variable), ("time_unit", time_unit))
                   if v is not None]
        if ignored:
            raise ReaderError(f"a ROS bag's sensor_msgs/Imu fixes the fields, units and time; "
                              f"{', '.join(ignored)} cannot be set")
        rec = read_rosbag(paths[0], topic=topic)
    elif topic is not None:
        raise ReaderError(f"topic applies to ROS bags; the {reader} reader has none")
    elif reader == "imutk":
        rec = _read_imutk(paths[0], paths[1], acc_unit, gyro_unit, time_unit)
    elif reader == "mat":
        rec = _read_mat(paths[0], columns, acc_unit, gyro_unit, rate, variable, time_unit)
    else:
        rec = _read_csv(paths[0], columns, acc_unit, gyro_unit, rate, time_unit)
    rec.metadata.setdefault("source", [str(p) for p in paths])
    rec.metadata["reader"] = reader
    return rec


def guess_reader(paths: Sequence[Path]) -> str:
    """``"rosbag"`` for ROS bags, ``"mat"`` for MATLAB files, ``"imutk"`` for two files, else ``"csv"``."""
    if is_rosbag(paths[0]):
        return "rosbag"
    head = paths[0].open("rb").read(128)
    if head.startswith(b"MATLAB") or (head[:4] in (b"\x00\x00\x00\x00",) and paths[0].suffix == ".mat"):
        return "mat"
    if len(paths) == 2:
        return "imutk"
    return "csv"


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


def _check_time(path: Path, t: np.ndarray, first_line: int, name: str = "time") -> None:
    d = np.diff(t)
    bad = np.nonzero(d <= 0)[0]
    if bad.size:
        i = int(bad[0])
        what = "duplicated" if d[i] == 0 else "goes backwards"
        raise ReaderError(
            f"{path}: line {first_line + i + 1}, {name}: timestamp {what} "
            f"({t[i]!r} then {t[i + 1]!r}); timestamps must increase strictly "
            "(sort the file or remove duplicated rows)"
        )


def _infer_time_unit(t: np.ndarray) -> str:
    """Unit of a time column from its median step, assuming 1 Hz … 100 kHz sampling.

    A median step above 1e4 means nanoseconds (≥ 10 µs in ns), above 10
    microseconds, above 0.5 milliseconds, else seconds.
    """
    if t.size < 2:
        return "s"
    step = float(np.median(np.diff(t)))
    if step > 1e4:
        return "ns"
    if step > 10:
        return "us"
    if step > 0.5:
        return "ms"
    return "s"


def _to_seconds(t: np.ndarray, unit: str, metadata: dict) -> np.ndarray:
    metadata["time_unit"] = unit
    metadata["t0"] = float(t[0])
    scale = TIME_UNITS[unit]
    seconds = t * scale
    # epoch-like stamps lose precision as float seconds: keep them relative to the start
    if abs(seconds[0]) > 1e6:
        seconds = (t - t[0]) * scale
        metadata["time_relative"] = True
    return seconds


# ------------------------------------------------------------------ imu_tk
def _read_imutk(acc_path: Path, gyro_path: Path, acc_unit, gyro_unit, time_unit) -> Recording:
    arrays = []
    for path in (acc_path, gyro_path):
        text = path.read_text(encoding="utf-8", errors="replace")
        arrays.append(_numeric_table(path, text, 4, ("time", "x", "y", "z")))
    acc, gyro = arrays
    meta: dict = {"source": [str(acc_path), str(gyro_path)]}
    unit = time_unit or "s"
    t_acc = _to_seconds(acc[:, 0], unit, meta)
    t_gyro = (gyro[:, 0] - acc[0, 0]) * TIME_UNITS[unit] if meta.get("time_relative") \
        else gyro[:, 0] * TIME_UNITS[unit]
    return Recording.from_streams(
        t_acc, acc[:, 1:], t_gyro, gyro[:, 1:],
        acc_unit=acc_unit or "counts", gyro_unit=gyro_unit or "counts", metadata=meta,
    )


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
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # fromstring warns on trailing garbage
            flat = np.fromstring(stripped, dtype=np.float64, sep=" ")
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
    _check_time(path, data[:, 0], 1)
    return data


# --------------------------------------------------------------------- CSV
_AXIS = r"[_\s\.\-]?\(?([xyz])\)?"
_PATTERNS = {
    "acc": re.compile(r"^(?:a|acc|accel|accelerometer|acceleration|linear_acceleration|"
                      r"a_rs_s|lin_acc)" + _AXIS + r"(?:$|[_\s\[\(])", re.I),
    "gyro": re.compile(r"^(?:g|gyr|gyro|gyroscope|w|omega|angular_velocity|rot|rate|"
                       r"w_rs_s)" + _AXIS + r"(?:$|[_\s\[\(])", re.I),
}
_TIME = re.compile(r"^#?\s*(?:t|time|timestamp|stamp|time_stamp)(?:$|[_\s\[\(])", re.I)
_TEMP = re.compile(r"^(?:temp|temperature)(?:$|[_\s\[\(])", re.I)


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
    for sep in (",", ";", "\t"):
        if sep in line:
            return sep
    return None  # whitespace


def _read_csv(path: Path, columns, acc_unit, gyro_unit, rate, time_unit) -> Recording:
    text = path.read_text(encoding="utf-8-sig", errors="replace")
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise ReaderError(f"{path}: empty file")
    sep = _sniff_separator(lines[0])

    def split(line):
        return [c.strip() for c in (line.split(sep) if sep else line.split())]

    first = split(lines[0])
    has_header = any(_not_number(c) for c in first)
    header = first if has_header else None
    body = lines[1:] if has_header else lines
    first_line = 2 if has_header else 1
    if not body:
        raise ReaderError(f"{path}: no data rows after the header")
    blank = [i for i, ln in enumerate(body) if not ln.strip()]
    if blank:
        raise ReaderError(f"{path}: line {first_line + blank[0]} is empty; remove blank lines")
    ncols = len(header) if header else len(split(body[0]))
    names = header or [f"column {j + 1}" for j in range(ncols)]
    mapping = _map_columns(path, names, columns, has_header)
    numeric_cols = sorted({j for j in mapping.values() if j is not None})
    # parse all columns that are numbers; others are kept as text
    cells = None
    try:
        data = _parse_block(path, body, first_line, ncols, sep, names)
    except ReaderError as exc:
        # a text column elsewhere is fine; the mapped ones must be numeric
        rows = [split(ln) for ln in body]
        for i, r in enumerate(rows):
            if len(r) != ncols:
                raise ReaderError(
                    f"{path}: line {first_line + i}: expected {ncols} values, found {len(r)}; "
                    "every row needs the same columns"
                ) from None
        cells = np.array(rows, dtype=object)
        data = np.full((len(rows), ncols), np.nan)
        for j in range(ncols):
            try:
                data[:, j] = cells[:, j].astype(np.float64)
            except ValueError:
                if j in numeric_cols:
                    raise exc from None
                continue
            if j in numeric_cols and not np.all(np.isfinite(data[:, j])):
                raise exc from None
    meta: dict = {"columns": {f: (names[j] if j is not None else None) for f, j in mapping.items()},
                  "column_names": list(names), "header": has_header, "separator": sep or " "}
    tcol = mapping["t"]
    if tcol is None:
        if rate is None:
            raise ReaderError(f"{path}: no time column found; pass --rate HZ (the sampling rate)")
        t = np.arange(len(body)) / rate
        meta["time_unit"] = None
    else:
        if rate is not None:
            raise ReaderError(
                f"{path}: the file has a time column ({names[tcol]!r}) and --rate was given; "
                "pass only one (use --columns with '-' for t to ignore the time column)"
            )
        raw_t = data[:, tcol]
        if np.max(np.abs(raw_t)) >= 2.0**53:
            # integer stamps (e.g. ns since the epoch) exceed float precision: parse exactly
            try:
                ints = np.array([split(ln)[tcol] for ln in body], dtype=np.int64)
                raw_t = (ints - ints[0]).astype(np.float64)
                offset = float(ints[0])
            except (ValueError, OverflowError):
                offset = 0.0
        else:
            offset = 0.0
        _check_time(path, raw_t, first_line, names[tcol])
        unit = time_unit or _unit_in(names[tcol]) if has_header else time_unit
        if unit not in TIME_UNITS:
            unit = time_unit or _infer_time_unit(raw_t)
        t = _to_seconds(raw_t, unit, meta)
        if offset:
            meta["t0"] = offset
            meta["time_relative"] = True
    acc = data[:, [mapping["ax"], mapping["ay"], mapping["az"]]]
    gyro = data[:, [mapping["gx"], mapping["gy"], mapping["gz"]]]
    au = acc_unit or (_unit_in(names[mapping["ax"]]) if has_header else None) or "counts"
    gu = gyro_unit or (_unit_in(names[mapping["gx"]]) if has_header else None) or "counts"
    if au not in ACC_UNITS:
        au = "counts"
    if gu not in GYRO_UNITS:
        gu = "counts"
    used = {j for j in mapping.values() if j is not None}
    temperature = None
    extra = {}
    for j, name in enumerate(names):
        if j in used:
            continue
        col = data[:, j] if (cells is None or np.all(np.isfinite(data[:, j]))) else cells[:, j]
        if temperature is None and has_header and _TEMP.match(name) and col.dtype != object:
            temperature = col
            meta["temperature_column"] = name
        extra[name] = col
    return Recording(t=t, acc=acc, gyro=gyro, acc_unit=au, gyro_unit=gu, temperature=temperature,
                     extra=extra, metadata=meta)


def _not_number(cell: str) -> bool:
    try:
        float(cell)
        return False
    except ValueError:
        return True


def _map_columns(path: Path, names: list[str], columns, has_header: bool) -> dict:
    """Column index of each of t, ax…gz (None for a missing time column)."""
    if columns is not None:
        columns = [c.strip() for c in columns]
        if len(columns) != 7:
            raise ReaderError(
                f"--columns needs 7 entries in the order {','.join(FIELDS)}; got {len(columns)}"
            )
        out = {}
        lower = [n.lower() for n in names]
        for field, c in zip(FIELDS, columns, strict=True):
            if c == "-" and field == "t":
                out[field] = None
            elif c.isdigit():
                j = int(c)
                if j >= len(names):
                    raise ReaderError(f"{path}: --columns {field}={c}: the file has only "
                                      f"{len(names)} columns (0-based indices)")
                out[field] = j
            elif c.lower() in lower:
                out[field] = lower.index(c.lower())
            else:
                raise ReaderError(f"{path}: --columns {field}={c!r}: no such column; the "
                                  f"columns are {', '.join(names)}")
        return out
    if not has_header:
        if len(names) == 7:
            warnings.warn(f"{path}: no header: the columns were taken as "
                          f"{','.join(FIELDS)} (pass --columns to say otherwise)",
                          ImucalibWarning, stacklevel=4)
            return dict(zip(FIELDS, range(7), strict=True))
        raise ReaderError(f"{path}: no header and {len(names)} columns: pass --columns with 7 "
                          f"0-based indices in the order {','.join(FIELDS)}")
    out: dict = {"t": None}
    for j, name in enumerate(names):
        if out["t"] is None and _TIME.match(name):
            out["t"] = j
            continue
        for kind, pat in _PATTERNS.items():
            m = pat.match(name)
            if m:
                key = ("a" if kind == "acc" else "g") + m.group(1).lower()
                out.setdefault(key, j)
    missing = [f for f in FIELDS[1:] if f not in out]
    if missing:
        raise ReaderError(
            f"{path}: missing columns {', '.join(missing)} (found {', '.join(names)}); pass "
            f"--columns with the names in the order {','.join(FIELDS)}"
        )
    return out


# ----------------------------------------------------------------- MATLAB
def _read_mat(path: Path, columns, acc_unit, gyro_unit, rate, variable, time_unit) -> Recording:
    from scipy.io import loadmat

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
        if len(cands) != 1:
            raise ReaderError(f"{path}: pass --variable NAME; variables present: "
                              f"{', '.join(found) or 'none'}")
        variable = cands[0]
    if variable not in found:
        raise ReaderError(f"{path}: no variable {variable!r}; variables present: "
                          f"{', '.join(found) or 'none'}")
    m = np.asarray(found[variable])
    if m.ndim != 2 or m.dtype.kind not in "fiu":
        raise ReaderError(f"{path}: variable {variable!r} must be a numeric matrix; got shape "
                          f"{m.shape} of {m.dtype}")
    m = m.astype(np.float64)
    if m.shape[1] < 6 and m.shape[0] >= 6:
        m = m.T
    names = [str(j) for j in range(m.shape[1])]
    if columns is None:
        if m.shape[1] < 7:
            raise ReaderError(f"{path}: variable {variable!r} has {m.shape[1]} columns; pass "
                              "--columns (use '-' for t with --rate when there is no time)")
        columns = [str(j) for j in range(7)]
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
        t = _to_seconds(raw_t, time_unit or _infer_time_unit(raw_t), meta)
    return Recording(
        t=t, acc=m[:, [mapping["ax"], mapping["ay"], mapping["az"]]],
        gyro=m[:, [mapping["gx"], mapping["gy"], mapping["gz"]]],
        acc_unit=acc_unit or "counts", gyro_unit=gyro_unit or "counts", metadata=meta,
    )
