"""Gyroscope estimators: building blocks the methods compose.

* :func:`fit_gravity_direction` — ``T_g``, ``k1`` (and ``b_g``) from the gravity
  direction carried by the integrated rates from one static pose to the next
  (Zhang 2021, eq. 14; Tedaldi 2014), Levenberg–Marquardt with the analytic
  Jacobian, and its 1σ errors;
* :func:`fit_known_turns` — the sensitivity matrix from turns by a known angle
  (Ferraris 1995);
* :func:`rotation_angles`, :func:`fit_measured_rotations` — turns whose angle
  the calibrated accelerometer measures (Qureshi 2017, eqs. 18–28).
"""

from __future__ import annotations

import numpy as np

from ..kinematics import IntervalIntegrator, angle_between, quat_from_rotvec, quat_to_matrix
from ..metrics import interval_means, transition_bounds
from ..models import AXES, TriadModel
from ..recording import Interval, Recording
from ..residuals import GyroLayout, gravity_direction_residuals, gravity_direction_residuals_jac
from ..solve import levenberg_marquardt, standard_errors
from .accelerometer import full_from_sensitivity

__all__ = ["MIN_POSES", "fit_gravity_direction", "fit_known_turns", "fit_measured_rotations",
           "gravity_direction_problem", "gyroscope_errors", "rotation_angles"]

#: the fewest static poses a gravity-direction fit takes
MIN_POSES = 4


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


def gravity_direction_problem(recording, intervals, accelerometer, bias, estimate_bias):
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


def fit_gravity_direction(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, bias: np.ndarray,
                  estimate_bias: bool = False) -> tuple[TriadModel, dict[str, float]]:
    """Gyroscope ``T_g``, ``K_g`` (and ``b_g``) from gravity directions between poses, and its 1σ errors.

    Minimises the residuals of Zhang 2021, eq. (14) (unit gravity directions)
    with Levenberg–Marquardt and the analytic first-order Jacobian of
    :func:`~imucalib.residuals.gravity_direction_residuals_jac`.
    """
    if len(intervals) < MIN_POSES:
        raise ValueError(f"gyroscope calibration needs at least 4 static poses; got {len(intervals)}")
    fun, jac, layout, dirs, (starts, stops) = gravity_direction_problem(recording, intervals, accelerometer, bias,
                                                            estimate_bias)
    k = _gyro_scale_guess(recording.gyro - bias, recording.t, starts, stops, dirs)
    theta0 = layout.pack(TriadModel(scale=np.full(3, k), bias=bias))
    sol = levenberg_marquardt(fun, jac, theta0, xtol=1e-12, ftol=1e-12)
    return layout.unpack(sol.x, bias), gyroscope_errors(sol.x, sol.jac, sol.fun, layout)


def gyroscope_errors(theta: np.ndarray, jac: np.ndarray, res: np.ndarray, layout: GyroLayout) -> dict[str, float]:
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


def rotation_angles(recording, intervals, acc_model: TriadModel, bias: np.ndarray, *,
                    axis_tolerance: float = 20.0, min_tilt: float = 45.0,
                    max_angle: float = 170.0) -> list[dict]:
    """Rotations between consecutive static poses: axis, accelerometer angle, mean raw rate, duration."""
    a = acc_model.forward(interval_means(recording.acc, intervals))
    u = a / np.linalg.norm(a, axis=1, keepdims=True)
    starts, stops = transition_bounds(intervals)
    out = []
    for k, (s0, s1) in enumerate(zip(starts, stops, strict=True)):
        raw = recording.gyro[s0 : s1 + 1]
        t = recording.t[s0 : s1 + 1]
        total = np.trapezoid(raw - bias, t, axis=0)
        i = int(np.argmax(np.abs(total)))
        e = np.zeros(3)
        e[i] = 1.0
        off_axis = np.degrees(np.arccos(np.clip(abs(total[i]) / np.linalg.norm(total), 0, 1)))
        tilt = np.degrees(np.arccos(np.clip(abs(u[k] @ e), 0, 1)))
        if off_axis > axis_tolerance or tilt < min_tilt:
            continue
        # body turns by +θ about e ⇒ gravity turns by −θ: θ = −atan2((g₀ × g₁)·e, g₀·g₁)
        # (the tilt change of eqs. 23–28 about a horizontal axis)
        theta = -np.arctan2(np.cross(u[k], u[k + 1]) @ e, u[k] @ u[k + 1])
        if abs(theta) > np.radians(max_angle):  # ±180° is ambiguous: the sign flips with noise
            continue
        duration = float(t[-1] - t[0])
        out.append({"axis": i, "angle": float(theta), "mean_rate": float(np.mean(raw[:, i])),
                    "duration": duration,
                    "mean_rate_trapezoid": float(np.trapezoid(raw[:, i], t) / duration)})
    return out


def fit_known_turns(recording: Recording, turns: dict[int, list[tuple[int, int, int]]], angle: float,
                    bias: np.ndarray, g_sensitivity: np.ndarray, acc_si: np.ndarray) -> TriadModel:
    """Ferraris 1995: ``S_g e_i = ± (∫(u_g − b_g − G a) dt) / θ`` over the turns about axis ``i``.

    ``turns`` maps each axis to its turns ``(start, stop, sign)``; ``angle`` is
    the known angle θ [rad]; ``acc_si`` the calibrated specific force of every
    sample (for the g-sensitivity term). Turns about one axis are averaged.
    """
    s_g = np.empty((3, 3))
    for i in range(3):
        cols = []
        for s0, s1, sign in turns[i]:
            t = recording.t[s0 : s1 + 1]
            u = recording.gyro[s0 : s1 + 1] - bias - acc_si[s0 : s1 + 1] @ g_sensitivity.T
            cols.append(sign * np.trapezoid(u, t, axis=0) / angle)
        s_g[:, i] = np.mean(cols, axis=0)
    return full_from_sensitivity(s_g, bias, g_sensitivity=g_sensitivity)


def fit_measured_rotations(rotations: list[dict], rest_bias: np.ndarray, approach: str
                           ) -> tuple[np.ndarray, np.ndarray, dict[str, float], list[int]]:
    """Per-axis gyroscope scale (and bias) from turns the accelerometer measured (Qureshi 2017).

    ``"static"``: ``b`` is ``rest_bias`` and ``k_i = Δθ_ik / ((ω̄_ik − b_i) T_k)``
    (eq. 18), combined over the turns about axis ``i`` by least squares;
    ``"dynamic"``: ``[ω̄_ik T_k, −T_k] [k_i, k_i b_i]ᵀ = Δθ_ik`` for ``k_i`` and
    ``b_i`` together (eqs. 19–21). A turn whose eq. (18) scale differs from the
    axis's median by more than 10 % was not a clean turn about the axis and is
    left out. Returns the scales, the biases, their 1σ errors by name and the
    number of turns left out per axis.
    """
    k = np.empty(3)
    b = np.array(rest_bias, dtype=float)
    errors: dict[str, float] = {}
    rejected = [0, 0, 0]
    need = 1 if approach == "static" else 2
    for i in range(3):
        rows = [r for r in rotations if r["axis"] == i]
        if len(rows) < need:
            raise ValueError(
                f"no usable rotation about the {AXES[i]} axis ({len(rows)} found, {need} needed): "
                "rotate about each axis while it is horizontal (at least 45° from gravity), "
                "as in the paper's Fig. 2"
            )
        theta = np.array([r["angle"] for r in rows])
        tk = np.array([r["duration"] for r in rows])
        wbar = np.array([r["mean_rate_trapezoid"] for r in rows])
        k_each = theta / ((wbar - rest_bias[i]) * tk)
        good = np.abs(k_each / np.median(k_each) - 1) < 0.1
        if np.count_nonzero(good) < need:
            raise ValueError(f"the turns about the {AXES[i]} axis disagree (eq. 18 scales "
                             f"{np.round(k_each, 9).tolist()}): turn about one axis at a time")
        theta, tk, wbar = theta[good], tk[good], wbar[good]
        rejected[i] = int(np.count_nonzero(~good))
        if approach == "static":
            x = (wbar - rest_bias[i]) * tk  # eq. (18) for each rotation, least squares over them
            k[i] = float(x @ theta / (x @ x))
            errors[f"gyroscope.scale.{AXES[i]}"] = float(standard_errors(x[:, None], k[i] * x - theta)[0])
        else:
            a_mat = np.column_stack([wbar * tk, -tk])  # eq. (19)
            sol = np.linalg.solve(a_mat.T @ a_mat, a_mat.T @ theta)  # eq. (21)
            k[i], b[i] = sol[0], sol[1] / sol[0]
            to_kb = np.array([[1.0, 0.0], [-sol[1] / sol[0] ** 2, 1.0 / sol[0]]])  # (k, k·b) → (k, b)
            se = standard_errors(a_mat, a_mat @ sol - theta, transform=to_kb)
            errors[f"gyroscope.scale.{AXES[i]}"], errors[f"gyroscope.bias.{AXES[i]}"] = map(float, se)
    return k, b, errors, rejected

