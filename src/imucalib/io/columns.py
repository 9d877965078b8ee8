"""Which column of a table is which: ``--columns``, the header's names, the width of a table without one.

``--columns`` is given in one of two forms (:func:`parse_columns`):

* positional, the entries in the order ``t,ax,ay,az,gx,gy,gz`` (7), ``t,ax,ay,az`` (4: an accelerometer-only
  log), ``t,ax,ay,az,gx,gy,gz,mx,my,mz`` (10: with a magnetometer) or the 10 and ``temp`` (11);
* by keyword, ``t=Time,ax=scaledAccelX,…,mx=scaledMagX,…,temp=Temp``, in any order: a field not named is
  absent (``t`` too: then ``--rate`` gives the time).

Each entry is a column's name (as the header writes it, any case), its 0-based index, or ``-`` for an absent
column (the time, the gyroscope, the magnetometer or the temperature; never the accelerometer). The same
form serves CSV files, DataFrames and MATLAB matrices (whose columns are their indices).

Without ``--columns``, a header's names are recognised (:data:`PATTERNS`, :data:`TIME`, :data:`TEMP`), a
column counting samples (``n_samples``, ``sample``, ``index``: :data:`COUNTER`) is taken for what it is, and
a table without a header is read by its width.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Sequence
from pathlib import Path

from ..recording import ImucalibWarning
from .errors import ReaderError

__all__ = ["ALL_FIELDS", "COUNTER", "FIELDS", "OPTIONAL", "PATTERNS", "TEMP", "TIME", "map_columns", "not_number",
           "parse_columns"]

#: the fields of the positional form, in its order
FIELDS = ("t", "ax", "ay", "az", "gx", "gy", "gz")
#: the fields a table may also give: the magnetometer's axes and the temperature
OPTIONAL = ("mx", "my", "mz", "temp")
ALL_FIELDS = FIELDS + OPTIONAL

_AXIS = r"[_\s\.\-]?\(?([xyz])\)?"
#: header names of the accelerometer's and the gyroscope's axes
PATTERNS = {
    "acc": re.compile(r"^(?:a|acc|accel|accelerometer|acceleration|linear_acceleration|"
                      r"a_rs_s|lin_acc)" + _AXIS + r"(?:$|[_\s\[\(])", re.I),
    "gyro": re.compile(r"^(?:g|gyr|gyro|gyroscope|w|omega|angular_velocity|rot|rate|"
                       r"w_rs_s)" + _AXIS + r"(?:$|[_\s\[\(])", re.I),
}
TIME = re.compile(r"^#?\s*(?:t|time|timestamp|stamp|time_stamp)(?:$|[_\s\[\(])", re.I)
TEMP = re.compile(r"^(?:temp|temperature)(?:$|[_\s\[\(])", re.I)
#: a column that counts samples (not a time, not a reading): imucal's ``n_samples``, a pandas index
COUNTER = re.compile(r"^(?:n_?samples?|samples?|sample_?(?:index|number|nr|no|count)|index|idx|counter|"
                     r"sample_?counter|unnamed:\s*0)$", re.I)


def not_number(cell: str) -> bool:
    """Whether ``cell`` is not a number ``float`` reads."""
    try:
        float(cell)
        return False
    except ValueError:
        return True


def parse_columns(columns: Sequence[str]) -> dict[str, str | None]:
    """``--columns``' entries (either form) as ``{field: entry or None}`` over :data:`ALL_FIELDS`, checked.

    Raises a :class:`ReaderError` saying what is wrong: a mix of the two forms, an unknown or repeated
    keyword, a count of positional entries other than 4, 7, 10 or 11, a missing accelerometer axis, a
    gyroscope or magnetometer given in part.
    """
    entries = [c.strip() for c in columns]
    keyed = ["=" in c for c in entries]
    out: dict[str, str | None] = dict.fromkeys(ALL_FIELDS)
    if any(keyed):
        if not all(keyed):
            raise ReaderError("--columns: give every entry as FIELD=COLUMN (t=Time,ax=AccX,…) or none (the "
                              f"positional form {','.join(FIELDS)}); got {','.join(entries)}")
        for c in entries:
            key, value = (s.strip() for s in c.split("=", 1))
            if key.lower() not in ALL_FIELDS:
                raise ReaderError(f"--columns: unknown field {key!r}; the fields are {', '.join(ALL_FIELDS)}")
            if out[key.lower()] is not None:
                raise ReaderError(f"--columns: {key} is given twice")
            out[key.lower()] = None if value in ("", "-") else value
    else:
        if len(entries) not in (4, 7, 10, 11):
            raise ReaderError(
                f"--columns needs 7 entries in the order {','.join(FIELDS)} (or 4, {','.join(FIELDS[:4])}, for an "
                f"accelerometer-only log; 10 with mx,my,mz; 11 with temp), or FIELD=COLUMN entries; got "
                f"{len(entries)}")
        for field, c in zip(ALL_FIELDS, entries, strict=False):
            out[field] = None if c == "-" else c
    absent_acc = [f for f in ("ax", "ay", "az") if out[f] is None]
    if absent_acc:
        raise ReaderError(f"--columns: the accelerometer's columns are needed ('-' or nothing given for "
                          f"{', '.join(absent_acc)}); '-' stands for an absent time column, gyroscope, magnetometer "
                          "or temperature")
    for sensor, axes in (("gyroscope", ("gx", "gy", "gz")), ("magnetometer", ("mx", "my", "mz"))):
        if 0 < sum(out[f] is None for f in axes) < 3:
            raise ReaderError(f"--columns: give all three {sensor} columns ({', '.join(axes)}), or none")
    return out


def _resolve(path: Path, names: Sequence[str], spec: dict[str, str | None]) -> dict[str, int | None]:
    lower = [n.lower() for n in names]
    out: dict[str, int | None] = {}
    for field, c in spec.items():
        if c is None:
            out[field] = None
        elif c.isdigit():
            j = int(c)
            if j >= len(names):
                raise ReaderError(f"{path}: --columns {field}={c}: the file has only {len(names)} columns "
                                  "(0-based indices)")
            out[field] = j
        elif c.lower() in lower:
            out[field] = lower.index(c.lower())
        else:
            raise ReaderError(f"{path}: --columns {field}={c!r}: no such column; the columns are {', '.join(names)}")
    return out


def map_columns(path: Path, names: list[str], columns, has_header: bool) -> dict[str, int | None]:
    """Column index of each field of :data:`ALL_FIELDS`, and ``"n"`` for a sample counter (None: absent).

    ``columns`` is ``--columns`` (:func:`parse_columns`). Without it, a header's names are matched
    (an accelerometer and no gyroscope is an accelerometer-only log, with a note; no time column but a
    :data:`COUNTER` column: that one counts the samples), and a file without a header is read by its width:
    7 or 6 columns with a gyroscope, 4 or 3 without (with a note).
    """
    if columns is not None:
        return {**_resolve(path, names, parse_columns(columns)), "n": None}
    none = {**dict.fromkeys(ALL_FIELDS), "n": None}
    if not has_header:
        width = len(names)
        if width in (7, 4):
            fields = FIELDS[:width]
            warnings.warn(f"{path}: no header: the columns were taken as {','.join(fields)}"
                          + (" (an accelerometer-only log)" if width == 4 else "")
                          + " (pass --columns to say otherwise)", ImucalibWarning, stacklevel=4)
            return {**none, **dict(zip(fields, range(width), strict=True))}
        if width in (6, 3):
            fields = FIELDS[1:width + 1]
            warnings.warn(f"{path}: no header and {width} columns: they were taken as {','.join(fields)}, "
                          "with no time column" + (" (an accelerometer-only log)" if width == 3 else "")
                          + " (pass --columns to say otherwise)", ImucalibWarning, stacklevel=4)
            return {**none, **dict(zip(fields, range(width), strict=True))}
        raise ReaderError(f"{path}: no header and {width} columns: pass --columns with 7 "
                          f"0-based indices in the order {','.join(FIELDS)} ('-' for t when there is "
                          f"no time column), or 4 ({','.join(FIELDS[:4])}) for an accelerometer-only log")
    out: dict = {"t": None}
    for j, name in enumerate(names):
        if out["t"] is None and TIME.match(name):
            out["t"] = j
            continue
        for kind, pat in PATTERNS.items():
            m = pat.match(name)
            if m:
                key = ("a" if kind == "acc" else "g") + m.group(1).lower()
                out.setdefault(key, j)
    if out["t"] is None:
        out["n"] = next((j for j, name in enumerate(names) if COUNTER.match(name.strip())), None)
    for key, j in out.items():
        twice = [k for k, name in enumerate(names) if j is not None and name.strip() == names[j].strip()]
        if len(twice) > 1:
            warnings.warn(f"{path}: the header names {names[j].strip()!r} {len(twice)} times (columns "
                          f"{', '.join(str(k) for k in twice)}, 0-based): the first is taken as {key}; say which "
                          f"with --columns (by index, e.g. {key}={twice[-1]})", ImucalibWarning, stacklevel=4)
    missing = [f for f in FIELDS[1:] if f not in out]
    if missing == ["gx", "gy", "gz"]:
        warnings.warn(f"{path}: no gyroscope columns (found {', '.join(names)}): read as an accelerometer-only log",
                      ImucalibWarning, stacklevel=4)
        return {**none, **out}
    if missing:
        raise ReaderError(
            f"{path}: missing columns {', '.join(missing)} (found {', '.join(names)}); pass --columns with the "
            f"names in the order {','.join(FIELDS)}, or by field (t=NAME,ax=NAME,…; see --help)"
        )
    return {**none, **out}
