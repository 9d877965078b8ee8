"""Check a calibration on a recording it was not made from, without refitting it.

A calibration made today says little about tomorrow's data by its own fit
figures: the sensor may have warmed, aged or been knocked. :func:`validate`
finds the static poses of a new recording without fitting anything, computes
the fit figures the calibration file holds (:func:`imucalib.metrics.fit_summary`)
on them with the calibration as it is, sets them beside the figures it had
when it was made, and gives the calibration a verdict on this recording
(:func:`imucalib.verdict.assess` with ``purpose="validate"``).

The poses: the initial rest (:func:`imucalib.segment.initial_rest`), then the
accelerometer variance detector of Tedaldi 2014 at a fixed threshold of
:data:`THRESHOLD_MULTIPLIER` × the rest's variance norm (1 s window, poses of
at least 1 s), cut to where the gyroscope is still (:func:`imucalib.segment.gyro_still`)
by the calibration's own gyroscope scale. No multiplier scan and no rough
scale: both need a fit, and a short check recording (a rest, one turn, one
pose) holds too few poses for one.
"""

from __future__ import annotations

import warnings

import numpy as np

from .calibration import Calibration
from .fitreport import FitReport
from .metrics import fit_summary, gap_flags
from .presets import MIN_HOLD, VALIDATE_MIN_POSES, VALIDATE_MULTIPLIER, hold_settings
from .recording import ImucalibWarning, Interval, Recording
from .segment import gyro_still, initial_rest, static_at, still_intervals
from .thermal import compensate
from .upright import inverted_rest_note
from .verdict import assess

__all__ = ["MIN_POSES", "RAW_KEYS", "THRESHOLD_MULTIPLIER", "VALIDATION_KEYS", "find_poses", "validate"]

#: the fit figures compared between the new recording and the calibration's own
VALIDATION_KEYS = ("accelerometer_residual_rms", "gyroscope_angle_error_mean_deg",
                   "gyroscope_angle_error_max_deg", "temperature_c")
#: the raw readings' figures on the new recording (the identity calibration, physical units only:
#: :mod:`imucalib.verdict.raw`), beside the calibrated ``accelerometer_residual_rms`` and
#: ``gyroscope_angle_error_mean_deg``
RAW_KEYS = ("accelerometer_residual_rms_raw", "gyroscope_angle_error_mean_deg_raw")
#: the accelerometer detector's threshold, in multiples of the initial rest's variance norm
THRESHOLD_MULTIPLIER = VALIDATE_MULTIPLIER
#: the fewest static poses (the initial rest included) a validation needs
MIN_POSES = VALIDATE_MIN_POSES


def find_poses(calibration: Calibration, recording: Recording, *, init_static: float | None = None,
               min_hold: float = MIN_HOLD) -> list[Interval]:
    """The static poses of ``recording``, found without fitting anything; the first is the initial rest.

    Parameters
    ----------
    calibration : Calibration
        Gives the gyroscope scale [rad/s per raw unit] that puts the stillness
        limit of :func:`imucalib.segment.gyro_still` in raw units.
    recording : Recording
        Starts with a rest.
    init_static : float, optional
        Length of the initial rest [s] (default: found automatically).
    min_hold : float
        The shortest hold that is a pose [s]: the detector's window and
        shortest run follow from it (:func:`imucalib.presets.hold_settings`).

    Raises
    ------
    ValueError
        Without an initial rest, or when the accelerometer is noise-free at rest.
    """
    rest = initial_rest(recording, init_static)
    # the detector at one threshold, without the scan's fits
    window, run = hold_settings(min_hold)
    candidates = static_at(recording, rest, THRESHOLD_MULTIPLIER, window=window, min_interval=run)
    if recording.gyro is None or calibration.gyroscope is None:  # accelerometer-only: the detector's poses
        return candidates
    scale = float(np.mean(np.abs(calibration.gyroscope.scale)))
    still = gyro_still(recording, rest, scale, candidates)
    return still_intervals(candidates, still, max(int(round(run * recording.rate)), 2))


def _ratio(now, then) -> float | None:
    if isinstance(now, int | float) and isinstance(then, int | float) and then:
        return float(now) / float(then)
    return None


def validate(calibration: Calibration, recording: Recording, gravity: float | None = None, *,
             init_static: float | None = None, min_hold: float = MIN_HOLD) -> dict:
    """A calibration's fit figures and verdict on a new recording, beside the figures it had at calibration.

    Parameters
    ----------
    calibration : Calibration
        The calibration to check; it is applied as it is (no refit).
    recording : Recording
        A recording that starts with a rest and has at least one more static
        pose (one turn is enough), in the raw units the calibration maps.
    gravity : float, optional
        Local gravity [m/s²] (default: the calibration's).
    init_static : float, optional
        Length of the initial rest [s] (default: found automatically).
    min_hold : float
        The shortest hold that is a pose [s] (:func:`find_poses`).

    Returns
    -------
    dict
        ``{"method", "gravity", "verdict", "verdict_reasons", "verdict_notes",
        "static_intervals", "accelerometer_residual_rms",
        "gyroscope_angle_error_mean_deg", "gyroscope_angle_error_max_deg",
        "temperature_c", "accelerometer_noise_floor", "accelerometer_residual_to_noise",
        "gyroscope_angle_error_predicted_deg", "gyroscope_error_to_noise",
        "accelerometer_residual_rms_raw", "gyroscope_angle_error_mean_deg_raw",
        "at_calibration": {...}, "ratios": {...}, "own_recording", "intervals"}``: the verdict of the
        calibration on this recording (``accepted``, ``suspect`` or ``rejected``,
        with the reasons, worst first), the figures on this recording (``None``
        where one cannot be computed, e.g. the temperature of a recording
        without one), the same figures and ``static_intervals`` from the
        calibration's own ``fit``, the ratios now / at calibration of the
        residual, the angle errors and the residual-to-noise figure (``None``
        where either is missing), and the poses as ``[start, stop)`` sample
        ranges. The ``…_raw`` figures are the raw readings' on this recording (the
        identity calibration, :mod:`imucalib.verdict.raw`; ``None`` for readings in
        counts): a calibration worse than them is rejected, as ``calibrate`` rejects it.
        Rotations with sampling gaps are named in ``verdict_notes``. ``own_recording`` is True when the
        recording is the one the calibration was made from, or a part of it
        (:meth:`~imucalib.calibration.Calibration.is_own_session`: known for a calibration that stored its
        session, i.e. one with a drifting gyroscope bias): then the check is no check of new data.

    Raises
    ------
    ValueError
        When the recording is not in the calibration's raw units, does not
        start with a rest, or has fewer than :data:`MIN_POSES` static poses.

    Examples
    --------
    A calibration checked on a recording of another device is rejected:

    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> from imucalib.validation import validate
    >>> cal = calibrate(session("handheld", rng=1, rest=10, n_poses=14).recording)
    >>> other = session("handheld", rng=3, rest=10, n_poses=14)
    >>> found = validate(cal, other.recording)
    >>> found["verdict"], found["own_recording"]
    ('rejected', False)
    >>> found["verdict_reasons"][0]
    'the gravity-norm residual is 148× the white-noise floor (limit 8×): ...'
    """
    gravity = gravity or calibration.gravity
    calibration.check_units(recording)
    then = calibration.fit
    own = calibration.is_own_session(recording)
    # a calibration that follows temperature: the recording compensated to its reference temperature, then
    # judged with the calibration there (thermal.py, T2)
    calibration, recording = compensate(calibration, recording)
    poses = find_poses(calibration, recording, init_static=init_static, min_hold=min_hold)
    if len(poses) < MIN_POSES:
        raise ValueError(
            f"{len(poses)} static pose(s) found in the {recording.duration:.3g} s recording; validate needs "
            f"the initial rest and at least {MIN_POSES - 1} more pose: after the rest, turn the sensor and hold "
            f"it still for at least {min_hold:g} s (the initial rest sets the detector's threshold: if it is "
            "found too short, give its length with --init-static SECONDS)")
    fit = fit_summary(calibration, recording, poses, gravity)
    note = inverted_rest_note(calibration, recording, poses[0])  # the sign convention (upright.py)
    if note is not None:
        warnings.warn(note, ImucalibWarning, stacklevel=2)
    # the checks apply to this recording: the calibration's own fit (its poses, turns, errors) is left behind
    verdict = assess(calibration.with_(gravity=gravity, fit=fit), recording, poses, purpose="validate")
    figures, before = _figures(fit.add(verdict)), _figures(then)
    reliable = verdict.gyroscope.angle_error_reliable_mean_deg
    return {"method": calibration.method, "gravity": gravity, "verdict": verdict.verdict.level,
            "verdict_reasons": verdict.verdict.reasons,
            # the gaps' rotations' angle errors are unreliable
            "verdict_notes": verdict.verdict.notes + gap_flags(recording, poses),
            **({} if reliable is None else {"gyroscope_angle_error_reliable_mean_deg": reliable}),
            **figures, "at_calibration": before,
            "ratios": {k: _ratio(figures[k], before[k])
                       for k in (*VALIDATION_KEYS[:3], "accelerometer_residual_to_noise")},
            "own_recording": own, "intervals": fit.poses.intervals}


def _figures(report: FitReport) -> dict:
    """The figures a validation compares, by name: the poses, :data:`VALIDATION_KEYS`, the noise floor, the
    gyroscope against its noise and :data:`RAW_KEYS`."""
    acc, gyro = report.accelerometer, report.gyroscope
    return {"static_intervals": report.poses.static_intervals, "accelerometer_residual_rms": acc.residual_rms,
            "gyroscope_angle_error_mean_deg": gyro.angle_error_mean_deg,
            "gyroscope_angle_error_max_deg": gyro.angle_error_max_deg, "temperature_c": report.thermal.temperature_c,
            "accelerometer_noise_floor": acc.noise_floor, "accelerometer_residual_to_noise": acc.residual_to_noise,
            "gyroscope_angle_error_predicted_deg": gyro.angle_error_predicted_deg,
            "gyroscope_error_to_noise": gyro.error_to_noise, "accelerometer_residual_rms_raw": acc.residual_rms_raw,
            "gyroscope_angle_error_mean_deg_raw": gyro.angle_error_mean_deg_raw}
