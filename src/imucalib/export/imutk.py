"""A calibration as imu_tk's two parameter files (``…_acc.calib``, ``…_gyro.calib``).

imu_tk (``include/imu_tk/calibration.h``, ``CalibratedTriad_``) corrects a raw
reading ``X`` as ``X' = T K (X − B)`` with ``T`` a misalignment matrix of unit
diagonal, ``K`` a diagonal scale matrix and ``B`` the bias, in the raw units it
was given. ``CalibratedTriad_::load`` reads, whitespace-separated, the 9 entries
of ``T`` row by row, the 9 of ``K`` row by row and the 3 of ``B``; ``save``
writes them as three blocks of rows separated by blank lines, the form written
here (with 17 significant digits instead of imu_tk's 6).

The canonical model maps onto it term by term when it is linear: ``T = T_a``
or ``T_g``, ``K = diag(k1)``, ``B = b`` (with an output bias ``d`` folded into
``B``: ``b − d/k1``). imu_tk has no g-sensitivity: a calibration with ``G ≠ 0``
cannot be exported. Units are kept: imu_tk's files map the same raw units.

:func:`from_imutk` reads such a pair back (imu_tk's own files, e.g. to check a
calibration imu_tk made with ``imucalib validate`` or to set it beside
imucalib's in ``imucalib compare --peer``): ``T``, ``K``, ``B`` become ``T_a``,
``diag(k1)``, ``b`` of a linear model; the raw units are the recording's, and
the output is in that unit when it is physical (imu_tk keeps units), in SI for
counts.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..calibration import Calibration, CalibrationFileError
from ..models import TriadModel
from ..recording import STANDARD_GRAVITY, ImucalibWarning
from .linear import UNIT_TO_SI, ExportError, gyroscope_part, linear_form

__all__ = ["from_imutk", "imutk_pair", "imutk_paths", "to_imutk"]

#: the largest imu_tk parameter file read (one is 21 numbers: a few hundred bytes)
MAX_CALIB_BYTES = 1 << 16


def _block(m: np.ndarray) -> str:
    rows = np.atleast_2d(m) if np.ndim(m) == 2 else np.asarray(m)[:, None]
    return "\n".join(" ".join(f"{v:.17g}" for v in row) for row in rows)


def to_imutk(calibration: Calibration) -> tuple[str, str]:
    """The text of imu_tk's accelerometer and gyroscope files (module docstring).

    An accelerometer-only calibration gets the identity as its gyroscope file
    (:func:`.linear.gyroscope_part`), with an :class:`~imucalib.recording.ImucalibWarning` saying so.

    Parameters
    ----------
    calibration : Calibration
        A linear calibration without gyroscope g-sensitivity, in the raw units imu_tk reads.

    Returns
    -------
    acc : str
        The accelerometer file's text: misalignment (unit diagonal), scale matrix and bias, blank-line separated.
    gyro : str
        The gyroscope file's text, in the same layout.

    Raises
    ------
    ExportError
        A gyroscope g-sensitivity (imu_tk has none) or nonlinear scale terms.

    Examples
    --------
    A simulated calibration's truth, without its g-sensitivity:

    >>> import numpy as np
    >>> from imucalib.scenarios import session
    >>> truth = session("handheld", rng=1).truth
    >>> cal = truth.with_(gyroscope=truth.gyroscope.with_(g_sensitivity=np.zeros((3, 3))))
    >>> from imucalib.export import to_imutk
    >>> acc, gyro = to_imutk(cal)
    >>> # misalignment, scale and bias: three lines each
    >>> [len(block.splitlines()) for block in acc.split(chr(10) * 2)[:3]]
    [3, 3, 3]
    >>> to_imutk(truth)
    Traceback (most recent call last):
        ...
    imucalib.export.linear.ExportError: imu_tk has no gyroscope g-sensitivity, and this ...
    """
    calibration, note = gyroscope_part(calibration, "imu_tk parameter files")
    if note:
        warnings.warn(note, ImucalibWarning, stacklevel=2)
    if np.any(calibration.gyroscope.g_sensitivity):
        raise ExportError("imu_tk has no gyroscope g-sensitivity, and this calibration has one (G not zero): "
                          "it cannot be exported to imu_tk without changing what it corrects")
    form = linear_form(calibration, "imu_tk")
    out = []
    for matrix, bias, k in ((form.acc_matrix, form.acc_bias, calibration.accelerometer.scale),
                            (form.gyro_matrix, form.gyro_bias, calibration.gyroscope.scale)):
        t = matrix / k  # T diag(k1) / k1 column by column: T, unit diagonal
        out.append(f"{_block(t)}\n\n{_block(np.diag(k))}\n\n{_block(bias)}\n\n")
    return out[0], out[1]


def imutk_paths(output: str) -> tuple[str, str]:
    """``NAME_acc.calib``, ``NAME_gyro.calib`` from ``-o NAME`` (a trailing ``.calib``, ``_acc``/``_gyro`` dropped).

    Parameters
    ----------
    output : str
        The name given: ``NAME``, ``NAME.calib``, ``NAME_acc.calib`` or ``NAME_gyro.calib`` (a folder may lead).

    Returns
    -------
    acc, gyro : str
        The two files' names.

    Raises
    ------
    ExportError
        No name left (``-o _acc.calib``, or a folder alone).

    Examples
    --------
    >>> from imucalib.export import imutk_paths
    >>> imutk_paths("xsens")
    ('xsens_acc.calib', 'xsens_gyro.calib')
    >>> imutk_paths("out/xsens_gyro.calib")
    ('out/xsens_acc.calib', 'out/xsens_gyro.calib')
    """
    stem = output[:-len(".calib")] if output.endswith(".calib") else output
    for end in ("_acc", "_gyro"):
        if stem.endswith(end):
            stem = stem[: -len(end)]
    if not stem or stem.endswith(("/", "\\")):
        raise ExportError(f"-o {output}: give a name for imu_tk's files, e.g. -o xsens (xsens_acc.calib, "
                          "xsens_gyro.calib)")
    return f"{stem}_acc.calib", f"{stem}_gyro.calib"


def imutk_pair(path: str) -> tuple[str, str]:
    """The accelerometer and gyroscope files of the imu_tk pair ``path`` belongs to (either may be named).

    ``xsens_acc.calib`` and ``xsens_gyro.calib`` name each other by their ends ``_acc``/``_gyro``.
    """
    name = str(path)
    for mine, other in (("_acc.calib", "_gyro.calib"), ("_gyro.calib", "_acc.calib")):
        if name.endswith(mine):
            pair = (name, name[: -len(mine)] + other)
            return pair if mine == "_acc.calib" else (pair[1], pair[0])
    raise CalibrationFileError(f"{path}: an imu_tk parameter file is named NAME_acc.calib or NAME_gyro.calib "
                               "(the other of the pair beside it)")


def _read_triad(path: str, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``T``, ``diag(K)``, ``B`` of one imu_tk parameter file (module docstring), its faults named."""
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_CALIB_BYTES + 1)
    except OSError as exc:
        raise CalibrationFileError(f"{path}: the imu_tk {what} file cannot be read ({exc.strerror})") from None
    if len(data) > MAX_CALIB_BYTES:
        raise CalibrationFileError(f"{path}: over {MAX_CALIB_BYTES} bytes; an imu_tk parameter file holds 21 "
                                   "numbers")
    try:
        values = np.array(data.decode("ascii").split(), dtype=np.float64)
    except (UnicodeDecodeError, ValueError):
        raise CalibrationFileError(f"{path}: not an imu_tk parameter file (21 numbers: T row by row, K row by "
                                   "row, B)") from None
    if values.size != 21 or not np.isfinite(values).all():
        raise CalibrationFileError(f"{path}: an imu_tk parameter file holds 21 finite numbers (T row by row, K "
                                   f"row by row, B); this one {values.size}")
    t, k, b = values[:9].reshape(3, 3), values[9:18].reshape(3, 3), values[18:]
    if np.any(k[~np.eye(3, dtype=bool)]) or not np.all(np.diag(k) > 0):
        raise CalibrationFileError(f"{path}: imu_tk's scale matrix K is diagonal with positive entries; got "
                                   f"{k.tolist()}")
    if not np.allclose(np.diag(t), 1.0, rtol=0, atol=1e-9):
        raise CalibrationFileError(f"{path}: imu_tk's misalignment T has a unit diagonal; got {np.diag(t)}")
    t = t.copy()
    np.fill_diagonal(t, 1.0)
    return t, np.diag(k).copy(), b


def from_imutk(acc_path: str, gyro_path: str | None, *, acc_unit: str, gyro_unit: str | None,
               gravity: float = STANDARD_GRAVITY) -> Calibration:
    """A :class:`~imucalib.calibration.Calibration` from imu_tk's parameter files (module docstring).

    Parameters
    ----------
    acc_path, gyro_path : str
        ``NAME_acc.calib`` and ``NAME_gyro.calib`` (``gyro_path`` None: an accelerometer-only calibration).
    acc_unit, gyro_unit : str
        The raw units of the readings imu_tk was given (those of the recording it is applied to).
    gravity : float
        The local gravity imu_tk was given [m/s²] (its files do not hold it).

    Raises
    ------
    CalibrationFileError
        Naming the file and what is wrong with it.
    """
    def triad(path, unit, shape, what):
        t, k, b = _read_triad(path, what)
        if shape == "upper" and np.any(np.tril(t, -1)):
            shape = "full"
        return TriadModel(misalignment=t, scale=k * UNIT_TO_SI.get(unit, 1.0), bias=b, shape=shape)

    acc = triad(acc_path, acc_unit, "upper", "accelerometer")
    gyro = None if gyro_path is None else triad(gyro_path, gyro_unit, "full", "gyroscope")
    units = {"accelerometer": {"raw": acc_unit, "calibrated": "m/s^2"}}
    if gyro is not None:
        units["gyroscope"] = {"raw": gyro_unit, "calibrated": "rad/s"}
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=float(gravity), method="imu_tk", units=units)
