"""The accelerometer calibrated from a table of averaged poses (:class:`imucalib.io.posetable.PoseTable`).

The table's pose means are the static means every method fits, so the
estimator is the one the methods share: the gravity-norm residuals
``r_k = ‖T_a K (u_k − b)‖ − g`` (Tedaldi 2014; Zhang 2021, eq. 10) minimised
for the richest linear model the poses determine
(:func:`imucalib.fit.accelerometer.fit_determined`): the full linear model
with upper-triangular ``T_a`` from nine poses spread over the sphere, else a
scale and a bias per axis (six poses, as the six-position method calibrates,
Ru 2022 §3.1), else a sphere; a reduced model is said in
``fit.accelerometer.model_reduced`` and makes the verdict suspect.

**Weights.** Where the table gives each pose's spread ``σ`` (and the samples
``n``), pose ``k``'s residual is weighted by ``1/σ_r,k``, the standard error
of its ``‖ā_k‖`` by the delta method: with ``c_k = K T_aᵀ d_k`` (``d_k`` the
pose's calibrated gravity direction, the gradient of ``‖a‖`` with respect to
the raw reading) and the axes' noises independent,
``σ_r,k² = Σ_i c_k,i² σ_k,i² / n_k`` (the along-gravity noise
:func:`imucalib.metrics.gravity_noise_floor` takes from a recording's samples).
The parameters' covariance is then ``(Jᵀ W J)⁻¹`` (Gauss–Markov, ``W`` the
weights squared), multiplied by the reduced ``χ² = Σ (w_k r_k)² / (M − P)`` where it
exceeds 1: the scale factor of the Particle Data Group's averages
(Review of Particle Physics, "Introduction", §5.2.2, ``S² = χ²/(N − 1)``),
since a hand's tremor correlates a pose's samples and ``σ/√n`` is then a lower
bound. Without ``σ`` every pose is weighted alike and the 1σ errors come from
the residuals' scatter (:func:`imucalib.fit.accelerometer.determined_figures`:
the HC3 sandwich, or the common scatter of a thin table); ``fit.accelerometer.weights``
says which.

**The verdict** is the one every calibration gets (:func:`imucalib.verdict.assess`),
the poses' figures taken from the table: poses per parameter, the residual
against the noise floor (``σ_r``'s RMS over the poses; without ``σ``, the
residuals' own scatter stands in for the floor in the check of the directions
no pose visited, and the residual is not judged), the 1σ limits, the
coverage of each axis up and down, the raw ``|a|`` against gravity, plausibility.

**The gyroscope** is not calibrated: a table of poses holds no rotation, and its
scales and misalignment are measured only by rotations. Where the table gives
the gyroscope's means, their mean over the poses is reported as the rate at rest
(``fit.gyroscope.rest_mean``, raw units, with the standard error of that mean
over the poses): the gyroscope's bias plus the Earth's rotation (at most
7.3e-5 rad/s) where the sensor was still. It is not put into the calibration,
whose gyroscope section would need scales the table cannot give.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..calibration import Calibration
from ..fit.accelerometer import REDUCED_MODELS, determined_figures, fit_determined, fit_sphere, reduced_expansion
from ..fitreport import (
    AccelerometerReport,
    FitReport,
    GyroscopeReport,
    SegmentationReport,
    UncertaintyReport,
    VerdictReport,
)
from ..io.posetable import PoseTable
from ..metrics import pose_coverage
from ..plans import next_poses
from ..residuals import AccelLayout, gravity_norm_residuals
from ..solve import errors_from_covariance, scaled_inverse
from ..verdict import assess

__all__ = ["CalibratedTable", "TablePoses", "apply_to_table", "calibrate_pose_table"]

#: the name a calibration from a pose table carries in ``method``
METHOD_NAME = "pose_table"


@dataclass(frozen=True)
class TablePoses:
    """The poses' figures the verdict reads (:func:`imucalib.verdict.assess`'s ``poses``), from a table.

    ``recording`` is the table (the verdict asks only whether there is one), ``intervals`` one entry per pose,
    ``means`` the raw means, ``up`` their calibrated specific force and ``floor`` the gravity-norm residual's
    noise floor [m/s²].
    """

    calibration: Calibration
    recording: PoseTable
    intervals: tuple[int, ...]
    means: np.ndarray
    up: np.ndarray
    floor: float


def norm_sigma(model, means: np.ndarray, mean_sigma: np.ndarray) -> np.ndarray:
    """``σ_r,k``: the standard error of each pose's calibrated ``‖ā_k‖`` [m/s²] (module docstring, delta method)."""
    a = model.forward(means)
    d = a / np.linalg.norm(a, axis=1, keepdims=True)
    c = (d @ model.misalignment) * model.scale  # c_k = K T_aᵀ d_k, as rows
    return np.sqrt(np.sum((c * mean_sigma) ** 2, axis=1))


def calibrate_pose_table(table: PoseTable, *, gravity: float) -> Calibration:
    """The accelerometer's calibration from ``table`` with its 1σ errors and verdict (module docstring).

    Parameters
    ----------
    table : PoseTable
        Averaged static poses (:func:`imucalib.io.read_pose_table`).
    gravity : float
        Local gravity [m/s²].

    Returns
    -------
    Calibration
        An accelerometer-only calibration (no gyroscope), with its fit figures and verdict in ``fit``.

    Raises
    ------
    ValueError
        When the poses determine no model (fewer than four, or in too few directions).

    Examples
    --------
    14 poses of an accelerometer reading 2 % high with a bias of 0.03 g, without noise:

    >>> import itertools
    >>> import numpy as np
    >>> from imucalib.io.posetable import PoseTable
    >>> from imucalib.methods._pose_table import calibrate_pose_table
    >>> corners = np.array(list(itertools.product((-1, 1), repeat=3))) / np.sqrt(3)
    >>> up = np.vstack([np.eye(3), -np.eye(3), corners])  # 14 directions of gravity
    >>> table = PoseTable(acc=1.02 * up + 0.03, acc_unit="g")
    >>> cal = calibrate_pose_table(table, gravity=9.81)
    >>> cal.accelerometer.scale.round(4), cal.accelerometer.bias.round(4)  # 9.81 / 1.02, 0.03
    (array([9.6176, 9.6176, 9.6176]), array([0.03, 0.03, 0.03]))
    >>> cal.gyroscope is None, cal.fit.verdict.level
    (True, 'accepted')
    """
    means = np.asarray(table.acc, dtype=np.float64)
    m = len(means)
    mean_sigma = table.mean_sigma()
    weighted = mean_sigma is not None and bool(np.all(mean_sigma.max(axis=1) > 0))
    if weighted:
        try:
            start = fit_sphere(means, gravity)
        except ValueError as exc:
            raise ValueError(f"the pose table's {m} poses determine no accelerometer model: {exc}") from None
        sigma_r = norm_sigma(start, means, mean_sigma)
        for _ in range(2):  # the weights at the fitted model: they change with it by its scale's few per cent
            model, residuals, which = fit_determined(means, gravity, weights=1.0 / sigma_r)
            sigma_r = norm_sigma(model, means, mean_sigma)
    else:
        model, residuals, which = fit_determined(means, gravity)
    name, p, _ = which
    rms = float(np.sqrt(np.mean(residuals**2)))
    acc = AccelerometerReport(model=name, residual_rms=rms)
    if weighted:
        floor = float(np.sqrt(np.mean(sigma_r**2)))
        fit = FitReport.of(_weighted_figures(model, means, gravity, which, 1.0 / sigma_r), acc.with_(
            weights="1/σ of each pose's |a| from the table's σ/√n (delta method)", noise_floor=floor,
            residual_to_noise=rms / floor))
    else:
        floor = float(np.sqrt(residuals @ residuals / (m - p))) if m > p else 0.0
        why = ("the table gives no σ" if mean_sigma is None else "the table's σ is zero in some pose")
        fit = FitReport.of(determined_figures(model, means, gravity, which), acc.with_(
            weights=f"{why}: every pose weighted alike, the 1σ errors from the residuals' scatter, and the "
                    "residual not judged against the sensor's noise"))
    cal = Calibration(accelerometer=model, gyroscope=None, gravity=gravity, method=METHOD_NAME, model="linear",
                      units={"accelerometer": {"raw": table.acc_unit, "calibrated": "m/s^2"}})
    up = cal.accelerometer_si(means)
    coverage, flags = pose_coverage(up)
    poses = SegmentationReport(static_intervals=m, pose_coverage=coverage)
    fit = fit.add(poses.with_(quality_flags=flags) if flags else poses, _table_gyroscope(table, m),
                  VerdictReport(next_poses=next_poses(up).tolist()))
    cal = cal.with_(fit=fit)
    verdict = assess(cal, poses=TablePoses(cal, table, tuple(range(m)), means, up, floor))
    # how the table was read and weighted, where it did not say: notes beside the verdict's
    notes = [*table.notes, *([] if weighted else [fit.accelerometer.weights]), *verdict.verdict.notes]
    return cal.with_(fit=fit.add(verdict, VerdictReport(notes=notes)))


def _table_gyroscope(table: PoseTable, m: int) -> GyroscopeReport:
    """Why a pose table's gyroscope is not calibrated, and the mean of its ``m`` poses' gyroscope means when it has
    them."""
    why = "a table of averaged poses holds no rotation, which the gyroscope's scales need"
    if table.gyro is None:
        return GyroscopeReport(not_calibrated=why)
    return GyroscopeReport(
        rest_mean=np.mean(table.gyro, axis=0).tolist(),
        rest_mean_sigma=(np.std(table.gyro, axis=0, ddof=1) / np.sqrt(m)).tolist() if m > 1 else [float("nan")] * 3,
        rest_mean_unit=table.gyro_unit,
        not_calibrated=f"{why}; the mean of the poses' gyroscope means (its bias where the sensor was still) is "
                       f"gyroscope_rest_mean [{table.gyro_unit}]")


def _weighted_figures(model, means: np.ndarray, gravity: float, which: tuple[str, int, str],
                      weights: np.ndarray) -> FitReport:
    """``accelerometer_model_reduced`` and ``uncertainty`` of the weighted fit (module docstring: ``(JᵀWJ)⁻¹``
    scaled by the reduced χ² where it exceeds 1)."""
    name, p, left = which
    m = len(means)
    acc, unc = AccelerometerReport(), UncertaintyReport()
    if name != REDUCED_MODELS[0][0]:
        acc = acc.with_(model_reduced=f"{m} static poses determine {p} accelerometer parameters: the model "
                                      f"is reduced to {name}, leaving out {left}")
    lay = AccelLayout("upper", 1)
    expand = reduced_expansion(name)
    r, j = gravity_norm_residuals(lay.pack(model), lay, means, gravity, jacobian=True)
    jw, rw = weights[:, None] * (j @ expand), weights * r
    col, _, inv, bad = scaled_inverse(jw)
    cov = inv / np.outer(col, col)
    if m > p:
        chi2 = float(rw @ rw) / (m - p)
        acc = acc.with_(reduced_chi2=chi2)
        cov *= max(1.0, chi2)
    else:  # nothing to check the table's σ against: the errors are the σ propagated, the verdict told so
        unc = unc.with_(unavailable=f"accelerometer: the {m} poses determine its {p} parameters exactly, "
                                    "which leaves no residual to check the table's σ against (the 1σ are "
                                    "its σ/√n propagated)")
    se = errors_from_covariance(cov, bad, transform=expand)
    fitted = np.any(expand != 0, axis=1)
    sigma = {k: float(v) for k, v, f in zip(lay.names("accelerometer"), se, fitted, strict=True) if f}
    return FitReport.of(acc, unc.with_(sigma=sigma))


@dataclass(frozen=True)
class CalibratedTable:
    """A pose table's calibrated means: ``acc`` [m/s²], ``gyro`` [rad/s] (None where not calibrated) and
    ``notes`` on what was left as it was."""

    acc: np.ndarray
    gyro: np.ndarray | None
    notes: tuple[str, ...] = ()


def apply_to_table(calibration: Calibration, table: PoseTable) -> CalibratedTable:
    """``calibration`` applied to the means of ``table`` (:meth:`Calibration.accelerometer_si`, ``gyroscope_si``).

    Parameters
    ----------
    calibration : Calibration
        The calibration to apply.
    table : PoseTable
        Averaged static poses in the raw units the calibration maps.

    Returns
    -------
    CalibratedTable
        The calibrated means of each pose and ``|a| − g``.

    Raises
    ------
    ValueError
        When the table's units are not the raw units the calibration maps.

    Examples
    --------
    The calibration of a table, applied to its own poses: every calibrated mean has the norm of gravity:

    >>> import itertools
    >>> import numpy as np
    >>> from imucalib.io.posetable import PoseTable
    >>> from imucalib.methods._pose_table import apply_to_table, calibrate_pose_table
    >>> corners = np.array(list(itertools.product((-1, 1), repeat=3))) / np.sqrt(3)
    >>> up = np.vstack([np.eye(3), -np.eye(3), corners])  # 14 directions of gravity
    >>> table = PoseTable(acc=1.02 * up + 0.03, acc_unit="g")
    >>> calibrated = apply_to_table(calibrate_pose_table(table, gravity=9.81), table)
    >>> np.linalg.norm(calibrated.acc, axis=1).round(6)
    array([9.81, 9.81, 9.81, 9.81, 9.81, 9.81, 9.81, 9.81, 9.81, 9.81, 9.81, 9.81, 9.81, 9.81])
    """
    pairs = [("accelerometer", table.acc_unit)]
    if calibration.gyroscope is not None and table.gyro is not None:
        pairs.append(("gyroscope", table.gyro_unit))
    for sensor, unit in pairs:
        expected = calibration.units[sensor]["raw"]
        if unit != expected:
            raise ValueError(f"this calibration maps {sensor} readings in {expected!r}, but the table's {sensor} "
                             f"means are in {unit!r}: read the table with the units used for calibration "
                             f"(--{'acc' if sensor == 'accelerometer' else 'gyro'}-unit {expected})")
    acc = calibration.accelerometer_si(table.acc)
    notes = []
    gyro = None
    if table.gyro is not None and calibration.gyroscope is not None:
        gyro = calibration.gyroscope_si(table.gyro, table.acc)
    elif table.gyro is not None:
        notes.append("the calibration has no gyroscope: the table's gyroscope means are left as they are")
    return CalibratedTable(acc, gyro, tuple(notes))
