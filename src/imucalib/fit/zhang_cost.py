"""The global cost of Zhang et al. (IEEE TII 2021), eq. (21), and its solution.

The parameter vector of each model variant (:class:`ZhangLayout`), the weighted residuals of the four terms
and their Jacobian (:class:`JointProblem`: the static means' gravity norm, eq. 10; their gyroscope means,
eq. 11; the gravity carried between poses by the gyroscope, eq. 14; the weightless samples' lever-arm
accelerations, eqs. 17–19 with :func:`lever_arm_matrix`), the weights ``C1…C4`` from the initial rest's noise
(:func:`weights`, eqs. 25–30), the Levenberg–Marquardt solution from the two-step estimate
(:func:`solve_joint`) and the parameters' 1σ errors (:func:`joint_errors`).
:mod:`imucalib.methods.zhang2021` is the method over them; its module docstring gives the model and the cost.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..kinematics import IntervalIntegrator, quat_to_matrix, segmented_five_point, skew
from ..metrics import interval_means, transition_bounds
from ..models import AXES, TriadModel, misalignment_entries
from ..recording import Interval, Recording
from ..solve import levenberg_marquardt, standard_errors

__all__ = ["MODELS", "JointProblem", "ZhangLayout", "concat_segments", "fitted_layout", "gyro_problem", "joint_errors",
           "lever_arm_matrix", "rotation_rows", "solve_joint", "weights"]

#: the model variants (Zhang 2021, Table II)
MODELS = ("linear", "quadratic", "cubic", "all")


# --------------------------------------------------------------------- layout
@dataclass(frozen=True)
class ZhangLayout:
    """The parameter vector of a model variant (names as in :meth:`imucalib.calibration.Calibration.parameters`).

    Order: accelerometer ``T`` (3), ``k1..k_order`` (3 each), ``b`` (3);
    gyroscope ``T`` (6), ``k1..k_order`` (3 each), ``b`` (3), ``G`` (9, if
    ``with_g``); lever arm ``r`` (3, if ``with_r``).
    """

    order: int = 3
    with_g: bool = True
    with_r: bool = True

    @classmethod
    def of(cls, model: str) -> ZhangLayout:
        if model not in MODELS:
            raise ValueError(f"zhang2021 model must be one of {', '.join(MODELS)}; got {model!r}")
        return {
            "linear": cls(1, False, False),
            "quadratic": cls(2, False, True),
            "cubic": cls(3, False, True),
            "all": cls(3, True, True),
        }[model]

    @property
    def acc_entries(self):
        return misalignment_entries("upper")

    @property
    def gyro_entries(self):
        return misalignment_entries("full")

    @property
    def n_acc(self) -> int:
        return 3 + 3 * self.order + 3

    @property
    def n_gyro(self) -> int:
        return 6 + 3 * self.order + 3 + (9 if self.with_g else 0)

    @property
    def size(self) -> int:
        return self.n_acc + self.n_gyro + (3 if self.with_r else 0)

    def names(self) -> list[str]:
        keys = ("scale", "scale_quadratic", "scale_cubic")[: self.order]
        out = [f"accelerometer.misalignment.{AXES[i]}{AXES[j]}" for i, j in self.acc_entries]
        out += [f"accelerometer.{k}.{a}" for k in keys for a in AXES]
        out += [f"accelerometer.bias.{a}" for a in AXES]
        out += [f"gyroscope.misalignment.{AXES[i]}{AXES[j]}" for i, j in self.gyro_entries]
        out += [f"gyroscope.{k}.{a}" for k in keys for a in AXES]
        out += [f"gyroscope.bias.{a}" for a in AXES]
        if self.with_g:
            out += [f"gyroscope.g_sensitivity.{a}{b}" for a in AXES for b in AXES]
        if self.with_r:
            out += [f"lever_arm.{a}" for a in AXES]
        return out

    def pack(self, acc: TriadModel, gyro: TriadModel, r: np.ndarray | None) -> np.ndarray:
        ks = ("scale", "scale_quadratic", "scale_cubic")[: self.order]
        parts = [np.array([acc.misalignment[i, j] for i, j in self.acc_entries])]
        parts += [getattr(acc, k) for k in ks] + [acc.bias]
        parts += [np.array([gyro.misalignment[i, j] for i, j in self.gyro_entries])]
        parts += [getattr(gyro, k) for k in ks] + [gyro.bias]
        if self.with_g:
            parts.append(gyro.g_sensitivity.ravel())
        if self.with_r:
            parts.append(np.zeros(3) if r is None else np.asarray(r, dtype=float))
        return np.concatenate(parts)

    def split(self, theta: np.ndarray):
        """``(T_a, K_a (order,3), b_a, T_g, K_g, b_g, G, r)`` as arrays."""
        o = self.order
        ta = np.eye(3)
        for (i, j), v in zip(self.acc_entries, theta[0:3], strict=True):
            ta[i, j] = v
        ka = theta[3 : 3 + 3 * o].reshape(o, 3)
        ba = theta[3 + 3 * o : 6 + 3 * o]
        s = self.n_acc
        tg = np.eye(3)
        for (i, j), v in zip(self.gyro_entries, theta[s : s + 6], strict=True):
            tg[i, j] = v
        kg = theta[s + 6 : s + 6 + 3 * o].reshape(o, 3)
        bg = theta[s + 6 + 3 * o : s + 9 + 3 * o]
        g = theta[s + 9 + 3 * o : s + 18 + 3 * o].reshape(3, 3) if self.with_g else np.zeros((3, 3))
        r = theta[self.n_acc + self.n_gyro :] if self.with_r else np.zeros(3)
        return ta, ka, ba, tg, kg, bg, g, r

    def models(self, theta: np.ndarray) -> tuple[TriadModel, TriadModel, np.ndarray | None]:
        ta, ka, ba, tg, kg, bg, g, r = self.split(theta)
        z = np.zeros(3)

        def triad(t, k, b, shape, gg):
            return TriadModel(misalignment=t, scale=k[0],
                              scale_quadratic=k[1] if self.order > 1 else z,
                              scale_cubic=k[2] if self.order > 2 else z,
                              bias=b, g_sensitivity=gg, shape=shape)

        return (triad(ta, ka, ba, "upper", np.zeros((3, 3))), triad(tg, kg, bg, "full", g),
                r.copy() if self.with_r else None)


# ------------------------------------------------------------ model Jacobians
def _triad(t, k, x, entries, jac):
    """``y = T f(x)``; with ``jac``: ∂y/∂T-entries (N,3,E), ∂y/∂K (N,3,3·order), ∂y/∂x (N,3,3)."""
    powers = [x]
    for _ in range(1, k.shape[0]):
        powers.append(powers[-1] * x)
    f = sum(kk * p for kk, p in zip(k, powers, strict=True))
    y = f @ t.T
    if not jac:
        return y, None, None, None
    n = x.shape[0]
    jt = np.zeros((n, 3, len(entries)))
    for c, (i, j) in enumerate(entries):
        jt[:, i, c] = f[:, j]  # ∂(T f)/∂T_ij = e_i f_j
    jk = np.empty((n, 3, 3 * len(powers)))
    for m, p in enumerate(powers):
        np.multiply(t[None, :, :], p[:, None, :], out=jk[:, :, 3 * m : 3 * m + 3])  # T[:, j] x_j^n
    dfdx = np.broadcast_to(k[0], x.shape) + sum(
        (m + 1) * k[m] * powers[m - 1] for m in range(1, k.shape[0]))
    dydx = t[None, :, :] * dfdx[:, None, :]
    return y, jt, jk, dydx


class JointProblem:
    """Residuals and Jacobian of the weighted global cost, eq. (21)."""

    def __init__(self, layout, gravity, static_acc, static_gyro, integ, motion_acc,
                 motion_gyro, wl_acc, wl_gyro, wl_starts, wl_stops, dt, c):
        self.layout = layout
        self.g = gravity
        self.static_acc, self.static_gyro = static_acc, static_gyro
        self.integ, self.motion_acc, self.motion_gyro = integ, motion_acc, motion_gyro
        self.wl_acc, self.wl_gyro = wl_acc, wl_gyro
        self.wl_starts, self.wl_stops, self.dt = wl_starts, wl_stops, dt
        self.w1 = np.sqrt(c["C1"])
        self.w2 = np.repeat(np.sqrt(c["C2"]), 3)
        self.w3 = np.repeat(np.sqrt(c["C3"]), 3)
        self.w4 = float(np.sqrt(c["C4"]))
        self.use_wl = layout.with_r and wl_acc is not None and wl_acc.shape[0] > 0 and c["C4"] > 0

    # accelerometer and gyroscope on samples, with Jacobians over the full vector
    def _acc(self, theta, raw, jac):
        lay = self.layout
        ta, ka, ba, *_ = lay.split(theta)
        a, jt, jk, dadx = _triad(ta, ka, raw - ba, lay.acc_entries, jac)
        if not jac:
            return a, None
        ja = np.concatenate([jt, jk, -dadx], axis=2)  # (N, 3, n_acc)
        return a, ja

    def _gyro(self, theta, raw_g, a, ja, jac):
        lay = self.layout
        _, _, _, tg, kg, bg, g, _ = lay.split(theta)
        x = raw_g - bg - a @ g.T
        w, jt, jk, dwdx = _triad(tg, kg, x, lay.gyro_entries, jac)
        if not jac:
            return w, None
        n = raw_g.shape[0]
        jw = np.empty((n, 3, lay.size))
        jw[:, :, lay.n_acc + lay.n_gyro :] = 0.0  # the lever-arm columns: r does not enter ω
        np.matmul(dwdx @ -g, ja, out=jw[:, :, : lay.n_acc])  # through G·a
        s = lay.n_acc
        o = lay.order
        jw[:, :, s : s + 6] = jt
        jw[:, :, s + 6 : s + 6 + 3 * o] = jk
        jw[:, :, s + 6 + 3 * o : s + 9 + 3 * o] = -dwdx
        if lay.with_g:
            # ∂ω/∂G_jl = −(∂ω/∂x)[:, j] a_l
            jw[:, :, s + 9 + 3 * o : s + 18 + 3 * o] = (
                -dwdx[:, :, :, None] * a[:, None, None, :]).reshape(n, 3, 9)
        return w, jw

    def residuals(self, theta, jac=False):
        lay = self.layout
        p = lay.size
        na = lay.n_acc
        res, jacs = [], []
        # eq. (10): ‖a_k‖² − g² on static means
        a_s, ja_s = self._acc(theta, self.static_acc, jac)
        r1 = np.sum(a_s * a_s, axis=1) - self.g**2
        res.append(self.w1 * r1)
        if jac:
            j1 = np.zeros((a_s.shape[0], p))
            j1[:, :na] = 2 * np.einsum("ni,nip->np", a_s, ja_s)
            jacs.append(self.w1[:, None] * j1)
        # eq. (11): u_g,k − b_g − G a_k on static means (raw gyro units)
        _, _, _, tg, kg, bg, g, r = lay.split(theta)
        e2 = self.static_gyro - bg - a_s @ g.T
        res.append(self.w2 * e2.ravel())
        if jac:
            m = a_s.shape[0]
            j2 = np.zeros((m, 3, p))
            j2[:, :, :na] = -np.einsum("ij,njp->nip", g, ja_s)
            s = na + 6 + 3 * lay.order
            j2[:, :, s : s + 3] = -np.eye(3)
            if lay.with_g:
                j2[:, :, s + 3 : s + 12] = (-np.eye(3)[None, :, :, None] * a_s[:, None, None, :]).reshape(m, 3, 9)
            jacs.append(self.w2[:, None] * j2.reshape(3 * m, p))
        # eq. (14): a_k − Rᵀ a_{k−1}, RK4 through the motions
        a_m, ja_m = self._acc(theta, self.motion_acc, jac)
        w_m, jw_m = self._gyro(theta, self.motion_gyro, a_m, ja_m, jac)
        if jac:
            q_end, wts = self.integ.sensitivity(w_m)
        else:
            q_end = self.integ.from_samples(w_m)
        rot = quat_to_matrix(q_end)
        pred = np.einsum("kji,kj->ki", rot, a_s[:-1])
        res.append(self.w3 * (a_s[1:] - pred).ravel())
        if jac:
            mm = rot.shape[0]
            summed = self.integ.weighted_sum(wts, jw_m)  # Σ_j A_j ∂ω_j/∂θ per transition
            j3 = -skew(pred) @ np.swapaxes(rot, 1, 2) @ summed
            j3[:, :, :na] += ja_s[1:] - np.swapaxes(rot, 1, 2) @ ja_s[:-1]
            jacs.append(self.w3[:, None] * j3.reshape(3 * mm, p))
        # eq. (19): weightless samples
        if self.use_wl:
            a_w, ja_w = self._acc(theta, self.wl_acc, jac)
            w_w, jw_w = self._gyro(theta, self.wl_gyro, a_w, ja_w, jac)
            wd = segmented_five_point(w_w, self.wl_starts, self.wl_stops, self.dt)
            lm = lever_arm_matrix(w_w, wd)
            e4 = a_w - lm @ r
            res.append(self.w4 * e4.ravel())
            if jac:
                n = a_w.shape[0]
                wr = np.sum(w_w * r, axis=1)
                # ∂f_C/∂ω = 2 r ωᵀ − (ω·r) I − ω rᵀ ;  ∂f_E/∂ω̇ = [r]×
                dfc = (2 * r[None, :, None] * w_w[:, None, :] - wr[:, None, None] * np.eye(3)
                       - w_w[:, :, None] * r[None, None, :])
                jwd = segmented_five_point(jw_w, self.wl_starts, self.wl_stops, self.dt)
                # j4 = w4 (∂a − ∂f_C/∂ω ∂ω − [r]× ∂ω̇ − L ∂r), built in place (the largest block)
                j4 = np.matmul(dfc, jw_w)
                j4 += np.matmul(skew(r), jwd)  # + [r]× ∂ω̇
                j4 *= -self.w4
                j4[:, :, :na] += self.w4 * ja_w
                j4[:, :, p - 3 :] = -self.w4 * lm
                jacs.append(j4.reshape(3 * n, p))
        r_all = np.concatenate(res)
        return (r_all, np.concatenate(jacs, axis=0)) if jac else r_all


# ------------------------------------------------------------------ lever arm
def lever_arm_matrix(w: np.ndarray, wdot: np.ndarray) -> np.ndarray:
    """``L`` with ``f_C(ω, r) + f_E(ω̇, r) = L r`` (Zhang 2021, eqs. 17–18), shape (N, 3, 3).

    ``f_C = ‖ω‖² r − ω (ω·r)`` and ``f_E = r × ω̇ = −[ω̇]× r``.
    """
    n2 = np.sum(w * w, axis=1)
    return n2[:, None, None] * np.eye(3) - w[:, :, None] * w[:, None, :] - skew(wdot)


# -------------------------------------------------------------------- weights
def weights(*, acc_var: np.ndarray, gyro_var: np.ndarray, k1_acc: np.ndarray, k1_gyro: np.ndarray,
            gravity: float, dt: float, g_max: float, motion_steps: float, mean_rate: float,
            omega_max: float, r_hat: np.ndarray, n_mean: np.ndarray) -> dict[str, np.ndarray]:
    """Weights ``C1…C4`` of the global cost (Zhang 2021, eqs. 25–30).

    The weights are the reciprocal variances of each residual. Eqs. (25)–(27)
    are written with single-sample noise variances, but the residuals of eqs.
    (10), (11) and (14) are computed on interval means, whose variance is
    ``σ²/n``: the noise variances are divided by each interval's sample count
    ``n_mean`` (pass ones to reproduce the literal per-sample weights). Without
    this the static terms are under-weighted ~n-fold and the accelerometer
    noise in the weightless term pulls the common scale of ``k1`` and ``r``
    down (about 4e-4 relative with Table I's noise).

    Parameters
    ----------
    acc_var, gyro_var : (3,) ndarray
        Per-axis raw noise variances over the initial rest.
    k1_acc, k1_gyro : (3,) ndarray
        Pre-estimated linear scales (Step 1).
    dt : float
        Sample interval [s].
    g_max : float
        Largest |entry| of the pre-estimated G (raw units per m/s²).
    motion_steps, mean_rate : float
        Mean number of integration steps of a motion (``m`` of eq. 28) and the
        mean absolute calibrated rate during motions ``ω̄`` [rad/s].
    omega_max : float
        Largest absolute rate component of the weightless data [rad/s].
    r_hat : (3,) ndarray
        Pre-estimated lever arm [m].
    n_mean : (M,) ndarray
        Samples averaged in each static interval.

    Returns
    -------
    dict
        ``C1`` (M,), ``C2`` (M,), ``C3`` (M−1,) per interval, ``C4`` scalar.
    """
    n = np.asarray(n_mean, dtype=float)
    s_ao = float(np.mean(k1_acc**2 * acc_var))  # σ̄²_a^o
    s_ws = float(np.mean(gyro_var))  # σ̄²_ω^s
    s_wo = float(np.mean(k1_gyro**2 * gyro_var))  # σ̄²_ω^o
    g2 = gravity**2
    s_ao_n = s_ao / n
    c1 = 1.0 / (6 * s_ao_n**2 + 4 * g2 * s_ao_n)  # eq. (30), from eq. (25)
    c2 = 1.0 / (s_ws / n + 3 * g_max**2 * s_ao_n)  # eq. (30), from eq. (26)
    # eq. (28): cumulative attitude variance over m steps
    sq = 0.0
    growth = 1 + 0.75 * dt**2 * mean_rate**2
    for _ in range(int(round(motion_steps))):
        sq = growth * sq + 0.25 * dt**2 * s_wo
    c3 = 1.0 / (s_ao_n[:-1] + s_ao_n[1:] + g2 * (4 * sq + 8 * sq**2))  # eq. (30), from eq. (27)
    rx, ry, rz = r_hat
    w2 = omega_max**2
    var29 = np.array([  # eq. (29)
        w2 * s_wo * ((2 * rx - ry) ** 2 + (2 * rx - rz) ** 2 + (ry + rz) ** 2)
        + s_wo**2 * (4 * rx**2 + ry**2 + rz**2) + 65 * s_wo * (ry**2 + rz**2) / (72 * dt**2) + s_ao,
        w2 * s_wo * ((2 * ry - rx) ** 2 + (2 * ry - rz) ** 2 + (rx + rz) ** 2)
        + s_wo**2 * (4 * ry**2 + rx**2 + rz**2) + 65 * s_wo * (rx**2 + rz**2) / (72 * dt**2) + s_ao,
        w2 * s_wo * ((2 * rz - rx) ** 2 + (2 * rz - ry) ** 2 + (rx + ry) ** 2)
        + s_wo**2 * (4 * rz**2 + rx**2 + ry**2) + 65 * s_wo * (rx**2 + ry**2) / (72 * dt**2) + s_ao,
    ])
    c4 = 1.0 / float(np.max(var29))
    return {"C1": c1, "C2": c2, "C3": c3, "C4": np.float64(c4)}


# ------------------------------------------------------------------ calibrate
def concat_segments(segments: Sequence[Recording]):
    """The weightless segments' raw readings end to end, with each segment's start and stop in them."""
    acc = np.concatenate([s.acc for s in segments])
    gyro = np.concatenate([s.gyro for s in segments])
    lengths = np.array([len(s) for s in segments])
    stops = np.cumsum(lengths)
    return acc, gyro, stops - lengths, stops


def _block_errors(jac: np.ndarray, res: np.ndarray, sizes: list[int]) -> np.ndarray:
    """1σ errors with one variance per cost term (eqs. 10, 11, 14, 19), each from its own residuals.

    The weights of eqs. (25)–(30) come from the rest's white noise; hand tremor,
    bias drift and unmodelled motion raise some terms' residuals and not
    others', so one common ``σ²`` would make the accelerometer's errors too
    large (the gyroscope terms' excess) and the gyroscope's too small. Each
    block's rows are scaled by ``1/s_b`` with ``s_b² = ‖r_b‖² / (n_b (N − P)/N)``
    (its share of the degrees of freedom), after which ``σ² = 1``.
    """
    n, p = jac.shape
    scale = np.ones(n)
    start = 0
    for size in sizes:
        if size > 0:
            rb = res[start : start + size]
            s2 = float(rb @ rb) / max(size * (n - p) / n, 1e-300)
            scale[start : start + size] = 1.0 / np.sqrt(s2) if s2 > 0 else 1.0
        start += size
    return standard_errors(jac * scale[:, None], res * scale)


def _held_drift(recording: Recording, static: list[Interval], samples: np.ndarray,
                drift: tuple[np.ndarray, float] | None) -> tuple[np.ndarray, np.ndarray]:
    """The static poses' gyroscope means and the motion samples' readings, less a held bias drift.

    ``drift``: ``(d, t_ref)`` as :func:`imucalib.fit.gyroscope.static_gyro`
    found it (eq. 11 with ``b + d (t − t_ref)``), or None: the readings as
    recorded. A pose's time is its samples' mean time, as there.
    """
    means, motion = interval_means(recording.gyro, static), recording.gyro[samples]
    if drift is None:
        return means, motion
    d, t_ref = drift
    times = np.array([float(np.mean(recording.t[iv.slice])) for iv in static])
    return means - np.outer(times - t_ref, d), motion - np.outer(recording.t[samples] - t_ref, d)


def gyro_problem(layout: ZhangLayout, recording: Recording, static: list[Interval], gravity: float,
                 left_out: dict[int, str], drift: tuple[np.ndarray, float] | None = None) -> JointProblem:
    """The eq. (14) term of eq. (21) alone: every other term and the rotations ``left_out`` weighted 0."""
    m = len(static)
    kept = np.ones(m - 1)
    kept[[int(k) for k in left_out]] = 0.0
    starts, stops = transition_bounds(static)
    integ = IntervalIntegrator(recording.t, starts, stops)
    none = np.zeros(0, dtype=int)
    c = {"C1": np.zeros(m), "C2": np.zeros(m), "C3": kept, "C4": np.float64(0.0)}
    static_gyro, motion_gyro = _held_drift(recording, static, integ.samples, drift)
    return JointProblem(replace(layout, with_r=False), gravity, interval_means(recording.acc, static),
                        static_gyro, integ, recording.acc[integ.samples],
                        motion_gyro, None, None, none, none, 1.0 / recording.rate, c)


def fitted_layout(layout: ZhangLayout, gyroscope: TriadModel) -> ZhangLayout:
    """``layout`` without the lever arm, with ``G`` wherever the gyroscope stage estimated it."""
    return replace(layout, with_r=False, with_g=layout.with_g or bool(np.any(gyroscope.g_sensitivity)))


def rotation_rows(m: int) -> slice:
    """The rows of eq. (14) in :class:`JointProblem`'s residuals (after eq. 10's ``m`` and eq. 11's ``3m``)."""
    return slice(4 * m, 4 * m + 3 * (m - 1))


def _rates(acc0: TriadModel, gyro0: TriadModel, raw_gyro: np.ndarray, raw_acc: np.ndarray) -> np.ndarray:
    """The calibrated rates [rad/s] of ``gyro0``, with ``acc0``'s specific force where it has a g-sensitivity (as
    :meth:`imucalib.calibration.Calibration.gyroscope_si` gives them)."""
    a = acc0.forward(raw_acc) if np.any(gyro0.g_sensitivity) else None
    return gyro0.forward(raw_gyro, a)


def solve_joint(recording: Recording, static: list[Interval], rest: Interval, layout: ZhangLayout, gravity: float,
                acc0: TriadModel, gyro0: TriadModel, left_out: dict[int, str], tosses, *, initial: str = "step1",
                noise_weights: bool = True, max_iter: int = 200, drift: tuple[np.ndarray, float] | None = None):
    """Eq. (21) by Levenberg–Marquardt from ``acc0``, ``gyro0`` (Step 2), the rotations ``left_out`` weighted 0.

    ``tosses``: ``(acc, gyro, starts, stops, r0, segments)`` of the method's tosses,
    or None (no eq. 19 term, ``C4 = 0``). Weights ``C1…C4`` from eqs. (25)–(30)
    with ``noise_weights``, else 1. ``drift``: ``(d, t_ref)``, the gyroscope
    bias's linear drift the shared stage found (:func:`imucalib.fit.gyroscope.static_gyro`),
    held: the readings enter eqs. (11) and (14) as ``u − d (t − t_ref)``, so
    the bias (at ``t_ref``) and ``G`` are not pulled by the drift. Returns the
    solution and the weights.
    """
    dt = 1.0 / recording.rate
    if tosses is None:
        wl_acc = wl_gyro = None
        wl_starts = wl_stops = np.zeros(0, dtype=int)
        r0 = np.zeros(3)
    else:
        wl_acc, wl_gyro, wl_starts, wl_stops, r0, _ = tosses
    starts, stops = transition_bounds(static)
    integ = IntervalIntegrator(recording.t, starts, stops)
    motion_acc = recording.acc[integ.samples]
    static_gyro, motion_gyro = _held_drift(recording, static, integ.samples, drift)
    m = len(static)
    if noise_weights:
        c = weights(
            acc_var=recording.acc[rest.slice].var(axis=0),
            gyro_var=recording.gyro[rest.slice].var(axis=0),
            k1_acc=acc0.scale, k1_gyro=gyro0.scale, gravity=gravity, dt=dt,
            g_max=float(np.max(np.abs(gyro0.g_sensitivity))), motion_steps=float(np.mean(stops - starts)),
            mean_rate=float(np.mean(np.abs(_rates(acc0, gyro0, motion_gyro, motion_acc)))),
            omega_max=0.0 if tosses is None else float(np.max(np.abs(_rates(acc0, gyro0, wl_gyro, wl_acc)))),
            r_hat=r0, n_mean=np.array([len(iv) for iv in static]),
        )
        if not all(np.all(np.isfinite(v)) for v in c.values()):
            raise ValueError("the initial rest has zero noise: the weights of eqs. (25)-(30) "
                             "are infinite (for noise-free data: noise_weights=False, on the command line "
                             "--no-noise-weights)")
    else:
        c = {"C1": np.ones(m), "C2": np.ones(m), "C3": np.ones(m - 1), "C4": np.float64(1.0)}
    if tosses is None:
        c["C4"] = np.float64(0.0)
    c["C3"] = np.array(c["C3"], dtype=float)
    c["C3"][[int(k) for k in left_out]] = 0.0  # the rotations the shared stage left out
    problem = JointProblem(layout, gravity, interval_means(recording.acc, static), static_gyro,
                           integ, motion_acc, motion_gyro, wl_acc, wl_gyro, wl_starts, wl_stops, dt, c)
    if initial == "step1":
        th0 = layout.pack(acc0, gyro0 if layout.with_g else gyro0.with_(g_sensitivity=np.zeros((3, 3))), r0)
    else:
        th0 = layout.pack(TriadModel(shape="upper"), TriadModel(shape="full"), np.zeros(3))
    sol = levenberg_marquardt(problem.residuals, lambda th: problem.residuals(th, jac=True)[1], th0,
                              max_iter=max_iter, stol=1e-4 if noise_weights else 0.0)
    return sol, problem, c


def joint_errors(layout: ZhangLayout, sol, c: dict, m: int) -> dict[str, float]:
    """1σ errors of an eq. (21) fit: :func:`_block_errors` over the rows it weighted.

    Each block's variance comes from its own weighted residuals, so the
    scatter of the static poses' gyroscope means (eq. 11: tremor, a
    wandering bias) is in the bias's 1σ once, as in the shared stage's
    random-effects regression (:func:`imucalib.fit.gyroscope.static_gyro`).
    Adding the scatter of one pose's eq. (11) residual on top (the bias at an
    arbitrary moment, not the session's) would count it twice: with the
    tosses of the ``zhang2021`` scenario it made the bias's 1σ seven times
    its error, on the hand-held scenario's ``all`` five times.
    """
    kept = c["C3"] > 0
    rows = np.concatenate([np.ones(4 * m, bool), np.repeat(kept, 3),
                           np.ones(len(sol.fun) - 4 * m - 3 * (m - 1), bool)])
    blocks = [m, 3 * m, 3 * int(np.count_nonzero(kept)), len(sol.fun) - m - 3 * m - 3 * (m - 1)]
    return {k: float(v) for k, v in
            zip(layout.names(), _block_errors(sol.jac[rows], sol.fun[rows], blocks), strict=True)}
