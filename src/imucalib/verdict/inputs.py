"""The checks of the inputs: a sampling rate an IMU records at, a time base a hand turns at, a gravity found on Earth.

A wrong time base or unit explains everything after it, so :func:`imucalib.verdict.assess` runs these first;
:func:`check_rate` refuses a recording before anything is fitted.
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..constants import GRAVITY_RANGE
from ..fit.accelerometer import fit_sphere
from ..metrics import transition_bounds
from ..recording import Interval, Recording
from .base import THRESHOLDS, Check, Poses, grade

__all__ = ["check_rate", "gravity_checks", "time_base_checks", "time_unit_hint", "turn_speed"]


def check_rate(recording: Recording) -> None:
    """Raise ValueError at a sampling rate no IMU records at: the time base is wrong and nothing can be fitted.

    Parameters
    ----------
    recording : Recording
        The recording whose sampling rate is checked.

    Returns
    -------
    None

    Raises
    ------
    ValueError
        At a sampling rate no IMU records at (the time base is in the wrong unit, or broken).

    Examples
    --------
    Times in milliseconds read as seconds make a 1 kHz recording a 1 mHz one:

    >>> import numpy as np
    >>> from imucalib import Recording
    >>> from imucalib.verdict import check_rate
    >>> check_rate(Recording(np.arange(10) / 1000, np.zeros((10, 3)), None))  # 1 kHz: fine
    >>> check_rate(Recording(np.arange(10) * 1000.0, np.zeros((10, 3)), None))
    Traceback (most recent call last):
        ...
    ValueError: the sampling rate is 0.001 Hz, outside 5-50000 Hz where IMUs record: ...
    """
    rate = recording.rate
    lo, hi = THRESHOLDS["rate_hz"]
    if not lo <= rate <= hi:
        raise ValueError(f"the sampling rate is {rate:.4g} Hz, outside {lo:g}-{hi:g} Hz where IMUs record: "
                         f"{time_unit_hint(recording)}")


#: the time units a time column can be read in, and their length [s]
_TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
_TIME_NAMES = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}


def time_unit_hint(recording: Recording) -> str:
    """What a sampling rate outside an IMU's range most likely means: which time unit was read as which.

    The time column was read in ``metadata["time_unit"]``; the other unit that
    puts the rate at 10 Hz-2 kHz (where most IMUs record) is named, e.g.
    "the timestamps look like milliseconds read as microseconds (62.5 Hz then)".
    """
    read_as = recording.metadata.get("time_unit")
    if read_as not in _TIME_UNITS:
        return "the time base is probably wrong (a time column in another unit, or a wrong --rate)"
    for unit, length in _TIME_UNITS.items():
        rate = recording.rate * _TIME_UNITS[read_as] / length  # the stamps were in unit, not read_as
        if unit != read_as and 10 <= rate <= 2000:
            return (f"the timestamps look like {_TIME_NAMES[unit]} read as {_TIME_NAMES[read_as]} ({rate:.4g} Hz "
                    f"then): pass --time-unit {unit}")
    return f"the time column (read in {_TIME_NAMES[read_as]}) is probably in another unit: see --time-unit"


def turn_speed(calibration: Calibration, recording: Recording, intervals: list[Interval]) -> float:
    """Median angular speed [deg/s] the accelerometer sees between poses (turns above 10°); NaN without any.

    The angle between the calibrated gravity directions of consecutive poses
    over the time between them: independent of the gyroscope and its unit.

    Parameters
    ----------
    calibration : Calibration
        Its accelerometer gives the gravity directions.
    recording : Recording
        The recording.
    intervals : list of Interval
        Its static poses, in time order.

    Returns
    -------
    float
        The median angular speed [deg/s], NaN without a turn above 10°.

    Examples
    --------
    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> from imucalib.verdict import turn_speed
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> round(turn_speed(sim.truth, sim.recording, intervals))  # deg/s, a hand's pace
    35
    """
    return _turn_speed(Poses(calibration, recording, intervals))


def _turn_speed(found: Poses) -> float:
    """:func:`turn_speed` from the poses' figures of one assessment."""
    recording, intervals = found.recording, found.intervals
    if len(intervals) < 2:
        return float("nan")
    acc = found.up
    u = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    ang = np.degrees(np.arccos(np.clip(np.sum(u[:-1] * u[1:], axis=1), -1, 1)))
    starts, stops = transition_bounds(intervals)
    dur = recording.t[stops] - recording.t[starts]
    ok = (ang > 10) & (dur > 0)
    return float(np.median(ang[ok] / dur[ok])) if np.any(ok) else float("nan")


def time_base_checks(found: Poses) -> list[Check]:
    """The time base judged by the turn speed the accelerometer sees between poses (:func:`turn_speed`): suspect
    outside a hand's range, rejected ten times beyond it."""
    speed = _turn_speed(found)
    lo, hi = THRESHOLDS["turn_speed_deg_s"]
    if not np.isfinite(speed) or lo <= speed <= hi:
        return []
    if not lo / 10 <= speed <= hi * 10:
        return [Check(2, f"between poses the accelerometer sees the sensor turn at {speed:.3g} deg/s (median), "
                         f"where a hand turns at {lo:g}-{hi:g} deg/s: the time base is wrong (check the time "
                         "column's unit)")]
    return [Check(1, f"between poses the accelerometer sees the sensor turn at {speed:.3g} deg/s (median), "
                     f"outside the {lo:g}-{hi:g} deg/s of a hand: check the time base")]


def gravity_checks(calibration: Calibration, found: Poses | None) -> list[Check]:
    """The declared gravity against the range on Earth's surface and, with physical accelerometer units, against
    the raw ``|a|`` at rest (the radius of the sphere through the poses' means)."""
    recording, intervals = (None, []) if found is None else (found.recording, found.intervals)
    g = calibration.gravity
    out = []
    lo, hi = GRAVITY_RANGE  # the command line warns outside the same range
    if not lo <= g <= hi:
        out.append(Check(2, f"the declared gravity {g:.5g} m/s² is outside {lo}-{hi} m/s², the range on Earth's "
                            "surface (a typo, or a value in g?); every accelerometer scale factor is off by the "
                            "same ratio"))
    unit = calibration.units["accelerometer"]["raw"]
    if recording is not None and len(intervals) >= 4 and unit in ("g", "m/s^2"):
        factor = g if unit == "g" else 1.0
        # the radius of the sphere through the static means: |a| at rest with the biases taken out
        means = found.means
        try:
            radius = g / float(fit_sphere(means, g).scale[0])
        except ValueError:
            radius = float(np.median(np.linalg.norm(means, axis=1)))
        norm = radius * factor
        rel = abs(norm / g - 1)
        level = grade(rel, THRESHOLDS["rest_norm_rel"])
        if level:
            out.append(Check(level, f"the raw |a| at rest is {norm:.4g} m/s² (read as {unit}, biases taken out), "
                                    f"{100 * rel:.1f} % "
                                    f"from the declared gravity {g:.5g} m/s²: check --gravity and --acc-unit"))
    return out
