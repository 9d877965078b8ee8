"""Tedaldi, Pretto & Menegatti (ICRA 2014): multi-position calibration without equipment.

The procedure (as summarised in the static/dynamic interval detection
fragment, §2, and implemented by imu_tk):

1. An initial rest of ``T_init`` seconds gives the accelerometer noise: the
   norm of its per-axis variance.
2. A sliding-window variance detector marks static intervals at a threshold of
   ``n × (that norm)``; for each multiplier ``n`` (2…10) the accelerometer is
   calibrated on the static intervals and the multiplier whose calibration has
   the lowest mean squared residual (**per residual**) is kept (imu_tk
   compares raw sums, which favours thresholds that find fewer intervals).
3. Accelerometer: ``a = T_a K_a (u − b_a)`` with ``T_a`` unit upper-triangular,
   fitted so that ``‖a‖ = g`` at every static pose (Levenberg–Marquardt,
   analytic Jacobian, interval means). The initial values come from an
   algebraic ellipsoid fit (no sensor-specific guess).
4. Gyroscope: ``ω = T_g K_g (u − b_g)`` with ``T_g`` unit-diagonal (6 terms);
   the calibrated rates are integrated (RK4) across each motion and the
   predicted gravity direction is compared with the measured one at the next
   pose (Zhang 2021, eq. 14 is the same residual). The paper takes ``b_g``
   from the initial rest; here the bias (with a linear drift where the poses
   show one) and the g-sensitivity come from every static pose's mean
   (Zhang 2021, eq. 11) in the same cost as the rotations
   (:func:`imucalib.fit.gyroscope.fit_gyroscope`), each over its own noise:
   the rotations alone trade the bias against the scales. The initial scale
   comes from a scalar search started at the ratio of the gravity-direction
   change to the integrated raw rate.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from ..assembly import POSES_IN_BLOCKS, assemble, rest_seconds
from ..calibration import Calibration, units_of
from ..constants import STANDARD_GRAVITY
from ..fit.accelerometer import (
    accelerometer_covariance,
    accelerometer_errors,
    accelerometer_figures,
    fit_determined,
    fit_gravity_norm,
)
from ..fit.gyroscope import errors_at, fit_gyroscope, joint_errors_at, static_gyro
from ..fitreport import AccelerometerReport, SegmentationReport
from ..methodinfo import MethodInfo, Option
from ..metrics import interval_means
from ..presets import FULL_MODEL_POSES, MIN_HOLD, MULTIPLIERS
from ..recording import Interval, Recording
from ..segment import detect_intervals, no_usable_rotations, pose_blocks, unreliable_transitions
from ..verdict import worse_than_nominal

METHOD = MethodInfo(
    name="tedaldi2014",
    summary="linear model, automatic static detection: the accelerometer on the static poses at the "
            "detector threshold that fits best, then the gyroscope on the rotations between them",
    needs=("static poses", "rotations"),
    models=("linear",),
    options=(
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
        Option("min_hold", 1.0, "s", "shortest hold that is a pose (sets the static detector's window)"),
        Option("multipliers", (2, 3, 4, 5, 6, 7, 8, 9, 10), "", "static-detector thresholds tried, in multiples "
               "of the rest's accelerometer variance"),
        Option("window", None, "s", "the static detector's variance window (from min_hold: half of it, at most "
               "1 s)"),
        Option("min_interval", None, "s", "shortest static interval kept (from min_hold: min_hold less the "
               "window)"),
        Option("estimate_gyro_bias", "auto", "", "fit the gyroscope bias with the rotations (auto: when the "
               "rests do not give it)"),
        Option("gyro_g_sensitivity", "auto", "", "fit the gyroscope's g-sensitivity (auto: when the poses "
               "determine it)"),
        Option("intervals", None, "samples", "static intervals given instead of found"),
    ),
    paper="static_dynamic_interval_detection_fragment.md (Tedaldi, Pretto & Menegatti, ICRA 2014), §2",
    accelerometer_only=True,
)

__all__ = ["calibrate", "uncertainty"]


def uncertainty(recording: Recording, intervals: list[Interval], calibration: Calibration) -> dict[str, float]:
    """1σ standard errors of the linear model's parameters, by name (as in :meth:`Calibration.parameters`).

    From the Jacobians of the two fits at the solution
    (:func:`~imucalib.solve.standard_errors`): the gravity-norm residuals of
    the static means for the accelerometer, the eq. (14) gravity-direction
    residuals for the gyroscope (:func:`imucalib.fit.gyroscope.errors_at`, with
    the rotations :func:`calibrate` left out, and the bias's covariance when it
    came from the static poses, :func:`imucalib.fit.gyroscope.static_gyro`, which
    also gives the g-sensitivity's). The gyroscope's errors treat the
    accelerometer's as fixed. NaN where the data cannot determine a parameter.
    :func:`calibrate` stores the same figures in ``fit.uncertainty.sigma``.
    """
    acc, gyro = calibration.accelerometer, calibration.gyroscope
    fitted = calibration.fit.gyroscope
    out = accelerometer_errors(acc, interval_means(recording.acc, intervals), calibration.gravity)
    weights = np.ones(len(intervals) - 1)
    weights[list(fitted.rotations_left_out or {})] = 0.0
    acc_cov = accelerometer_covariance(acc, interval_means(recording.acc, intervals), calibration.gravity)
    if fitted.bias_source == "joint":
        return out | joint_errors_at(recording, intervals, acc, gyro, fitted, acc_cov=acc_cov)
    estimated = fitted.bias_source == "fit"
    static = static_gyro(recording, intervals, acc, g_sensitivity=bool(np.any(gyro.g_sensitivity)), drift=False)
    return (out | errors_at(recording, intervals, acc, gyro, estimated, weights=weights,
                            bias_cov=None if estimated else static.bias_cov, acc_cov=acc_cov) | static.errors)


def calibrate(
    recording: Recording,
    *,
    gravity: float = STANDARD_GRAVITY,
    init_static: float | None = None, min_hold: float = MIN_HOLD,
    multipliers: Iterable[float] = MULTIPLIERS,
    window: float | None = None,
    min_interval: float | None = None,
    estimate_gyro_bias: bool | str = "auto",
    gyro_g_sensitivity: bool | str = "auto",
    intervals: list[Interval] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Calibration:
    """Calibrate accelerometer and gyroscope by Tedaldi et al. (ICRA 2014).

    Parameters
    ----------
    recording : Recording
        Raw readings (any units) starting with an initial rest, then static
        poses of ≥ ``min_interval`` s with rotations between them.
    gravity : float
        Local gravity [m/s²].
    init_static : float, optional
        Length of the initial rest [s]; found automatically by default.
    min_hold : float
        The shortest hold that is a pose [s]; it sets the detector's window
        and shortest static interval (:func:`imucalib.presets.hold_settings`).
    multipliers : iterable of float
        Detector thresholds to scan, in units of the initial rest's variance norm.
    window, min_interval : float, optional
        Detector window and shortest static interval [s] (default: from ``min_hold``).
    estimate_gyro_bias : bool or "auto"
        ``"auto"``: the bias from the static poses' means and the rotations in
        one cost (:func:`imucalib.fit.gyroscope.fit_gyroscope`); False: from
        the static poses alone; True: from the rotations alone (for a session
        whose rests cannot be trusted).
    gyro_g_sensitivity : bool or "auto"
        Estimate the gyroscope's g-sensitivity from the static poses (True),
        leave it out as Tedaldi 2014 does (False), or keep it where the poses
        support it ("auto", :func:`imucalib.fit.gyroscope.static_gyro`).
    intervals : list of Interval, optional
        Static intervals to use instead of detecting them (the first one is then taken as the initial rest).
    progress : callable, optional
        Called with a short message at each stage.

    Returns
    -------
    Calibration
        ``fit`` holds the figures every method gives (``docs/architecture.rst``) plus ``threshold_multiplier`` and
        ``initial_rest_seconds``. Without a gyroscope (accelerometer-only recording), without rotations recorded
        (poses in blocks), or when no rotation is reliable (:func:`imucalib.segment.no_usable_rotations`:
        saturated, spiking or gapped rotations are left out), the calibration has no gyroscope and
        ``fit.gyroscope.not_calibrated`` says why.

    Examples
    --------
    A short simulated hand-held session (an initial rest, then 14 poses), calibrated by this method alone; the
    scale factors come out within 0.1 % of the simulation's truth:

    >>> from imucalib.methods import tedaldi2014
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> cal = tedaldi2014.calibrate(sim.recording, gravity=sim.truth.gravity)
    >>> (cal.accelerometer.scale / sim.truth.accelerometer.scale).round(3)
    array([1., 1., 1.])
    >>> len(cal.fit.poses.intervals), cal.fit.poses.threshold_multiplier  # the rest and the 14 poses
    (15, 7.0)
    """
    say = progress or (lambda msg: None)
    say("detecting static intervals")
    if intervals is None:
        intervals, mult, rest, acc_model = detect_intervals(
            recording, gravity, init_static=init_static, min_hold=min_hold, multipliers=multipliers,
            window=window, min_interval=min_interval,
        )
    else:
        intervals, mult, rest, acc_model = _given(recording, intervals, gravity)
    means = interval_means(recording.acc, intervals)
    acc_model, which, reduced = _determined(recording, means, gravity,
                                            acc_model if len(intervals) >= FULL_MODEL_POSES else None)
    blocks = recording.gyro is None or pose_blocks(recording) is not None  # no gyroscope, or no rotations recorded
    exclude = {} if blocks else unreliable_transitions(recording, intervals)
    why = None if blocks else no_usable_rotations(intervals, exclude)
    if blocks or why:  # nothing to fit the gyroscope to: the accelerometer's calibration, and why
        return _accelerometer_alone(recording, intervals, acc_model, which, gravity, mult, rest, why, exclude,
                                    reduced=reduced)
    say("calibrating the gyroscope")
    acc_cov = accelerometer_covariance(acc_model, means, gravity, which=which)
    gyro = fit_gyroscope(recording, intervals, acc_model, estimate_bias=estimate_gyro_bias,
                         g_sensitivity=gyro_g_sensitivity, acc_cov=acc_cov, exclude=exclude)
    return assemble("tedaldi2014", recording, intervals, acc_model, gyro.model, gravity=gravity,
                    integrator=gyro.integrator, uncertainty=gyro.errors, unreliable=exclude,
                    figures=_figures(recording, intervals, acc_model, which, gravity, mult, rest, reduced,
                                     gyro.report()))


def _figures(recording: Recording, intervals: list[Interval], acc_model, which, gravity: float, mult: float,
             rest: Interval, reduced: str | None, *records) -> list:
    """The method's own records of the fit report: the detector's threshold, the rest, ``records``, the
    accelerometer's figures and why its model is reduced."""
    means = interval_means(recording.acc, intervals)
    out = [SegmentationReport(threshold_multiplier=mult), *records, rest_seconds(recording, rest),
           accelerometer_figures(acc_model, means, gravity, which)]
    if reduced:
        out.append(AccelerometerReport(model_reduced=reduced))
    return out


def _given(recording: Recording, intervals: list[Interval], gravity: float) -> tuple:
    """The static intervals given, as :func:`detect_intervals` returns those it finds (no detector threshold,
    the first interval the rest, the full linear model only from :data:`FULL_MODEL_POSES` poses)."""
    intervals = [iv for iv in intervals if iv.kind == "static"]
    acc_model = None
    if len(intervals) >= FULL_MODEL_POSES:
        acc_model, _ = fit_gravity_norm(interval_means(recording.acc, intervals), gravity)
    return intervals, float("nan"), intervals[0], acc_model


def _determined(recording: Recording, means: np.ndarray, gravity: float, acc_model) -> tuple:
    """The accelerometer model the poses determine: ``acc_model`` (the full linear model, None for fewer than
    :data:`FULL_MODEL_POSES` poses), or the reduced one of :func:`fit_determined`, with which it is (None: the full
    one) and why its misalignment is held at none (None: it is not)."""
    if acc_model is None:  # few poses: the model they determine (the full one from 9 spread poses)
        acc_model, _, which = fit_determined(means, gravity)
        return acc_model, which, None
    reduced = undetermined_misalignment(acc_model, means, gravity, recording)
    if not reduced:
        return acc_model, None, None
    # a misalignment the poses do not determine is held at none rather than guessed
    acc_model, _, which = fit_determined(means, gravity, richest="scale and bias per axis")
    return acc_model, which, reduced


def undetermined_misalignment(acc_model, means: np.ndarray, gravity: float, recording: Recording) -> str | None:
    """Why the full linear model's misalignment is not determined by these poses, or None when it is.

    A misalignment term whose 1σ moves the calibrated output by more than holding it at none would, and by more
    than the verdict tolerates (:func:`imucalib.verdict.worse_than_nominal`: poses that never visit the
    directions that determine it, e.g. an axis never held down), makes the calibration worse than none: the
    accelerometer is then fitted with a scale and a bias per axis (:func:`fit_determined`), and the verdict
    asks for the poses that would determine the full model.
    """
    figures = accelerometer_figures(acc_model, means, gravity, None)
    cal = Calibration(accelerometer=acc_model, gyroscope=None, gravity=gravity, units=units_of(recording))
    terms = [c.text.split(":")[0].split(".")[-1] for c in worse_than_nominal(cal, figures.uncertainty.sigma or {},
                                                                             cal.parameters())
             if ".misalignment." in c.text.split(":")[0]]
    if not terms:
        return None
    return (f"the poses do not determine the accelerometer's misalignment {', '.join(terms)} (its 1σ would move "
            "the output more than holding it at none): the model is reduced to scale and bias per axis, leaving "
            "out the misalignment (taken as none)")


def _accelerometer_alone(recording: Recording, intervals: list[Interval], acc_model, which, gravity: float,
                         mult: float, rest: Interval, why: str | None = None,
                         left_out: dict[int, str] | None = None, reduced: str | None = None) -> Calibration:
    """The accelerometer part of the method: a calibration with no gyroscope, for an accelerometer-only
    recording, one whose poses were recorded as separate blocks (no rotations between them), or one whose
    rotations were all left out as unreliable (``why``; ``left_out``: the rotations, and why)."""
    not_calibrated = why or (POSES_IN_BLOCKS if recording.gyro is not None else None)
    return assemble("tedaldi2014", recording, intervals, acc_model, None, gravity=gravity,
                    not_calibrated=not_calibrated, left_out=left_out if why else None,
                    figures=_figures(recording, intervals, acc_model, which, gravity, mult, rest, reduced))
