"""The MATLAB reader: a ``.mat`` file's matrix (or its sensors' variables) as a recording."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from ..recording import ImucalibWarning, Recording
from . import expansion, packets
from .columns import map_columns as _map_columns
from .errors import ReaderError
from .matvars import assemble as assemble_mat
from .stamps import check_increasing as _check_time
from .stamps import guess_unit as _infer_time_unit
from .stamps import to_seconds

__all__ = ["read_mat"]


def read_mat(path: Path, columns, acc_unit, gyro_unit, rate, variable, time_unit) -> Recording:
    """A MATLAB file's matrix (``variable``, else the one that fits, else its sensors' variables put together)
    as a recording; its other variables are used (a magnetometer, a temperature) or named in a note."""
    found = _mat_variables(path)
    variable, columns, found = _chosen_variable(path, found, variable, columns)
    m = _oriented_matrix(path, found, variable)
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
    t = _mat_times(path, m, mapping, rate, time_unit, meta)
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


def _mat_variables(path: Path) -> dict:
    """The variables of a MATLAB file (v4 to v7; a v7.3 file and one that is no MAT file are refused)."""
    from scipy.io import loadmat  # scipy.io costs 40 ms at start-up, for MATLAB files only

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
    return {k: v for k, v in content.items() if not k.startswith("__")}


def _chosen_variable(path: Path, found: dict, variable, columns):
    """The matrix to read: ``variable``, else the one numeric matrix that fits, else the sensors' own variables
    put together (:func:`.matvars.assemble`, the columns then without a time); with the columns and variables."""
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
    return variable, columns, found


def _oriented_matrix(path: Path, found: dict, variable: str) -> np.ndarray:
    """The variable as a float matrix of one row a sample (a matrix stored a sample a column is transposed)."""
    m = np.asarray(found[variable])
    if m.ndim != 2 or m.dtype.kind not in "fiu":
        raise ReaderError(f"{path}: variable {variable!r} must be a numeric matrix; got shape "
                          f"{m.shape} of {m.dtype}")
    m = m.astype(np.float64)
    if m.shape[1] < 6 and m.shape[0] >= 6 and m.shape[1] not in (3, 4):
        m = m.T
    elif m.shape[0] in (3, 4) and m.shape[1] > m.shape[0]:  # an accelerometer-only matrix stored as rows
        m = m.T
    return m


def _mat_times(path: Path, m: np.ndarray, mapping: dict, rate, time_unit, meta: dict) -> np.ndarray:
    """The times [s]: the time column's (its unit given or inferred), else the rows at ``rate``."""
    if mapping["t"] is None:
        if rate is None:
            raise ReaderError(f"{path}: no time column; pass --rate HZ")
        return np.arange(m.shape[0]) / rate
    if rate is not None:
        raise ReaderError(f"{path}: a time column and --rate were given; pass only one")
    raw_t = m[:, mapping["t"]]
    _check_time(path, raw_t, 1, "time (row)")
    return to_seconds(raw_t, time_unit or _infer_time_unit(raw_t, path, f"column {mapping['t']}"), meta)


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
