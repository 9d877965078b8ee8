"""The ellipsoid (norm) method (Ru 2022, §3.2): accelerometer by an algebraic ellipsoid fit.

Static readings ``u`` of an accelerometer with ``a = T·K·(u − b)`` and
``‖a‖ = g`` lie on the ellipsoid ``(u − b)ᵀ A (u − b) = g²`` with
``A = (T K)ᵀ (T K)``; :func:`imucalib.fit.accelerometer.fit_ellipsoid` fits it
in closed form. The gyroscope comes from the rotations between the poses
(:func:`imucalib.fit.gyroscope.fit_gravity_direction`, Zhang 2021 eq. 14).
"""

from __future__ import annotations

from ..calibration import Calibration, units_of
from ..fit.accelerometer import accelerometer_covariance, accelerometer_errors, fit_ellipsoid, fit_gravity_norm
from ..fit.gyroscope import fit_gyroscope
from ..metrics import fit_summary, interval_means
from ..segment import static_poses, unreliable_transitions

__all__ = ["calibrate"]


def calibrate(recording, *, gravity: float, intervals=None, refine: bool = False,
              init_static: float | None = None) -> Calibration:
    """Accelerometer by the ellipsoid fit (Ru 2022, §3.2), gyroscope from the rotations between poses.

    The static means of ≥ 9 poses give ``T_a``, ``k1`` and ``b_a`` in closed
    form, optionally refined by Levenberg–Marquardt on the gravity-norm
    residuals. The gyroscope bias is the mean of the initial rest.
    """
    intervals = static_poses(recording, gravity, intervals, init_static=init_static)
    means = interval_means(recording.acc, intervals)
    acc = fit_ellipsoid(means, gravity)
    if refine:
        acc, _ = fit_gravity_norm(means, gravity, initial=acc)
    gyro_fit = None if recording.gyro is None else fit_gyroscope(  # none for an accelerometer-only recording
        recording, intervals, acc, exclude=unreliable_transitions(recording, intervals),
        acc_cov=accelerometer_covariance(acc, means, gravity))
    gyro, gyro_errors = (gyro_fit.model, gyro_fit.errors) if gyro_fit is not None else (None, {})
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="ellipsoid",
                      model="linear", units=units_of(recording))
    fit = fit_summary(cal, recording, intervals, gravity)
    if gyro_fit is not None:
        fit |= gyro_fit.summary()
    # first-order errors of the gravity-norm fit at this solution (the algebraic fit is close to it)
    fit["uncertainty"] = accelerometer_errors(acc, means, gravity) | gyro_errors
    return cal.with_(fit=fit)
