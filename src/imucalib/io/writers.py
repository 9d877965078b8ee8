"""Writers: a recording (and its calibrated columns) as CSV."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..recording import Recording
from .atomic import atomic_write
from .readers import TIME_UNITS

__all__ = ["write_csv"]


def _original_time(rec: Recording) -> np.ndarray:
    unit = rec.metadata.get("time_unit")
    if not unit:
        return rec.t
    t = rec.t / TIME_UNITS[unit]
    if rec.metadata.get("time_relative"):
        t = t + rec.metadata["t0"]
    return t


def write_csv(
    path: str | Path,
    recording: Recording,
    calibrated_acc: np.ndarray | None = None,
    calibrated_gyro: np.ndarray | None = None,
    *,
    float_format: str = "%.10g",
) -> None:
    """Write every row and column of ``recording`` as CSV, then the calibrated columns.

    Columns keep the names and order they had in a CSV input (``metadata
    ["column_names"]``) and time keeps its original unit; otherwise the
    columns are ``t [s], ax [unit] … gz [unit]``, the temperature if there is one,
    then any extra columns. The added
    columns are ``acc_x_cal [m/s^2]`` … and ``gyro_x_cal [rad/s]`` ….

    The rows go to a temporary file next to ``path``, moved onto ``path`` only
    when all are written (:func:`imucalib.io.atomic.atomic_write`): a failed
    or interrupted write leaves an existing ``path`` as it was.
    """
    rec = recording
    n = len(rec)
    cols: dict[str, np.ndarray] = {}
    names = rec.metadata.get("column_names")
    mapping = rec.metadata.get("columns") or {}
    if names and mapping:
        by_name = {v: k for k, v in mapping.items() if v is not None}
        source = {"t": _original_time(rec), "ax": rec.acc[:, 0], "ay": rec.acc[:, 1],
                  "az": rec.acc[:, 2], "gx": rec.gyro[:, 0], "gy": rec.gyro[:, 1],
                  "gz": rec.gyro[:, 2]}
        for name in names:
            if name in by_name:
                cols[name] = source[by_name[name]]
            elif name in rec.extra:
                cols[name] = rec.extra[name]
    else:
        unit = rec.metadata.get("time_unit") or "s"
        cols[f"t [{unit}]"] = _original_time(rec)
        for i, a in enumerate("xyz"):  # the unit in the name, so that reading the file back keeps it
            cols[f"a{a} [{rec.acc_unit}]"] = rec.acc[:, i]
        for i, a in enumerate("xyz"):
            cols[f"g{a} [{rec.gyro_unit}]"] = rec.gyro[:, i]
        if rec.temperature is not None:
            cols["temperature [C]"] = rec.temperature
        for k, v in rec.extra.items():
            cols[k] = v
    if calibrated_acc is not None:
        for i, a in enumerate("xyz"):
            cols[f"acc_{a}_cal [m/s^2]"] = np.asarray(calibrated_acc)[:, i]
    if calibrated_gyro is not None:
        for i, a in enumerate("xyz"):
            cols[f"gyro_{a}_cal [rad/s]"] = np.asarray(calibrated_gyro)[:, i]
    for k, v in cols.items():
        if len(v) != n:
            raise ValueError(f"column {k!r} has {len(v)} rows; the recording has {n}")
    values, formats = [], []
    for v in cols.values():
        v = np.asarray(v)
        numeric = v.dtype.kind in "fiub"
        values.append(v.astype(np.float64) if numeric else v.astype(str))
        formats.append(float_format if numeric else "%s")
    row_format = ",".join(formats)
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(",".join(cols) + "\n")
        chunk = 100_000  # rows formatted at a time: one format per row is ~3x faster than per column
        for start in range(0, n, chunk):
            rows = zip(*(v[start : start + chunk].tolist() for v in values), strict=True)
            fh.write("\n".join(row_format % row for row in rows))
            fh.write("\n")
