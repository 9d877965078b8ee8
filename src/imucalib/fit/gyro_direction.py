r"""The gravity-direction problem of the gyroscope fit: the rotations between static poses.

The transitions' rates and the poses' gravity directions (:class:`Transitions`), the residuals of the
direction each rotation carries (Zhang 2021, eq. 14; Tedaldi 2014) and their solve, the first guesses of the
scale (:func:`rough_scale`) and the check of the axes' order and signs (:func:`axes_disagreement`).

With ``ā_k`` the calibrated accelerometer's mean at pose ``k`` and ``R_k`` the attitude change over the motion
before it, integrated (RK4, :mod:`imucalib.kinematics`) from the rates of the linear model of Zhang 2021,
eqs. (5)–(6) with this project's bias sign, the residuals are eq. (14)'s with unit directions (with the
body-to-reference ``R`` of :mod:`imucalib.kinematics`, Zhang's ``R_{k−1,k}`` is ``R_kᵀ``):

.. math::

    \boldsymbol\omega = \mathbf M\, (\mathbf u_g - \mathbf b_g - \mathbf G\, \mathbf a), \quad
    \mathbf M = \mathbf T_g\, \mathrm{diag}(\mathbf k_1) \quad \text{(5), (6)}, \qquad
    \mathbf d_k = \frac{\bar{\mathbf a}_k}{\lVert \bar{\mathbf a}_k \rVert}, \qquad
    \mathbf r_k = w_k \bigl(\mathbf d_k - \mathbf R_k^\top \mathbf d_{k-1}\bigr) \quad (14)

The first guess of a common scale ``k`` takes each motion as one rotation about its integrated raw rate
``Φ_i = ∫(u − b) dt`` by ``k‖Φ_i‖`` (this project's, derived here; Rodrigues' formula for ``R``):

.. math::

    k = \arg\min_k \sum_i \bigl\lVert \mathbf d_i' - \mathbf R(k \boldsymbol\Phi_i)^\top \mathbf d_i \bigr\rVert^2
    \qquad \text{(R1)}

    \mathbf R(\theta \mathbf n)^\top \mathbf d = \mathbf d \cos\theta - (\mathbf n \times \mathbf d) \sin\theta
    + \mathbf n (\mathbf n \cdot \mathbf d)(1 - \cos\theta) \qquad \text{(R2)}
"""

from __future__ import annotations

import itertools

import numpy as np

from ..kinematics import IntervalIntegrator, angle_between, quat_from_rotvec, quat_to_matrix
from ..metrics import interval_means, transition_bounds
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
from ..solve import levenberg_marquardt

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
        v = gyro[a:b] - bias
        dt = t[a + 1:b + 1] - t[a:b]
        phi_vec[i] = dt @ v  # Φ_i = ∫(u − b) dt
        path[i] = dt @ np.sqrt(np.einsum("ij,ij->i", v, v))
    theta = angle_between(gravity_dirs[:, 0], gravity_dirs[:, 1])
    ok = (theta > np.radians(10)) & (path > 0)
    if not np.any(ok):
        ok = path > 0
    if not np.any(ok):
        raise ValueError("the gyroscope does not move between the static poses")
    k0 = float(np.median(theta[ok] / path[ok]))
    ks = k0 * np.geomspace(0.3, 30.0, 600)
    return float(ks[int(np.argmin(_single_rotation_costs(phi_vec, gravity_dirs, ks)))])  # eq. (R1)


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
    return np.sum(terms[None, :] - 2 * (along * np.cos(angle) - across * np.sin(angle)), axis=1)  # eqs. (R1), (R2)


#: every order and sign of three axes: (permutation, signs), the identity first
SIGNED_PERMUTATIONS = [(perm, signs) for perm in itertools.permutations(range(3))
                       for signs in itertools.product((1.0, -1.0), repeat=3)]


def _direction_errors(phi: np.ndarray, gravity_dirs: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """Per transition, the angle [rad] between the next pose's gravity direction and the previous one carried
    by the rotation ``exp(k Φ_i)`` (the single-rotation approximation of :func:`_gyro_scale_guess`), at the
    ``k`` of ``ks`` that fits them best."""
    best = ks[int(np.argmin(_single_rotation_costs(phi, gravity_dirs, ks)))]
    pred = np.einsum("kji,kj->ki", quat_to_matrix(quat_from_rotvec(best * phi)), gravity_dirs[:, 0])  # eq. (R1)
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
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)  # d_k of eq. (14)
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
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)  # d_k of eq. (14)
    return _gyro_scale_guess(recording.gyro, bias, recording.t, *transition_bounds(intervals), dirs)


class Transitions:
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
            raw[a : a + part.size] -= accelerometer.forward(recording.acc[part]) @ g  # eq. (5): u − G a
    return raw


def gravity_direction_problem(recording, intervals, accelerometer, bias, estimate_bias, weights=None,
                              g_sensitivity=None, transitions: Transitions | None = None):
    """Residuals of Zhang 2021, eq. (14) in the :class:`GyroLayout` parameters, their Jacobian, the pose directions.

    ``weights`` (one per transition between consecutive poses) scale each
    transition's three residuals; 0 leaves a transition out. A known
    ``g_sensitivity`` ``G`` (raw per m/s²) is taken out of the readings first:
    ``u − G a`` with ``a`` the calibrated specific force (eq. 6).
    ``transitions``: the fit's :class:`Transitions` of these intervals, shared
    with its other problems (a new one by default).
    """
    tr = Transitions(recording, intervals) if transitions is None else transitions
    acc = accelerometer.forward(tr.acc_means())
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)  # d_k of eq. (14)
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
        return (raw - b) @ m.T  # eq. (5): M (u − G a − b)

    def fun(th, directions=None):
        q = tr.attitudes(key(th), lambda: rates_at(th))
        r = gravity_direction_residuals(None, lambda _: q, dirs if directions is None else directions)  # eq. (14)
        return r if w is None else r * w  # eq. (14): w_k

    def jac(th):
        m, b = split(th)
        v = raw - b
        rates = v @ m.T
        rate_jac = linear_rate_jacobian(m, v, bias=estimate_bias, workspace=space)
        j = gravity_direction_residuals_jac(rates, rate_jac, integrator, dirs, tr.steps(key(th), rates, keep=False))[1]
        return j if w is None else j * w[:, None]

    return fun, jac, layout, dirs, (tr.starts, tr.stops)


def solve_direction(recording, intervals, accelerometer, bias, estimate_bias, weights, g_sensitivity,
                     start: TriadModel | None = None, transitions: Transitions | None = None
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


def transition_errors(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                      gyroscope: TriadModel) -> np.ndarray:
    """‖r_k‖ of eq. (14) for each transition: the gravity-direction error [rad, small-angle]."""
    fun, _, layout, _, _ = gravity_direction_problem(recording, intervals, accelerometer, gyroscope.bias, False,
                                                     g_sensitivity=gyroscope.g_sensitivity)
    return np.linalg.norm(fun(layout.pack(gyroscope)).reshape(-1, 3), axis=1)


def direction_acc_jacobian(recording, intervals, accelerometer, gyroscope, transitions=None) -> np.ndarray:
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
