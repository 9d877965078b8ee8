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
4. Gyroscope: ``ω = T_g K_g (u − b_g)`` with ``T_g`` unit-diagonal (6 terms),
   ``b_g`` the mean of the initial rest (or estimated); the calibrated rates are
   integrated (RK4) across each motion and the predicted gravity direction is
   compared with the measured one at the next pose (Zhang 2021, eq. 14 is the
   same residual). The initial scale comes from a scalar search started at
   the ratio of the gravity-direction change to the integrated raw rate.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from ..calibration import Calibration
from ..kinematics import IntervalIntegrator, angle_between, quat_from_rotvec, quat_to_matrix
from ..metrics import fit_summary, interval_means, transition_bounds
from ..models import AXES, TriadModel
from ..recording import STANDARD_GRAVITY, Interval, Recording
from ..residuals import (
    AccelLayout,
    GyroLayout,
    gravity_direction_residuals,
    gravity_direction_residuals_jac,
    gravity_norm_residuals,
)
from ..segment import detect_static, find_initial_rest, variance_norm
from ..solve import levenberg_marquardt, standard_errors
from .ellipsoid import fit_ellipsoid, fit_sphere

__all__ = ["accelerometer_errors", "calibrate", "calibrate_accelerometer", "calibrate_gyroscope", "detect_intervals",
           "fit_gyroscope", "uncertainty"]

MIN_INTERVALS = 9


def calibrate_accelerometer(
    raw_means: np.ndarray, gravity: float, *, order: int = 1, initial: TriadModel | None = None
) -> tuple[TriadModel, np.ndarray]:
    """Fit ``a = T_a f(u − b)`` to ``‖a‖ = g`` on static means (Tedaldi 2014).

    Returns the model and the final residuals ``‖a_k‖ − g`` [m/s²].
    """
    if initial is None:
        try:
            initial = fit_ellipsoid(raw_means, gravity)
        except ValueError:
            initial = fit_sphere(raw_means, gravity)
    layout = AccelLayout("upper", order)
    theta0 = layout.pack(initial)
    if raw_means.shape[0] < layout.size:
        raise ValueError(
            f"the accelerometer model has {layout.size} parameters but only "
            f"{raw_means.shape[0]} static poses were found: record more poses"
        )

    def fun(th):
        return gravity_norm_residuals(th, layout, raw_means, gravity)

    def jac(th):
        return gravity_norm_residuals(th, layout, raw_means, gravity, jacobian=True)[1]

    sol = levenberg_marquardt(fun, jac, theta0, xtol=1e-14, ftol=1e-14)
    return layout.unpack(sol.x, initial), sol.fun


def detect_intervals(
    recording: Recording,
    gravity: float,
    *,
    init_static: float | None = None,
    multipliers: Iterable[float] = range(2, 11),
    window: float = 1.0,
    min_interval: float = 1.0,
) -> tuple[list[Interval], float, Interval, TriadModel]:
    """Static intervals by the Tedaldi 2014 detector with the multiplier scan.

    Returns the intervals, the chosen multiplier, the initial rest and the
    accelerometer model calibrated on those intervals.
    """
    rate = recording.rate
    if init_static is None:
        rest = find_initial_rest(recording)
    else:
        n = int(round(init_static * rate))
        if not 1 < n < len(recording):
            raise ValueError(
                f"--init-static {init_static} s does not fit the {recording.duration:.3g} s recording"
            )
        rest = Interval(0, n, "static")
    base = float(np.linalg.norm(np.var(recording.acc[rest.slice], axis=0)))
    if base <= 0:
        raise ValueError(
            "the initial rest has zero accelerometer variance (quantised or synthetic "
            "noise-free data?): the detector threshold cannot be set from it"
        )
    win = int(round(window * rate)) | 1
    min_len = max(int(round(min_interval * rate)), 2)
    stat = variance_norm(recording.acc, win)
    best = None
    tried = []
    for mult in multipliers:
        intervals = detect_static(None, mult * base, window=win, min_length=min_len, statistic=stat)
        tried.append((mult, len(intervals)))
        if len(intervals) < max(MIN_INTERVALS, 10):
            continue
        means = interval_means(recording.acc, intervals)
        try:
            model, res = calibrate_accelerometer(means, gravity)
        except ValueError:
            continue
        score = float(res @ res) / len(res)  # per residual
        if best is None or score < best[0]:
            best = (score, mult, intervals, model)
    if best is None:
        counts = ", ".join(f"×{m}: {c}" for m, c in tried)
        raise ValueError(
            "too few static intervals for a calibration at every detector threshold "
            f"({counts}; at least {max(MIN_INTERVALS, 10)} are needed): hold the sensor still "
            f"for at least {min_interval} s in each of many poses"
        )
    _, mult, intervals, model = best
    return intervals, float(mult), rest, model


def _gyro_scale_guess(
    v: np.ndarray, t: np.ndarray, starts: np.ndarray, stops: np.ndarray, gravity_dirs: np.ndarray,
) -> float:
    """Common gyroscope scale [rad/s per raw unit] for the initial values.

    Each motion is approximated by one rotation about the axis of its integrated
    raw rate ``Φ_i = ∫(u − b) dt``, by the angle ``k‖Φ_i‖``; ``k`` minimises the
    gravity-direction residuals of these rotations over a dense logarithmic grid
    around ``median(angle between poses / ∫‖u − b‖dt)`` (no sensor-specific guess).
    """
    dt = np.diff(t, append=t[-1])[:, None]
    c = np.concatenate([np.zeros((1, 4)),
                        np.cumsum(np.column_stack([v * dt, np.linalg.norm(v, axis=1) * dt[:, 0]]), axis=0)])
    phi_vec = c[stops, :3] - c[starts, :3]
    path = c[stops, 3] - c[starts, 3]
    theta = angle_between(gravity_dirs[:-1], gravity_dirs[1:])
    ok = (theta > np.radians(10)) & (path > 0)
    if not np.any(ok):
        ok = path > 0
    if not np.any(ok):
        raise ValueError("the gyroscope does not move between the static poses")
    k0 = float(np.median(theta[ok] / path[ok]))
    ks = k0 * np.geomspace(0.3, 30.0, 600)
    rot = quat_to_matrix(quat_from_rotvec(ks[:, None, None] * phi_vec[None, :, :]))
    pred = np.einsum("skji,kj->ski", rot, gravity_dirs[:-1])
    cost = np.sum((gravity_dirs[None, 1:] - pred) ** 2, axis=(1, 2))
    return float(ks[int(np.argmin(cost))])


def _gyro_problem(recording, intervals, accelerometer, bias, estimate_bias):
    """Residuals of Zhang 2021, eq. (14) in the :class:`GyroLayout` parameters, their Jacobian, the pose directions."""
    acc = accelerometer.forward(interval_means(recording.acc, intervals))
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    starts, stops = transition_bounds(intervals)
    integrator = IntervalIntegrator(recording.t, starts, stops)
    raw = recording.gyro[integrator.samples]  # only the samples the integration reads
    layout = GyroLayout(estimate_bias)
    d = np.zeros((raw.shape[0], 3, layout.size))

    def split(th):
        return th[:9].reshape(3, 3), (th[9:12] if estimate_bias else bias)

    def fun(th):
        m, b = split(th)
        return gravity_direction_residuals((raw - b) @ m.T, integrator.from_samples, dirs)

    def jac(th):
        m, b = split(th)
        v = raw - b
        for a in range(3):
            d[:, a, 3 * a : 3 * a + 3] = v  # ∂(M v)_a / ∂M_aj = v_j
        if estimate_bias:
            d[:, :, 9:12] = -m
        return gravity_direction_residuals_jac(v @ m.T, d, integrator, dirs)[1]

    return fun, jac, layout, dirs, (starts, stops)


def calibrate_gyroscope(
    recording: Recording,
    intervals: list[Interval],
    accelerometer: TriadModel,
    bias: np.ndarray,
    *,
    estimate_bias: bool = False,
) -> TriadModel:
    """Gyroscope ``T_g``, ``K_g`` (and ``b_g``) from gravity directions between poses.

    Minimises the residuals of Zhang 2021, eq. (14) (unit gravity directions)
    with Levenberg–Marquardt and the analytic first-order Jacobian of
    :func:`~imucalib.residuals.gravity_direction_residuals_jac`.
    """
    return fit_gyroscope(recording, intervals, accelerometer, bias, estimate_bias)[0]


def fit_gyroscope(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, bias: np.ndarray,
                  estimate_bias: bool = False) -> tuple[TriadModel, dict[str, float]]:
    """:func:`calibrate_gyroscope`, also returning its 1σ errors by name."""
    if len(intervals) < 4:
        raise ValueError(f"gyroscope calibration needs at least 4 static poses; got {len(intervals)}")
    fun, jac, layout, dirs, (starts, stops) = _gyro_problem(recording, intervals, accelerometer, bias,
                                                            estimate_bias)
    k = _gyro_scale_guess(recording.gyro - bias, recording.t, starts, stops, dirs)
    theta0 = layout.pack(TriadModel(scale=np.full(3, k), bias=bias))
    sol = levenberg_marquardt(fun, jac, theta0, xtol=1e-12, ftol=1e-12)
    return layout.unpack(sol.x, bias), _gyro_errors(sol.x, sol.jac, sol.fun, layout)


def uncertainty(recording: Recording, intervals: list[Interval], calibration: Calibration, *,
                estimate_gyro_bias: bool = False) -> dict[str, float]:
    """1σ standard errors of the linear model's parameters, by name (``DESIGN.md``).

    From the Jacobians of the two fits at the solution
    (:func:`~imucalib.solve.standard_errors`): the gravity-norm residuals of
    the static means for the accelerometer, the eq. (14) gravity-direction
    residuals for the gyroscope. A direction residual has two degrees of
    freedom, not three (both directions are unit vectors), which sets ``σ²``.
    The gyroscope's errors treat the accelerometer's as fixed, and its bias as
    exact unless it is estimated. NaN where the data cannot determine a
    parameter. :func:`calibrate` stores the same figures in ``fit["uncertainty"]``.
    """
    acc, gyro = calibration.accelerometer, calibration.gyroscope
    out = accelerometer_errors(acc, interval_means(recording.acc, intervals), calibration.gravity)
    fun, jac, layout, _, _ = _gyro_problem(recording, intervals, acc, gyro.bias, estimate_gyro_bias)
    theta = layout.pack(gyro)
    return out | _gyro_errors(theta, jac(theta), fun(theta), layout)


def accelerometer_errors(acc: TriadModel, means: np.ndarray, gravity: float) -> dict[str, float]:
    """1σ errors of a linear upper-triangular accelerometer model from the gravity-norm fit at ``acc``."""
    lay = AccelLayout("upper", 1)
    r, j = gravity_norm_residuals(lay.pack(acc), lay, means, gravity, jacobian=True)
    return {k: float(v) for k, v in zip(lay.names("accelerometer"), standard_errors(j, r), strict=True)}


def _gyro_errors(theta: np.ndarray, jac: np.ndarray, res: np.ndarray, layout: GyroLayout) -> dict[str, float]:
    """Errors of ``M = T_g diag(k1)`` (and ``b``) carried to ``T_g`` and ``k1`` by the delta method."""
    m = theta[:9].reshape(3, 3)
    off = [(i, j) for i in range(3) for j in range(3) if i != j]
    names = [f"gyroscope.misalignment.{AXES[i]}{AXES[j]}" for i, j in off]
    names += [f"gyroscope.scale.{a}" for a in AXES]
    a = np.zeros((layout.size, layout.size))
    for row, (i, j) in enumerate(off):  # T_ij = M_ij / M_jj
        a[row, 3 * i + j] = 1.0 / m[j, j]
        a[row, 4 * j] = -m[i, j] / m[j, j] ** 2
    for j in range(3):  # k_j = M_jj
        a[6 + j, 4 * j] = 1.0
    if layout.estimate_bias:
        names += [f"gyroscope.bias.{ax}" for ax in AXES]
        a[9:12, 9:12] = np.eye(3)
    dof = 2 * (len(res) // 3) - layout.size  # two degrees of freedom per direction residual
    return {k: float(v) for k, v in zip(names, standard_errors(jac, res, dof=dof, transform=a), strict=True)}


def calibrate(
    recording: Recording,
    *,
    gravity: float = STANDARD_GRAVITY,
    init_static: float | None = None,
    multipliers: Iterable[float] = range(2, 11),
    window: float = 1.0,
    min_interval: float = 1.0,
    estimate_gyro_bias: bool = False,
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
    multipliers : iterable of float
        Detector thresholds to scan, in units of the initial rest's variance norm.
    window, min_interval : float
        Detector window and shortest static interval [s].
    estimate_gyro_bias : bool
        Estimate the gyroscope bias with the other parameters instead of taking
        the mean of the initial rest.
    intervals : list of Interval, optional
        Static intervals to use instead of detecting them (the first one is
        then taken as the initial rest).
    progress : callable, optional
        Called with a short message at each stage.

    Returns
    -------
    Calibration
        ``fit`` holds the DESIGN figures plus ``threshold_multiplier`` and
        ``initial_rest_seconds``.
    """
    say = progress or (lambda msg: None)
    say("detecting static intervals")
    if intervals is None:
        intervals, mult, rest, acc_model = detect_intervals(
            recording, gravity, init_static=init_static, multipliers=multipliers,
            window=window, min_interval=min_interval,
        )
    else:
        intervals = [iv for iv in intervals if iv.kind == "static"]
        if len(intervals) < MIN_INTERVALS:
            raise ValueError(f"at least {MIN_INTERVALS} static intervals are needed; got {len(intervals)}")
        mult, rest = float("nan"), intervals[0]
        acc_model, _ = calibrate_accelerometer(interval_means(recording.acc, intervals), gravity)
    say("calibrating the gyroscope")
    bias = recording.gyro[rest.slice].mean(axis=0)
    gyro_model, gyro_errors = fit_gyroscope(recording, intervals, acc_model, bias, estimate_gyro_bias)
    cal = Calibration(
        accelerometer=acc_model,
        gyroscope=gyro_model,
        gravity=gravity,
        method="tedaldi2014",
        model="linear",
        units={
            "accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"},
            "gyroscope": {"raw": recording.gyro_unit, "calibrated": "rad/s"},
        },
    )
    fit = fit_summary(cal, recording, intervals, gravity)
    fit["threshold_multiplier"] = mult
    fit["initial_rest_seconds"] = float(recording.t[rest.stop - 1] - recording.t[rest.start])
    means = interval_means(recording.acc, intervals)
    fit["uncertainty"] = accelerometer_errors(acc_model, means, gravity) | gyro_errors
    return cal.with_(fit=fit)
