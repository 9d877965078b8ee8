"""MATLAB files that keep each sensor in a variable of its own, or in the fields of a struct.

Lab scripts often save ``t``, ``acc`` and ``gyro`` (or ``imu.time``, ``imu.acc``, ``imu.gyro``; ``Acc`` and
``Gyr`` with the time in their first column) rather than one matrix of every column. :func:`assemble` finds
the accelerometer's and the gyroscope's variables by name and lays them out as the one matrix
``t, ax, ay, az, gx, gy, gz`` (``ax … gz`` without a time) the MATLAB reader takes
(:func:`imucalib.io.read`), with a note saying which variables it used. Two streams with time columns of
their own and different lengths (different rates) are put on the accelerometer's stamps
(:meth:`imucalib.Recording.from_streams`).
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from ..recording import ImucalibWarning, Recording
from .errors import ReaderError

__all__ = ["assemble"]

_ACC = re.compile(r"^(?:a|acc|accel|accelerometer|acc_?data|accelerometer_?data|accelerations?)$", re.I)
_GYRO = re.compile(r"^(?:w|gyr|gyro|gyroscope|gyr_?data|gyro_?data|omega|angular_?rates?|angular_?velocity)$",
                   re.I)
_TIME = re.compile(r"^(?:t|time|times|timestamps?|ts)$", re.I)


def _numeric(value) -> bool:
    return isinstance(value, np.ndarray) and value.dtype.kind in "fiu" and value.size > 0


def _flatten(found: dict) -> dict[str, np.ndarray]:
    """The numeric arrays of a loaded MATLAB file by name, a struct's fields as ``name.field`` (one level)."""
    out = {}
    for name, value in found.items():
        if _numeric(value):
            out[name] = value
        elif isinstance(value, np.ndarray) and value.dtype.names and value.size == 1:
            record = value.reshape(-1)[0]
            for field in value.dtype.names:
                inner = np.asarray(record[field])
                while inner.dtype == object and inner.size == 1:  # loadmat wraps a field's value in cells
                    inner = np.asarray(inner.reshape(-1)[0])
                if _numeric(inner):
                    out[f"{name}.{field}"] = inner
    return out


def _pick(flat: dict[str, np.ndarray], pattern: re.Pattern) -> list[str]:
    return [k for k in flat if pattern.match(k.rsplit(".", 1)[-1])]


def _rows(m: np.ndarray) -> np.ndarray:
    """A sensor's samples as rows: (N, 3) or (N, 4) with the time first; a matrix stored as columns transposed."""
    m = np.asarray(m, dtype=np.float64)
    if m.ndim == 2 and m.shape[0] in (3, 4) and m.shape[1] > m.shape[0]:
        m = m.T
    return m


def assemble(path: Path, found: dict) -> tuple[str, np.ndarray, set[str]] | None:
    """``(label, matrix, used)``: the sensors' variables of a MATLAB file as one ``t, acc, gyro`` matrix, with a
    note, and the file's variables it took them from; None when the file does not keep one accelerometer and one
    gyroscope variable by those names."""
    flat = _flatten(found)
    acc_names, gyro_names = _pick(flat, _ACC), _pick(flat, _GYRO)
    if len(acc_names) != 1 or len(gyro_names) != 1:
        return None
    acc, gyro = _rows(flat[acc_names[0]]), _rows(flat[gyro_names[0]])
    if acc.ndim != 2 or gyro.ndim != 2 or acc.shape[1] not in (3, 4) or gyro.shape[1] not in (3, 4):
        raise ReaderError(f"{path}: {acc_names[0]} and {gyro_names[0]} hold the accelerometer and the gyroscope, "
                          f"but as {acc.shape} and {gyro.shape} matrices: each needs 3 columns (x, y, z), or 4 "
                          "with the time first")
    times = _pick(flat, _TIME)
    t_acc = acc[:, 0] if acc.shape[1] == 4 else None
    t_gyro = gyro[:, 0] if gyro.shape[1] == 4 else None
    if t_acc is None and len(times) == 1 and np.asarray(flat[times[0]]).size == acc.shape[0]:
        t_acc = np.asarray(flat[times[0]], dtype=np.float64).reshape(-1)
    if t_gyro is None and t_acc is not None and gyro.shape[0] == acc.shape[0]:
        t_gyro = t_acc
    used = ", ".join(acc_names + gyro_names + (times if acc.shape[1] == 3 and times else []))
    acc, gyro = acc[:, -3:], gyro[:, -3:]
    if t_acc is None:
        if acc.shape[0] != gyro.shape[0]:
            raise ReaderError(f"{path}: {acc_names[0]} has {acc.shape[0]} samples and {gyro_names[0]} "
                              f"{gyro.shape[0]}, and no time column says when each was taken")
        matrix = np.column_stack([acc, gyro])  # no time: ax … gz, the rate from --rate
    elif t_gyro is None:
        raise ReaderError(f"{path}: {gyro_names[0]} has {gyro.shape[0]} samples, {acc_names[0]} "
                          f"{acc.shape[0]}, and no time column of its own")
    elif t_gyro is t_acc or (t_gyro.shape == t_acc.shape and np.array_equal(t_gyro, t_acc)):
        matrix = np.column_stack([t_acc, acc, gyro])
    else:
        try:
            rec = Recording.from_streams(t_acc, acc, t_gyro, gyro)
        except ValueError as exc:
            raise ReaderError(f"{path}: {exc}") from None
        matrix = np.column_stack([rec.t, rec.acc, rec.gyro])
    label = f"{acc_names[0]}+{gyro_names[0]}"
    taken = {name.split(".", 1)[0] for name in acc_names + gyro_names + (times if t_acc is not None else [])}
    warnings.warn(f"{path}: no matrix of every column: the variables {used} were read as the accelerometer and the "
                  "gyroscope" + ("" if t_acc is not None else " (no time: pass --rate)"), ImucalibWarning,
                  stacklevel=5)
    return label, matrix, taken
