"""Leave-one-pose-out cross-validation of a calibration method on static poses.

A calibration that merely fits noise looks good on its own poses; held-out
poses show it. For each static pose ``k`` (the initial rest always stays in
training) the method is run on the other poses and judged on ``k``:

* accelerometer: ``‖a_k‖ − g`` [m/s²] with ``a_k`` the calibrated mean;
* gyroscope: the angle between the gravity direction measured at ``k`` and the
  one predicted by integrating the calibrated gyroscope from pose ``k−1``.

The figures are the RMS of the first and the mean of the second over the
held-out poses (the file's ``fit`` metrics, ``docs/architecture.rst``, out of sample).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .kinematics import IntervalIntegrator, angle_between, quat_to_matrix
from .metrics import interval_means
from .recording import Interval, Recording

__all__ = ["leave_one_pose_out"]


def leave_one_pose_out(
    recording: Recording,
    intervals: Sequence[Interval],
    fit: Callable[[list[Interval]], object],
    *,
    gravity: float,
    folds: Sequence[int] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Cross-validated gravity residual and gyroscope angle error.

    Parameters
    ----------
    recording : Recording
        Raw readings.
    intervals : sequence of Interval
        Static intervals, the initial rest first.
    fit : callable
        ``fit(training_intervals) -> Calibration``: the method under test.
    gravity : float
        ``g`` [m/s²].
    folds : sequence of int, optional
        Which poses to hold out (default every pose but the rest, 1…M−1).
    progress : callable, optional
        ``progress(done, total)`` after each fold.

    Returns
    -------
    dict
        ``cv_accelerometer_residual_rms`` [m/s²],
        ``cv_gyroscope_angle_error_mean_deg`` (None without a gyroscope), ``folds`` (folds that ran),
        ``folds_skipped`` (folds where the method could not be fitted without the
        held-out pose, with the reason) and the per-fold values
        ``accelerometer_residuals`` and ``gyroscope_angle_errors_deg``.
    """
    intervals = list(intervals)
    m = len(intervals)
    folds = list(range(1, m)) if folds is None else [int(k) for k in folds]
    if any(not 1 <= k < m for k in folds):
        raise ValueError(f"folds must lie in 1…{m - 1} (pose 0 is the initial rest)")
    raw_means = interval_means(recording.acc, intervals)
    acc_res, angles, skipped = [], [], []
    for i, k in enumerate(folds):
        training = intervals[:k] + intervals[k + 1 :]
        try:
            cal = fit(training)
        except ValueError as exc:  # e.g. a face-based method that lost its only +x pose
            skipped.append({"fold": k, "reason": str(exc)})
            if progress is not None:
                progress(i + 1, len(folds))
            continue
        a = cal.accelerometer_si(raw_means[[k - 1, k]])
        acc_res.append(float(np.linalg.norm(a[1]) - gravity))
        if recording.gyro is not None and cal.gyroscope is not None:  # none in an accelerometer-only recording
            integ = IntervalIntegrator(recording.t, np.array([intervals[k - 1].stop - 1]),
                                       np.array([intervals[k].start]))
            rates = cal.gyroscope_si(recording.gyro[integ.samples], recording.acc[integ.samples])
            rot = quat_to_matrix(integ.from_samples(rates))[0]
            u = a / np.linalg.norm(a, axis=1, keepdims=True)
            angles.append(float(np.degrees(angle_between(u[1], rot.T @ u[0]))))
        if progress is not None:
            progress(i + 1, len(folds))
    if not acc_res:
        raise ValueError(f"the method could not be fitted without any of the held-out poses: "
                         f"{skipped[0]['reason']}")
    acc_res_a = np.array(acc_res)
    return {
        "cv_accelerometer_residual_rms": float(np.sqrt(np.mean(acc_res_a**2))),
        "cv_gyroscope_angle_error_mean_deg": float(np.mean(angles)) if angles else None,
        "folds": len(acc_res),
        "folds_skipped": skipped,
        "accelerometer_residuals": acc_res,
        "gyroscope_angle_errors_deg": angles,
    }
