"""Algebraic ellipsoid fit of static accelerometer readings.

Static readings ``u`` of an accelerometer with ``a = T·K·(u − b)`` and
``‖a‖ = g`` lie on the ellipsoid ``(u − b)ᵀ A (u − b) = g²`` with
``A = (T K)ᵀ (T K)`` (Ru 2022, §3.2, the ellipsoid/norm methods). Fitting the
general quadric ``uᵀ A u + 2 vᵀ u = 1`` by linear least squares gives the centre
``b = −A⁻¹ v``; the upper Cholesky factor of the normalised ``A`` is ``T K``
with ``T`` unit upper-triangular — exactly the canonical accelerometer model
(DESIGN, Tedaldi 2014 / Zhang 2021 eq. 4). It needs no initial guess and is
exact on noise-free data, so it initialises every accelerometer calibration.
"""

from __future__ import annotations

import numpy as np

from ..models import TriadModel

__all__ = ["fit_ellipsoid", "fit_sphere"]


def fit_sphere(raw: np.ndarray, gravity: float) -> TriadModel:
    """Centre and one common scale from a sphere fit (≥ 4 well-spread poses).

    ``‖u − b‖² = ρ²`` is linear in ``(b, ρ² − ‖b‖²)``; the scale is ``g / ρ``.
    """
    raw = np.asarray(raw, dtype=np.float64)
    if raw.shape[0] < 4:
        raise ValueError(f"a sphere fit needs at least 4 static poses; got {raw.shape[0]}")
    mu = raw.mean(axis=0)
    s = np.abs(raw - mu).max() or 1.0
    z = (raw - mu) / s
    design = np.column_stack([2 * z, np.ones(len(z))])
    sol, *_ = np.linalg.lstsq(design, np.sum(z * z, axis=1), rcond=None)
    c = sol[:3]
    rho2 = sol[3] + c @ c
    if not rho2 > 0:
        raise ValueError("the static poses do not determine a sphere (too few directions)")
    k = gravity / (np.sqrt(rho2) * s)
    return TriadModel(scale=np.full(3, k), bias=mu + s * c, shape="upper")


def fit_ellipsoid(raw: np.ndarray, gravity: float) -> TriadModel:
    """Linear accelerometer model from static means by an algebraic ellipsoid fit.

    Parameters
    ----------
    raw : (M, 3) array_like
        Raw accelerometer means of M ≥ 9 static poses, spread over directions.
    gravity : float
        ``g`` [m/s²].

    Returns
    -------
    TriadModel
        ``T`` unit upper-triangular, ``k1`` (SI per raw unit), ``b`` (raw units).

    Raises
    ------
    ValueError
        Too few poses, or poses that do not determine an ellipsoid (e.g. all
        about one axis): the quadric is then not positive definite.
    """
    raw = np.asarray(raw, dtype=np.float64)
    if raw.ndim != 2 or raw.shape[1] != 3:
        raise ValueError(f"raw must have shape (M, 3); got {raw.shape}")
    if raw.shape[0] < 9:
        raise ValueError(
            f"an ellipsoid fit needs at least 9 static poses in different directions; "
            f"got {raw.shape[0]}"
        )
    mu = raw.mean(axis=0)
    s = np.abs(raw - mu).max() or 1.0
    z = (raw - mu) / s  # conditioning: centred, unit range
    x, y, w = z[:, 0], z[:, 1], z[:, 2]
    design = np.column_stack([x * x, y * y, w * w, 2 * x * y, 2 * x * w, 2 * y * w, 2 * x, 2 * y, 2 * w])
    p, *_ = np.linalg.lstsq(design, np.ones(len(z)), rcond=None)
    a = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
    v = p[6:9]
    try:
        c = -np.linalg.solve(a, v)
    except np.linalg.LinAlgError:
        raise ValueError("the static poses do not determine an ellipsoid (singular quadric)") from None
    kappa = 1.0 + c @ a @ c
    q = a * (gravity**2 / kappa) / s**2  # (u − b)ᵀ Q (u − b) = g² in raw units
    try:
        lower = np.linalg.cholesky(q)
    except np.linalg.LinAlgError:
        raise ValueError(
            "the static poses do not determine an ellipsoid (the fitted quadric is not "
            "positive definite): record poses spread over all directions"
        ) from None
    tk = lower.T  # upper triangular, (T K)ᵀ (T K) = Q
    k = np.diag(tk).copy()
    t = np.triu(tk / k[None, :], 1) + np.eye(3)
    return TriadModel(misalignment=t, scale=k, bias=mu + s * c, shape="upper")


def calibrate(recording, *, gravity: float, intervals=None, refine: bool = False,
              init_static: float | None = None):
    """Accelerometer by the ellipsoid fit (Ru 2022, §3.2), gyroscope as in Tedaldi 2014.

    The ellipsoid (norm) method is an accelerometer method: the static means of
    ≥ 9 poses give ``T_a``, ``k1`` and ``b_a`` in closed form
    (:func:`fit_ellipsoid`), optionally refined by Levenberg–Marquardt on the
    gravity-norm residuals. The gyroscope bias is the mean of the initial rest
    and its scale and misalignment come from the rotations between the poses
    (:func:`imucalib.methods.tedaldi2014.calibrate_gyroscope`).
    """
    from ..calibration import Calibration
    from ..metrics import fit_summary, interval_means
    from .tedaldi2014 import accelerometer_errors, calibrate_accelerometer, detect_intervals, fit_gyroscope

    if intervals is None:
        intervals = detect_intervals(recording, gravity, init_static=init_static)[0]
    intervals = [iv for iv in intervals if iv.kind == "static"]
    means = interval_means(recording.acc, intervals)
    acc = fit_ellipsoid(means, gravity)
    if refine:
        acc, _ = calibrate_accelerometer(means, gravity, initial=acc)
    bias = recording.gyro[intervals[0].slice].mean(axis=0)
    gyro, gyro_errors = fit_gyroscope(recording, intervals, acc, bias, False)
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="ellipsoid",
                      model="linear",
                      units={"accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"},
                             "gyroscope": {"raw": recording.gyro_unit, "calibrated": "rad/s"}})
    fit = fit_summary(cal, recording, intervals, gravity)
    # first-order errors of the gravity-norm fit at this solution (the algebraic fit is close to it)
    fit["uncertainty"] = accelerometer_errors(acc, means, gravity) | gyro_errors
    return cal.with_(fit=fit)
