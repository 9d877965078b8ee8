"""The calibration against the raw readings: a calibration worse than none is rejected.

Readings in physical units (declared with ``--acc-unit`` / ``--gyro-unit``, or recognised by the reader from
a header or a format) are a calibration already: the *identity* one, with no bias, the unit's nominal scale
(1 for m/s² and rad/s, π/180 for deg/s, ``g`` for g) and no misalignment. A fit that follows the noise of a
few poses, or that was fitted to a few of the rotations, can leave the readings worse than they came in; its
own figures, over the data it was fitted to, do not show it. Two figures, each computed by the same
function for the calibration and for the identity on the same data, do:

* ``|a| − g`` RMS over the static poses (:func:`imucalib.metrics.gravity_residuals`: each pose's raw mean
  calibrated, Zhang 2021 eq. (10));
* the mean gravity-direction error over **every** rotation between consecutive poses
  (:func:`imucalib.metrics.gravity_direction_errors`: each rotation integrated from the gyroscope, Tedaldi
  2014 §IV-B; Zhang 2021 eq. (14)), the rotations the fit left out for spikes, saturation, gaps or an
  error far from the others' included: the identity sees the same faults, so the comparison is fair, and a
  gyroscope fitted on a few rotations is judged on all of them.

A calibration whose figure is larger than the raw readings' (strictly: the raw readings are better) is
rejected, with both figures. Readings in counts have no identity calibration to compare with: the check
is skipped and a note says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..calibration import Calibration
from ..fitreport import AccelerometerReport, FitReport, GyroscopeReport
from ..metrics import gravity_direction_errors
from ..models import TriadModel
from .base import NOMINAL, Check, Poses

__all__ = ["PHYSICAL_UNITS", "RawComparison", "compare_with_raw", "raw_checks", "raw_scale"]

#: the raw units whose readings are a calibration already (the identity one), per sensor
PHYSICAL_UNITS = {"accelerometer": ("g", "m/s^2"), "gyroscope": ("deg/s", "rad/s")}


def raw_scale(calibration: Calibration, sensor: str) -> float | None:
    """The nominal factor [SI per raw unit] of ``sensor``'s declared raw unit; None for counts (no identity)."""
    unit = (calibration.units.get(sensor) or {}).get("raw")
    if unit not in PHYSICAL_UNITS[sensor]:
        return None
    return float(calibration.gravity) if unit == "g" else float(NOMINAL[unit])


@dataclass(frozen=True)
class RawComparison:
    """The calibration's figures beside the raw readings' (the identity calibration's), on the same data.

    Attributes
    ----------
    residual_rms, residual_rms_raw : float or None
        ``|a| − g`` RMS over the static poses [m/s²], calibrated and raw; None when the accelerometer's
        readings are counts.
    angle_error_mean_deg, angle_error_mean_deg_raw : float or None
        The mean gravity-direction error over every rotation between the poses [deg], calibrated and raw;
        None without a calibrated gyroscope, with fewer than two poses, or when either sensor's readings are
        counts.
    poses, rotations : int
        How many poses and rotations the figures are over.
    skipped : tuple of str
        Why a figure was not compared, in words.

    Examples
    --------
    What :func:`compare_with_raw` returns; readings in counts have no figures of their own:

    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> from imucalib.verdict.base import Poses
    >>> from imucalib.verdict.raw import compare_with_raw
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> found = compare_with_raw(Poses(sim.truth, sim.recording, intervals))
    >>> found.poses, found.rotations, found.residual_rms_raw, found.skipped
    (15, 14, None,
     ("the accelerometer's readings are counts", "the gyroscope's readings are counts"))
    """

    residual_rms: float | None
    residual_rms_raw: float | None
    angle_error_mean_deg: float | None
    angle_error_mean_deg_raw: float | None
    poses: int
    rotations: int
    skipped: tuple[str, ...]


def compare_with_raw(found: Poses) -> RawComparison:
    """The calibration of ``found`` and the identity calibration, on ``found``'s poses and rotations.

    Parameters
    ----------
    found : Poses
        The poses, the rotations between them and the calibration, as the verdict found them.

    Returns
    -------
    RawComparison
        The calibration's figures beside the raw readings' (None where the readings are counts).

    Examples
    --------
    Readings already in m/s² and rad/s (a simulated session calibrated by its truth), calibrated again: the
    new calibration is better than the readings taken as they are:

    >>> from imucalib import Interval
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> from imucalib.verdict.base import Poses
    >>> from imucalib.verdict.raw import compare_with_raw
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> readings = sim.truth.apply(sim.recording)
    >>> cal = calibrate(readings)
    >>> intervals = [Interval(a, b) for a, b in cal.fit.poses.intervals]
    >>> found = compare_with_raw(Poses(cal, readings, intervals))
    >>> found.residual_rms < found.residual_rms_raw
    True
    >>> found.angle_error_mean_deg < found.angle_error_mean_deg_raw
    True
    """
    calibration, recording, intervals = found.calibration, found.recording, found.intervals
    g = calibration.gravity
    k_acc = raw_scale(calibration, "accelerometer")
    has_gyro = calibration.gyroscope is not None and recording.gyro is not None and len(intervals) >= 2
    k_gyro = raw_scale(calibration, "gyroscope") if has_gyro else None
    skipped = []
    rms = rms_raw = angle = angle_raw = None
    if k_acc is None:
        skipped.append("the accelerometer's readings are counts")
    elif intervals:
        raw_up = k_acc * np.asarray(found.means)  # the identity calibration: the nominal scale only
        rms = float(np.sqrt(np.mean((np.linalg.norm(found.up, axis=1) - g) ** 2)))
        rms_raw = float(np.sqrt(np.mean((np.linalg.norm(raw_up, axis=1) - g) ** 2)))
    if has_gyro and k_gyro is None:
        skipped.append("the gyroscope's readings are counts")
    if has_gyro and k_gyro is not None and k_acc is not None:
        identity = calibration.with_(
            accelerometer=TriadModel(shape="upper", scale=np.full(3, k_acc)),
            gyroscope=TriadModel(shape="full", scale=np.full(3, k_gyro)),
            lever_arm=None, magnetometer=None, thermal=None)
        angle = float(np.degrees(np.mean(found.direction_errors)))
        errors_raw = gravity_direction_errors(identity, recording, intervals, up=k_acc * np.asarray(found.means))
        angle_raw = float(np.degrees(np.mean(errors_raw)))
    return RawComparison(rms, rms_raw, angle, angle_raw, len(intervals), max(len(intervals) - 1, 0),
                         tuple(skipped))


def raw_checks(calibration: Calibration, found: Poses | None, fitted: bool = True) -> tuple[list[Check], FitReport]:
    """Rejected when the calibration leaves ``|a| − g`` or the gyroscope's gravity-direction error larger than
    the raw readings do (:func:`compare_with_raw`); a note when the readings are counts.

    ``fitted=False``: ``found`` is a recording the calibration was not made from (``validate``), and the
    reason says the sensor has changed since. Returns the findings and the figures
    ``accelerometer_residual_rms_raw`` and
    ``gyroscope_angle_error_mean_deg_raw`` (beside ``accelerometer_residual_rms`` and
    ``gyroscope_angle_error_mean_deg``, the calibrated ones over the same poses and every rotation).
    """
    if found is None or not found.intervals:
        return [], FitReport()
    c = compare_with_raw(found)
    figures = FitReport()
    worse = []
    if c.residual_rms_raw is not None:
        figures = figures.add(AccelerometerReport(residual_rms_raw=c.residual_rms_raw))
        if c.residual_rms > c.residual_rms_raw:
            ratio = c.residual_rms / c.residual_rms_raw if c.residual_rms_raw > 0 else np.inf
            worse.append(f"|a| − g RMS over the {c.poses} poses is {c.residual_rms:.3g} m/s² calibrated against "
                         f"{c.residual_rms_raw:.3g} m/s² raw ({ratio:.3g}×)")
    if c.angle_error_mean_deg_raw is not None:
        figures = figures.add(GyroscopeReport(angle_error_mean_deg_raw=c.angle_error_mean_deg_raw))
        if c.angle_error_mean_deg > c.angle_error_mean_deg_raw:
            ratio = c.angle_error_mean_deg / c.angle_error_mean_deg_raw if c.angle_error_mean_deg_raw > 0 else np.inf
            worse.append(f"the gravity-direction error over all {c.rotations} rotations between poses (those left "
                         f"out of the fit included) is {c.angle_error_mean_deg:.3g}° (mean) calibrated against "
                         f"{c.angle_error_mean_deg_raw:.3g}° raw ({ratio:.3g}×)")
    checks = []
    if worse:
        why = ("The fit holds on what it was fitted to, not on the rest (too few poses or rotations, or "
               "rotations it left out): the raw readings are better than this calibration; record again with more "
               "poses and rotations, turning slowly (no spikes, no clipping), or choose a method that suits the "
               "recording" if fitted else
               "On this recording the raw readings are better than this calibration: the sensor has changed since "
               "it was calibrated (its biases moved, or it is another sensor); calibrate it again")
        checks.append(Check(2, "the calibration is worse than the raw readings (no bias, the unit's nominal "
                               f"scale, no misalignment): {'; '.join(worse)}. {why}"))
    if c.skipped:
        counts = ("the accelerometer's and the gyroscope's readings are counts" if len(c.skipped) == 2
                  else c.skipped[0])
        checks.append(Check(0, f"{counts} (no physical unit declared or recognised): the "
                               "calibration is not compared with the raw readings (pass --acc-unit and --gyro-unit "
                               "if the readings are in physical units)"))
    return checks, figures
