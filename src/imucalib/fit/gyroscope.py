r"""Gyroscope estimators: building blocks the methods compose.

The gyroscope's model is Zhang 2021's, eqs. (5)–(6), linear and with this
project's bias sign (:mod:`imucalib.models`), ``M = T_g diag(k1)``; the
rotation ``R_k`` from pose ``k − 1`` to pose ``k``, integrated from these
rates (:mod:`imucalib.kinematics`), carries the unit gravity direction ``d``
the calibrated accelerometer measures at one pose onto the next (Zhang 2021,
eqs. (12)–(14); with the body-to-reference ``R`` of :mod:`imucalib.kinematics`
its ``R_{k−1,k}`` is ``R_kᵀ``):

.. math::

    \boldsymbol\omega = \mathbf M\, (\mathbf u_g - \mathbf b_g - \mathbf G\, \mathbf a)
    \quad \text{(5), (6)}, \qquad
    L = \sum_{k=2}^{M} \bigl\lVert \mathbf d_k - \mathbf R_k^\top \mathbf d_{k-1} \bigr\rVert^2
    \quad (14)

* :func:`fit_gravity_direction` — ``T_g``, ``k1`` (and ``b_g``) from the gravity
  direction carried by the integrated rates from one static pose to the next
  (Zhang 2021, eq. 14; Tedaldi 2014), Levenberg–Marquardt with the analytic
  Jacobian, and its 1σ errors;
* :func:`fit_known_turns` — the sensitivity matrix from turns by a known angle
  (Ferraris 1995);
* :func:`rotation_angles`, :func:`fit_measured_rotations` — turns whose angle
  the calibrated accelerometer measures (Qureshi 2017, eqs. 18–28);
* :func:`axes_disagreement` — whether the gyroscope's rotations carry gravity
  from one pose to the next as the accelerometer sees it, and which order and
  signs of the gyroscope's axes would (swapped or reversed axes on one sensor).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..fitreport import GyroscopeReport
from ..kinematics import IntervalIntegrator
from ..metrics import interval_means, transition_bounds
from ..models import AXES, TriadModel
from ..recording import Interval, Recording
from ..residuals import GyroLayout
from ..solve import standard_errors
from .accelerometer import full_from_sensitivity
from .gyro_direction import (
    MIN_POSES,
    SIGNED_PERMUTATIONS,
    Transitions,
    axes_disagreement,
    direction_acc_jacobian,
    gravity_direction_problem,
    rough_scale,
    solve_direction,
    transition_errors,
)
from .gyro_joint import accelerometer_joint_step, joint_errors, joint_errors_at, joint_problem, solve_joint
from .gyro_static import StaticGyro, static_gyro

__all__ = ["MIN_POSES", "SIGNED_PERMUTATIONS", "GyroFit", "StaticGyro", "accelerometer_joint_step",
           "axes_disagreement", "errors_at", "fit_gravity_direction", "fit_gyroscope", "fit_known_turns",
           "fit_measured_rotations", "gravity_direction_problem", "gyroscope_errors", "joint_errors",
           "joint_errors_at", "joint_problem", "rotation_angles", "rough_scale", "static_gyro", "transition_errors"]


def fit_gravity_direction(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, bias: np.ndarray,
                          estimate_bias: bool = False, *, weights: np.ndarray | None = None,
                          bias_cov: np.ndarray | None = None,
                          g_sensitivity: np.ndarray | None = None) -> tuple[TriadModel, dict[str, float]]:
    """Gyroscope ``T_g``, ``K_g`` (and ``b_g``) from gravity directions between poses, and its 1σ errors.

    Minimises the residuals of Zhang 2021, eq. (14) (unit gravity directions)
    with Levenberg–Marquardt and the analytic first-order Jacobian of
    :func:`~imucalib.residuals.gravity_direction_residuals_jac`. ``weights``
    (one per transition, 0 to leave it out) weight the residuals; with the
    bias held at ``bias``, ``bias_cov`` (3, 3) is its covariance, carried into
    the other parameters' errors and reported as the bias's own error. A known
    ``g_sensitivity`` is taken out of the readings and kept in the model.
    """
    model, _ = solve_direction(recording, intervals, accelerometer, bias, estimate_bias, weights, g_sensitivity)
    return model, errors_at(recording, intervals, accelerometer, model, estimate_bias, weights=weights,
                            bias_cov=bias_cov)


def errors_at(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, gyroscope: TriadModel,
              estimate_bias: bool, *, weights: np.ndarray | None = None, bias_cov: np.ndarray | None = None,
              acc_cov: np.ndarray | None = None, transitions: Transitions | None = None) -> dict[str, float]:
    """1σ errors of a gravity-direction gyroscope fit at its solution ``gyroscope``, by name.

    From the Jacobian and residuals of eq. (14) (:func:`~imucalib.solve.standard_errors`;
    a direction residual has two degrees of freedom, not three). Inputs the
    fit held fixed are carried into the parameters to first order
    (``∂θ̂/∂x = −J⁺ ∂r/∂x``, so ``C += S C_x Sᵀ``): the bias when it is not
    estimated (``bias_cov``, also reported as the bias's own error) and the
    accelerometer's parameters, which set the measured gravity directions
    (``acc_cov``, in :class:`~imucalib.residuals.AccelLayout` ``("upper", 1)``
    order; where the poses leave the accelerometer poorly determined, the
    gyroscope's errors say so instead of being falsely small). The bias's own
    error is ``bias_cov``'s (the static poses' regression, their scatter
    included: :func:`static_gyro`). ``transitions``: as for :func:`gravity_direction_problem`.
    """
    fun, jac, layout, dirs, _ = gravity_direction_problem(recording, intervals, accelerometer, gyroscope.bias, True,
                                                          weights, gyroscope.g_sensitivity, transitions)
    theta = layout.pack(gyroscope)
    res = fun(theta)
    j12 = jac(theta)
    n = len(intervals) - 1 if weights is None else int(np.count_nonzero(weights))
    jg = j12 if estimate_bias else j12[:, :9]
    pinv = np.linalg.pinv(jg)
    extra = np.zeros((jg.shape[1], jg.shape[1]))
    if bias_cov is not None and not estimate_bias:
        sens = -pinv @ j12[:, 9:]
        extra += sens @ bias_cov @ sens.T
    undetermined = acc_cov is not None and not np.all(np.isfinite(np.diag(acc_cov)))
    if acc_cov is not None and not undetermined:
        w_eff = np.ones(len(res) // 3) if weights is None else np.asarray(weights, dtype=float)
        j_acc = (direction_acc_jacobian(recording, intervals, accelerometer, gyroscope, transitions)
                 * np.repeat(w_eff, 3)[:, None])
        sens = -pinv @ j_acc
        extra += sens @ acc_cov @ sens.T
    use = layout if estimate_bias else GyroLayout(False)
    errors = gyroscope_errors(use.pack(gyroscope), jg, res, use, n_transitions=n, extra_cov=extra)
    if undetermined:  # the poses leave the gravity directions themselves undetermined
        errors = {k: float("nan") for k in errors}
    if bias_cov is not None and not estimate_bias:
        errors |= {f"gyroscope.bias.{a}": float(s) for a, s in zip(AXES, np.sqrt(np.diag(bias_cov)), strict=True)}
    return errors


@dataclass
class GyroFit:
    """A gyroscope calibrated from the rotations between static poses, with what was decided on the way."""

    model: TriadModel
    errors: dict[str, float]
    bias_source: str  # "joint" (static poses and rotations), "poses" (the poses' means) or "fit" (the rotations)
    left_out: dict[int, str] = field(default_factory=dict)  # transition k (pose k → k+1) → why
    drift: np.ndarray | None = None  # the bias's drift [raw per s] the static poses show, None without
    drift_se: np.ndarray | None = None
    t_ref: float = 0.0  # the time [s] at which ``model.bias`` holds (the mean of the poses' times)
    rotation_sigma: float | None = None  # the rotations' direction noise per component [rad] (joint fit)
    #: the integrator of the motions between the poses (for figures that integrate them again with the result)
    integrator: IntervalIntegrator | None = field(default=None, repr=False, compare=False)

    def report(self) -> GyroscopeReport:
        """The fit report's record of how the gyroscope was fitted."""
        out = GyroscopeReport(bias_source=self.bias_source,
                              g_sensitivity="estimated" if np.any(self.model.g_sensitivity) else "none")
        if self.drift is not None:
            out = out.with_(bias_drift_per_s=[float(x) for x in self.drift],
                            bias_drift_se_per_s=[float(x) for x in self.drift_se], bias_time_s=float(self.t_ref))
        if self.rotation_sigma is not None:
            out = out.with_(rotation_sigma_rad=float(self.rotation_sigma))
        if self.left_out:
            out = out.with_(rotations_left_out=dict(sorted(self.left_out.items())))
        return out


#: a transition whose error exceeds this many robust standard deviations of the others is left out
OUTLIER_SIGMA = 5.0


def fit_gyroscope(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, *,
                  estimate_bias: bool | str = "auto", g_sensitivity: bool | str = "auto",
                  exclude: dict[int, str] | None = None, robust: bool = True,
                  acc_cov: np.ndarray | None = None) -> GyroFit:
    """The gyroscope from the static poses and the rotations between them together.

    * The static poses give the bias, its linear drift and the g-sensitivity
      where they show them (:func:`static_gyro`, Zhang 2021 eq. 11).
    * ``estimate_bias="auto"`` (the default) fits ``T_g``, ``k1``, the bias and
      its drift to one cost holding both (:func:`joint_problem`): the
      rotations' gravity-direction errors (Zhang 2021, eq. 14) over their own
      noise and the poses' means (eq. 11) over their standard errors. The
      poses pin the bias to what the gyroscope reads at rest; the rotations
      move it only within that. ``False`` holds the bias at the poses'
      estimate; ``True`` estimates it from the rotations alone (eq. 14 only:
      for a rest that cannot be trusted).
    * Transitions in ``exclude`` (index ``k``: from pose ``k`` to ``k+1`` → the
      reason: saturated or spiking samples, a gap) are left out.
    * ``robust``: a transition whose error is more than :data:`OUTLIER_SIGMA`
      robust standard deviations (the median of the 2-D error norms is
      ``1.1774 σ``, Rayleigh) is left out and the fit repeated, at most a fifth
      of them; one bad rotation does not drag the rest.
    * ``acc_cov``: the accelerometer's parameter covariance, carried into the
      gyroscope's errors.
    """
    left_out = dict(exclude or {})
    n_tr = len(intervals) - 1
    if len(intervals) < MIN_POSES:
        raise ValueError(f"gyroscope calibration needs at least {MIN_POSES} static poses; got {len(intervals)}")
    joint = estimate_bias == "auto"
    static = static_gyro(recording, intervals, accelerometer, g_sensitivity=g_sensitivity,
                         drift="auto" if joint else False)
    tr = Transitions(recording, intervals)
    start = None
    sigma = None
    for _ in range(3):
        weights = np.ones(n_tr)
        weights[list(left_out)] = 0.0
        est = bool(estimate_bias) and not joint
        model, e = solve_direction(recording, intervals, accelerometer, static.bias, est, weights,
                                    static.g_sensitivity, start, tr)
        start = model
        if joint and np.any(weights > 0):
            model, theta, e, sigma, (fun, jac) = solve_joint(recording, intervals, accelerometer, static, weights,
                                                             model, tr)
            errors = joint_errors(recording, intervals, accelerometer, model, theta, jac, fun(theta), weights,
                                  sigma, static, acc_cov=acc_cov, transitions=tr)
        else:
            errors = errors_at(recording, intervals, accelerometer, model, est, weights=weights,
                               bias_cov=None if est else static.bias_cov, acc_cov=acc_cov, transitions=tr)
            if est and not all(np.isfinite(errors.get(f"gyroscope.bias.{a}", np.nan)) for a in AXES):
                est = False  # the bias is not observable from these rotations
                model, e = solve_direction(recording, intervals, accelerometer, static.bias, False, weights,
                                            static.g_sensitivity, start, tr)
                errors = errors_at(recording, intervals, accelerometer, model, False, weights=weights,
                                   bias_cov=static.bias_cov, acc_cov=acc_cov, transitions=tr)
        if not robust:
            break
        kept = weights > 0
        if not np.any(kept):
            break
        sigma_r = float(np.median(e[kept])) / 1.1774
        worst = [int(k) for k in np.argsort(-e) if kept[k] and e[k] > OUTLIER_SIGMA * sigma_r]
        room = n_tr // 5 - sum(1 for k in left_out if k not in (exclude or {}))
        if not worst or room <= 0:
            break
        for k in worst[:room]:
            left_out[k] = (f"its gravity-direction error {np.degrees(e[k]):.2f}° is {e[k] / sigma_r:.0f}× the "
                           f"others' robust σ ({np.degrees(sigma_r):.3f}°)")
    source = "joint" if joint else ("fit" if est else "poses")
    return GyroFit(model, errors | static.errors, source, left_out, static.drift if joint else None,
                   static.drift_se if joint else None, static.t_ref, sigma, tr.integrator)


def gyroscope_errors(theta: np.ndarray, jac: np.ndarray, res: np.ndarray, layout: GyroLayout, *,
                     n_transitions: int | None = None, extra_cov: np.ndarray | None = None) -> dict[str, float]:
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
    n = len(res) // 3 if n_transitions is None else n_transitions
    dof = 2 * n - layout.size  # two degrees of freedom per direction residual
    se = standard_errors(jac, res, dof=dof, transform=a, extra_cov=extra_cov)
    return {k: float(v) for k, v in zip(names, se, strict=True)}


def rotation_angles(recording, intervals, acc_model: TriadModel, bias: np.ndarray, *,
                    axis_tolerance: float = 20.0, min_tilt: float = 45.0,
                    max_angle: float = 170.0) -> list[dict]:
    r"""Rotations between consecutive static poses: axis, accelerometer angle, mean raw rate, duration.

    The angle is the tilt change the calibrated accelerometer measures
    (Qureshi 2017, appendix, eqs. 23–28: ``tan θ = g_X′ / √(g² − g_X′²)`` for a
    turn about a horizontal axis), written here for any pair of unit gravity
    directions ``g₀``, ``g₁`` and the turn's axis ``e`` (the body turns by
    ``+θ`` about ``e``, so gravity turns by ``−θ``), and the turn's axis is
    the one of the largest integrated raw rate:

    .. math::

        \theta = -\operatorname{atan2}\bigl((\mathbf g_0 \times \mathbf g_1) \cdot \mathbf e,\;
        \mathbf g_0 \cdot \mathbf g_1\bigr), \qquad
        i = \arg\max_j \Bigl| \int (u_j - b_j)\, dt \Bigr|
    """
    a = acc_model.forward(interval_means(recording.acc, intervals))
    u = a / np.linalg.norm(a, axis=1, keepdims=True)
    starts, stops = transition_bounds(intervals)
    out = []
    for k, (s0, s1) in enumerate(zip(starts, stops, strict=True)):
        raw = recording.gyro[s0 : s1 + 1]
        t = recording.t[s0 : s1 + 1]
        total = np.trapezoid(raw - bias, t, axis=0)
        i = int(np.argmax(np.abs(total)))  # the turn's axis: the largest ∫(u − b) dt
        e = np.zeros(3)
        e[i] = 1.0
        off_axis = np.degrees(np.arccos(np.clip(abs(total[i]) / np.linalg.norm(total), 0, 1)))
        tilt = np.degrees(np.arccos(np.clip(abs(u[k] @ e), 0, 1)))
        if off_axis > axis_tolerance or tilt < min_tilt:
            continue
        # body turns by +θ about e ⇒ gravity turns by −θ: θ = −atan2((g₀ × g₁)·e, g₀·g₁)
        # (the tilt change of eqs. 23–28 about a horizontal axis)
        theta = -np.arctan2(np.cross(u[k], u[k + 1]) @ e, u[k] @ u[k + 1])  # eqs. (23)–(28), any tilt
        if abs(theta) > np.radians(max_angle):  # ±180° is ambiguous: the sign flips with noise
            continue
        duration = float(t[-1] - t[0])
        out.append({"axis": i, "angle": float(theta), "mean_rate": float(np.mean(raw[:, i])),
                    "duration": duration,
                    "mean_rate_trapezoid": float(np.trapezoid(raw[:, i], t) / duration)})  # ω̄_ik of eq. (16)
    return out


def fit_known_turns(recording: Recording, turns: dict[int, list[tuple[int, int, int]]], angle: float,
                    bias: np.ndarray, g_sensitivity: np.ndarray, acc_si: np.ndarray) -> TriadModel:
    r"""Ferraris 1995: ``S_g e_i = ± (∫(u_g − b_g − G a) dt) / θ`` over the turns about axis ``i``.

    The turn-table method of Ferraris et al. 1995 with the sensitivity model
    ``u_g = S_g ω + b_g + G a`` (the paper's equations are not in the
    project's paper set, so they go unnumbered), the ``n_i`` turns about axis
    ``i`` by the known angle ``θ``, each with its sign ``s_j``, averaged:

    .. math::

        \mathbf S_g \mathbf e_i = \frac{1}{n_i} \sum_{j=1}^{n_i} \frac{s_j}{\theta}
        \int_{t_{j,0}}^{t_{j,1}} (\mathbf u_g - \mathbf b_g - \mathbf G \mathbf a)\, dt, \qquad
        \mathbf T_g\, \mathrm{diag}(\mathbf k) = \mathbf S_g^{-1}

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
            cols.append(sign * np.trapezoid(u, t, axis=0) / angle)  # Ferraris 1995: ∫(u − b − G a) dt / θ
        s_g[:, i] = np.mean(cols, axis=0)  # Ferraris 1995: S_g e_i
    return full_from_sensitivity(s_g, bias, g_sensitivity=g_sensitivity)


def fit_measured_rotations(rotations: list[dict], rest_bias: np.ndarray, approach: str
                           ) -> tuple[np.ndarray, np.ndarray, dict[str, float], list[int]]:
    r"""Per-axis gyroscope scale (and bias) from turns the accelerometer measured (Qureshi 2017).

    Qureshi 2017, eqs. (15)–(21): the model ``ω = K (ω^s − B)`` (15), a turn
    ``k`` about axis ``i`` by the measured angle ``Δθ_ik`` (:func:`rotation_angles`)
    at the mean raw rate ``ω̄_ik`` over its duration ``T_k``:

    .. math::

        \Delta\theta_{ik} = k_i (\bar\omega_{ik} - b_i) T_k \quad (17), \qquad
        k_i = \frac{\Delta\theta_{ik}}{(\bar\omega_{ik} - b_i) T_k} \quad (18)

        \mathbf A = \begin{bmatrix} \bar\omega_{i1} T_1 & -T_1 \\ \vdots & \vdots \\
        \bar\omega_{in} T_n & -T_n \end{bmatrix}, \quad
        \mathbf x = \begin{bmatrix} k_i \\ k_i b_i \end{bmatrix}, \quad
        \mathbf b = \begin{bmatrix} \Delta\theta_{i1} \\ \vdots \\ \Delta\theta_{in} \end{bmatrix}
        \quad (19), \qquad
        \mathbf A^\top \mathbf A\, \mathbf x = \mathbf A^\top \mathbf b \quad (21)

    (the static approach's eq. (18) over several turns in least squares:
    ``k_i = Σ x_k Δθ_ik / Σ x_k²``, ``x_k = (ω̄_ik − b_i) T_k``).

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
        k_each = theta / ((wbar - rest_bias[i]) * tk)  # eq. (18), each turn
        good = np.abs(k_each / np.median(k_each) - 1) < 0.1
        if np.count_nonzero(good) < need:
            raise ValueError(f"the turns about the {AXES[i]} axis disagree (eq. 18 scales "
                             f"{np.round(k_each, 9).tolist()}): turn about one axis at a time")
        theta, tk, wbar = theta[good], tk[good], wbar[good]
        rejected[i] = int(np.count_nonzero(~good))
        if approach == "static":
            x = (wbar - rest_bias[i]) * tk  # eq. (18) for each rotation, least squares over them
            k[i] = float(x @ theta / (x @ x))  # eq. (18) in least squares
            errors[f"gyroscope.scale.{AXES[i]}"] = float(standard_errors(x[:, None], k[i] * x - theta)[0])
        else:
            a_mat = np.column_stack([wbar * tk, -tk])  # eq. (19)
            sol = np.linalg.solve(a_mat.T @ a_mat, a_mat.T @ theta)  # eq. (21)
            k[i], b[i] = sol[0], sol[1] / sol[0]  # eq. (19): x = (k_i, k_i b_i)
            to_kb = np.array([[1.0, 0.0], [-sol[1] / sol[0] ** 2, 1.0 / sol[0]]])  # (k, k·b) → (k, b)
            se = standard_errors(a_mat, a_mat @ sol - theta, transform=to_kb)
            errors[f"gyroscope.scale.{AXES[i]}"], errors[f"gyroscope.bias.{AXES[i]}"] = map(float, se)
    return k, b, errors, rejected
