"""The ellipsoid (norm) method (Ru 2022, §3.2): accelerometer by an algebraic ellipsoid fit.

Static readings ``u`` of an accelerometer with ``a = T·K·(u − b)`` and
``‖a‖ = g`` lie on the ellipsoid ``(u − b)ᵀ A (u − b) = g²`` with
``A = (T K)ᵀ (T K)``; :func:`imucalib.fit.accelerometer.fit_ellipsoid` fits it
in closed form. The gyroscope comes from the static poses and the rotations
between them together (:func:`imucalib.fit.gyroscope.fit_gyroscope`: Zhang
2021 eqs. 11 and 14 in one cost).
"""

from __future__ import annotations

from ..assembly import POSES_IN_BLOCKS, assemble
from ..calibration import Calibration
from ..fit.accelerometer import (
    accelerometer_covariance,
    accelerometer_figures,
    fit_determined,
    fit_ellipsoid,
    fit_gravity_norm,
)
from ..fit.gyroscope import fit_gyroscope
from ..methodinfo import MethodInfo, Option
from ..metrics import interval_means
from ..presets import MIN_HOLD
from ..segment import no_usable_rotations, pose_blocks, static_poses, unreliable_transitions

METHOD = MethodInfo(
    name="ellipsoid",
    summary="accelerometer by an algebraic ellipsoid fit of the static poses; gyroscope on the poses and "
            "rotations",
    needs=("static poses", "rotations"),
    models=("linear",),
    options=(
        Option("intervals", None, "samples", "static intervals given instead of found"),
        Option("refine", False, "", "refine the closed form by Levenberg–Marquardt on the gravity norms"),
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
        Option("min_hold", 1.0, "s", "shortest hold that is a pose (sets the static detector's window)"),
    ),
    paper="ru2022_mems_calibration_review.md (Ru 2022), §3.2",
    accelerometer_only=True,
)

__all__ = ["calibrate"]


def calibrate(recording, *, gravity: float, intervals=None, refine: bool = False,
              init_static: float | None = None, min_hold: float = MIN_HOLD) -> Calibration:
    """Accelerometer by the ellipsoid fit (Ru 2022, §3.2), gyroscope from the rotations between poses.

    The static means of ≥ 9 poses give ``T_a``, ``k1`` and ``b_a`` in closed
    form, optionally refined by Levenberg–Marquardt on the gravity-norm
    residuals; fewer poses give the model they determine
    (:func:`~imucalib.fit.accelerometer.fit_determined`, ``fit`` says which).
    The gyroscope (bias, drift, g-sensitivity, scales and misalignment) by
    :func:`imucalib.fit.gyroscope.fit_gyroscope` over the poses and the rotations;
    a recording in blocks (no motion recorded between its poses), or one whose
    rotations are all unreliable (:func:`imucalib.segment.no_usable_rotations`),
    leaves the gyroscope uncalibrated and says why in
    ``fit.gyroscope.not_calibrated``.

    Parameters
    ----------
    recording : Recording or Session
        The recording: an initial rest, then static poses with rotations between them.
    gravity : float
        Local gravity [m/s²].
    intervals : list of Interval, optional
        The static poses as sample ranges; by default found by the method's detector.
    refine : bool
        Refine the closed-form accelerometer by Levenberg–Marquardt on the gravity-norm residuals.
    init_static : float, optional
        Length of the initial rest [s]; by default found automatically.

    Returns
    -------
    Calibration
        The calibration, with its fit figures, 1σ errors and verdict in ``fit``.

    Examples
    --------
    A short simulated hand-held session: the ellipsoid through the poses' means gives the accelerometer's
    scale factors within 0.1 % of the truth:

    >>> from imucalib.methods import ellipsoid
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> cal = ellipsoid.calibrate(sim.recording, gravity=sim.truth.gravity)
    >>> (cal.accelerometer.scale / sim.truth.accelerometer.scale).round(3)
    array([1., 1., 1.])
    """
    intervals = static_poses(recording, gravity, intervals, init_static=init_static, min_hold=min_hold)
    means = interval_means(recording.acc, intervals)
    which = None
    if len(means) >= 9:
        acc = fit_ellipsoid(means, gravity)
        if refine:
            acc, _ = fit_gravity_norm(means, gravity, initial=acc)
    else:  # fewer poses than the ellipsoid's 9 parameters: the model they determine
        acc, _, which = fit_determined(means, gravity)
    blocks = pose_blocks(recording) is not None
    exclude = {} if recording.gyro is None or blocks else unreliable_transitions(recording, intervals)
    why_not = None if recording.gyro is None or blocks else no_usable_rotations(intervals, exclude)
    gyro_fit = None if recording.gyro is None or blocks or why_not else fit_gyroscope(  # none without rotations
        recording, intervals, acc, exclude=exclude, acc_cov=accelerometer_covariance(acc, means, gravity, which=which))
    gyro, gyro_errors = (gyro_fit.model, gyro_fit.errors) if gyro_fit is not None else (None, {})
    # why_not: nothing to fit the gyroscope to, the accelerometer's calibration, and why
    not_calibrated = POSES_IN_BLOCKS if blocks and recording.gyro is not None else why_not
    # first-order errors of the gravity-norm fit at this solution (the algebraic fit is close to it)
    figures = [accelerometer_figures(acc, means, gravity, which)]
    return assemble("ellipsoid", recording, intervals, acc, gyro, gravity=gravity, uncertainty=gyro_errors,
                    figures=figures if gyro_fit is None else [gyro_fit.report(), *figures],
                    not_calibrated=not_calibrated, left_out=exclude, unreliable=exclude)
