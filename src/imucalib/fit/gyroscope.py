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

from ..fitreport import GyroscopeReport
from ..kinematics import IntervalIntegrator, angle_between, quat_from_rotvec, quat_to_matrix
from ..metrics import interval_means, rowwise, transition_bounds
from ..models import AXES, TriadModel
from ..presets import GYRO_MIN_POSES
from ..recording import Interval, Recording
from ..residuals import (
    AccelLayout,
    GyroLayout,
    gravity_direction_residuals,
    gravity_direction_residuals_jac,
    linear_rate_jacobian,
)
from ..solve import levenberg_marquardt, scaled_inverse, standard_errors
from .accelerometer import full_from_sensitivity

__all__ = ["MIN_POSES", "SIGNED_PERMUTATIONS", "GyroFit", "StaticGyro", "accelerometer_joint_step",
           "axes_disagreement", "errors_at", "fit_gravity_direction", "fit_gyroscope", "fit_known_turns",
           "fit_measured_rotations", "gravity_direction_problem", "gyroscope_errors", "joint_errors",
           "joint_errors_at", "joint_problem", "rotation_angles", "rough_scale", "static_gyro", "transition_errors"]

#: the fewest static poses a gravity-direction fit takes
MIN_POSES = GYRO_MIN_POSES


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
        v = rowwise(np.subtract, gyro[a:b], bias)
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
    return float(ks[int(np.argmin(_single_rotation_costs(phi_vec, gravity_dirs, ks)))])


def _single_rotation_costs(phi: np.ndarray, gravity_dirs: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """``Σ_i ‖g_i′ − R(k Φ_i)ᵀ g_i‖²`` for each ``k`` of ``ks``: gravity carried by one rotation per motion.

    By Rodrigues' formula, ``R(θn)ᵀ g = g cos θ − (n × g) sin θ + n (n·g)(1 − cos θ)``,
    so with ``θ = k‖Φ_i‖`` each term is
    ``‖g′‖² + ‖g‖² − 2 [(g′·g − c) cos θ − g′·(n × g) sin θ + c]``, ``c = (n·g′)(n·g)``:
    a cosine and a sine per motion and ``k`` instead of a rotation matrix.
    ``gravity_dirs`` (K, 2, 3): each motion's gravity before and after.
    """
    g0, g1 = gravity_dirs[:, 0], gravity_dirs[:, 1]
    norm = np.linalg.norm(phi, axis=1)
    n = phi / np.where(norm > 0, norm, 1.0)[:, None]
    c = np.einsum("ij,ij->i", n, g1) * np.einsum("ij,ij->i", n, g0)
    along = np.einsum("ij,ij->i", g1, g0) - c
    across = np.einsum("ij,ij->i", g1, np.cross(n, g0))
    angle = ks[:, None] * norm[None, :]
    terms = np.einsum("ij,ij->i", g1, g1) + np.einsum("ij,ij->i", g0, g0) - 2 * c
    return np.sum(terms[None, :] - 2 * (along * np.cos(angle) - across * np.sin(angle)), axis=1)


#: every order and sign of three axes: (permutation, signs), the identity first
SIGNED_PERMUTATIONS = [(perm, signs) for perm in itertools.permutations(range(3))
                       for signs in itertools.product((1.0, -1.0), repeat=3)]


def _direction_errors(phi: np.ndarray, gravity_dirs: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """Per transition, the angle [rad] between the next pose's gravity direction and the previous one carried
    by the rotation ``exp(k Φ_i)`` (the single-rotation approximation of :func:`_gyro_scale_guess`), at the
    ``k`` of ``ks`` that fits them best."""
    best = ks[int(np.argmin(_single_rotation_costs(phi, gravity_dirs, ks)))]
    pred = np.einsum("kji,kj->ki", quat_to_matrix(quat_from_rotvec(best * phi)), gravity_dirs[:, 0])
    return angle_between(pred, gravity_dirs[:, 1])


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


class _Transitions:
    """The motions between consecutive poses as the gyroscope problems of one fit read them.

    Their integrator (:class:`~imucalib.kinematics.IntervalIntegrator`), the
    gyroscope's readings at their samples less ``G a`` (:func:`_readings`, one
    array per accelerometer and ``G``), the calibrated specific force there, and
    the RK4 factors (:meth:`~imucalib.kinematics.IntervalIntegrator.step_factors`)
    and end attitudes of the rates last integrated, under a key that names the
    problem and its parameters. Levenberg–Marquardt evaluates the Jacobian
    where it last evaluated the cost, the second joint fit starts where the
    first ended and the errors are formed at the solution: the same rates each
    time, integrated once (the same numbers). One set of factors is kept at a
    time, and the Jacobian frees them (``keep=False``); the end attitudes (one
    quaternion per motion) stay with their key.
    """

    def __init__(self, recording: Recording, intervals: list[Interval]) -> None:
        self.recording = recording
        self.intervals = intervals
        self._acc_means: np.ndarray | None = None
        self.starts, self.stops = transition_bounds(intervals)
        self.integrator = IntervalIntegrator(recording.t, self.starts, self.stops)
        self._readings: dict = {}
        self._force: dict = {}
        self._key: tuple | None = None
        self._steps: np.ndarray | None = None
        self._q: np.ndarray | None = None

    def readings(self, accelerometer: TriadModel, g_sensitivity: np.ndarray | None) -> np.ndarray:
        """:func:`_readings` at the motions' samples (formed once per accelerometer and ``G``; not to be changed)."""
        if g_sensitivity is None or not np.any(g_sensitivity):
            key = None
        else:
            key = (id(accelerometer), np.asarray(g_sensitivity, dtype=np.float64).tobytes())
        if key not in self._readings:  # the accelerometer kept with them: its id stays its own
            self._readings[key] = (accelerometer, _readings(self.recording, self.integrator.samples, accelerometer,
                                                            None if key is None else g_sensitivity))
        return self._readings[key][1]

    def acc_means(self) -> np.ndarray:
        """The raw accelerometer's mean over each pose (:func:`~imucalib.metrics.interval_means`, formed once;
        not to be changed)."""
        if self._acc_means is None:
            self._acc_means = interval_means(self.recording.acc, self.intervals)
        return self._acc_means

    def specific_force(self, accelerometer: TriadModel) -> np.ndarray:
        """The calibrated specific force [m/s²] at the motions' samples."""
        if id(accelerometer) not in self._force:
            self._force[id(accelerometer)] = (accelerometer,
                                              accelerometer.forward(self.recording.acc[self.integrator.samples]))
        return self._force[id(accelerometer)][1]

    def steps(self, key: tuple, rates: np.ndarray, keep: bool = True) -> np.ndarray:
        """The RK4 factors of ``rates``, the rates of the problem and parameters ``key``."""
        same = key == self._key
        steps = self._steps if same else None
        q = self._q if same else None
        self._key = self._steps = self._q = None  # the old ones freed before new ones are formed
        if steps is None:
            steps = self.integrator.step_factors(rates)
        self._key, self._q = key, q
        if keep:
            self._steps = steps
        return steps

    def attitudes(self, key: tuple, rates) -> np.ndarray:
        """The end attitudes (M, 4) of the rates ``rates()`` of ``key`` (:meth:`IntervalIntegrator.from_samples`)."""
        if key == self._key and self._q is not None:
            return self._q
        r = rates()
        steps = self.steps(key, r)
        self._q = self.integrator.from_samples(r, steps)
        return self._q


#: samples whose g-sensitivity term :func:`_readings` forms at once
READ_CHUNK = 1 << 16


def _readings(recording: Recording, samples: np.ndarray, accelerometer: TriadModel,
              g_sensitivity: np.ndarray | None) -> np.ndarray:
    """The gyroscope's readings at ``samples`` less ``G a`` (Zhang 2021, eq. 6), ``a`` the calibrated specific force.

    The calibration's temporaries exist for :data:`READ_CHUNK` samples at a time, not for every sample of the
    motions (each row is computed alone, so the numbers are those of the whole at once).
    """
    raw = recording.gyro[samples]
    if g_sensitivity is not None and np.any(g_sensitivity):
        g = np.asarray(g_sensitivity).T
        for a in range(0, samples.size, READ_CHUNK):
            part = samples[a : a + READ_CHUNK]
            raw[a : a + part.size] -= accelerometer.forward(recording.acc[part]) @ g
    return raw


def gravity_direction_problem(recording, intervals, accelerometer, bias, estimate_bias, weights=None,
                              g_sensitivity=None, transitions: _Transitions | None = None):
    """Residuals of Zhang 2021, eq. (14) in the :class:`GyroLayout` parameters, their Jacobian, the pose directions.

    ``weights`` (one per transition between consecutive poses) scale each
    transition's three residuals; 0 leaves a transition out. A known
    ``g_sensitivity`` ``G`` (raw per m/s²) is taken out of the readings first:
    ``u − G a`` with ``a`` the calibrated specific force (eq. 6).
    ``transitions``: the fit's :class:`_Transitions` of these intervals, shared
    with its other problems (a new one by default).
    """
    tr = _Transitions(recording, intervals) if transitions is None else transitions
    acc = accelerometer.forward(tr.acc_means())
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    integrator = tr.integrator
    raw = tr.readings(accelerometer, g_sensitivity)  # only those the integration reads
    layout = GyroLayout(estimate_bias)
    w = None if weights is None else np.repeat(np.asarray(weights, dtype=float), 3)
    held = b"" if estimate_bias else np.asarray(bias, dtype=np.float64).tobytes()

    space: dict = {}  # the rate Jacobian's block buffer, kept from one Jacobian to the next

    def split(th):
        return th[:9].reshape(3, 3), (th[9:12] if estimate_bias else bias)

    def key(th):
        return ("direction", id(raw), held, np.asarray(th, dtype=np.float64).tobytes())

    def rates_at(th):
        m, b = split(th)
        return rowwise(np.subtract, raw, b) @ m.T

    def fun(th, directions=None):
        q = tr.attitudes(key(th), lambda: rates_at(th))
        r = gravity_direction_residuals(None, lambda _: q, dirs if directions is None else directions)
        return r if w is None else r * w

    def jac(th):
        m, b = split(th)
        v = rowwise(np.subtract, raw, b)
        rates = v @ m.T
        rate_jac = linear_rate_jacobian(m, v, bias=estimate_bias, workspace=space)
        j = gravity_direction_residuals_jac(rates, rate_jac, integrator, dirs, tr.steps(key(th), rates, keep=False))[1]
        return j if w is None else j * w[:, None]

    return fun, jac, layout, dirs, (tr.starts, tr.stops)


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
                     start: TriadModel | None = None, transitions: _Transitions | None = None
                     ) -> tuple[TriadModel, np.ndarray]:
    """The eq. (14) fit: the model and each transition's weighted error norm [rad] (``start``: no scale search)."""
    if len(intervals) < MIN_POSES:
        raise ValueError(f"gyroscope calibration needs at least {MIN_POSES} static poses; got {len(intervals)}")
    fun, jac, layout, dirs, (starts, stops) = gravity_direction_problem(recording, intervals, accelerometer, bias,
                                                                        estimate_bias, weights, g_sensitivity,
                                                                        transitions)
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
              acc_cov: np.ndarray | None = None, transitions: _Transitions | None = None) -> dict[str, float]:
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
        j_acc = (_direction_acc_jacobian(recording, intervals, accelerometer, gyroscope, transitions)
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


def transition_errors(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                      gyroscope: TriadModel) -> np.ndarray:
    """‖r_k‖ of eq. (14) for each transition: the gravity-direction error [rad, small-angle]."""
    fun, _, layout, _, _ = gravity_direction_problem(recording, intervals, accelerometer, gyroscope.bias, False,
                                                     g_sensitivity=gyroscope.g_sensitivity)
    return np.linalg.norm(fun(layout.pack(gyroscope)).reshape(-1, 3), axis=1)


@dataclass(frozen=True)
class StaticGyro:
    """The gyroscope at rest over the static poses: ``ū_k = b + d (t_k − t_ref) + G a_k`` (Zhang 2021, eq. 11).

    ``variances`` (M, 3) are each pose mean's variance as the fit weights it:
    the white noise of its samples over their number plus the scatter
    between poses the noise does not explain (tremor, a random walk of the
    bias), ``scatter`` per axis.
    """

    bias: np.ndarray
    bias_cov: np.ndarray  # of the estimate: what it carries into the other parameters
    g_sensitivity: np.ndarray | None  # None when the poses do not support it
    errors: dict[str, float]
    spread: np.ndarray  # per axis, the scatter of one pose's mean about the fit: drift and turn-on changes
    drift: np.ndarray | None = None  # the bias's linear drift [raw per s], None when the poses show none
    t_ref: float = 0.0  # the time [s] at which ``bias`` holds: the mean of the poses' times
    times: np.ndarray | None = None  # (M,) each pose's mean time [s]
    means: np.ndarray | None = None  # (M, 3) each pose's mean reading [raw]
    accel: np.ndarray | None = None  # (M, 3) each pose's calibrated specific force [m/s²]
    variances: np.ndarray | None = None  # (M, 3) each pose mean's variance [raw²], scatter included
    scatter: np.ndarray | None = None  # (3,) the scatter between poses beyond the white noise [raw]
    drift_se: np.ndarray | None = None  # (3,) 1σ of ``drift``
    g_cov: np.ndarray | None = None  # (3, 3, 3) per gyroscope axis, the covariance of its row of ``g_sensitivity``


def _regression_solve(x: np.ndarray, u: np.ndarray, v: np.ndarray, tau2: float):
    """One axis's weighted least squares of ``u ≈ x c`` with weights ``1/(v + τ²)``: ``c``, its covariance, χ², the
    residuals.

    The covariance is the pseudo-inverse of ``xᵀ W x`` (``np.linalg.pinv``'s operations, relative cut-off
    1e-15, without its per-call overhead: the same numbers).
    """
    w = 1.0 / (v + tau2)
    xw = x * w[:, None]
    cov = _pinv(x.T @ xw)
    c = cov @ (xw.T @ u)
    r = u - x @ c
    return c, cov, float(np.add.reduce(w * r * r)), r


def _pinv(a: np.ndarray) -> np.ndarray:
    """``np.linalg.pinv(a)`` of a real (…, p, p) array by its own operations: the same numbers, bit for bit.

    From the thin SVD ``a = U S Vᵀ``, ``a⁺ = V S⁺ Uᵀ`` with ``1/s`` for the singular values above 1e-15 times
    the largest, 0 for the others.
    """
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    large = s > 1e-15 * s.max(axis=-1, keepdims=True)
    s = np.divide(1, s, where=large, out=s)
    s[~large] = 0
    return np.matmul(np.swapaxes(vt, -1, -2), np.multiply(s[..., None], np.swapaxes(u, -1, -2)))


def _weighted_regressions(problems: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> list[tuple]:
    """:func:`_weighted_regression` of each ``(x, u, v)``, the searches for ``τ²`` run side by side.

    Each search is the bisection :func:`_weighted_regression` describes, with
    the same brackets, midpoints and stopping test; only the χ² that decides
    each step is formed for all of them at once (one stacked pseudo-inverse,
    the regressors padded with zero columns, which leave the fit as it is).
    The χ² at ``τ² = 0`` that decides whether to search, and every returned
    fit, are computed one by one as in the single case, so a search can only
    end elsewhere if a step's χ² lies within rounding of the degrees of
    freedom.
    """
    first = [_regression_solve(x, u, v, 0.0) for x, u, v in problems]
    dofs = [max(x.shape[0] - x.shape[1], 1) for x, _, _ in problems]
    tau2 = [0.0] * len(problems)
    todo = [k for k, (f, dof) in enumerate(zip(first, dofs, strict=True)) if f[2] > dof]
    if todo:
        width = max(problems[k][0].shape[1] for k in todo)
        m = problems[todo[0]][0].shape[0]
        x = np.zeros((len(todo), m, width))
        for i, k in enumerate(todo):
            x[i, :, : problems[k][0].shape[1]] = problems[k][0]
        u = np.array([problems[k][1] for k in todo])
        v = np.array([problems[k][2] for k in todo])
        dof = np.array([dofs[k] for k in todo], dtype=float)
        lo = np.zeros(len(todo))
        hi = np.array([float(np.max(first[k][3] * first[k][3])) * 10 + 1e-300 for k in todo])
        active = np.ones(len(todo), bool)
        xt, uc = np.swapaxes(x, 1, 2), u[:, :, None]
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            w = 1.0 / (v + mid[:, None])
            xw = x * w[:, :, None]
            c = _pinv(xt @ xw) @ (np.swapaxes(xw, 1, 2) @ uc)
            r = u - (x @ c)[:, :, 0]
            above = np.add.reduce(w * r * r, axis=1) > dof
            lo = np.where(active & above, mid, lo)
            hi = np.where(active & ~above, mid, hi)
            active &= ~(hi - lo <= 1e-10 * hi)
            if not active.any():
                break
        for i, k in enumerate(todo):
            tau2[k] = float(hi[i])
    out = []
    for (x, u, v), f, t in zip(problems, first, tau2, strict=True):
        c, cov, _, r = f if t == 0.0 else _regression_solve(x, u, v, t)
        var = v + t
        loglik = -0.5 * float(np.sum(np.log(2 * np.pi * var) + r * r / var))
        out.append((c, cov, t, np.array([loglik])))
    return out


def _weighted_regression(x: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, float,
                                                                                 np.ndarray]:
    """One axis: least squares of ``u ≈ x c`` weighted by ``1/(v + τ²)``, ``τ²`` by Paule & Mandel.

    ``τ²`` ≥ 0 is the between-pose variance that makes the weighted residuals'
    χ² equal their degrees of freedom (Paule & Mandel 1982, the random-effects
    estimator of meta-analysis); 0 when the white noise ``v`` already explains
    the scatter. It is found by bisection on ``[0, 10 max r²]`` (χ² decreases
    with ``τ²``) to a relative 1e-10. Returns the coefficients, their
    covariance, ``τ²`` and the log-likelihood of the pose means.
    """
    return _weighted_regressions([(x, u, v)])[0]


def static_gyro(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, *,
                g_sensitivity: bool | str = "auto", drift: bool | str = "auto") -> StaticGyro:
    """Bias, drift and g-sensitivity of the gyroscope from its means at the static poses.

    At rest the gyroscope reads ``ū_k = b + G a_k`` (Zhang 2021, eq. 11, with
    the canonical sign), with the bias free to drift linearly in time,
    ``b + d (t_k − t_ref)`` (``t_k`` the pose's mean time, ``t_ref`` the mean of
    them, so ``b`` is the bias the poses show on average): a linear regression
    over the poses with the calibrated specific force ``a_k``, each pose
    weighted by the variance of its mean, ``σ_k²/n_k + τ²`` (``σ_k²`` its
    samples' variance, ``τ²`` the scatter between poses beyond that noise:
    tremor, a random walk; :func:`_weighted_regression`).

    ``g_sensitivity`` and ``drift`` ``"auto"``: each is kept when it lowers
    the Bayesian information criterion ``−2 ln L + p ln n`` of the pose means
    (``n = 3M``; ``p`` counts 3 per coefficient and the 3 ``τ²``); a turn-on
    change or random walk scatters the means without a pattern in ``a`` or
    ``t`` and makes neither appear. ``G`` needs more than 8 poses and the drift
    more than 5. The bias (at ``t_ref``) has the regression's covariance,
    which holds the scatter between poses through ``τ²``; ``spread`` (the
    scatter of one pose's mean about the fit) is reported beside it, not
    added to it.
    """
    u = interval_means(recording.gyro, intervals)
    a = accelerometer.forward(interval_means(recording.acc, intervals))
    m = len(u)
    add = np.add.reduce  # the sums of np.mean and np.var, without their per-call overhead: the same numbers
    times = np.array([float(add(recording.t[iv.slice]) / len(iv)) for iv in intervals])
    t_ref = float(np.mean(times))
    v = np.empty((m, 3))
    for k, iv in enumerate(intervals):  # np.var(gyro, axis=0) of each pose, over its samples' count less one
        seg = recording.gyro[iv.slice]
        d = seg - add(seg, axis=0, keepdims=True) / len(iv)
        np.multiply(d, d, out=d)
        v[k] = add(d, axis=0) / len(iv) / max(len(iv) - 1, 1)
    v = np.maximum(v, 1e-300)  # a quantised constant reading: no noise at all
    opts_g = [False, True] if g_sensitivity == "auto" else [bool(g_sensitivity)]
    opts_d = [False, True] if drift == "auto" else [bool(drift)]
    fits = {}
    for with_g in opts_g:
        if with_g and m <= 8:
            continue
        for with_d in opts_d:
            if with_d and m <= 5:
                continue
            cols = [np.ones(m)] + ([times - t_ref] if with_d else []) + ([*a.T] if with_g else [])
            fits[with_g, with_d] = np.column_stack(cols)
    regressions = _weighted_regressions([(x, u[:, j], v[:, j]) for x in fits.values() for j in range(3)])
    for i, (key, x) in enumerate(list(fits.items())):
        per_axis = regressions[3 * i : 3 * i + 3]
        loglik = sum(float(f[3][0]) for f in per_axis)
        n, p = 3 * m, 3 * x.shape[1] + 3
        fits[key] = (-2 * loglik + p * np.log(n), x, per_axis)
    if not fits:  # too few poses for what was asked: the plain mean
        x = np.ones((m, 1))
        fits[False, False] = (0.0, x, [_weighted_regression(x, u[:, j], v[:, j]) for j in range(3)])
    with_g, with_d = min(fits, key=lambda k: fits[k][0])
    _, x, per_axis = fits[with_g, with_d]
    coef = np.column_stack([f[0] for f in per_axis])  # (p, 3)
    covs = [f[1] for f in per_axis]
    tau2 = np.array([f[2] for f in per_axis])
    res = u - x @ coef
    dof = max(m - x.shape[1], 1)
    spread = np.sqrt(np.sum(res**2, axis=0) / dof)
    bias = coef[0]
    bias_cov = np.diag([c[0, 0] for c in covs])
    errors: dict[str, float] = {}
    g = d = d_se = g_cov = None
    first_g = 2 if with_d else 1
    if with_d:
        d = coef[1].copy()
        d_se = np.sqrt([c[1, 1] for c in covs])
    if with_g:
        g = coef[first_g:].T  # row: gyroscope axis, column: accelerometer axis
        g_cov = np.array([c[first_g:, first_g:] for c in covs])
        se = np.sqrt(np.array([np.diag(c) for c in g_cov]))
        errors = {f"gyroscope.g_sensitivity.{AXES[i]}{AXES[j]}": float(se[i, j]) for i in range(3) for j in range(3)}
    return StaticGyro(bias, bias_cov, g, errors, spread, d, t_ref, times, u, a, v + tau2[None, :],
                      np.sqrt(tau2), d_se, g_cov)


def joint_problem(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, static: StaticGyro,
                  weights: np.ndarray, sigma_rot: float, transitions: _Transitions | None = None):
    """Residuals and Jacobian of the joint gyroscope cost: the rotations and the static poses together.

    Parameters ``θ = [M (9), b (3), d (3, with a drift)]`` with ``M = T_g diag(k1)``;
    the rates are ``ω = M (u − b − d (t − t_ref) − G a)`` (Zhang 2021, eq. 6,
    with ``G`` of the static poses held). The residuals are

    * each kept rotation's gravity-direction error (Zhang 2021, eq. 14) over
      ``sigma_rot``, the rotations' own noise per component [rad];
    * each pose's mean reading against ``b + d (t_k − t_ref) + G a_k``
      (Zhang 2021, eq. 11) over its standard error ``√static.variances``.

    ``jac(θ, with_g=True)`` appends the 9 columns of ``∂r/∂G`` (``G`` row-major,
    held in the fit): ``G`` enters the poses' targets, ``(ū_k − G a_k − …)/se_k``,
    so ``∂r_{k,i}/∂G_ij = −a_{k,j}/se_{k,i}``, and every rotation sample's rate
    ``ω = M (u − b − d τ − G a)``, so ``∂ω/∂G_ij = −M e_i a_j`` with ``a`` the
    sample's calibrated specific force, through the same gravity-direction
    Jacobian as the other parameters (one integration for both).
    ``transitions``: as for :func:`gravity_direction_problem`.

    Returns ``fun``, ``jac``, the pose directions and the number of parameters.
    """
    tr = _Transitions(recording, intervals) if transitions is None else transitions
    acc = static.accel if static.accel is not None else accelerometer.forward(tr.acc_means())
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    integrator = tr.integrator
    g_sens = static.g_sensitivity
    raw = tr.readings(accelerometer, g_sens)
    tau = recording.t[integrator.samples] - static.t_ref
    with_d = static.drift is not None
    size = 15 if with_d else 12
    w = np.repeat(np.asarray(weights, dtype=float), 3) / sigma_rot
    target = static.means - (0.0 if g_sens is None else static.accel @ np.asarray(g_sens).T)
    se = np.sqrt(static.variances)
    dt_pose = static.times - static.t_ref

    space: dict = {}  # the rate Jacobian's block buffer, kept from one Jacobian to the next

    def split(th):
        return th[:9].reshape(3, 3), th[9:12], (th[12:15] if with_d else np.zeros(3))

    def key(th):
        return ("joint", id(raw), static.t_ref, with_d, np.asarray(th, dtype=np.float64).tobytes())

    def readings_at(th):  # u − G a − b − d τ
        _, b, dr = split(th)
        v = rowwise(np.subtract, raw, b)
        for a in range(0, len(v), READ_CHUNK):  # τ d: each sample's τ repeated for the three axes, a chunk at a time
            part = v[a : a + READ_CHUNK]
            part -= rowwise(np.multiply, np.repeat(tau[a : a + READ_CHUNK], 3).reshape(-1, 3), dr)
        return v

    def fun(th):
        m, b, dr = split(th)
        q = tr.attitudes(key(th), lambda: readings_at(th) @ m.T)
        r_rot = gravity_direction_residuals(None, lambda _: q, dirs) * w
        r_st = (target - b - dt_pose[:, None] * dr) / se
        return np.concatenate([r_rot, r_st.ravel()])

    def jac(th, with_g: bool = False):
        m, b, dr = split(th)
        v = readings_at(th)
        rate_jac = linear_rate_jacobian(m, v, drift_time=tau if with_d else None, workspace=space)
        g_jac = _g_rate_jacobian(m, tr.specific_force(accelerometer)) if with_g else None
        cols = size + 9 if with_g else size
        rates = v @ m.T
        j_rot = gravity_direction_residuals_jac(rates, rate_jac, integrator, dirs,
                                                tr.steps(key(th), rates, keep=False), g_jac)[1] * w[:, None]
        mm = len(static.means)
        j_st = np.zeros((mm, 3, cols))
        for i in range(3):
            j_st[:, i, 9 + i] = -1.0 / se[:, i]
            if with_d:
                j_st[:, i, 12 + i] = -dt_pose / se[:, i]
            if with_g:
                j_st[:, i, size + 3 * i:size + 3 * i + 3] = -static.accel / se[:, i:i + 1]
        return np.vstack([j_rot, j_st.reshape(3 * mm, cols)])

    return fun, jac, dirs, size


#: samples whose specific force :func:`_g_rate_jacobian` tiles at once
TILE_ROWS = 1 << 12


def _g_rate_jacobian(m: np.ndarray, force: np.ndarray):
    """``∂ω/∂G_ij = −M e_i a_j`` (``G`` row-major) of the samples ``a … b − 1`` as a block function (as
    :func:`~imucalib.residuals.linear_rate_jacobian`), ``a`` the calibrated specific force ``force`` (S, 3)."""
    buf = np.zeros((0, 3, 9))
    minus_m = np.repeat(-m.ravel(), 3)  # at 9r + 3i + j: −M_ri

    def block(a: int, b: int) -> np.ndarray:
        nonlocal buf
        if b - a > buf.shape[0]:
            buf = np.empty((b - a, 3, 9))
        out = buf[: b - a]
        # entry (k, r, 3i + j) = a_kj (−M_ri): every entry written, a sample's 27 in one row-wise pass over the
        # force tiled nine times (TILE_ROWS samples at a time: the tiled copy stays small)
        flat = out.reshape(b - a, 27)
        for c in range(a, b, TILE_ROWS):
            d = min(b, c + TILE_ROWS)
            rowwise(np.multiply, np.tile(force[c:d], (1, 9)), minus_m, out=flat[c - a : d - a])
        return out

    return block


def _solve_joint(recording, intervals, accelerometer, static, weights, start: TriadModel,
                 transitions: _Transitions | None = None):
    """The joint fit (:func:`joint_problem`), twice: the rotations' noise re-estimated from the first.

    Returns the model, θ, each transition's error norm [rad], ``sigma_rot`` and the final problem.
    """
    tr = _Transitions(recording, intervals) if transitions is None else transitions
    n_kept = int(np.count_nonzero(weights))
    e0 = _transition_norms(recording, intervals, accelerometer, start, static, weights, tr)[1]  # its problem freed
    sigma = _rotation_sigma(e0, weights, 9)
    theta = np.concatenate([GyroLayout(False).pack(start), static.bias,
                            static.drift if static.drift is not None else np.zeros(0)])
    for _ in range(2):
        fun, jac, dirs, size = joint_problem(recording, intervals, accelerometer, static, weights, sigma, tr)
        sol = levenberg_marquardt(fun, jac, theta, xtol=1e-12, ftol=1e-12)
        del fun, jac  # with what they hold, before the next problem is formed
        theta = sol.x
        e = np.linalg.norm(sol.fun[: 3 * (len(intervals) - 1)].reshape(-1, 3), axis=1) * sigma
        del sol  # and the problem its Jacobian would be formed from
        sigma = _rotation_sigma(e, weights, 9) if n_kept else sigma
    model = GyroLayout(True).unpack(theta[:12], theta[9:12])
    if static.g_sensitivity is not None:
        model = model.with_(g_sensitivity=static.g_sensitivity)
    fun, jac, _, _ = joint_problem(recording, intervals, accelerometer, static, weights, sigma, tr)
    return model, theta, e, sigma, (fun, jac)


def _rotation_sigma(e: np.ndarray, weights: np.ndarray, p: int) -> float:
    """Per-component noise [rad] of the kept rotations' direction errors ``e``: two components each, ``p`` fitted."""
    kept = np.asarray(weights) > 0
    dof = max(2 * int(np.count_nonzero(kept)) - p, 1)
    s = float(np.sqrt(np.sum(e[kept] ** 2) / dof))
    return s if s > 0 else 1e-12


def _transition_norms(recording, intervals, accelerometer, model, static, weights, transitions=None):
    """Each transition's direction error norm [rad] of ``model`` with the static bias (weights 0 → 0)."""
    fun, _, layout, _, _ = gravity_direction_problem(recording, intervals, accelerometer, model.bias, False,
                                                     None, static.g_sensitivity, transitions)
    e = np.linalg.norm(fun(layout.pack(model)).reshape(-1, 3), axis=1)
    return fun, e * (np.asarray(weights) > 0)


def joint_errors(recording, intervals, accelerometer, model, theta, jac_fun, res, weights, sigma_rot, static, *,
                 acc_cov=None, acc_joint=None, transitions: _Transitions | None = None) -> dict[str, float]:
    """1σ errors of the joint fit (:func:`joint_problem`) from its Jacobian, by name.

    ``C = s² (JᵀJ)⁻¹`` with ``s² = ‖r‖²/dof`` (:func:`~imucalib.solve.standard_errors`;
    ``s² ≈ 1`` since each residual is divided by its own noise; ``dof`` counts
    two per kept rotation and three per pose, less the parameters), carried
    to ``T_g`` and ``k1`` by the delta method. The accelerometer's covariance
    ``acc_cov`` enters through the gravity directions to first order
    (``∂θ̂/∂x = −J⁺ ∂r/∂x``, as in :func:`errors_at`); so does the
    g-sensitivity the joint fit holds at the static poses' estimate
    (``static.g_cov``): its error moves the bias the poses show. The bias is the bias
    at ``static.t_ref`` and its 1σ is the error of that: each pose's mean is
    weighted by its white noise plus the scatter between poses
    (``static.variances``, random effects: :func:`_weighted_regression`), so
    tremor and a wandering bias are in it once. Adding the scatter of one pose
    about the fit again (the bias at an arbitrary moment, not at ``t_ref``)
    would count them twice: on the hand-held scenario that made the bias's 1σ
    eight times its error.

    ``acc_joint = (which, prior_var)``: the accelerometer parameters ``which``
    (indices in ``AccelLayout("upper", 1)`` order) were estimated with the
    gyroscope from the same rotations (:func:`accelerometer_joint_step`), each
    with a zero-mean prior of variance ``prior_var``. They are then columns of
    the Jacobian (``∂r/∂x`` of the rotations, one prior row ``x/σ_p`` each),
    so the gyroscope's errors are the marginals of the joint covariance, and
    their own 1σ is returned too; ``acc_cov`` then carries only the others.
    ``jac_fun`` is the problem's Jacobian (``jac`` of :func:`joint_problem`,
    which forms ``∂r/∂G`` in the same pass); ``transitions`` as for
    :func:`gravity_direction_problem`.
    """
    with_g = static.g_cov is not None and np.all(np.isfinite(static.g_cov))
    j = jac_fun(theta, with_g=True) if with_g else jac_fun(theta)
    if with_g:
        j, j_g = j[:, :-9], j[:, -9:]
    size = j.shape[1]
    n_rot = 3 * (len(intervals) - 1)
    dof = 2 * int(np.count_nonzero(weights)) + 3 * len(static.means) - size
    lay = AccelLayout("upper", 1)
    which = [] if acc_joint is None else [int(i) for i in acc_joint[0]]
    fixed = [i for i in range(lay.size) if i not in which]
    undetermined = acc_cov is not None and not np.all(np.isfinite(np.diag(acc_cov)[fixed]))
    j_acc = None
    if which or (acc_cov is not None and not undetermined):
        j_acc = np.zeros((j.shape[0], lay.size))
        w = np.repeat(np.asarray(weights, dtype=float), 3) / sigma_rot
        j_acc[:n_rot] = _direction_acc_jacobian(recording, intervals, accelerometer, model, transitions) * w[:, None]
    n_joint = len(which)
    if n_joint:
        prior_sd = np.sqrt(np.asarray(acc_joint[1], dtype=float))
        j = np.block([[j, j_acc[:, which]], [np.zeros((n_joint, size)), np.diag(1.0 / prior_sd)]])
        res = np.concatenate([res, lay.pack(accelerometer)[which] / prior_sd])
        j_acc = np.vstack([j_acc, np.zeros((n_joint, lay.size))])
    extra = None
    pinv = None
    if acc_cov is not None and not undetermined and fixed:
        pinv = np.linalg.pinv(j)
        sens = -pinv @ j_acc[:, fixed]
        extra = sens @ np.asarray(acc_cov)[np.ix_(fixed, fixed)] @ sens.T
    if with_g:
        sens = -(np.linalg.pinv(j) if pinv is None else pinv) @ np.vstack([j_g, np.zeros((n_joint, 9))])
        c_g = np.zeros((9, 9))
        for i in range(3):  # the rows of G come from independent regressions, one per gyroscope axis
            c_g[3 * i:3 * i + 3, 3 * i:3 * i + 3] = static.g_cov[i]
        extra = (0.0 if extra is None else extra) + sens @ c_g @ sens.T
    m = theta[:9].reshape(3, 3)
    off = [(i, k) for i in range(3) for k in range(3) if i != k]
    names = [f"gyroscope.misalignment.{AXES[i]}{AXES[k]}" for i, k in off]
    names += [f"gyroscope.scale.{ax}" for ax in AXES] + [f"gyroscope.bias.{ax}" for ax in AXES]
    names += [lay.names("accelerometer")[i] for i in which]
    a = np.zeros((12 + n_joint, size + n_joint))
    for row, (i, k) in enumerate(off):  # T_ik = M_ik / M_kk
        a[row, 3 * i + k] = 1.0 / m[k, k]
        a[row, 4 * k] = -m[i, k] / m[k, k] ** 2
    for k in range(3):  # k1_k = M_kk
        a[6 + k, 4 * k] = 1.0
    a[9:12, 9:12] = np.eye(3)
    a[12:, size:] = np.eye(n_joint)
    if dof <= 0:
        se = np.full(len(names), np.nan)
    else:
        cov, bad = _joint_covariance(j, res, n_rot, weights, leverage=n_joint > 0)
        if extra is not None:
            cov = cov + extra
        bad = np.abs(a) @ bad.astype(float) > 0
        se = np.sqrt(np.clip(np.diag(a @ cov @ a.T), 0.0, None))
        if n_joint:
            se *= _small_sample_factor(j, n_rot, weights, a, 0.0 if extra is None else np.diag(a @ extra @ a.T))
        se[bad] = np.nan
    if undetermined:  # the poses leave the gravity directions themselves undetermined
        se = np.full_like(se, np.nan)
    return {k: float(v) for k, v in zip(names, se, strict=True)}


def _g_sensitivity_jacobian(recording, intervals, accelerometer, static: StaticGyro, weights, sigma_rot,
                            theta) -> np.ndarray:
    """∂r/∂G of the joint residuals (:func:`joint_problem`) at ``theta``, ``G`` row-major, analytic (the last
    columns of its ``jac(θ, with_g=True)``)."""
    _, jac, _, _ = joint_problem(recording, intervals, accelerometer, static, weights, sigma_rot)
    return jac(theta, with_g=True)[:, -9:]


def _inverse_sqrt(a: np.ndarray) -> np.ndarray:
    """``a^(−1/2)`` of a symmetric positive semi-definite matrix; directions with no variance are left as they are."""
    w, v = np.linalg.eigh(a)
    return (v / np.sqrt(np.where(w > 1e-8, w, 1.0))) @ v.T


def _small_sample_factor(j: np.ndarray, n_rot: int, weights: np.ndarray, a: np.ndarray, known,
                         *, rcond: float = 1e-10) -> np.ndarray:
    """Per parameter ``√(ν/(ν − 2))``: the 1σ of a variance estimated from ``ν`` effective degrees of freedom.

    A variance ``V̂`` estimated from few residuals is unbiased, yet the error
    over ``√V̂`` follows Student's t with ``ν`` degrees of freedom, whose
    variance is ``ν/(ν − 2)``, not 1: a 1σ that says how far the estimate
    is from the truth on average is ``√V̂`` times that. For the rotations'
    cluster sandwich with the bias-reduced residuals of
    :func:`_joint_covariance` (``leverage``), ``ν`` is Satterthwaite's for the
    contrast ``c`` (a row of ``a``), as Bell & McCaffrey (2002, §4) give it:
    with every residual of unit variance, ``V̂ = εᵀ Q ε`` with
    ``Q = (I − H) W Wᵀ (I − H)``, ``W``'s columns the rotations' weights
    ``(I − H_kk)^(−1/2) J_k (JᵀJ)⁻¹ c`` on their rows, and
    ``ν = 2 E[V]² / Var[V] = (v₀ + tr Q)² / tr Q²``, where ``v₀`` is the
    part known without residuals (the static poses', the prior's and
    ``known``, the variance the accelerometer's and g-sensitivity's
    covariances add). ``ν`` is held at 3 at least (a factor of √3 at most).
    """
    col, js, inv, _ = scaled_inverse(j, rcond)
    proj = np.eye(js.shape[0]) - js @ inv @ js.T
    kept = np.nonzero(np.asarray(weights) > 0)[0]
    cs = (a / col).T  # contrasts in the scaled parameters, one per column
    u = js @ inv @ cs  # (rows, contrasts)
    j_st = js[n_rot:]
    v0 = np.einsum("pc,pq,qc->c", cs, inv @ j_st.T @ j_st @ inv, cs) + np.asarray(known, dtype=float)
    wmat = np.zeros((js.shape[0], len(kept), cs.shape[1]))
    for col_k, k in enumerate(kept):
        rows = slice(3 * k, 3 * k + 3)
        hk = proj[rows, rows]
        wmat[rows, col_k, :] = _inverse_sqrt(0.5 * (hk + hk.T)) @ u[rows]
    out = np.ones(cs.shape[1])
    for c in range(cs.shape[1]):
        mw = proj @ wmat[:, :, c]
        tr_q = float(np.sum(mw**2))
        tr_q2 = float(np.sum((mw.T @ mw) ** 2))
        if tr_q2 > 0:
            nu = max((v0[c] + tr_q) ** 2 / tr_q2, 3.0)
            out[c] = np.sqrt(nu / (nu - 2.0))
    return out


def _joint_covariance(j: np.ndarray, res: np.ndarray, n_rot: int, weights: np.ndarray, *,
                      rcond: float = 1e-10, leverage: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Covariance of the joint fit's parameters, each rotation's share from its own residual; which are undetermined.

    The sandwich ``(JᵀJ)⁻¹ B (JᵀJ)⁻¹``. The static poses' rows are divided by
    their standard errors (between-pose scatter included), so their part of
    ``B`` is ``J_sᵀ J_s``. A rotation's gravity-direction error is not the
    common white noise ``sigma_rot``: the longer, faster turns carry more of
    the integration's and the hand's errors, and those are the turns that
    pull the bias and the scales most. Its part of ``B`` is
    ``J_kᵀ r_k r_kᵀ J_k`` from its own three residuals, one cluster per
    rotation (the cluster-robust sandwich of Liang & Zeger 1986,
    *Biometrika* 73, 13–22, §2; White 1980 for one residual per cluster),
    times ``n/(n − 9/2)`` for the nine parameters of ``M`` that the ``n``
    rotations' two components each fit. Columns scaled to unit norm and
    unobservable directions dropped as in :func:`imucalib.solve.covariance`.

    ``leverage``: each rotation's residuals are first scaled up for its own
    pull on the fit, ``r̃_k = (I − H_kk)^(−1/2) r_k`` with ``H_kk = J_k (JᵀJ)⁻¹ J_kᵀ``
    its block of the hat matrix (the bias-reduced linearisation of Bell &
    McCaffrey 2002, *Survey Methodology* 28, 169–181, "CR2": unbiased for a
    common variance; the jackknife's ``(I − H_kk)⁻¹`` overstates), instead of the
    ``n/(n − 9/2)`` factor: for a fit whose rotations determine more than
    ``M`` (the accelerometer's misalignment with it, :func:`joint_errors`)
    on a dozen rotations, each rotation's leverage is near one half and the
    plain sandwich would shrink the errors by as much.
    """
    col, js, inv, bad = scaled_inverse(j, rcond)
    j_st = js[n_rot:]
    meat = j_st.T @ j_st
    kept = np.nonzero(np.asarray(weights) > 0)[0]
    if kept.size:
        jk = js[:n_rot].reshape(-1, 3, js.shape[1])[kept]
        rk = res[:n_rot].reshape(-1, 3)[kept]
        if leverage:
            h = np.einsum("kij,jl,kml->kim", jk, inv, jk)
            rk = np.stack([_inverse_sqrt(np.eye(3) - 0.5 * (hk + hk.T)) @ r for hk, r in zip(h, rk, strict=True)])
        g = np.einsum("kij,ki->kj", jk, rk)
        n = kept.size
        meat = meat + (g.T @ g) * (1.0 if leverage else n / max(n - 4.5, 0.5))
    cov = inv @ meat @ inv
    return cov / np.outer(col, col), bad


def _joint_at(recording, intervals, accelerometer, gyroscope, fitted: GyroscopeReport):
    """The joint problem of a fit again, from its report: static poses, weights, σ, θ, residuals, Jacobian."""
    drift = fitted.bias_drift_per_s
    static = static_gyro(recording, intervals, accelerometer, g_sensitivity=bool(np.any(gyroscope.g_sensitivity)),
                         drift=drift is not None)
    weights = np.ones(len(intervals) - 1)
    weights[list(fitted.rotations_left_out or {})] = 0.0
    sigma = float(fitted.rotation_sigma_rad)
    theta = np.concatenate([GyroLayout(True).pack(gyroscope), np.asarray(drift if drift is not None else [])])
    fun, jac, _, _ = joint_problem(recording, intervals, accelerometer, static, weights, sigma)
    return static, weights, sigma, theta, fun, jac


def joint_errors_at(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                    gyroscope: TriadModel, fitted: GyroscopeReport, *, acc_cov: np.ndarray | None = None,
                    acc_joint: tuple | None = None) -> dict[str, float]:
    """The 1σ errors :func:`fit_gyroscope` gave a joint fit, again from its report (:meth:`GyroFit.report`,
    a calibration's ``fit.gyroscope``).

    The static poses' regression is repeated with the choices the fit made
    (g-sensitivity, drift), the rotations left out and their noise
    (``rotation_sigma_rad``) are the fit's. ``acc_joint``: as in
    :func:`joint_errors`.
    """
    static, weights, sigma, theta, fun, jac = _joint_at(recording, intervals, accelerometer, gyroscope, fitted)
    return joint_errors(recording, intervals, accelerometer, gyroscope, theta, jac, fun(theta), weights, sigma,
                        static, acc_cov=acc_cov, acc_joint=acc_joint) | static.errors


def accelerometer_joint_step(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                             gyroscope: TriadModel, fitted: GyroscopeReport, which, prior_var) -> np.ndarray:
    """A Gauss–Newton step for accelerometer parameters the rotations determine along with the gyroscope.

    The rotations carry gravity from one pose to the next (Zhang 2021, eq. 14):
    the directions at both ends come from the accelerometer, so its
    parameters enter the residuals ``r`` of the joint problem
    (:func:`joint_problem`) as the gyroscope's do. A rigid rotation cannot
    carry one sheared set of directions into another, and the gyroscope's
    ``M = T_g diag(k1)`` (any linear map of the rates) does not make up for
    it: rotations about axes between the sensor's axes measure the
    accelerometer's misalignment, which gravity's norm at poses near the
    axes does not (its first-order change there, ``2 a_i a_j T_ij``, is
    nil). With the gyroscope's ``θ`` at its optimum for the present
    accelerometer, the step ``δ`` for the parameters ``which`` (indices in
    ``AccelLayout("upper", 1)`` order) solves ``[J_θ J_x; 0 P] [δθ; δ] ≈
    −[r; x/σ_p]`` in least squares, ``P = diag(1/σ_p)`` a zero-mean prior of
    variance ``prior_var`` per parameter (what a datasheet bounds; it
    decides only where the rotations do not). Returns ``δ``.
    """
    static, weights, sigma, theta, fun, jac = _joint_at(recording, intervals, accelerometer, gyroscope, fitted)
    which = [int(i) for i in which]
    j, r = jac(theta), fun(theta)
    n_rot = 3 * (len(intervals) - 1)
    w = np.repeat(weights, 3) / sigma
    j_x = np.zeros((j.shape[0], len(which)))
    j_x[:n_rot] = _direction_acc_jacobian(recording, intervals, accelerometer, gyroscope)[:, which] * w[:, None]
    prior_sd = np.sqrt(np.asarray(prior_var, dtype=float))
    x = AccelLayout("upper", 1).pack(accelerometer)[which]
    big = np.block([[j, j_x], [np.zeros((len(which), j.shape[1])), np.diag(1.0 / prior_sd)]])
    col = np.linalg.norm(big, axis=0)
    col = np.where(col > 0, col, 1.0)
    step = -np.linalg.lstsq(big / col, np.concatenate([r, x / prior_sd]), rcond=None)[0] / col
    return step[j.shape[1]:]


def _direction_acc_jacobian(recording, intervals, accelerometer, gyroscope, transitions=None) -> np.ndarray:
    """∂r/∂(accelerometer parameters) of the eq. (14) residuals (``AccelLayout("upper", 1)`` order), unweighted."""
    fun, _, layout, dirs, _ = gravity_direction_problem(recording, intervals, accelerometer, gyroscope.bias, True,
                                                        None, gyroscope.g_sensitivity, transitions)
    theta = layout.pack(gyroscope)
    n_tr = len(intervals) - 1
    lay = AccelLayout("upper", 1)
    base = lay.pack(accelerometer)
    means = interval_means(recording.acc, intervals) if transitions is None else transitions.acc_means()
    rt = np.empty((n_tr, 3, 3))
    for j in range(3):
        e = np.zeros_like(dirs)
        e[:, j] = 1.0
        rt[:, :, j] = e[1:] - fun(theta, e).reshape(-1, 3)
    j_acc = np.empty((3 * n_tr, lay.size))
    for i in range(lay.size):
        h = 1e-6 * max(abs(base[i]), 1e-12) if base[i] else 1e-9
        step = base.copy()
        step[i] += h
        d = lay.unpack(step, accelerometer).forward(means)
        delta = (d / np.linalg.norm(d, axis=1, keepdims=True) - dirs) / h
        j_acc[:, i] = (delta[1:] - np.einsum("kij,kj->ki", rt, delta[:-1])).ravel()
    return j_acc


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
    tr = _Transitions(recording, intervals)
    start = None
    sigma = None
    for _ in range(3):
        weights = np.ones(n_tr)
        weights[list(left_out)] = 0.0
        est = bool(estimate_bias) and not joint
        model, e = _solve_direction(recording, intervals, accelerometer, static.bias, est, weights,
                                    static.g_sensitivity, start, tr)
        start = model
        if joint and np.any(weights > 0):
            model, theta, e, sigma, (fun, jac) = _solve_joint(recording, intervals, accelerometer, static, weights,
                                                             model, tr)
            errors = joint_errors(recording, intervals, accelerometer, model, theta, jac, fun(theta), weights,
                                  sigma, static, acc_cov=acc_cov, transitions=tr)
        else:
            errors = errors_at(recording, intervals, accelerometer, model, est, weights=weights,
                               bias_cov=None if est else static.bias_cov, acc_cov=acc_cov, transitions=tr)
            if est and not all(np.isfinite(errors.get(f"gyroscope.bias.{a}", np.nan)) for a in AXES):
                est = False  # the bias is not observable from these rotations
                model, e = _solve_direction(recording, intervals, accelerometer, static.bias, False, weights,
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

