"""Zhang et al. (IEEE TII 2021): nonlinear scale factors, g-sensitivity and lever arm.

Model (canonical form; Zhang 2021 eqs. 1–8 with the bias sign flipped)::

    a = T_a · f_a(u_a − b_a)                 T_a unit upper-triangular (eq. 4)
    ω = T_g · f_g(u_g − b_g − G · a)          T_g unit-diagonal (eq. 8), G eq. (6)
    f(x)_i = k1_i x_i + k2_i x_i² + k3_i x_i³   (eqs. 2, 7)

Paper → canonical: ``b^a = −b_a``, ``b^g = −b_g``, ``G^g = −G`` (the paper adds
``b + G a`` to the raw reading), ``k_{i1}, k_{i2}, k_{i3}`` = ``scale``,
``scale_quadratic``, ``scale_cubic`` of axis ``i``; ``T^a`` entries
``(−α_yz, α_zy, −α_zx)`` = ``misalignment.xy, .xz, .yz``.

Data: RD1 — static poses with rotations between them (an initial rest first);
RD2 — spinning tosses in free fall ("weightless"), where the accelerometer
senses only the centripetal and Euler accelerations of the lever arm ``r``
(eqs. 16–18).

Cost (eq. 21), as weighted least squares::

    C1 Σ_k (‖a_k‖² − g²)²                       static means, eq. (10)
    C2 Σ_k ‖u_g,k − b_g − G a_k‖²               static means, eq. (11)
    C3 Σ_k ‖a_k − R_{k−1,k}ᵀ a_{k−1}‖²          poses, RK4 between them, eq. (14)
    C4 Σ_j ‖a_j − f_C(ω_j, r) − f_E(ω̇_j, r)‖²   weightless samples, eq. (19)

with ``f_C(ω, r) = ‖ω‖² r − ω(ω·r)`` (eq. 17), ``f_E(ω̇, r) = r × ω̇`` (eq. 18),
``ω̇`` by the five-point stencil (eq. 20), and weights ``C1…C4`` from the
noise of the initial rest (eqs. 25–30). (The paper writes ``R_{k−1,k} a_{k−1}``
for the gravity carried into pose ``k``; with our attitude convention that is
``Rᵀ``.)

The recipe (:func:`calibrate`) runs over the stages every method shares, the
same as :mod:`imucalib.methods.tedaldi2014`: the static poses by the
gyroscope-gated accelerometer detector (:func:`imucalib.segment.detect_intervals`),
the rotations whose integration cannot be trusted left out
(:func:`imucalib.segment.unreliable_transitions`), the accelerometer on the
static means alone (eq. 10, :func:`imucalib.fit.accelerometer.gravity_norm_fit`)
and the gyroscope by :func:`imucalib.fit.gyroscope.fit_gyroscope` (bias and
``G`` from the static poses, eq. 11; ``T_g``, ``k1`` from the rotations, eq. 14).
Its own terms come after: the gyroscope's polynomial scale factors on the
rotations (eq. 14), and with tosses Step 2 of the paper, eq. (21) over every
parameter from those estimates (Step 1). Without tosses no joint cost is
minimised: in eq. (21) the rotations' unmodelled residuals (hand tremor, bias
drift between poses) pull the accelerometer away from what its static poses
say.

Model variants (Zhang 2021, Table II): ``linear`` (RD1 only, C4 = 0, no r),
``quadratic`` (k2, r), ``cubic`` (k2, k3, r), ``all`` (k2, k3, G, r). ``all``
always estimates ``G``; the others keep it where the static poses support it
(the shared gyroscope stage's criterion), as a sensor with a g-sensitivity
leaves it in every rotation otherwise; with tosses, ``G`` enters the joint
fit of ``all`` only.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..calibration import Calibration, units_of
from ..fit.accelerometer import GravityNormFit, accelerometer_covariance, gravity_norm_fit
from ..fit.gyroscope import GyroFit, fit_gyroscope
from ..kinematics import IntervalIntegrator, five_point_derivative, quat_to_matrix, segmented_five_point, skew
from ..methodinfo import MethodInfo, Option, accelerometer_only
from ..metrics import fit_summary, interval_means, transition_bounds
from ..models import AXES, TriadModel, misalignment_entries
from ..presets import MIN_HOLD
from ..recording import STANDARD_GRAVITY, ImucalibWarning, Interval, Recording
from ..segment import (
    detect_intervals,
    detect_static_gyro,
    find_initial_rest,
    gyro_norm_variance,
    runs,
    unreliable_transitions,
)
from ..solve import levenberg_marquardt, standard_errors
from ..verdict import THRESHOLDS, plausible

METHOD = MethodInfo(
    name="zhang2021",
    summary="the main method: 3rd-order scale factors, misalignment, biases, gyro g-sensitivity and lever "
            "arm; the model variant chosen by Akaike's criterion",
    needs=("static poses", "rotations", "tosses", "gyroscope"),
    models=("all", "linear", "quadratic", "cubic"),
    options=(
        Option("weightless", None, "", "spinning weightless tosses (recordings) for the lever arm"),
        Option("intervals", None, "samples", "static intervals given instead of found"),
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
        Option("min_hold", 1.0, "s", "shortest hold that is a pose (sets the static detector's window)"),
        Option("initial", "step1", "", "the starting point of the joint fit (step1: the two-step estimate)"),
        Option("noise_weights", True, "", "weigh each residual by its noise (False: for noise-free data)"),
        Option("max_iter", 200, "", "Levenberg–Marquardt iterations at most"),
        Option("fall_threshold", 2.5, "m/s^2", "eq. (19) loss below which a sample is falling"),
        Option("select", True, "", "drop nonlinear terms Akaike's criterion does not support"),
        Option("detector", "accelerometer", "", "static detector: accelerometer variance or the gyroscope "
               "norm of eq. (22)"),
        Option("estimate_gyro_bias", "auto", "", "fit the gyroscope bias with the rotations (auto: when the "
               "rests do not give it)"),
    ),
    paper="zhang2021_nonlinear_scale_factors.md (Zhang et al., IEEE TII 2021), eqs. 1–22",
)

__all__ = [
    "MODELS",
    "ZhangLayout",
    "calibrate",
    "detect_weightless",
    "detect_fall",
    "fall_loss",
    "lever_arm_matrix",
    "weights",
]

MODELS = ("linear", "quadratic", "cubic", "all")
#: the fewest static poses (the initial rest included) a calibration takes
MIN_INTERVALS = 10


# --------------------------------------------------------------------- layout
@dataclass(frozen=True)
class ZhangLayout:
    """The parameter vector of a model variant (names as in :meth:`Calibration.parameters`).

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


class _Problem:
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


# ------------------------------------------------------------- weightless part
def lever_arm_matrix(w: np.ndarray, wdot: np.ndarray) -> np.ndarray:
    """``L`` with ``f_C(ω, r) + f_E(ω̇, r) = L r`` (Zhang 2021, eqs. 17–18), shape (N, 3, 3).

    ``f_C = ‖ω‖² r − ω (ω·r)`` and ``f_E = r × ω̇ = −[ω̇]× r``.
    """
    n2 = np.sum(w * w, axis=1)
    return n2[:, None, None] * np.eye(3) - w[:, :, None] * w[:, None, :] - skew(wdot)


def detect_weightless(
    recording: Recording,
    *,
    rest: Interval,
    window: float = 0.05,
    multiplier: float = 1000.0,
    min_length: float = 0.2,
    min_rate: float | None = None,
    relative: float = 0.01,
) -> list[Interval]:
    """Weightless (spinning free-fall) intervals by the detector of Zhang 2021, eq. (22).

    ``ζ(t) = var_{t_w}(‖u_g‖)``, the variance of the raw gyroscope norm over a
    window of ``window`` seconds, must stay below the threshold while the body
    spins (the bias-free gyroscope norm exceeds ``min_rate``, raw units;
    default 50 × the rest's noise). The threshold is ``multiplier × ζ_init``
    (ζ over the initial rest, the paper's ``n ζ_init``) or, if larger,
    ``(relative × ‖u_g‖)²``: with a low-noise sensor the raw norm of a
    free spin still drifts slowly as the axis cones (axis-dependent scale and
    misalignment errors), which ``n ζ_init`` alone would reject, while the
    spin-up in the hand and the catch change the norm far faster. The
    accelerometer confirms the fall later, in :func:`calibrate`, through the
    loss of eq. (19).
    """
    rate = recording.rate
    win = max(int(round(window * rate)) | 1, 3)
    norm, zeta = gyro_norm_variance(recording, rest, window)  # eq. (22)
    zeta_init = float(np.median(zeta[rest.slice]))
    noise = float(np.std(norm[rest.slice]))
    if min_rate is None:
        min_rate = 50.0 * max(noise, np.finfo(float).tiny)
    threshold = np.maximum(multiplier * zeta_init, (relative * norm) ** 2)
    mask = (zeta < threshold) & (norm > min_rate)
    shrink = win // 2  # drop the window's reach into the toss and the catch
    n_min = max(int(round(min_length * rate)), 5)
    return [Interval(iv.start + shrink, iv.stop - shrink, "weightless")
            for iv in runs(mask) if len(iv) - 2 * shrink >= n_min]


def fall_loss(calibration: Calibration, recording: Recording) -> np.ndarray:
    """Per-sample loss ``‖a − f_C(ω, r) − f_E(ω̇, r)‖`` [m/s²] of eq. (19) (Zhang 2021, §IV-C).

    Near zero in free fall; about ``g`` at rest.
    """
    if calibration.lever_arm is None:
        raise ValueError("this calibration has no lever arm: calibrate with model 'quadratic', "
                         "'cubic' or 'all' and weightless data")
    out = calibration.apply(recording)
    dt = 1.0 / recording.rate
    wd = five_point_derivative(out.gyro, dt)
    e = out.acc - lever_arm_matrix(out.gyro, wd) @ calibration.lever_arm
    return np.linalg.norm(e, axis=1)


def detect_fall(calibration: Calibration, recording: Recording, *, threshold: float = 2.5,
                min_length: float = 0.05) -> list[Interval]:
    """Falling-state intervals: eq. (19) loss below ``threshold`` m/s² (Zhang 2021, §IV-C)."""
    if len(recording) < 5:
        raise ValueError("fall detection needs at least 5 samples")
    loss = fall_loss(calibration, recording)
    return runs(loss < threshold, max(int(round(min_length * recording.rate)), 1), "weightless")


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
def _concat(segments: Sequence[Recording]):
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


def _without_lever_arm(layout: ZhangLayout, model: str, why: str) -> ZhangLayout:
    warnings.warn(
        f"zhang2021 model {model!r}: {why}; the lever arm is not estimated and the weightless "
        "term (eq. 19) is left out, so the nonlinear terms rest on the static poses and "
        "rotations alone (record spinning tosses for the full method)",
        ImucalibWarning,
        stacklevel=3,
    )
    return replace(layout, with_r=False)


@dataclass
class _Stages:
    """One model variant fitted by the shared stages (and, for the nonlinear variants, eq. 21 after them)."""

    layout: ZhangLayout
    acc: TriadModel
    acc_residuals: np.ndarray  # ‖a_k‖ − g over the static poses [m/s²]
    gyro: GyroFit  # the shared gyroscope stage: the bias source and the rotations left out
    gyroscope: TriadModel  # with the polynomial scale factors of the variant
    errors: dict[str, float]
    converged: bool
    iterations: int


def _pose_budget(layout: ZhangLayout, poses: int) -> bool:
    """Whether ``poses`` static poses are enough for the variant's accelerometer by the verdict's own limit.

    The verdict rejects a calibration with at most ``THRESHOLDS["poses_per_parameter"][1]`` poses per
    estimated accelerometer parameter (:mod:`imucalib.verdict`); model selection never picks such a variant.
    """
    return poses / layout.n_acc > THRESHOLDS["poses_per_parameter"][1]


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


def _gyro_problem(layout: ZhangLayout, recording: Recording, static: list[Interval], gravity: float,
                  left_out: dict[int, str], drift: tuple[np.ndarray, float] | None = None) -> _Problem:
    """The eq. (14) term of eq. (21) alone: every other term and the rotations ``left_out`` weighted 0."""
    m = len(static)
    kept = np.ones(m - 1)
    kept[[int(k) for k in left_out]] = 0.0
    starts, stops = transition_bounds(static)
    integ = IntervalIntegrator(recording.t, starts, stops)
    none = np.zeros(0, dtype=int)
    c = {"C1": np.zeros(m), "C2": np.zeros(m), "C3": kept, "C4": np.float64(0.0)}
    static_gyro, motion_gyro = _held_drift(recording, static, integ.samples, drift)
    return _Problem(replace(layout, with_r=False), gravity, interval_means(recording.acc, static),
                    static_gyro, integ, recording.acc[integ.samples],
                    motion_gyro, None, None, none, none, 1.0 / recording.rate, c)


def _fitted_layout(layout: ZhangLayout, gyroscope: TriadModel) -> ZhangLayout:
    """``layout`` without the lever arm, with ``G`` wherever the gyroscope stage estimated it."""
    return replace(layout, with_r=False, with_g=layout.with_g or bool(np.any(gyroscope.g_sensitivity)))


def _rotation_rows(m: int) -> slice:
    """The rows of eq. (14) in :class:`_Problem`'s residuals (after eq. 10's ``m`` and eq. 11's ``3m``)."""
    return slice(4 * m, 4 * m + 3 * (m - 1))


def _solve_joint(recording: Recording, static: list[Interval], rest: Interval, layout: ZhangLayout, gravity: float,
                 acc0: TriadModel, gyro0: TriadModel, left_out: dict[int, str], tosses, *, initial: str = "step1",
                 noise_weights: bool = True, max_iter: int = 200, drift: tuple[np.ndarray, float] | None = None):
    """Eq. (21) by Levenberg–Marquardt from ``acc0``, ``gyro0`` (Step 2), the rotations ``left_out`` weighted 0.

    ``tosses``: ``(acc, gyro, starts, stops, r0, segments)`` of :func:`_tosses`,
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
    cal0 = Calibration(accelerometer=acc0, gyroscope=gyro0)
    m = len(static)
    if noise_weights:
        c = weights(
            acc_var=recording.acc[rest.slice].var(axis=0),
            gyro_var=recording.gyro[rest.slice].var(axis=0),
            k1_acc=acc0.scale, k1_gyro=gyro0.scale, gravity=gravity, dt=dt,
            g_max=float(np.max(np.abs(gyro0.g_sensitivity))), motion_steps=float(np.mean(stops - starts)),
            mean_rate=float(np.mean(np.abs(cal0.gyroscope_si(motion_gyro, motion_acc)))),
            omega_max=0.0 if tosses is None else float(np.max(np.abs(cal0.gyroscope_si(wl_gyro, wl_acc)))),
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
    problem = _Problem(layout, gravity, interval_means(recording.acc, static), static_gyro,
                       integ, motion_acc, motion_gyro, wl_acc, wl_gyro, wl_starts, wl_stops, dt, c)
    if initial == "step1":
        th0 = layout.pack(acc0, gyro0 if layout.with_g else gyro0.with_(g_sensitivity=np.zeros((3, 3))), r0)
    else:
        th0 = layout.pack(TriadModel(shape="upper"), TriadModel(shape="full"), np.zeros(3))
    sol = levenberg_marquardt(problem.residuals, lambda th: problem.residuals(th, jac=True)[1], th0,
                              max_iter=max_iter, stol=1e-4 if noise_weights else 0.0)
    return sol, problem, c


def _drift(gyro: GyroFit) -> tuple[np.ndarray, float] | None:
    """The bias drift the shared stage kept, with its reference time, for :func:`_solve_joint`; None without."""
    return None if gyro.drift is None else (np.asarray(gyro.drift, dtype=float), float(gyro.t_ref))


def _joint_errors(layout: ZhangLayout, sol, c: dict, m: int) -> dict[str, float]:
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


def _stages(layout: ZhangLayout, recording: Recording, static: list[Interval], rest: Interval, gravity: float, *,
            linear: GravityNormFit, exclude: dict[int, str], estimate_gyro_bias: bool | str,
            noise_weights: bool, max_iter: int) -> _Stages:
    """Fit one variant by the shared stages, as :mod:`imucalib.methods.tedaldi2014` does, then its own terms.

    1. Accelerometer: ``‖a_k‖ = g`` on the static means alone (eq. 10,
       ``linear``, from :func:`imucalib.fit.accelerometer.gravity_norm_fit`).
    2. Gyroscope: :func:`imucalib.fit.gyroscope.fit_gyroscope` with that
       accelerometer — the bias (and ``G`` of eq. 6: always for ``all``, where
       the static poses support it otherwise) from the static poses (eq. 11),
       ``T_g`` and ``k1`` from the rotations (eq. 14), the unreliable rotations
       and outliers left out.
    3. The nonlinear variants (eqs. 2, 7): eq. (21) without the tosses' term,
       started at 1–2, on the rotations 2 kept. Their polynomial terms need the
       gravity directions the rotations carry: fitted to the static norms alone,
       a cubic accelerometer follows the poses and fails on held-out ones.
    """
    means = interval_means(recording.acc, static)
    acc_cov = accelerometer_covariance(linear.model, means, gravity)
    gyro = fit_gyroscope(recording, static, linear.model, estimate_bias=estimate_gyro_bias,
                         g_sensitivity=True if layout.with_g else "auto", acc_cov=acc_cov, exclude=exclude)
    if layout.order == 1:
        return _Stages(layout, linear.model, linear.residuals, gyro, gyro.model, linear.errors(1) | gyro.errors,
                       linear.converged, linear.iterations)
    lay = _fitted_layout(layout, gyro.model)
    sol, problem, c = _solve_joint(recording, static, rest, lay, gravity, linear.model, gyro.model, gyro.left_out,
                                   None, noise_weights=noise_weights, max_iter=max_iter, drift=_drift(gyro))
    acc, gyroscope, _ = lay.models(sol.x)
    residuals = np.linalg.norm(acc.forward(means), axis=1) - gravity
    errors = _joint_errors(lay, sol, c, len(static))
    return _Stages(layout, acc, residuals, gyro, gyroscope, errors, linear.converged and sol.success,
                   linear.iterations + int(sol.njev))


def _criterion(st: _Stages, recording: Recording, static: list[Interval], gravity: float,
               left_out: set[int]) -> float:
    """Akaike's criterion of a variant with the small-sample correction, summed over the terms of eq. (21).

    One Gaussian term per block ``b`` with its own variance and its own
    parameters ``p_b``: ``n_b ln(RSS_b/n_b) + 2 p_b + 2 p_b (p_b + 1)/(n_b − p_b − 1)``
    (AICc; Hurvich & Tsai, Biometrika 1989). The blocks: eq. (10) (``M``
    residuals, the accelerometer's parameters), eq. (11) (``3M``, the bias and
    ``G``) and eq. (14) on the rotations no variant left out (``2`` degrees of
    freedom each, ``T_g`` and the scale factors). The correction matters where
    it should: 20 poses for 15 accelerometer parameters leave almost nothing to
    judge a fit by, and the uncorrected criterion then favours the polynomial.
    """
    lay = _fitted_layout(st.layout, st.gyroscope)
    m = len(static)
    prob = _gyro_problem(lay, recording, static, gravity, {k: "" for k in left_out}, _drift(st.gyro))
    res = prob.residuals(lay.pack(st.acc, st.gyroscope, None))[_rotation_rows(m)]
    a = st.acc.forward(interval_means(recording.acc, static))
    e11 = prob.static_gyro - st.gyroscope.bias - a @ st.gyroscope.g_sensitivity.T
    p14 = 6 + 3 * lay.order + (3 if st.gyro.bias_source == "fit" else 0)
    blocks = [(st.acc_residuals, m, lay.n_acc), (e11.ravel(), 3 * m, lay.n_gyro - p14),
              (res, 2 * (len(prob.w3) // 3 - len(left_out)), p14)]
    total = 0.0
    for r, n, p in blocks:
        if n - p - 1 <= 0:
            return float("inf")
        total += n * np.log(max(float(r @ r), 1e-300) / n) + 2 * p + 2 * p * (p + 1) / (n - p - 1)
    return float(total)


def _poses(recording: Recording, gravity: float, intervals, init_static, detector,
           min_hold: float = MIN_HOLD) -> tuple[list[Interval], Interval]:
    """The static poses (the initial rest first): given, or by the shared detector, or by eq. (22)."""
    if intervals is not None:
        static = [iv for iv in intervals if iv.kind == "static"]
        rest = static[0] if static else None
    elif detector == "gyroscope":
        rest0 = (find_initial_rest(recording) if init_static is None
                 else Interval(0, int(round(init_static * recording.rate)), "static"))
        static = detect_static_gyro(recording, rest0)  # eq. (22), t_w = 2 s, n = 6
        if len(static) < MIN_INTERVALS:
            raise ValueError(f"the gyroscope detector (eq. 22) found {len(static)} static intervals; "
                             f"at least {MIN_INTERVALS} are needed")
        rest = static[0]
    elif detector == "accelerometer":
        static, _, rest, _ = detect_intervals(recording, gravity, init_static=init_static, min_hold=min_hold)
    else:
        raise ValueError(f"detector must be 'accelerometer' or 'gyroscope'; got {detector!r}")
    if len(static) < MIN_INTERVALS:
        raise ValueError(f"zhang2021 needs at least {MIN_INTERVALS} static intervals; got {len(static)}")
    return static, rest


def calibrate(
    recording: Recording,
    *,
    weightless: Sequence[Recording] | None = None,
    model: str = "all",
    gravity: float = STANDARD_GRAVITY,
    intervals: Sequence[Interval] | None = None,
    init_static: float | None = None, min_hold: float = MIN_HOLD,
    initial: str = "step1",
    noise_weights: bool = True,
    max_iter: int = 200,
    fall_threshold: float = 2.5,
    select: bool = True,
    detector: str = "accelerometer",
    estimate_gyro_bias: bool | str = "auto",
    progress: Callable[[str], None] | None = None,
) -> Calibration:
    """Calibrate by Zhang et al. 2021 over the shared stages, with its own terms.

    The static poses, the rotations left out, the accelerometer and the
    gyroscope come from the stages every method shares (:func:`_stages`; the
    same as :func:`imucalib.methods.tedaldi2014.calibrate`); Zhang 2021 adds
    the polynomial scale factors (eqs. 2, 7), the g-sensitivity (eq. 6) and,
    with spinning tosses, the lever arm (eqs. 16–19). With tosses the shared
    stages' linear estimates are Step 1 and eq. (21) is minimised over every
    parameter (Step 2): only the tosses reach the large rates and accelerations
    that determine the nonlinear terms together, and no rotation the stages
    left out enters.

    Parameters
    ----------
    recording : Recording
        RD1: an initial rest, then static poses with rotations between them
        (raw units). When ``weightless`` is None, spinning free-fall segments
        in this recording are detected (eq. 22) and used as RD2.
    weightless : sequence of Recording, optional
        RD2 segments (each entirely weightless, ≥ 5 samples, same rate).
    model : {"linear", "quadratic", "cubic", "all"}
        Table II variants.
    gravity : float
        Local gravity [m/s²].
    intervals : sequence of Interval, optional
        Static intervals of ``recording`` (the first is the initial rest);
        detected by default with ``detector``.
    init_static : float, optional
        Length of the initial rest [s] for the detector.
    min_hold : float
        The shortest hold that is a pose [s], for the accelerometer detector
        (:func:`imucalib.presets.hold_settings`).
    initial : {"step1", "identity"}
        Start the joint fit with tosses from the Step-1 estimates (the paper)
        or from the identity model (unit scales, zero biases) — for robustness
        studies.
    noise_weights : bool
        Weights of the joint fit from eqs. (25)–(30); ``False`` weighs every residual by 1.
    max_iter : int
        Most Levenberg–Marquardt iterations of each fit.
    fall_threshold : float
        Detected weightless segments whose eq. (19) loss RMS with the Step-1
        parameters exceeds this [m/s²] are not free fall and are dropped.
    select : bool
        Without weightless data, also fit the simpler variants and return the
        one Akaike's criterion (small-sample corrected, :func:`_criterion`) prefers (``fit["model_selection"]``
        says which), among the variants the poses can carry: never one with so few
        poses per accelerometer parameter that the verdict rejects it.
    detector : {"accelerometer", "gyroscope"}
        The shared detector (Tedaldi 2014's accelerometer variance with its
        threshold scan, gated by the gyroscope; default), or the
        gyroscope-norm detector of Zhang 2021, eq. (22).
    estimate_gyro_bias : bool or "auto"
        The gyroscope bias from the static poses (False), with the rotations
        (True), or as the data decide (:func:`imucalib.fit.gyroscope.fit_gyroscope`).
    progress : callable, optional
        Called with a message at each stage.

    Returns
    -------
    Calibration
        Accelerometer and gyroscope models (with polynomial scales and g-sensitivity as ``model`` has
        them, and the lever arm with tosses) in the recording's raw units, with the fit's figures, 1σ
        errors and verdict in ``fit``.

    Raises
    ------
    ValueError
        An accelerometer-only recording, an unknown ``model``, ``detector`` or ``initial``, fewer static
        intervals than the fit needs, or an initial rest with zero noise.
    """
    if recording.gyro is None:
        raise ValueError("zhang2021 calibrates the gyroscope with the accelerometer and this recording is "
                         f"accelerometer-only; the methods that take it are {', '.join(accelerometer_only())}")
    say = progress or (lambda msg: None)
    layout = ZhangLayout.of(model)
    if initial not in ("step1", "identity"):
        raise ValueError(f"initial must be 'step1' or 'identity'; got {initial!r}")
    say("detecting static intervals")
    static, rest = _poses(recording, gravity, intervals, init_static, detector, min_hold)
    exclude = unreliable_transitions(recording, static)
    static_acc = interval_means(recording.acc, static)
    linear = gravity_norm_fit(static_acc, gravity, max_iter=max_iter)
    fitted: dict[tuple[int, bool], _Stages] = {}

    def stages(lay: ZhangLayout) -> _Stages:
        key = (lay.order, lay.with_g)
        if key not in fitted:
            fitted[key] = _stages(lay, recording, static, rest, gravity, linear=linear, exclude=exclude,
                                  estimate_gyro_bias=estimate_gyro_bias, noise_weights=noise_weights,
                                  max_iter=max_iter)
        return fitted[key]

    say("calibrating the accelerometer and the gyroscope")
    if layout.with_r:
        step1 = stages(replace(layout, order=1, with_r=False))
        tosses = _tosses(recording, weightless, rest, step1, fall_threshold)
        if isinstance(tosses, str):
            layout = _without_lever_arm(layout, model, tosses)
        else:
            say("step 2: global optimisation with the tosses")
            return _joint(recording, static, rest, layout, model, gravity, step1, tosses, initial=initial,
                          noise_weights=noise_weights, max_iter=max_iter)
    selection = None
    if select and layout.order > 1:
        names = MODELS[: MODELS.index(model) + 1]
        budget = {name: _pose_budget(ZhangLayout.of(name), len(static)) for name in names}
        cands, unfit = {}, {}
        for name in names:
            if budget[name] or name == "linear":
                try:
                    cands[name] = stages(replace(ZhangLayout.of(name), with_r=False))
                except ValueError as exc:  # more parameters than poses: that variant cannot be fitted at all
                    if name == "linear":
                        raise
                    unfit[name] = str(exc)
        left_out = set().union(*(set(st.gyro.left_out) for st in cands.values()))
        aic = {name: _criterion(st, recording, static, gravity, left_out) for name, st in cands.items()}
        # a fit that did not converge, or whose parameters are implausible (a cross-axis term of tens of
        # degrees, a scale far from the unit's nominal), is never chosen, however low its criterion
        usable = {name: aic[name] for name, st in cands.items()
                  if st.converged and plausible(_stage_calibration(st, gravity, recording))}
        best = min(usable or aic, key=(usable or aic).get)
        over = [name for name in names if not budget[name]]
        selection = {"criterion": "aicc", "aic": aic, "requested": model, "selected": best,
                     "excluded": sorted(set(aic) - set(usable)) + sorted(unfit), "over_pose_budget": over}
        if best != model:
            why = (f"{len(static)} static poses carry at most "
                   f"{len(static) / THRESHOLDS['poses_per_parameter'][1]:.3g} accelerometer parameters"
                   if model in over else "the poses do not support the extra terms")
            warnings.warn(
                f"zhang2021 model {model!r}: without weightless data {why} (Akaike's criterion prefers "
                f"{best!r} among the variants they carry); the {best!r} solution is returned with the other "
                "terms at zero (to keep them: select=False, on the command line --keep-terms)",
                ImucalibWarning, stacklevel=2,
            )
        chosen = cands[best]
    else:
        chosen = stages(layout)
    cal = _stage_calibration(chosen, gravity, recording).with_(
        method="zhang2021", model=model if selection is None else selection["selected"])
    fit = fit_summary(cal, recording, static, gravity)
    fit |= chosen.gyro.summary()
    fit["uncertainty"] = chosen.errors
    fit["iterations"] = chosen.iterations
    fit["converged"] = chosen.converged
    fit["initial_rest_seconds"] = float(recording.t[rest.stop - 1] - recording.t[rest.start])
    if selection is not None:
        fit["model_selection"] = selection
    return cal.with_(fit=fit)


def _stage_calibration(st: _Stages, gravity: float, recording: Recording) -> Calibration:
    return Calibration(accelerometer=st.acc, gyroscope=st.gyroscope, gravity=gravity,
                       units=units_of(recording), fit={"converged": st.converged})


def _tosses(recording: Recording, weightless, rest: Interval, step1: _Stages, fall_threshold: float):
    """RD2 as ``(acc, gyro, starts, stops, r0, segments)``, or why there is none (a string).

    Detected tosses (``weightless`` None, eq. 22) are confirmed by the
    accelerometer: a segment whose eq. (19) loss RMS with the Step-1 parameters
    and the lever arm fitted to them exceeds ``fall_threshold`` is not free fall
    (Zhang 2021, §IV-C); ``r̂`` is refitted on the rest.
    """
    detected = weightless is None
    if detected:
        weightless = [recording[iv] for iv in detect_weightless(recording, rest=rest)]
    weightless = [w for w in weightless if len(w) >= 5]
    if not weightless:
        return "no weightless segments were found"
    cal0 = Calibration(accelerometer=step1.acc, gyroscope=step1.gyroscope)
    dt = 1.0 / recording.rate

    def lever(segments):
        acc, gyro, starts, stops = _concat(segments)
        a_w = cal0.accelerometer_si(acc)
        w_w = cal0.gyroscope_si(gyro, acc)
        lm = lever_arm_matrix(w_w, segmented_five_point(w_w, starts, stops, dt))
        r0, *_ = np.linalg.lstsq(lm.reshape(-1, 3), a_w.ravel(), rcond=None)  # eq. (19), linear in r
        return acc, gyro, starts, stops, r0, a_w, lm

    acc, gyro, starts, stops, r0, a_w, lm = lever(weightless)
    if detected:
        loss = np.linalg.norm(a_w - lm @ r0, axis=1)
        seg_rms = np.sqrt(np.add.reduceat(loss**2, starts) / (stops - starts))
        keep = seg_rms < fall_threshold
        if not np.any(keep):
            return (f"none of the {len(keep)} candidate weightless segments fits free fall "
                    f"(eq. 19 loss ≥ {fall_threshold} m/s²)")
        if not np.all(keep):
            weightless = [w for w, k in zip(weightless, keep, strict=True) if k]
            acc, gyro, starts, stops, r0, _, _ = lever(weightless)
    return acc, gyro, starts, stops, r0, weightless


def _joint(recording: Recording, static: list[Interval], rest: Interval, layout: ZhangLayout, model: str,
           gravity: float, step1: _Stages, tosses, *, initial: str, noise_weights: bool,
           max_iter: int) -> Calibration:
    """Step 2 with tosses: eq. (21) by Levenberg–Marquardt from the shared stages' linear estimates (Step 1)."""
    wl_acc, wl_gyro, wl_starts, wl_stops, _, weightless = tosses
    dt = 1.0 / recording.rate
    sol, problem, c = _solve_joint(recording, static, rest, layout, gravity, step1.acc, step1.gyroscope,
                                   step1.gyro.left_out, tosses, initial=initial, noise_weights=noise_weights,
                                   max_iter=max_iter, drift=_drift(step1.gyro))
    m = len(static)
    acc, gyro, r = layout.models(sol.x)
    cal = Calibration(accelerometer=acc, gyroscope=gyro, lever_arm=r, gravity=gravity, method="zhang2021",
                      model=model, units=units_of(recording))
    fit = fit_summary(cal, recording, static, gravity)
    fit |= step1.gyro.summary()
    fit["gyroscope_g_sensitivity"] = "estimated" if layout.with_g else "none"
    fit["weights"] = {k: float(np.mean(v)) for k, v in c.items()}  # means over intervals
    fit["cost"] = float(sol.cost)
    # 1σ errors from the weighted Jacobian at the solution, σ² from the weighted residuals of each cost term
    fit["uncertainty"] = _joint_errors(layout, sol, c, m)
    fit["iterations"] = int(sol.njev)
    fit["converged"] = bool(sol.success)
    fit["initial_rest_seconds"] = float(recording.t[rest.stop - 1] - recording.t[rest.start])
    fit["weightless_segments"] = len(weightless)
    cal_w = cal.apply(Recording(np.arange(wl_acc.shape[0]) * dt, wl_acc, wl_gyro,
                                acc_unit=recording.acc_unit, gyro_unit=recording.gyro_unit))
    wd = segmented_five_point(cal_w.gyro, wl_starts, wl_stops, dt)
    e4 = cal_w.acc - lever_arm_matrix(cal_w.gyro, wd) @ r
    fit["weightless_residual_rms"] = float(np.sqrt(np.mean(np.sum(e4**2, axis=1))))
    return cal.with_(fit=fit)
