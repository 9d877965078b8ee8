"""The simulated-session directory format, the part below the calibration record: ``session.json`` checked,
the session's recordings and tables read and written.

A session directory (``imucalib simulate -o DIR``) holds ``session.json`` (the index: scenario, units,
files and their segments), the recordings as CSV files and the truth (``truth.json``, a calibration file).
This module reads and writes all but the truth; the session records and the truth are
:mod:`imucalib.sessions`.

``session.json`` is checked entry by entry: every fault is a :class:`SessionFileError` (a ValueError)
naming the file and the entry or line, never a KeyError or numpy's own text.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..recording import ACC_UNITS, GYRO_UNITS, Interval, Recording
from .atomic import atomic_write
from .jsontext import JsonTextError, dumps, loads

__all__ = ["SessionFileError", "is_session_directory", "load_meta", "read_recording", "read_table", "segments",
           "write_meta", "write_recording", "write_table"]


class SessionFileError(ValueError):
    """A simulated session directory that cannot be read; the message names the file and entry.

    Examples
    --------
    >>> import tempfile
    >>> from imucalib.io.sessionfiles import SessionFileError, load_meta
    >>> from pathlib import Path
    >>> try:
    ...     load_meta(Path(tempfile.mkdtemp()))
    ... except SessionFileError as exc:
    ...     print(exc)
    /...: not a simulated session directory (no session.json)
    """


def _kind(value) -> str:
    if value is None:
        return "null"
    return {dict: "an object", list: "a list", str: "a string", bool: "true/false", int: "a number",
            float: "a number"}.get(type(value), type(value).__name__)


def load_meta(directory: Path) -> dict:
    """``session.json`` of ``directory``, checked: its format, scenario, units and files."""
    path = directory / "session.json"
    if not path.is_file():
        raise SessionFileError(f"{directory}: not a simulated session directory (no session.json)")
    try:
        meta = loads(path.read_bytes().decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise SessionFileError(f"{path}: not a text file") from None
    except json.JSONDecodeError as exc:
        raise SessionFileError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})") \
            from None
    except JsonTextError as exc:
        raise SessionFileError(f"{path}: not a session file: {exc}") from None
    if not isinstance(meta, dict):
        raise SessionFileError(f"{path}: expected a JSON object; got {_kind(meta)}")
    if meta.get("format") != "imucalib.session":
        raise SessionFileError(f"{path}: not an imucalib session file ('format' is "
                               f"{json.dumps(meta.get('format'))}, not \"imucalib.session\")")
    if not isinstance(meta.get("scenario"), str):
        raise SessionFileError(f"{path}: 'scenario': expected a string; got {_kind(meta.get('scenario'))}")
    files = meta.get("files")
    if not isinstance(files, dict):
        raise SessionFileError(f"{path}: 'files': expected an object naming the session's files; "
                               f"got {_kind(files)}")
    for name in files:
        if not (directory / name).is_file():
            raise SessionFileError(f"{path}: 'files' names {name}, which is not in {directory}")
    if meta["scenario"] == "wang2019":
        for name in ("positions.csv", "turns.csv"):
            if name not in files:
                raise SessionFileError(f"{path}: 'files' lacks {name}, which a wang2019 session has")
        return meta
    units = meta.get("units")
    if not isinstance(units, dict):
        raise SessionFileError(f"{path}: 'units': expected an object {{\"accelerometer\": …, \"gyroscope\": …}}; "
                               f"got {_kind(units)}" if units is not None else
                               f"{path}: lacks 'units' (the raw units of the recordings)")
    for sensor, allowed in (("accelerometer", ACC_UNITS), ("gyroscope", GYRO_UNITS)):
        if units.get(sensor) not in allowed:
            raise SessionFileError(f"{path}: 'units.{sensor}': expected one of {', '.join(allowed)}; got "
                                   f"{json.dumps(units.get(sensor))}")
    if "recording.csv" not in files:
        raise SessionFileError(f"{path}: 'files' lacks recording.csv, the session's main recording")
    for name, value in files.items():
        segments(path, name, value)
    return meta


def segments(path: Path, name: str, value) -> list[Interval]:
    """The intervals listed for file ``name`` in ``session.json`` (``path``), checked."""
    where = f"{path}: 'files.{name}'"
    if not isinstance(value, list):
        raise SessionFileError(f"{where}: expected a list of segments; got {_kind(value)}")
    out = []
    for k, s in enumerate(value):
        ok = (isinstance(s, dict) and all(type(s.get(key)) is int for key in ("start", "stop"))
              and isinstance(s.get("kind", "static"), str))
        if not ok or not 0 <= s["start"] < s["stop"]:
            raise SessionFileError(f"{where}, segment {k + 1}: expected {{\"start\": i, \"stop\": j, \"kind\": …}} "
                                   f"with 0 <= i < j; got {json.dumps(s)[:80]}")
        out.append(Interval(s["start"], s["stop"], s.get("kind", "static")))
    return out


def read_table(path: Path, ncols: int) -> np.ndarray:
    """A comma-separated table of ``ncols`` finite numbers a row after one header line."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError:
        raise SessionFileError(f"{path}: not a text file") from None
    rows = []
    for i, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        if len(cells) != ncols:
            raise SessionFileError(f"{path}: line {i}: expected {ncols} values, found {len(cells)}")
        try:
            row = [float(c) for c in cells]
        except ValueError:
            raise SessionFileError(f"{path}: line {i}: a value is not a number") from None
        if not all(np.isfinite(row)):
            raise SessionFileError(f"{path}: line {i}: a value is not finite (NaN or inf)")
        rows.append(row)
    if not rows:
        raise SessionFileError(f"{path}: no rows after the header")
    return np.array(rows, dtype=np.float64)


def read_recording(path: Path, units: dict, intervals: list[Interval]) -> Recording:
    """One recording of the session (``t,ax,ay,az,gx,gy,gz`` in the session's units), its segments checked."""
    from .magnetometer import attach_magnetometer  # imucalib.io.magnetometer costs 108 ms at start-up
    from .readers import read  # imucalib.io.readers costs 174 ms at start-up

    rec = read(path, reader="csv", columns=["t", "ax", "ay", "az", "gx", "gy", "gz"],
               acc_unit=units["accelerometer"], gyro_unit=units["gyroscope"], time_unit="s")
    for iv in intervals:
        if iv.stop > len(rec):
            raise SessionFileError(f"{path}: session.json gives it a segment up to sample {iv.stop}, but it has "
                                   f"{len(rec)} samples")
    rec = attach_magnetometer(rec, units.get("magnetometer") if "mx" in rec.extra else None)
    return Recording(rec.t, rec.acc, rec.gyro, acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit,
                     metadata={"source": [str(path)]}, temperature=rec.temperature, mag=rec.mag,
                     mag_unit=rec.mag_unit)


# ------------------------------------------------------------------ writing
def write_table(path: Path, data: np.ndarray, header: str) -> None:
    """A CSV of numbers at full precision, through a temporary file moved into place."""
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        np.savetxt(fh, data, delimiter=",", fmt="%.17g", header=header, comments="")


def write_meta(path: Path, meta: dict) -> None:
    """``session.json``, written last: a session is complete when it is there."""
    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write(dumps(meta, indent=1) + "\n")


def write_recording(path: Path, rec: Recording) -> None:
    cols, names = [rec.t, rec.acc, rec.gyro], "t,ax,ay,az,gx,gy,gz"
    if rec.mag is not None:
        cols.append(rec.mag)
        names += ",mx,my,mz"
    if rec.temperature is not None:
        cols.append(rec.temperature)
        names += ",temperature"
    write_table(path, np.column_stack(cols), names)


def is_session_directory(paths: Sequence[str | Path], reader: str | None = None) -> bool:
    """True when ``paths`` name a simulated session directory (``imucalib simulate -o DIR``).

    ``reader="session"`` says so; without a reader, one directory that is not a ROS 2 bag is taken
    for a session.
    """
    if reader == "session":
        return True
    if reader is not None or len(paths) != 1 or not Path(paths[0]).is_dir():
        return False
    from .rosbag import is_rosbag  # a directory: perhaps a ROS 2 bag

    return not is_rosbag(Path(paths[0]))
