"""Detector presets: the windows, thresholds and shortest intervals the static-pose detectors default to.

One place for the values :mod:`imucalib.segment`, the methods, :mod:`imucalib.validation` and the command
line share, each with its source. Times are in seconds; multipliers are of the initial rest's detector
statistic.
"""

from __future__ import annotations

import math

__all__ = ["BLOCK_MULTIPLIER", "FALL_MIN_LENGTH", "FALL_THRESHOLD", "FULL_MODEL_POSES", "GYRO_MIN_POSES",
           "GYRO_MULTIPLIER", "GYRO_VARIANCE_WINDOW", "MIN_HOLD", "MIN_INTERVAL", "MIN_INTERVALS", "MULTIPLIERS",
           "REST_FACTOR", "REST_MIN_SECONDS", "REST_SHORTEST_SECONDS", "REST_TAP_DEG", "REST_TAP_HORIZON",
           "REST_TAP_SECONDS", "REST_WINDOW", "STILL_N_SIGMA", "STILL_RATE", "STILL_WINDOW", "VALIDATE_MIN_POSES",
           "VALIDATE_MULTIPLIER", "VARIANCE_WINDOW", "hold_settings"]

# ----------------------------------------------- the accelerometer variance detector (Tedaldi 2014)
#: the shortest hold that is a pose [s]: imu_tk's users hold each pose 1–4 s, Tedaldi 2014's procedure 1–2 s
#: (the detection fragment, §2). The variance window and the shortest static run follow from it
#: (:func:`hold_settings`).
MIN_HOLD = 1.0
#: the longest variance window t_w [s] (the window of a detector for holds of 2 s or more)
VARIANCE_WINDOW = 1.0
#: the shortest static interval kept [s] by the detectors that are not given a hold (validation, live recording)
MIN_INTERVAL = 1.0
#: the threshold multipliers scanned, × the initial rest's variance norm (Tedaldi 2014's scan, k = 2 … 10)
MULTIPLIERS = tuple(range(2, 11))
#: the fewest static intervals the multiplier scan accepts, and zhang2021 takes (the initial rest included)
MIN_INTERVALS = 10
#: the fewest static poses from which tedaldi2014 fits the full linear accelerometer model (its 9 parameters;
#: with fewer, the model they determine, :func:`imucalib.fit.accelerometer.fit_determined`)
FULL_MODEL_POSES = 9
#: the fewest static poses a gravity-direction fit of the gyroscope takes (:mod:`imucalib.fit.gyroscope`)
GYRO_MIN_POSES = 4
#: the fewest static poses (the initial rest included) a validation needs (:mod:`imucalib.validation`)
VALIDATE_MIN_POSES = 2
#: the fixed multiplier of a validation recording, too short for a scan (:mod:`imucalib.validation`)
VALIDATE_MULTIPLIER = 6.0
#: the fixed multiplier of the still part of a block (a recording made of blocks has no rotations to scan
#: against): the validation's, × the blocks' median level (:func:`imucalib.segment.blocks.still_blocks`)
BLOCK_MULTIPLIER = VALIDATE_MULTIPLIER



def hold_settings(min_hold: float) -> tuple[float, float]:
    """The variance window and the shortest static run [s] that find every hold of ``min_hold`` seconds.

    A sample is static when the centred window around it lies inside a hold (its variance is the noise's);
    the samples of a hold of ``H`` seconds whose window of ``w`` seconds lies inside it span ``H − w``
    seconds. So the window is at most half the shortest hold (``w = min(VARIANCE_WINDOW, min_hold / 2)``),
    and the shortest run kept is what remains of that hold, ``min_hold − w``: ``min_hold = 2`` gives the
    window and run of 1 s each of Tedaldi 2014's detector as the detection fragment (§2) states it.
    """
    if not (math.isfinite(min_hold) and min_hold > 0):
        raise ValueError(f"the minimum hold must be a positive number of seconds; got {min_hold!r}")
    window = min(VARIANCE_WINDOW, 0.5 * min_hold)
    return window, min_hold - window


# --------------------------------------------------------------------------------- the initial rest
#: the detector window over which the rest's noise level is measured [s]
REST_WINDOW = 1.0
#: the rest ends where a statistic first exceeds this many times its level over the first seconds
REST_FACTOR = 30.0
#: the seconds at the start taken to be at rest when the noise level is measured (the rest the detector would like)
REST_MIN_SECONDS = 2.0
#: the shortest initial rest found automatically [s]; one shorter than :data:`REST_MIN_SECONDS` gets a note
REST_SHORTEST_SECONDS = 1.0
#: a movement of the initial rest at most this long [s], after which the sensor lies as before, is a tap (a knock
#: on the table, a finger on the board): the rest goes on after it
REST_TAP_SECONDS = 0.5
#: … "as before": the mean accelerometer direction before and after it differ by less than this [deg]
REST_TAP_DEG = 1.0
#: how far into a recording a rest cut by taps is looked for [s]
REST_TAP_HORIZON = 120.0

# ----------------------------------------------------- the gyroscope detector (Zhang 2021, eq. 22)
#: the variance window t_w of eq. (22) [s] (Zhang 2021, §IV-A: T_w = 2 s for RD1)
GYRO_VARIANCE_WINDOW = 2.0
#: the threshold n × ζ_init of eq. (22) (Zhang 2021, §IV-A: n = 6 for RD1)
GYRO_MULTIPLIER = 6.0

# ------------------------------------------------------------------------- a still gyroscope
#: a pose is still when the gyroscope's mean rate over STILL_WINDOW s, bias removed, stays below this [rad/s]
STILL_RATE = math.radians(0.7)
#: the window of that mean [s]
STILL_WINDOW = 0.25
#: … or below this many standard deviations of the rest's mean over that window, whichever is larger
STILL_N_SIGMA = 6.0

# ---------------------------------------------------------------- free fall (Zhang 2021, §IV-C)
#: the weightless loss (Zhang 2021, eq. 19) below which a sample is falling [m/s²]
FALL_THRESHOLD = 2.5
#: the shortest fall kept [s]
FALL_MIN_LENGTH = 0.05
