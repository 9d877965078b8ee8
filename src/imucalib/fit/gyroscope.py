"""Gyroscope estimators: building blocks the methods compose.

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

import itertools
from dataclasses import dataclass, field

import numpy as np

from ..kinematics import IntervalIntegrator, angle_between, quat_from_rotvec, quat_to_matrix
from ..metrics import interval_means, transition_bounds
from ..models import AXES, TriadModel
from ..recording import Interval, Recording
from ..residuals import AccelLayout, GyroLayout, gravity_direction_residuals, gravity_direction_residuals_jac
from ..solve import levenberg_marquardt, standard_errors
from .accelerometer import full_from_sensitivity

__all__ = ["MIN_POSES", "SIGNED_PERMUTATIONS", "GyroFit", "StaticGyro", "axes_disagreement", "errors_at",
           "fit_gravity_direction", "fit_gyroscope", "fit_known_turns", "fit_measured_rotations",
           "gravity_direction_problem", "gyroscope_errors", "rotation_angles", "rough_scale", "static_gyro",
           "transition_errors"]

#: the fewest static poses a gravity-direction fit takes
MIN_POSES = 4


def _gyro_scale_guess(
    gyro: np.ndarray, bias: np.ndarray, t: np.ndarray, starts: np.ndarray, stops: np.ndarray,
    gravity_dirs: np.ndarray, pairs: np.ndarray | None = None,
) -> float:
    """Common gyroscope scale [rad/s per raw unit] for the initial values.

    Each motion is approximated by one rotation about the axis of its integrated
    raw rate ``Φ_i = ∫(u − b) dt``, by the angle ``k‖Φ_i‖``; ``k`` minimises the
    gravity-direction residuals of these rotations over a dense logarithmic grid
    around ``median(angle between poses / ∫‖u − b‖dt)`` (no sensor-specific guess).
    ``pairs`` are the transitions' first poses when not all consecutive poses are used.
    The integrals are sums over each motion's own samples (rectangles of the
    forward steps ``t_{j+1} − t_j``).
    """
    if pairs is not None:
        gravity_dirs = np.stack([gravity_dirs[pairs], gravity_dirs[pairs + 1]], axis=1)
    else:
        gravity_dirs = np.stack([gravity_dirs[:-1], gravity_dirs[1:]], axis=1)
    phi_vec = np.zeros((len(starts), 3))
    path = np.zeros(len(starts))
    for i, (a, b) in enumerate(zip(starts, stops, strict=True)):
        v = gyro[a:b] - bias
        dt = t[a + 1:b + 1] - t[a:b]
        phi_vec[i] = dt @ v
        path[i] = dt @ np.sqrt(np.einsum("ij,ij->i", v, v))
    theta = angle_between(gravity_dirs[:, 0], gravity_dirs[:, 1])
    ok = (theta > np.radians(10)) & (path > 0)
    if not np.any(ok):
        ok = path > 0
    if not np.any(ok):
        raise ValueError("the gyroscope does not move between the static poses")
    k0 = float(np.median(theta[ok] / path[ok]))
    ks = k0 * np.geomspace(0.3, 30.0, 600)
    rot = quat_to_matrix(quat_from_rotvec(ks[:, None, None] * phi_vec[None, :, :]))
    pred = np.einsum("skji,kj->ski", rot, gravity_dirs[:, 0])
    cost = np.sum((gravity_dirs[None, :, 1] - pred) ** 2, axis=(1, 2))
    return float(ks[int(np.argmin(cost))])


#: every order and sign of three axes: (permutation, signs), the identity first
SIGNED_PERMUTATIONS = [(perm, signs) for perm in itertools.permutations(range(3))
                       for signs in itertools.product((1.0, -1.0), repeat=3)]


def _direction_errors(phi: np.ndarray, gravity_dirs: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """Per transition, the angle [rad] between the next pose's gravity direction and the previous one carried
    by the rotation ``exp(k Φ_i)`` (the single-rotation approximation of :func:`_gyro_scale_guess`), at the
    ``k`` of ``ks`` that fits them best."""
    rot = quat_to_matrix(quat_from_rotvec(ks[:, None, None] * phi[None, :, :]))
    pred = np.einsum("skji,kj->ski", rot, gravity_dirs[:, 0])
    cost = np.sum((gravity_dirs[None, :, 1] - pred) ** 2, axis=(1, 2))
    best = int(np.argmin(cost))
    return angle_between(pred[best], gravity_dirs[:, 1])


def axes_disagreement(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                      bias: np.ndarray, *, disagree_deg: float = 20.0, agree_deg: float = 10.0) -> str | None:
    """A message when the accelerometer and the gyroscope disagree about the rotations between poses, else None.

    Between consecutive static poses the gyroscope's integrated rotation carries
    the previous pose's gravity direction onto the next one's (Zhang 2021,
    eq. 14; Tedaldi 2014). Each motion is taken as one rotation about its
    integrated raw rate ``Φ_i`` by ``k‖Φ_i‖``, with the common scale ``k`` fitted
    as in :func:`_gyro_scale_guess`, once for the gyroscope's axes as they are
    and once for each of the 47 other orders and signs. When the axes as they
    are leave a median error above ``disagree_deg`` and another order or sign
    brings it under ``agree_deg`` (and under a third of it), one sensor's axes
    are swapped or reversed against the other's: the message names that order.
    """
    if len(intervals) < 3:
        return None
    acc = accelerometer.forward(interval_means(recording.acc, intervals))
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    pairs = np.stack([dirs[:-1], dirs[1:]], axis=1)
    starts, stops = transition_bounds(intervals)
    phi = np.zeros((len(starts), 3))
    path = np.zeros(len(starts))
    for i, (a, b) in enumerate(zip(starts, stops, strict=True)):
        v = recording.gyro[a:b] - bias
        dt = recording.t[a + 1:b + 1] - recording.t[a:b]
        phi[i] = dt @ v
        path[i] = dt @ np.sqrt(np.einsum("ij,ij->i", v, v))
    theta = angle_between(pairs[:, 0], pairs[:, 1])
    ok = (theta > np.radians(10)) & (path > 0)
    if np.count_nonzero(ok) < 3:
        return None
    phi, pairs = phi[ok], pairs[ok]
    ks = float(np.median(theta[ok] / path[ok])) * np.geomspace(0.3, 3.0, 200)
    errors = [float(np.degrees(np.median(_direction_errors(phi[:, list(perm)] * np.array(signs), pairs, ks))))
              for perm, signs in SIGNED_PERMUTATIONS]
    best = int(np.argmin(errors))
    as_is = errors[0]
    if best == 0 or as_is <= disagree_deg or errors[best] > min(agree_deg, as_is / 3):
        return None
    perm, signs = SIGNED_PERMUTATIONS[best]
    order = ", ".join(f"{'-' if sg < 0 else ''}{AXES[p]}" for p, sg in zip(perm, signs, strict=True))
    what = [f"{AXES[i]} and {AXES[j]} swapped" for i, j in ((0, 1), (0, 2), (1, 2))
            if perm[i] == j and perm[j] == i]
    if perm != (0, 1, 2) and not what:
        what.append("its axes in another order")
    negated = sorted(AXES[p] for p, sg in zip(perm, signs, strict=True) if sg < 0)
    if negated:
        what.append(f"the {', '.join(negated)} column{'s' if len(negated) > 1 else ''} negated")
    return (f"the accelerometer and the gyroscope disagree about the rotations between the poses: carried by the "
            f"gyroscope's rotations, gravity lands a median {as_is:.0f}° away from where the accelerometer finds "
            f"it in the next pose; with the gyroscope's axes read as ({order}) ({'; '.join(what)}) they agree "
            f"within {errors[best]:.1f}°. One sensor's axes are swapped or reversed against the other's: check "
            "the order and signs of the gyroscope's (or the accelerometer's) columns (--columns)")


def rough_scale(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                bias: np.ndarray) -> float:
    """A common gyroscope scale [rad/s per raw unit] good to a few per cent, from the rotations between poses."""
    acc = accelerometer.forward(interval_means(recording.acc, intervals))
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    return _gyro_scale_guess(recording.gyro, bias, recording.t, *transition_bounds(intervals), dirs)


def gravity_direction_problem(recording, intervals, accelerometer, bias, estimate_bias, weights=None,
                              g_sensitivity=None):
    """Residuals of Zhang 2021, eq. (14) in the :class:`GyroLayout` parameters, their Jacobian, the pose directions.

    ``weights`` (one per transition between consecutive poses) scale each
    transition's three residuals; 0 leaves a transition out. A known
    ``g_sensitivity`` ``G`` (raw per m/s²) is taken out of the readings first:
    ``u − G a`` with ``a`` the calibrated specific force (eq. 6).
    """
    acc = accelerometer.forward(interval_means(recording.acc, intervals))
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    starts, stops = transition_bounds(intervals)
    integrator = IntervalIntegrator(recording.t, starts, stops)
    raw = recording.gyro[integrator.samples]  # only the samples the integration reads
    if g_sensitivity is not None and np.any(g_sensitivity):
        raw = raw - accelerometer.forward(recording.acc[integrator.samples]) @ np.asarray(g_sensitivity).T
    layout = GyroLayout(estimate_bias)
    d = np.zeros((raw.shape[0], 3, layout.size))
    w = None if weights is None else np.repeat(np.asarray(weights, dtype=float), 3)

    def split(th):
        return th[:9].reshape(3, 3), (th[9:12] if estimate_bias else bias)

    def fun(th, directions=None):
        m, b = split(th)
        r = gravity_direction_residuals((raw - b) @ m.T, integrator.from_samples,
                                        dirs if directions is None else directions)
        return r if w is None else r * w

    def jac(th):
        m, b = split(th)
        v = raw - b
        for a in range(3):
            d[:, a, 3 * a : 3 * a + 3] = v  # ∂(M v)_a / ∂M_aj = v_j
        if estimate_bias:
            d[:, :, 9:12] = -m
        j = gravity_direction_residuals_jac(v @ m.T, d, integrator, dirs)[1]
        return j if w is None else j * w[:, None]

    return fun, jac, layout, dirs, (starts, stops)


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
    model, _ = _solve_direction(recording, intervals, accelerometer, bias, estimate_bias, weights, g_sensitivity)
    return model, errors_at(recording, intervals, accelerometer, model, estimate_bias, weights=weights,
                            bias_cov=bias_cov)


def _solve_direction(recording, intervals, accelerometer, bias, estimate_bias, weights, g_sensitivity,
                     start: TriadModel | None = None) -> tuple[TriadModel, np.ndarray]:
    """The eq. (14) fit: the model and each transition's weighted error norm [rad] (``start``: no scale search)."""
    if len(intervals) < MIN_POSES:
        raise ValueError(f"gyroscope calibration needs at least {MIN_POSES} static poses; got {len(intervals)}")
    fun, jac, layout, dirs, (starts, stops) = gravity_direction_problem(recording, intervals, accelerometer, bias,
                                                                        estimate_bias, weights, g_sensitivity)
    if start is None:
        keep = np.ones(len(starts), bool) if weights is None else np.asarray(weights) > 0
        k = _gyro_scale_guess(recording.gyro, bias, recording.t, starts[keep], stops[keep],
                              dirs, pairs=np.nonzero(keep)[0])
        start = TriadModel(scale=np.full(3, k), bias=bias)
    sol = levenberg_marquardt(fun, jac, layout.pack(start), xtol=1e-12, ftol=1e-12)
    model = layout.unpack(sol.x, bias)
    if g_sensitivity is not None:
        model = model.with_(g_sensitivity=g_sensitivity)
    return model, np.linalg.norm(sol.fun.reshape(-1, 3), axis=1)  # weighted: 0 for a transition left out


def errors_at(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, gyroscope: TriadModel,
              estimate_bias: bool, *, weights: np.ndarray | None = None, bias_cov: np.ndarray | None = None,
              acc_cov: np.ndarray | None = None, bias_spread: np.ndarray | None = None) -> dict[str, float]:
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
    error adds ``bias_spread`` (per axis) to ``bias_cov``.
    """
    fun, jac, layout, dirs, _ = gravity_direction_problem(recording, intervals, accelerometer, gyroscope.bias, True,
                                                          weights, gyroscope.g_sensitivity)
    theta = layout.pack(gyroscope)
    j12 = jac(theta)
    n = len(intervals) - 1 if weights is None else int(np.count_nonzero(weights))
    res = fun(theta)
    jg = j12 if estimate_bias else j12[:, :9]
    pinv = np.linalg.pinv(jg)
    extra = np.zeros((jg.shape[1], jg.shape[1]))
    if bias_cov is not None and not estimate_bias:
        sens = -pinv @ j12[:, 9:]
        extra += sens @ bias_cov @ sens.T
    undetermined = acc_cov is not None and not np.all(np.isfinite(np.diag(acc_cov)))
    if acc_cov is not None and not undetermined:
        lay = AccelLayout("upper", 1)
        base = lay.pack(accelerometer)
        means = interval_means(recording.acc, intervals)
        # r_k = d_{k+1} − R_kᵀ d_k is linear in the directions d: R_kᵀ from three evaluations, then the
        # directions' derivatives by finite differences of the means alone
        w_eff = np.ones(len(res) // 3) if weights is None else np.asarray(weights, dtype=float)
        rt = np.empty((len(res) // 3, 3, 3))
        for j in range(3):
            e = np.zeros_like(dirs)
            e[:, j] = 1.0
            rt[:, :, j] = e[1:] - fun(theta, e).reshape(-1, 3) / np.where(w_eff > 0, w_eff, 1.0)[:, None]
        j_acc = np.empty((len(res), lay.size))
        for i in range(lay.size):
            h = 1e-6 * max(abs(base[i]), 1e-12) if base[i] else 1e-9
            step = base.copy()
            step[i] += h
            d = lay.unpack(step, accelerometer).forward(means)
            delta = (d / np.linalg.norm(d, axis=1, keepdims=True) - dirs) / h
            j_acc[:, i] = ((delta[1:] - np.einsum("kij,kj->ki", rt, delta[:-1])) * w_eff[:, None]).ravel()
        sens = -pinv @ j_acc
        extra += sens @ acc_cov @ sens.T
    use = layout if estimate_bias else GyroLayout(False)
    errors = gyroscope_errors(use.pack(gyroscope), jg, res, use, n_transitions=n, extra_cov=extra)
    if undetermined:  # the poses leave the gravity directions themselves undetermined
        errors = {k: float("nan") for k in errors}
    if bias_cov is not None and not estimate_bias:
        var = np.diag(bias_cov) + (0.0 if bias_spread is None else np.asarray(bias_spread) ** 2)
        errors |= {f"gyroscope.bias.{a}": float(s) for a, s in zip(AXES, np.sqrt(var), strict=True)}
    return errors


def transition_errors(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                      gyroscope: TriadModel) -> np.ndarray:
    """‖r_k‖ of eq. (14) for each transition: the gravity-direction error [rad, small-angle]."""
    fun, _, layout, _, _ = gravity_direction_problem(recording, intervals, accelerometer, gyroscope.bias, False,
                                                     g_sensitivity=gyroscope.g_sensitivity)
    return np.linalg.norm(fun(layout.pack(gyroscope)).reshape(-1, 3), axis=1)


@dataclass(frozen=True)
class StaticGyro:
    """The gyroscope's reading at rest over the static poses: ``ū_k = b + G a_k`` (Zhang 2021, eq. 11)."""

    bias: np.ndarray
    bias_cov: np.ndarray  # of the estimate: what it carries into the other parameters
    g_sensitivity: np.ndarray | None  # None when the poses do not support it
    errors: dict[str, float]
    spread: np.ndarray  # per axis, the scatter of one pose's mean about the fit: drift and turn-on changes


def static_gyro(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, *,
                g_sensitivity: bool | str = "auto") -> StaticGyro:
    """Bias (and g-sensitivity) of the gyroscope from its means at the static poses.

    At rest the gyroscope reads ``ū_k = b + G a_k`` (Zhang 2021, eq. 11, with
    the canonical sign): a linear regression over the poses with the calibrated
    specific force ``a_k``. ``g_sensitivity="auto"`` keeps ``G`` when it
    lowers the Bayesian information criterion ``n ln(RSS/n) + p ln n`` of the
    pose means (``n = 3M``; ``p`` = 3 without ``G``, 12 with it); a turn-on
    change or slow drift of the bias scatters the means without a pattern in
    ``a`` and does not make ``G`` appear. The bias's covariance is the
    regression's (its standard error over the poses, the scatter included);
    the bias's own reported 1σ adds the scatter of one pose about the fit,
    since a drifting bias is that far from the session's mean at any moment.
    """
    u = interval_means(recording.gyro, intervals)
    a = accelerometer.forward(interval_means(recording.acc, intervals))
    m = len(u)
    x0 = np.ones((m, 1))
    x1 = np.column_stack([np.ones(m), a])
    fits = {}
    for with_g, x in ((False, x0), (True, x1)):
        if with_g and (g_sensitivity is False or m <= 8):
            continue
        if not with_g and g_sensitivity is True and m > 8:
            continue
        coef, *_ = np.linalg.lstsq(x, u, rcond=None)
        res = u - x @ coef
        rss = float(np.sum(res**2))
        n, p = 3 * m, 3 * x.shape[1]
        bic = n * np.log(max(rss, 1e-300) / n) + p * np.log(n)
        fits[with_g] = (bic, coef, res, x)
    with_g = min(fits, key=lambda k: fits[k][0])
    _, coef, res, x = fits[with_g]
    dof = max(m - x.shape[1], 1)
    s2 = np.sum(res**2, axis=0) / dof  # per gyroscope axis
    xtx = np.linalg.pinv(x.T @ x)
    bias = coef[0]
    bias_cov = np.diag(s2 * xtx[0, 0])
    errors: dict[str, float] = {}
    g = None
    if with_g:
        g = coef[1:].T  # row: gyroscope axis, column: accelerometer axis
        se = np.sqrt(np.outer(s2, np.diag(xtx)[1:]))
        errors = {f"gyroscope.g_sensitivity.{AXES[i]}{AXES[j]}": float(se[i, j]) for i in range(3) for j in range(3)}
    return StaticGyro(bias, bias_cov, g, errors, np.sqrt(s2))


@dataclass
class GyroFit:
    """A gyroscope calibrated from the rotations between static poses, with what was decided on the way."""

    model: TriadModel
    errors: dict[str, float]
    bias_source: str  # "poses" (the static poses' means) or "fit" (estimated from the rotations)
    left_out: dict[int, str] = field(default_factory=dict)  # transition k (pose k → k+1) → why

    def summary(self) -> dict:
        """The ``fit`` entries that say how the gyroscope was fitted."""
        out: dict = {"gyroscope_bias_source": self.bias_source,
                     "gyroscope_g_sensitivity": "estimated" if np.any(self.model.g_sensitivity) else "none"}
        if self.left_out:
            out["rotations_left_out"] = {str(k): why for k, why in sorted(self.left_out.items())}
        return out


#: a transition whose error exceeds this many robust standard deviations of the others is left out
OUTLIER_SIGMA = 5.0


def fit_gyroscope(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, *,
                  estimate_bias: bool | str = "auto", g_sensitivity: bool | str = "auto",
                  exclude: dict[int, str] | None = None, robust: bool = True,
                  acc_cov: np.ndarray | None = None) -> GyroFit:
    """The gyroscope by gravity-direction propagation (Zhang 2021, eq. 14), robust and with the bias chosen by the data.

    * The static poses give the bias and, where they support it, the
      g-sensitivity (:func:`static_gyro`, Zhang 2021 eq. 11).
    * Transitions in ``exclude`` (index ``k``: from pose ``k`` to ``k+1`` → the
      reason: saturated or spiking samples, a gap) are left out.
    * ``robust``: a transition whose error is more than :data:`OUTLIER_SIGMA`
      robust standard deviations (the median of the 2-D error norms is
      ``1.1774 σ``, Rayleigh) is left out and the fit repeated, at most a fifth
      of them; one bad rotation does not drag the rest.
    * ``estimate_bias="auto"``: the bias is estimated with the other
      parameters when that lowers the Bayesian information criterion of the
      residuals (``n ln(RSS/n) + p ln n``, ``n`` = 2 per transition), else taken
      from the static poses with its covariance.
    * ``acc_cov``: the accelerometer's parameter covariance, carried into the
      gyroscope's errors (:func:`errors_at`).
    """
    left_out = dict(exclude or {})
    n_tr = len(intervals) - 1
    static = static_gyro(recording, intervals, accelerometer, g_sensitivity=g_sensitivity)
    options = [False, True] if estimate_bias == "auto" else [bool(estimate_bias)]
    start = None
    for _ in range(3):
        weights = np.ones(n_tr)
        weights[list(left_out)] = 0.0
        n = 2 * int(np.count_nonzero(weights))
        fits = []
        for est in options:
            model, e = _solve_direction(recording, intervals, accelerometer, static.bias, est, weights,
                                        static.g_sensitivity, start)
            start = model  # the next candidate starts where this one ended
            rss = float(np.sum((e * weights) ** 2))
            bic = n * np.log(max(rss, 1e-300) / n) + (12 if est else 9) * np.log(n)
            fits.append((bic, est, model, e))
        bic, est, model, e = min(fits, key=lambda f: f[0])
        errors = errors_at(recording, intervals, accelerometer, model, est, weights=weights,
                           bias_cov=None if est else static.bias_cov, acc_cov=acc_cov, bias_spread=static.spread)
        if est and not all(np.isfinite(errors.get(f"gyroscope.bias.{a}", np.nan)) for a in AXES):
            bic, est, model, e = fits[0]  # the bias is not observable from these rotations
            errors = errors_at(recording, intervals, accelerometer, model, False, weights=weights,
                               bias_cov=static.bias_cov, acc_cov=acc_cov, bias_spread=static.spread)
        if not robust:
            break
        kept = weights > 0
        sigma = float(np.median(e[kept])) / 1.1774
        worst = [int(k) for k in np.argsort(-e) if kept[k] and e[k] > OUTLIER_SIGMA * sigma]
        room = n_tr // 5 - sum(1 for k in left_out if k not in (exclude or {}))
        if not worst or room <= 0:
            break
        for k in worst[:room]:
            left_out[k] = (f"its gravity-direction error {np.degrees(e[k]):.2f}° is {e[k] / sigma:.0f}× the "
                           f"others' robust σ ({np.degrees(sigma):.3f}°)")
    return GyroFit(model, errors | static.errors, "fit" if est else "poses", left_out)


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

