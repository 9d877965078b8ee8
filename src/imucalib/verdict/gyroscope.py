"""The gyroscope's checks: its error between poses against the noise, its rate at rest, its rotations, known turns.

Each returns the :class:`~imucalib.verdict.base.Check` s :func:`imucalib.verdict.assess` gathers (and, where the
check rests on figures of its own, the :class:`~imucalib.fitreport.GyroscopeReport` of them).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..fitreport import GyroscopeReport
from ..recording import Interval, Recording
from .base import GYRO_ROTATION_PARAMETERS, THRESHOLDS, Check, Poses, grade, predicted_error_of, rest_rates_of

__all__ = ["bias_drift_checks", "gyroscope_noise_checks", "known_turn_checks", "rest_rate_checks",
           "rotations_used_checks"]


def gyroscope_noise_checks(calibration: Calibration, found: Poses) -> tuple[list[Check], GyroscopeReport]:
    """The gyroscope's gravity-direction error between poses against what the sensor noise alone predicts.

    Judged on every rotation whose integration the data allow (:func:`imucalib.segment.unreliable_transitions`
    finds the rest: saturated samples, spikes, sampling gaps, unsteady poses — faults of the data, found from
    the recording alone), the ones the fit left out because their error was far from the others' included:
    ``calibrate`` and ``validate`` judge the same rotations of the same data by the same limits.
    """
    intervals = found.intervals
    fit = calibration.fit
    if fit.gyroscope.angle_error_mean_deg is None or len(intervals) < 2:
        return [], GyroscopeReport()
    pred = predicted_error_of(found, None)
    errors = found.direction_errors
    left_out = fit.gyroscope.rotations_left_out or {}
    left = set(left_out)
    faulty = found.unreliable
    judged = np.array([k not in faulty for k in range(len(pred))])
    figures = GyroscopeReport()
    out = []
    if left:
        kept = np.array([k not in left for k in range(len(pred))])
        if np.any(kept):
            figures = figures.with_(angle_error_kept_mean_deg=float(np.degrees(np.mean(errors[kept]))))
        if len(left) > len(pred) / 3:
            out.append(Check(1, f"{len(left)} of the {len(pred)} rotations between poses were left out of the "
                                "gyroscope fit (notes below say why): the rest may not cover every axis well"))
    if np.any(judged):
        mean_deg = float(np.degrees(np.mean(errors[judged])))
        pred_deg = float(np.degrees(np.mean(pred[judged])))
        ratio = mean_deg / pred_deg if pred_deg > 0 else float("inf")
        figures = figures.with_(angle_error_predicted_deg=pred_deg, error_to_noise=ratio)
        if faulty:
            figures = figures.with_(angle_error_reliable_mean_deg=mean_deg)
        floor = THRESHOLDS["gyro_error_floor_deg"]
        level = min(grade(ratio, THRESHOLDS["gyro_error_to_noise"]), grade(mean_deg, floor))
        over = (f" over the {int(np.sum(judged))} rotations without saturated samples, spikes or gaps"
                if faulty else "")
        if level:
            out.append(Check(level, f"the gyroscope's gravity-direction error between poses is {mean_deg:.3g}° "
                                    f"(mean{over}), {ratio:.3g}× the {pred_deg:.2g}° the sensor noise alone "
                                    f"predicts for these rotations (limit {THRESHOLDS['gyro_error_to_noise'][0]:g}×): "
                                    "the gyroscope calibration does not explain the rotations"))
    for k, why in sorted(left_out.items()):
        out.append(Check(0, f"the rotation from pose {k + 1} to {k + 2} was left out of the gyroscope "
                            f"fit: {why}"))
    return out, figures


def rest_rate_checks(found: Poses) -> tuple[list[Check], GyroscopeReport]:
    """The calibrated gyroscope at rest against what the poses' scatter allows.

    Per axis, the mean calibrated rate over the static poses ``r̄`` (each pose
    one weight) against its standard error ``s/√M`` from the scatter ``s`` of
    the poses' means (noise, tremor, drift: whatever makes them differ): a
    bias the poses support leaves ``|r̄| ≲ 3 s/√M``. A bias taken from the
    rotations alone, or from a rest that was not still, reads tens of times
    that. Below ``rest_rate_floor_deg_s`` the figure is not a reason.
    """
    if len(found.intervals) < 4:
        return [], GyroscopeReport()
    w = np.degrees(rest_rates_of(found))
    m = w.shape[0]
    mean = w.mean(axis=0)
    se = w.std(axis=0, ddof=1) / np.sqrt(m)
    z = np.divide(np.abs(mean), se, out=np.full(3, np.inf), where=se > 0)
    z[(mean == 0)] = 0.0
    figures = GyroscopeReport(rest_rate_deg_s=[float(x) for x in mean], rest_rate_to_scatter=float(z.max()))
    levels = [min(grade(float(z[j]), THRESHOLDS["rest_rate_to_scatter"]),
                  grade(float(abs(mean[j])), THRESHOLDS["rest_rate_floor_deg_s"])) for j in range(3)]
    j = int(np.argmax(levels))
    if not levels[j]:
        return [], figures
    return [Check(levels[j], f"at rest the calibrated gyroscope reads {mean[j]:.3g} °/s about {'xyz'[j]} (mean over "
                             f"the {m} static poses), {z[j]:.3g}× the {se[j]:.2g} °/s the poses' scatter allows "
                             f"(limit {THRESHOLDS['rest_rate_to_scatter'][0]:g}×): the gyroscope bias is not what "
                             "the sensor reads at rest")], figures


def rotations_used_checks(calibration: Calibration, intervals: list[Interval]) -> list[Check]:
    """Enough rotations for the gyroscope's parameters: two direction components per rotation kept."""
    fit = calibration.fit
    if fit.gyroscope.bias_source is None or len(intervals) < 2:  # not a fit over the rotations between poses
        return []
    n = len(intervals) - 1
    kept = n - len(fit.gyroscope.rotations_left_out or {})
    per = 2 * kept / GYRO_ROTATION_PARAMETERS
    lim = THRESHOLDS["rotations_per_parameter"]
    level = 2 if per <= lim[1] else 1 if per < lim[0] else 0
    if not level:
        return []
    return [Check(level, f"the gyroscope rests on {kept} of the {n} rotations between poses ({2 * kept} direction "
                         f"components for its {GYRO_ROTATION_PARAMETERS} scale and misalignment parameters, "
                         f"{per:.2g} per parameter; at least {lim[0]:g} wanted): "
                         + ("they cannot determine it" if level == 2 else "too few to determine it well")
                         + "; record again without gaps, with more rotations")]


def known_turn_checks(calibration: Calibration, recording: Recording) -> list[Check]:
    """Each turn by a known angle (``fit.gyroscope.turn_sections``) re-integrated with the calibration, against
    that angle."""
    fit = calibration.fit
    turns = fit.gyroscope.turn_sections
    angle = fit.gyroscope.turn_angle_deg
    if not turns or not angle:
        return []
    out = []
    lim = THRESHOLDS["turn_angle_rel"]
    for sec in turns:
        s0, s1, axis = int(sec["start"]), int(sec["stop"]), int(sec["axis"])
        measured = sec.get("measured_deg")
        if measured is None:
            w = calibration.gyroscope_si(recording.gyro[s0:s1], recording.acc[s0:s1])
            measured = float(np.degrees(abs(np.trapezoid(w[:, axis], recording.t[s0:s1]))))
        rel = abs(measured / angle - 1)
        level = grade(rel, lim)
        if "measured_deg" in sec and level == 1:
            level = 0  # one rough scale for all three axes is itself good to a few per cent only
        if level:
            how = "by the poses' rough gyroscope scale" if "measured_deg" in sec else "with this calibration"
            out.append(Check(level, f"the turn about {'xyz'[axis]} (samples {s0}-{s1}) measures {measured:.4g}° "
                                    f"{how}, {100 * rel:.0f} % from the known angle {angle:g}° (limit "
                                    f"{100 * lim[0]:g} %): a wrong --turn-angle, or a motion that is not the turn"))
    return out



def bias_drift_checks(calibration: Calibration) -> list[Check]:
    """A note on how far the gyroscope bias drifted over the session, when the fit found it drifting.

    From ``fit.gyroscope.bias_drift_over_session_deg_s``
    (:func:`imucalib.calibration.with_bias_session`): the calibrated rate at
    rest the drift adds to the stored (constant) bias's at the session's start
    and end. Never a reason: the fit models the drift, and ``apply`` corrects
    the calibrated session with it; the note tells that another recording's
    bias is off by as much unless taken from a rest of its own.
    """
    ends = calibration.fit.gyroscope.bias_drift_over_session_deg_s
    if ends is None:
        return []
    start, end = (np.asarray(row, dtype=float) for row in ends)
    j = int(np.argmax(np.maximum(np.abs(start), np.abs(end))))
    return [Check(0, f"the gyroscope bias drifted over the session: against the bias stored (at the poses' mean "
                     f"time) the rate at rest reads {start[j]:+.3g} °/s about {'xyz'[j]} at the start and "
                     f"{end[j]:+.3g} °/s at the end (x, y, z at the start: {', '.join(f'{v:+.2g}' for v in start)}; "
                     f"at the end: {', '.join(f'{v:+.2g}' for v in end)}); apply corrects this recording with the "
                     "drift, but another recording keeps the constant bias: take its bias from a rest of its own")]
