"""Fit-quality figures of a calibration on static poses (the file's ``fit``, ``docs/architecture.rst``).

* ``accelerometer_residual_rms`` — RMS over static intervals of ``‖a‖ − g``
  [m/s²], with ``a`` the calibrated mean of each interval (the raw readings are
  averaged first, then calibrated, as Zhang 2021 eq. (10) averages ``a^s``);
* ``gyroscope_angle_error_mean_deg`` / ``_max_deg`` — angles between the gravity
  direction measured at each static pose and the one predicted by integrating
  the calibrated gyroscope (RK4) from the previous pose (Tedaldi 2014; Zhang
  2021, eq. 14), over every rotation between consecutive poses: a rotation a
  fit leaves out of its cost (spikes, saturation, an outlier) is still scored;
* ``next_poses`` — up to three up-directions (body frame, unit vectors) that,
  recorded next, would most shrink the worst 1σ of the linear accelerometer
  model (:func:`imucalib.plans.next_poses`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .calibration import Calibration
from .fitreport import AccelerometerReport, FitReport, GyroscopeReport, SegmentationReport, ThermalReport, VerdictReport
from .kinematics import IntervalIntegrator, angle_between, quat_to_matrix
from .plans import next_poses
from .recording import Interval, Recording

__all__ = [
    "interval_means",
    "pose_specific_force",
    "transition_bounds",
    "gravity_residuals",
    "predicted_gravity",
    "gravity_direction_errors",
    "fit_summary",
    "pose_coverage",
    "gap_flags",
    "gravity_noise_floor",
    "COVERAGE_CONE_DEG",
]

#: a pose visits the directions within this angle [deg] of its gravity direction: an axis no pose points within it
#: of up (or down) leaves that side's bias and scale to the other side alone (:func:`pose_coverage`)
COVERAGE_CONE_DEG = 60.0

#: samples whose rates :func:`predicted_gravity` calibrates at once (the calibration's temporaries, not the motion's)
RATE_CHUNK = 1 << 16

def interval_means(x: np.ndarray, intervals: Sequence[Interval]) -> np.ndarray:
    """Mean of ``x`` (N, K) over each interval → (M, K), in float64.

    Interval by interval, each column over the interval's own samples less
    its first one (pairwise sums of small numbers keep the mean accurate; a
    constant interval's mean is exact): no temporary the size of the
    recording. An interval's differences are laid out a column to a row, so
    one reduction along the rows sums every column by the same pairwise
    additions as a reduction of that column alone.
    """
    x = np.asarray(x, dtype=np.float64)
    width, m = x.shape[1], len(intervals)
    sums = np.empty((m, width))
    counts = np.empty((m, 1), dtype=np.intp)
    starts = [iv.start for iv in intervals]
    refs = x[starts]  # each interval's first sample
    add, sub, empty = np.add.reduce, np.subtract, np.empty  # ndarray.mean's own sum (pairwise), without its overhead
    for k, (iv, ref) in enumerate(zip(intervals, refs[:, :, None], strict=True)):
        seg = x[iv.start:iv.stop]
        d = empty((width, seg.shape[0]))  # C-ordered: each column's differences contiguous, as a 1-D sum reads them
        sub(seg.T, ref, out=d)
        add(d, axis=1, out=sums[k])
        counts[k] = seg.shape[0]
    return sums / counts + refs  # each mean's division and addition, all at once


def transition_bounds(intervals: Sequence[Interval]) -> tuple[np.ndarray, np.ndarray]:
    """First and last sample of each integration between consecutive static poses.

    The integration runs from the last sample of pose ``i`` to the first sample
    of pose ``i+1``.
    """
    starts = np.array([iv.stop - 1 for iv in intervals[:-1]], dtype=np.intp)
    stops = np.array([iv.start for iv in intervals[1:]], dtype=np.intp)
    return starts, stops


def pose_specific_force(calibration: Calibration, recording: Recording, intervals: Sequence[Interval]) -> np.ndarray:
    """The calibrated specific force [m/s²] of each static interval (M, 3): the model of its raw mean.

    The raw readings are averaged first (:func:`interval_means`), then
    calibrated, as Zhang 2021 eq. (10) averages ``a^s``. The array is
    read-only, so the figures that share it cannot change it for each other.
    """
    up = calibration.accelerometer_si(interval_means(recording.acc, intervals))
    up.flags.writeable = False
    return up


def gravity_residuals(calibration: Calibration, recording: Recording, intervals: Sequence[Interval],
                      gravity: float | None = None, *, up: np.ndarray | None = None) -> np.ndarray:
    """``‖a_k‖ − g`` [m/s²] for each static interval ``k`` (interval means).

    ``up`` is :func:`pose_specific_force` of the same intervals, when the
    caller has it already.
    """
    g = calibration.gravity if gravity is None else gravity
    a = pose_specific_force(calibration, recording, intervals) if up is None else up
    return np.linalg.norm(a, axis=1) - g


def predicted_gravity(
    calibration: Calibration, recording: Recording, intervals: Sequence[Interval],
    integrator: IntervalIntegrator | None = None, *, up: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Measured and gyro-predicted gravity directions at poses 1…M−1.

    ``up`` is :func:`pose_specific_force` of the same intervals, when the
    caller has it already.

    Returns
    -------
    measured, predicted : (M-1, 3) ndarray
        Unit vectors: the calibrated accelerometer direction at pose ``k`` and
        ``R_{k-1,k}ᵀ`` times the direction at pose ``k−1``.
    """
    acc_means = pose_specific_force(calibration, recording, intervals) if up is None else up
    u = acc_means / np.linalg.norm(acc_means, axis=1, keepdims=True)
    if integrator is None:
        integrator = IntervalIntegrator(recording.t, *transition_bounds(intervals))
    used = integrator.samples  # only the samples the rotations are integrated over are calibrated
    rates = np.empty((used.size, 3))
    for a in range(0, used.size, RATE_CHUNK):  # the calibration's temporaries a chunk at a time
        part = used[a : a + RATE_CHUNK]
        rates[a : a + part.size] = calibration.gyroscope_si(recording.gyro.take(part, axis=0),
                                                            recording.acc.take(part, axis=0))
    r = quat_to_matrix(integrator.from_samples(rates))
    predicted = np.einsum("kji,kj->ki", r, u[:-1])  # Rᵀ · g_{k-1}
    return u[1:], predicted


def gravity_direction_errors(calibration: Calibration, recording: Recording,
                             intervals: Sequence[Interval], *, up: np.ndarray | None = None,
                             integrator: IntervalIntegrator | None = None) -> np.ndarray:
    """Angle [rad] between measured and gyro-predicted gravity at each new pose.

    ``up`` is :func:`pose_specific_force` of the same intervals, when the
    caller has it already; ``integrator`` the motions' integrator
    (:func:`predicted_gravity`).
    """
    measured, predicted = predicted_gravity(calibration, recording, intervals, integrator, up=up)
    return angle_between(measured, predicted)


def fit_summary(calibration: Calibration, recording: Recording, intervals: Sequence[Interval],
                gravity: float | None = None, *, integrator: IntervalIntegrator | None = None) -> FitReport:
    """The fit report's figures every method gives (``docs/architecture.rst``).

    The poses' calibrated means (:func:`pose_specific_force`) are computed
    once and serve every figure that reads them.

    Parameters
    ----------
    calibration : Calibration
        The calibration whose figures are computed.
    recording : Recording
        The recording it was made from.
    intervals : sequence of Interval
        Its static poses.
    gravity : float, optional
        Local gravity [m/s²]; by default the calibration's.
    integrator : IntervalIntegrator, optional
        The :class:`~imucalib.kinematics.IntervalIntegrator` of the motions between these intervals, when the
        caller has one (the gyroscope's fit).

    Returns
    -------
    FitReport
        Static poses, the residual and its noise floor, the gyroscope's angle errors, the pose coverage and the
        next poses to record (``docs/architecture.rst`` names each).

    Examples
    --------
    The figures of a simulated session's true calibration on that session:

    >>> from imucalib.metrics import fit_summary
    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> fit = fit_summary(sim.truth, sim.recording, intervals)
    >>> fit.poses.static_intervals
    15
    >>> # the residual is below its noise floor: noise is all the truth leaves
    >>> fit.accelerometer.residual_rms < fit.accelerometer.noise_floor
    True
    """
    up = pose_specific_force(calibration, recording, intervals)
    res = gravity_residuals(calibration, recording, intervals, gravity, up=up)
    rms = float(np.sqrt(np.mean(res**2)))
    acc = AccelerometerReport(residual_rms=rms)
    gyro = GyroscopeReport()
    if len(intervals) >= 2 and recording.gyro is not None and calibration.gyroscope is not None:
        ang = np.degrees(gravity_direction_errors(calibration, recording, intervals, up=up, integrator=integrator))
        gyro = GyroscopeReport(angle_error_mean_deg=float(np.mean(ang)), angle_error_max_deg=float(np.max(ang)),
                               angle_errors_deg=ang.tolist())
    coverage, flags = pose_coverage(up)
    flags += gap_flags(recording, intervals)
    floor = gravity_noise_floor(calibration, recording, intervals)
    if floor > 0:
        ratio = rms / floor
        acc = acc.with_(noise_floor=floor, residual_to_noise=ratio)
        if ratio > 5:
            flags.append(f"the gravity-norm residual is {ratio:.0f}× what the sensor noise explains: the model "
                         "leaves structure (nonlinear scale factors? temperature drift?) or some poses were not "
                         "still; compare the model variants (imucalib compare)")
    poses = SegmentationReport(static_intervals=len(intervals),
                               intervals=[[int(iv.start), int(iv.stop)] for iv in intervals],  # [start, stop)
                               pose_coverage=coverage)
    if flags:
        poses = poses.with_(quality_flags=flags)
    # what to record next: the up-directions that most shrink the worst 1σ (imucalib.plans.next_poses)
    out = FitReport.of(poses, acc, gyro, VerdictReport(next_poses=next_poses(up).tolist()))
    if recording.temperature is not None and np.any(np.isfinite(recording.temperature)):
        # biases and scales of MEMS sensors drift with temperature: say where this calibration holds
        temp = recording.temperature[np.isfinite(recording.temperature)]
        out = out.add(ThermalReport(temperature_c=[float(temp.min()), float(temp.mean()), float(temp.max())]))
    return out


def gravity_noise_floor(calibration: Calibration, recording: Recording, intervals: Sequence[Interval]) -> float:
    """RMS over the poses of the white-noise error of ``‖ā_k‖`` [m/s²], the floor of the gravity-norm residual.

    For pose ``k`` with ``n_k`` samples, ``‖ā_k‖`` carries the noise of the
    samples along the mean direction divided by ``√n_k``; a perfect model
    would leave residuals of about this size, so ``residual / floor`` well
    above 1 means model error or poses that were not still.

    A sensor read faster than it updates repeats each reading for several rows (held samples): a pose
    of ``n`` rows then holds only its ``n_k`` updates' worth of noise, and ``n_k`` (the rows that differ
    from the row before, plus one) takes the place of ``n`` where over :data:`HELD_FRACTION` of the
    pose's rows repeat the row before exactly.

    Parameters
    ----------
    calibration : Calibration
        The calibration whose accelerometer model converts the samples.
    recording : Recording
        The recording.
    intervals : sequence of Interval
        Its static poses.

    Returns
    -------
    float
        The floor [m/s²].

    Examples
    --------
    >>> from imucalib.metrics import gravity_noise_floor
    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> round(gravity_noise_floor(sim.truth, sim.recording, intervals), 4)  # m/s²
    0.0017
    """
    var = []
    model = calibration.accelerometer
    linear = model.is_linear and not np.any(model.g_sensitivity)
    add = np.add.reduce  # the sums ndarray.mean, np.var and np.linalg.norm take, without their per-call overhead
    poses = [recording.acc[iv.slice] for iv in intervals if len(iv) >= 2]
    sums = [add(raw, axis=0) for raw in poses] if linear else None  # each pose's raw.sum(axis=0)
    for k, raw in enumerate(poses):
        n = raw.shape[0]
        if linear:
            # a = T diag(k1) (u − b) + T d is affine in u: its mean is the model of the mean, and its
            # component along û is u · (diag(k1) Tᵀ û) plus a constant, so no calibrated copy is needed
            u = model.forward((sums[k] / n)[None, :])[0]  # raw.mean(axis=0)
            along = raw @ (model.scale * (model.misalignment.T @ (u / np.sqrt(u.dot(u)))))
        else:
            a = calibration.accelerometer_si(raw)
            u = add(a, axis=0) / n
            along = a @ (u / np.sqrt(u.dot(u)))
        var.append(_sample_variance(along) / _updates(raw))
    return float(np.sqrt(np.mean(var))) if var else 0.0


#: the share of a pose's rows repeating the row before above which they are taken as held samples
HELD_FRACTION = 0.25


def _updates(raw: np.ndarray) -> int:
    """The independent readings of a pose's rows ``raw`` (N, 3): N, or its updates when its samples are held."""
    n = raw.shape[0]
    held = int(np.count_nonzero(np.all(raw[1:] == raw[:-1], axis=1)))
    return n - held if held > HELD_FRACTION * (n - 1) else n


def _sample_variance(x: np.ndarray) -> float:
    """``np.var(x, ddof=1)`` of a 1-D float64 array ``x`` by the same operations, without the per-call overhead."""
    n = x.shape[0]
    d = x - np.add.reduce(x, axis=None, keepdims=True) / n
    np.square(d, out=d)
    return np.add.reduce(d) / (n - 1)


def gap_flags(recording: Recording, intervals: Sequence[Interval], *, factor: float = 2.5) -> list[str]:
    """Advice on sampling gaps (a step over ``factor`` × the median) inside the rotations between poses.

    The attitude change of a rotation is integrated sample to sample (RK4,
    Zhang 2021 eq. 23); across a gap the rate is only interpolated, so that
    rotation's gravity-direction residual (eq. 14) is unreliable. Where blocks
    recorded apart were joined (``metadata["blocks"]``: one file per pose,
    blocks cut by a logger's prompts) the gap is no fault: no motion was
    recorded there and nothing is integrated across it (the reader says so
    once). Without a gyroscope nothing is integrated at all.
    """
    if len(recording) < 3 or len(intervals) < 2 or recording.gyro is None:
        return []
    dt = np.diff(recording.t)
    if dt.max() <= factor * dt.min():  # no step exceeds factor × the median (≥ the smallest): skip the median
        return []
    joins = [int(stop) - 1 for _, stop in (recording.metadata.get("blocks") or [])[:-1]]
    big = np.setdiff1d(np.nonzero(dt > factor * np.median(dt))[0], joins)
    if big.size == 0:
        return []
    starts, stops = transition_bounds(intervals)
    flags = []
    for k, (a, b) in enumerate(zip(starts, stops, strict=True)):
        inside = big[(big >= a) & (big < b)]
        if inside.size:
            i = int(inside[np.argmax(dt[inside])])
            flags.append(f"the rotation from pose {k + 1} to {k + 2} has {inside.size} sampling gap(s), the longest "
                         f"{dt[i]:.3g} s at t = {recording.t[i] - recording.t[0]:.3f} s: the gyroscope is "
                         "integrated across it by interpolation, so this rotation's residual is unreliable")
    return flags


def pose_coverage(acc_means: np.ndarray, *, cone_deg: float = COVERAGE_CONE_DEG) -> tuple[dict, list[str]]:
    """How the static poses cover each axis's up and down, and advice where they do not.

    For each body axis, the range of the gravity direction's component over
    the poses (``[min, max]`` of ``a/‖a‖``, 1 = straight up). An axis that is
    never within ``cone_deg`` of up (or of down) leaves its bias and scale
    factor to be told apart by the other side alone (Ru 2022, §3.1: each
    axis is calibrated from both orientations), so it gets a flag naming the
    missing orientation.

    Parameters
    ----------
    acc_means : numpy.ndarray
        The poses' mean accelerometer readings, shape ``(n, 3)`` (any unit: only their directions count).
    cone_deg : float
        How close to straight up (or down) [deg] an axis must come to count as visited.

    Returns
    -------
    coverage : dict
        ``{"x": [min, max], "y": …, "z": …}``: the range of each axis's gravity component.
    flags : list of str
        One sentence per orientation never visited.

    Examples
    --------
    >>> import numpy as np
    >>> from imucalib.metrics import pose_coverage
    >>> up = np.array([[0, 0, 9.8], [0, 0, -9.8], [9.8, 0, 0], [0, 9.8, 0]])
    >>> cover, flags = pose_coverage(up)
    >>> cover["z"], len(flags)
    ([-1.0, 1.0], 2)
    """
    u = acc_means / np.linalg.norm(acc_means, axis=1, keepdims=True)
    lo, hi = u.min(axis=0), u.max(axis=0)
    limit = np.cos(np.radians(cone_deg))
    coverage = {a: [float(lo[i]), float(hi[i])] for i, a in enumerate("xyz")}
    flags = []
    for i, a in enumerate("xyz"):
        for side, ok in (("up", hi[i] >= limit), ("down", lo[i] <= -limit)):
            if not ok:
                flags.append(f"no pose has the {a} axis within {cone_deg:.0f}° of {side} "
                             f"(its gravity component spans {lo[i]:+.2f}..{hi[i]:+.2f}): its bias and scale "
                             f"are poorly separated; add poses with {a} pointing {side}")
    return coverage, flags
