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
"""

from __future__ import annotations

import warnings

import numpy as np

from ..calibration import Calibration
from ..recording import ImucalibWarning
from .linear import ExportError, gyroscope_part, linear_form

__all__ = ["imutk_paths", "to_imutk"]


def _block(m: np.ndarray) -> str:
    rows = np.atleast_2d(m) if np.ndim(m) == 2 else np.asarray(m)[:, None]
    return "\n".join(" ".join(f"{v:.17g}" for v in row) for row in rows)


def to_imutk(calibration: Calibration) -> tuple[str, str]:
    """The text of imu_tk's accelerometer and gyroscope files (module docstring).

    An accelerometer-only calibration gets the identity as its gyroscope file
    (:func:`.linear.gyroscope_part`), with an :class:`~imucalib.recording.ImucalibWarning` saying so.
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
    """``NAME_acc.calib``, ``NAME_gyro.calib`` from ``-o NAME`` (a trailing ``.calib``, ``_acc``/``_gyro`` dropped)."""
    stem = output[:-len(".calib")] if output.endswith(".calib") else output
    for end in ("_acc", "_gyro"):
        if stem.endswith(end):
            stem = stem[: -len(end)]
    if not stem or stem.endswith(("/", "\\")):
        raise ExportError(f"-o {output}: give a name for imu_tk's files, e.g. -o xsens (xsens_acc.calib, "
                          "xsens_gyro.calib)")
    return f"{stem}_acc.calib", f"{stem}_gyro.calib"
