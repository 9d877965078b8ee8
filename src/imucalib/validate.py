"""Check a calibration on a recording it was not made from, without refitting it.

A calibration made today says little about tomorrow's data by its own fit
figures: the sensor may have warmed, aged or been knocked. :func:`validate`
detects the static poses of a new recording (the Tedaldi 2014 detector, as
``tedaldi2014`` uses), computes the same fit figures the calibration file
holds (:func:`imucalib.metrics.fit_summary`) on them with the calibration as
it is, and sets them beside the figures it had when it was made.
"""

from __future__ import annotations

from .calibration import Calibration
from .metrics import fit_summary
from .recording import Recording
from .segment import detect_intervals

__all__ = ["VALIDATION_KEYS", "validate"]

#: the fit figures compared between the new recording and the calibration's own
VALIDATION_KEYS = ("accelerometer_residual_rms", "gyroscope_angle_error_mean_deg",
                   "gyroscope_angle_error_max_deg", "temperature_c")


def validate(calibration: Calibration, recording: Recording, gravity: float | None = None) -> dict:
    """A calibration's fit figures on a new recording, beside the ones it had at calibration.

    Parameters
    ----------
    calibration : Calibration
        The calibration to check; it is applied as it is (no refit).
    recording : Recording
        A recording of static poses joined by rotations, in the raw units the
        calibration maps.
    gravity : float, optional
        Local gravity [m/s²] (default: the calibration's).

    Returns
    -------
    dict
        ``{"method", "gravity", "static_intervals", "accelerometer_residual_rms",
        "gyroscope_angle_error_mean_deg", "gyroscope_angle_error_max_deg",
        "temperature_c", "at_calibration": {...}, "intervals"}``: the figures on
        this recording (``None`` where one cannot be computed, e.g. the angle
        errors with fewer than two poses, or the temperature of a recording
        without one), the same figures and ``static_intervals`` from the
        calibration's own ``fit``, and the detected poses as ``[start, stop)``
        sample ranges.

    Raises
    ------
    ValueError
        When the recording is not in the calibration's raw units, or too few
        static poses are found in it.
    """
    gravity = gravity or calibration.gravity
    calibration.check_units(recording)
    intervals = detect_intervals(recording, gravity)[0]
    fit = fit_summary(calibration, recording, intervals, gravity)
    then = calibration.fit or {}
    return {"method": calibration.method, "gravity": gravity, "static_intervals": fit["static_intervals"],
            **{k: fit.get(k) for k in VALIDATION_KEYS},
            "at_calibration": {k: then.get(k) for k in ("static_intervals", *VALIDATION_KEYS)},
            "intervals": fit["intervals"]}
