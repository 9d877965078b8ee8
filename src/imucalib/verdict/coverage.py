"""The directions the poses did not visit: the 1σ of the calibrated ``|a|`` there against the noise floor.

See :func:`unvisited_sigma`; :func:`unvisited_checks` is the verdict's check on it.
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..fit.accelerometer import REDUCED_MODELS, accelerometer_covariance, pose_covariance
from ..fitreport import AccelerometerReport
from ..recording import Interval, Recording
from ..residuals import AccelLayout, gravity_norm_residuals
from ..solve import covariance
from .base import THRESHOLDS, Check, Poses, grade

__all__ = ["unvisited_checks", "unvisited_sigma"]


def _sphere_directions(n: int) -> np.ndarray:
    """``n`` unit vectors spread evenly over the sphere (a Fibonacci lattice: equal areas, no pole crowding)."""
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + np.sqrt(5.0)) * k
    r = np.sqrt(1 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


#: the directions :func:`unvisited_sigma` evaluates the calibrated |a|'s 1σ at (4.5° apart on average)
_SPHERE = _sphere_directions(2000)


def _accelerometer_covariances(calibration: Calibration, means: np.ndarray, floor: float
                                ) -> tuple[AccelLayout, np.ndarray, np.ndarray]:
    """The accelerometer's parameter layout and two covariances of the gravity-norm fit at ``means``.

    The fit's: the covariance the methods' 1σ come from (:func:`imucalib.fit.accelerometer.pose_covariance`,
    each pose's scatter from its own residual; a reduced model, ``fit.accelerometer.model``, has none on
    the terms it holds). The noise's: ``floor² (JᵀJ)⁻¹`` of the model with every term
    (:func:`imucalib.solve.covariance`, the Gauss–Markov covariance of least squares with pose errors of
    variance ``floor²``): each pose mean's white noise alone, the least any pose carries, with the terms a
    reduced model held at none counted as unknown. The fit's scatter comes from the ``M − P`` residual degrees
    of freedom — none where the poses determine the parameters exactly, two or three on a thin session, where a
    small χ² makes it arbitrarily small — so neither bounds the other. Both infinite on the diagonal of a
    parameter the poses do not determine.
    """
    acc = calibration.accelerometer
    g = calibration.gravity
    order = 3 if np.any(acc.scale_cubic) else 2 if np.any(acc.scale_quadratic) else 1
    layout = AccelLayout("upper", order)
    r, j = gravity_norm_residuals(layout.pack(acc), layout, means, g, jacobian=True)
    if order == 1:
        name = calibration.fit.accelerometer.model
        row = next((r for r in REDUCED_MODELS if r[0] == name and name != "linear"), None)
        fitted = accelerometer_covariance(acc, means, g, which=None if row is None else (row[0], row[2], row[3]))
    else:
        fitted, bad = pose_covariance(j, r)
        fitted[bad, bad] = np.inf
    noise, bad = covariance(j, np.full(len(means), floor), dof=len(means))
    noise[bad, bad] = np.inf
    return layout, fitted, noise


def unvisited_sigma(calibration: Calibration, recording: Recording, intervals: list[Interval]) -> dict | None:
    """The 1σ of the calibrated ``|a|`` over the gravity directions no pose visited, against the noise floor.

    A static pose visits the directions within :data:`THRESHOLDS` ``["coverage_cone_deg"]`` of its gravity
    direction. An axis side (``+z``: z up) that no pose visits (:func:`imucalib.metrics.pose_coverage`: Ru 2022,
    §3.1, each axis is calibrated from both orientations) leaves the directions in its cone that no pose's
    cone reaches unvisited. Over those directions ``u`` of an even grid on the sphere, the raw reading ``x_u``
    the calibration maps to ``g u`` and

    ``σ(u)² = j(u)ᵀ C j(u)``,   ``j(u) = ∂‖h(x_u, θ)‖/∂θ``

    (the delta method: first-order propagation of the parameters' covariance ``C`` through ``‖h‖``, the
    norm of the accelerometer model ``h`` of Zhang 2021, eqs. (1)-(2), whose residual ``‖h(x_k, θ)‖ − g``
    eq. (10) fits), with ``C`` the HC3 sandwich of the gravity-norm fit at the calibration's own parameters
    (:func:`imucalib.fit.accelerometer.pose_covariance`; MacKinnon & White 1985), or the poses' white noise
    alone where that gives more (``floor² (JᵀJ)⁻¹``: a fit with few residual degrees of freedom can
    find a scatter below what the noise allows). ``σ(u)`` is the RMS of
    the error ``‖h(x_u)‖ − g`` a pose in direction ``u`` would show, so ``σ(u)`` over the noise floor
    (:func:`imucalib.metrics.gravity_noise_floor` on the calibration's poses, the floor ``validate``
    divides the residual of a new recording by) is the ratio ``validate`` would find on poses there.

    Returns
    -------
    dict or None
        ``{"ratio", "sigma", "floor", "direction", "unvisited"}``: the largest ``σ(u)`` over the unvisited
        directions [m/s²] and its ratio to the floor (infinite where a parameter the poses do not determine
        moves ``|a|``), the floor [m/s²], that direction (unit vector) and the fraction of the sphere
        unvisited; ``ratio`` 0 when every direction is visited. None with fewer than four poses, without a
        noise floor, or for a polynomial model that does not invert over gravity's range.
    """
    return _unvisited_sigma(Poses(calibration, recording, intervals))


def _unvisited_sigma(found: Poses) -> dict | None:
    """:func:`unvisited_sigma` from the poses' figures of one assessment."""
    calibration, intervals = found.calibration, found.intervals
    if len(intervals) < 4:
        return None
    means = found.means
    up = found.up
    up = up / np.linalg.norm(up, axis=1, keepdims=True)
    lim = np.cos(np.radians(THRESHOLDS["coverage_cone_deg"]))
    # the axis sides no pose points within the cone of (metrics.pose_coverage), and in their cones the
    # directions no pose's cone reaches
    sides = [(i, s) for i in range(3) for s in (1.0, -1.0) if np.max(s * up[:, i]) < lim]
    cap = np.zeros(len(_SPHERE), dtype=bool)
    for i, s in sides:
        cap |= s * _SPHERE[:, i] >= lim
    far = cap & (np.max(_SPHERE @ up.T, axis=1) < lim)
    floor = found.floor
    if not floor > 0:
        return None
    if not np.any(far):
        return {"ratio": 0.0, "sigma": 0.0, "floor": floor, "direction": None, "unvisited": 0.0}
    u = _SPHERE[far]
    try:
        raw = calibration.accelerometer.inverse(calibration.gravity * u)
    except ValueError:  # a polynomial the gravity's range does not invert: the model check says why
        return None
    layout, *covariances = _accelerometer_covariances(calibration, means, floor)
    _, j = gravity_norm_residuals(layout.pack(calibration.accelerometer), layout, raw, calibration.gravity,
                                  jacobian=True)
    sigma = np.zeros(len(u))
    for cov in covariances:
        undetermined = ~np.isfinite(np.diag(cov))
        finite = np.where(np.isfinite(cov), cov, 0.0)
        s = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", j, finite, j), 0.0))
        s[np.any(np.abs(j[:, undetermined]) > 0, axis=1)] = np.inf
        sigma = np.maximum(sigma, s)
    k = int(np.argmax(sigma))
    return {"ratio": float(sigma[k] / floor), "sigma": float(sigma[k]), "floor": float(floor),
            "direction": u[k].tolist(), "unvisited": float(np.mean(far))}


def unvisited_checks(calibration: Calibration, poses: Poses) -> tuple[list[Check], AccelerometerReport]:
    """Rejected when, in a direction no pose visited, the fit's own 1σ of ``|a|`` is what ``validate`` rejects.

    The limits are ``validate``'s (:data:`THRESHOLDS` ``["residual_to_noise_high"]``): a calibration whose
    ``|a|`` has, where the poses did not look, a 1σ above the rejecting limit × the noise floor would be
    rejected by ``validate`` on a recording with poses there, so it is rejected now, naming the direction.
    Above the suspect limit, suspect. No parameter is held at a nominal value instead: the combination the
    poses leave undetermined mixes the axis's scale, bias and misalignment, and a nominal scale (the unit's
    factor, or the other axes' mean for counts) is itself off by tenths of a per cent to per cents, far
    above the floor, so the reduced model would fail the same test.
    """
    if calibration.accelerometer is None:
        return [], AccelerometerReport()
    found = _unvisited_sigma(poses)
    if found is None:
        return [], AccelerometerReport()
    # a JSON number, or None where a parameter the poses do not determine moves |a| there (an infinite 1σ)
    figures = AccelerometerReport(unvisited_sigma_to_noise=found["ratio"] if np.isfinite(found["ratio"]) else None)
    limits = THRESHOLDS["residual_to_noise_high"]
    level = grade(found["ratio"], limits)
    if not level:
        return [], figures
    u = np.asarray(found["direction"])
    i = int(np.argmax(np.abs(u)))
    up = poses.up
    c = up[:, i] / np.linalg.norm(up, axis=1)
    cone = THRESHOLDS["coverage_cone_deg"]
    lim = np.cos(np.radians(cone))
    both = c.max() < lim and c.min() > -lim
    side = ("±" if both else "+" if u[i] > 0 else "−") + "xyz"[i]
    where = "up or down" if both else "up" if u[i] > 0 else "down"
    how = ("a parameter the poses do not determine moves |a| there" if not np.isfinite(found["ratio"]) else
           f"the fit leaves |a| a 1σ of {found['sigma']:.2g} m/s² there, {found['ratio']:.3g}× the "
           f"{found['floor']:.2g} m/s² noise floor validate judges by (limit {limits[level - 1]:g}×)")
    text = (f"the poses do not visit {side} (the gravity direction's {'xyz'[i]} component spans {c.min():+.2f}.."
            f"{c.max():+.2f}, none within {cone:g}° of {'xyz'[i]} {where}): {how}; with {'xyz'[i]} {where} the "
            f"calibration {'would not' if level == 2 else 'may not'} hold: record poses with {'xyz'[i]} pointing "
            f"{'up and down' if both else where}")
    return [Check(level, text)], figures
