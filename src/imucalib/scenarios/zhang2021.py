"""The ``zhang2021`` scenario: the simulated sessions of Zhang 2021, §IV-A, with known truth.

A session holds raw recordings made by distorting true signals with a true
:class:`~imucalib.calibration.Calibration` (Zhang 2021, eqs. 31–32: the exact
inverse of the canonical model, then Gaussian noise), the truth itself and the
segment layout. Everything is deterministic for a given seed.

The ``zhang2021`` scenario
--------------------------
* **RD1** — an initial rest of ``t_init`` seconds, then ``n1 = 40`` random
  gravity directions, each held ``t1 = 3`` s, joined by ``t2 = 2`` s
  rotations about the normal of consecutive directions. The paper divides the
  angle by 2 s (a constant rate that starts and stops abruptly); sampled at
  100 Hz, such a step cannot be integrated consistently (the RK4 rate is
  linear between samples), so the rate follows a raised cosine with the same
  mean (angle / 2 s): ``ω(t) = −n̂ θ/t2 (1 − cos 2πt/t2)``. The accelerometer
  vector moves along the great circle between the two directions (the
  rotation the gyroscope measures) rather than along the chord, so its norm
  stays ``g``; noise-free, RK4 integration of the sampled rates reproduces the
  pose change to < 1e-6 rad.
* **RD2** — ``n2 = 100`` one-second weightless spins from eq. (33). As printed,
  eq. (33) has unit norm; it is read as a rate of constant magnitude
  ``ω_set`` whose axis cones around ``R(q_rand)·ẑ``::

      ω(t) = ω_set R(q_rand) [ω_set sin ψ, ω_set cos ψ, 80]ᵀ / √(ω_set² + 80²)
      ω_set = |2π (¼ rand() + ¾) V_spin|,  V_spin = 7,  ψ(t) = 0.8 t + 2π rand()

  with ``rand()`` of mean 0 and variance 1 (standard normal) and ``ω_set``
  kept positive. ``ω̇`` is analytic; the accelerometer senses
  ``f_C(ω, r) + f_E(ω̇, r)`` (eqs. 17–18) with the lever arm ``r``.
* **RD3** — 10 test sequences for §IV-B: 1 s on a base, 0.3 s toss (the rate
  spins up smoothly while the hand accelerates the body), a weightless spin
  (eq. 33, 0.6 s), 0.3 s catch (the rate spins down), 1 s on the base again.

Raw readings: ``u = f⁻¹(T⁻¹ s) + b (+ G a for the gyroscope) + ν`` with the
noise ``ν`` given in SI units (σ_a in m/s², σ_g in rad/s per sample) and
converted to raw units through each axis's ``k1``. Default truth: the "set
values" of Zhang 2021, Table I in the canonical convention (raw accelerometer
unit g, so ``k1 ≈ 9.81``; the gyroscope bias reads 0.04 in the table's set
column but both fitted columns give 0.40, which is used).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..kinematics import integrate, quat_normalize, quat_to_matrix
from ..models import TriadModel
from ..recording import STANDARD_GRAVITY, Interval, Recording
from .base import TossSequence, distort, noise_levels

__all__ = ["generate", "random_truth", "table1_truth"]


def table1_truth(gravity: float = STANDARD_GRAVITY) -> Calibration:
    """Zhang 2021, Table I "set values" in the canonical convention.

    The paper adds ``b + G a`` to the raw reading, so the canonical bias and
    g-sensitivity are their negatives; ``T`` and the ``k`` are as printed
    (raw accelerometer unit g, raw gyroscope unit such that ``k1 ≈ 3.12``).
    """
    acc = TriadModel(
        misalignment=[[1, 0.03, -0.04], [0, 1, 0.035], [0, 0, 1]],
        scale=[9.81, 9.79, 9.76], scale_quadratic=[-0.03, 0.04, 0.03],
        scale_cubic=[0.04, 0.04, 0.06], bias=[-0.04, -0.5, 0.35], shape="upper",
    )
    gyro = TriadModel(
        misalignment=[[1, -0.02, 0.04], [0.02, 1, -0.02], [-0.026, 0.03, 1]],
        scale=[3.12, 3.15, 3.09], scale_quadratic=[0.015, -0.027, 0.02],
        scale_cubic=[0.023, 0.021, 0.03], bias=[-0.40, 0.15, -0.55],
        g_sensitivity=-1e-4 * np.array([[1, 2, -1], [-1, 2, 1], [2, 3, 1]]), shape="full",
    )
    return Calibration(accelerometer=acc, gyroscope=gyro, lever_arm=[0.07, 0.07, 0.07],
                       gravity=gravity, method="truth", model="all",
                       units={"accelerometer": {"raw": "g", "calibrated": "m/s^2"},
                              "gyroscope": {"raw": "counts", "calibrated": "rad/s"}})


def random_truth(rng, *, gravity: float = STANDARD_GRAVITY, misalignment: float = 0.05) -> Calibration:
    """A random truth around Table I: every nonlinear term, misalignment up to ``misalignment``.

    Scales within ±2 % of Table I's, ``k2`` in ±0.05 (acc) / ±0.03 (gyro), ``k3``
    in [0.01, 0.07] / [0.01, 0.035] (kept positive so the polynomials stay
    monotonic), biases in ±0.5 / ±0.6, ``G`` in ±3e-4, ``r`` in [0.03, 0.10] m.
    """
    rng = np.random.default_rng(rng)
    base = table1_truth(gravity)

    def u(lo, hi, n=3):
        return rng.uniform(lo, hi, n)

    ta = np.eye(3)
    ta[0, 1], ta[0, 2], ta[1, 2] = u(-misalignment, misalignment)
    tg = np.eye(3)
    for (i, j), v in zip(((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)),
                         u(-misalignment, misalignment, 6), strict=True):
        tg[i, j] = v
    acc = TriadModel(misalignment=ta, scale=base.accelerometer.scale * u(0.98, 1.02),
                     scale_quadratic=u(-0.05, 0.05), scale_cubic=u(0.01, 0.07),
                     bias=u(-0.5, 0.5), shape="upper")
    gyro = TriadModel(misalignment=tg, scale=base.gyroscope.scale * u(0.98, 1.02),
                      scale_quadratic=u(-0.03, 0.03), scale_cubic=u(0.01, 0.035),
                      bias=u(-0.6, 0.6), g_sensitivity=rng.uniform(-3e-4, 3e-4, (3, 3)),
                      shape="full")
    return base.with_(accelerometer=acc, gyroscope=gyro, lever_arm=u(0.03, 0.10))


# --------------------------------------------------------------- signals
def _random_directions(rng, n: int) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def _spin(rng, t: np.ndarray, v_spin: float = 7.0) -> tuple[np.ndarray, np.ndarray]:
    """Body rate and its derivative of one weightless spin (Zhang 2021, eq. 33, read as documented)."""
    rq = quat_to_matrix(quat_normalize(rng.normal(size=4)))  # R(q_rand), eq. (13)
    w_set = abs(2 * np.pi * (0.25 * rng.normal() + 0.75) * v_spin)
    psi0 = 2 * np.pi * rng.normal()
    psi = 0.8 * t + psi0  # ψ(t) = 0.8t + 2π rand()
    s = w_set / np.hypot(w_set, 80.0)
    w = np.column_stack([np.sin(psi) * w_set, np.cos(psi) * w_set, np.full_like(t, 80.0)]) @ rq.T * s
    wd = np.column_stack([np.cos(psi) * 0.8 * w_set, -np.sin(psi) * 0.8 * w_set,
                          np.zeros_like(t)]) @ rq.T * s
    return w, wd  # Zhang 2021, eq. (33)


def _weightless_force(w: np.ndarray, wd: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``f_C(ω, r) + f_E(ω̇, r)`` (Zhang 2021, eqs. 17–18)."""
    fc = np.sum(w * w, axis=1)[:, None] * r - w * (w @ r)[:, None]  # eq. (17)
    fe = np.cross(r, wd)  # eq. (18)
    return fc + fe


def _rd1(rng, gravity: float, *, n1: int, t1: float, t2: float, t_init: float, rate: float):
    """True specific force and rate of RD1 and its segments."""
    dirs = _random_directions(rng, n1)
    n_init, n1s, n2s = int(round(t_init * rate)), int(round(t1 * rate)), int(round(t2 * rate))
    dt = 1.0 / rate
    tau = np.arange(n2s) * dt
    shape = 1.0 - np.cos(2 * np.pi * tau / t2)  # raised cosine, mean 1
    acc_blocks = [np.tile(gravity * dirs[0], (n_init, 1))]
    gyro_blocks = [np.zeros((n_init, 3))]
    segments = [Interval(0, n_init, "static")]
    pos = n_init
    for k in range(1, n1):
        a0, a1 = dirs[k - 1], dirs[k]
        axis = np.cross(a0, a1)
        theta = float(np.arctan2(np.linalg.norm(axis), a0 @ a1))
        axis = axis / np.linalg.norm(axis)
        w = np.outer(-(theta / t2) * shape, axis)  # body rate turning g_b from a0 to a1
        # attitude by RK4 of the sampled rates, so integration reproduces the poses exactly
        q = integrate(np.r_[tau, t2], np.vstack([w, np.zeros((1, 3))]))
        g_b = np.einsum("nji,j->ni", quat_to_matrix(q), gravity * a0)  # Rᵀ g
        acc_blocks.append(g_b[:-1])
        gyro_blocks.append(w)
        segments.append(Interval(pos, pos + n2s, "motion"))
        pos += n2s
        end = g_b[-1]
        dirs[k] = end / np.linalg.norm(end)
        acc_blocks.append(np.tile(end, (n1s, 1)))
        gyro_blocks.append(np.zeros((n1s, 3)))
        segments.append(Interval(pos, pos + n1s, "static"))
        pos += n1s
    return np.concatenate(acc_blocks), np.concatenate(gyro_blocks), segments


def _rd3_sequence(rng, gravity: float, r: np.ndarray, rate: float):
    """One toss: base, spin-up, free spin, spin-down, base (true signals and segments)."""
    dt = 1.0 / rate
    n_base, n_ramp, n_free = int(rate), int(round(0.3 * rate)), int(round(0.6 * rate))
    g0 = gravity * _random_directions(rng, 1)[0]
    t_free = np.arange(n_free) * dt
    w_free, wd_free = _spin(rng, t_free)
    ramp = 0.5 - 0.5 * np.cos(np.pi * (np.arange(n_ramp) + 1) / n_ramp)  # 0 → 1 smoothly
    w_up = ramp[:, None] * w_free[0]
    w_down = ramp[::-1, None] * w_free[-1]
    w = np.concatenate([np.zeros((n_base, 3)), w_up, w_free, w_down, np.zeros((n_base, 3))])
    t = np.arange(w.shape[0]) * dt
    q = integrate(t, w)
    g_b = np.einsum("nji,j->ni", quat_to_matrix(q), g0)  # gravity in the body frame
    # specific force: on the base g; in the hand g plus a push along gravity; in free fall
    # only the lever-arm terms
    push = np.sin(np.pi * (np.arange(n_ramp) + 0.5) / n_ramp)[:, None]
    a = g_b.copy()
    s0 = n_base
    a[s0 : s0 + n_ramp] += 6.0 * push * g_b[s0 : s0 + n_ramp] / gravity
    a[s0 + n_ramp : s0 + n_ramp + n_free] = _weightless_force(w_free, wd_free, r)
    s1 = s0 + n_ramp + n_free
    a[s1 : s1 + n_ramp] += 6.0 * push[::-1] * g_b[s1 : s1 + n_ramp] / gravity
    segments = [
        Interval(0, n_base, "static"),
        Interval(n_base, s0 + n_ramp, "motion"),
        Interval(s0 + n_ramp, s1, "weightless"),
        Interval(s1, s1 + n_ramp, "motion"),
        Interval(s1 + n_ramp, w.shape[0], "static"),
    ]
    return t, a, w, segments


# --------------------------------------------------------------- scenarios
def generate(rng, *, truth: Calibration | None, noise, n1: int = 40, n2: int = 100,
               n3: int = 10, t1: float = 3.0, t2: float = 2.0, t_init: float = 10.0,
               rate: float = 100.0, full_scale: dict | None = None,
               lsb: dict | None = None) -> dict:
    truth = truth or table1_truth()
    if truth.lever_arm is None:
        raise ValueError("the zhang2021 scenario needs a truth with a lever arm")
    g = truth.gravity
    noise = noise_levels(noise)
    units = truth.units
    a1, w1, segments = _rd1(rng, g, n1=n1, t1=t1, t2=t2, t_init=t_init, rate=rate)
    t = np.arange(a1.shape[0]) / rate
    acc, gyro = distort(truth, a1, w1, rng, noise, full_scale, lsb)
    rec = Recording(t, acc, gyro, acc_unit=units["accelerometer"]["raw"],
                    gyro_unit=units["gyroscope"]["raw"], metadata={"segment": "RD1"})
    wl = []
    t_spin = np.arange(int(round(rate))) / rate
    for i in range(n2):
        w, wd = _spin(rng, t_spin)
        a = _weightless_force(w, wd, truth.lever_arm)
        acc, gyro = distort(truth, a, w, rng, noise, full_scale, lsb)
        wl.append(Recording(t_spin + 2.0 * i, acc, gyro, acc_unit=rec.acc_unit,
                            gyro_unit=rec.gyro_unit, metadata={"segment": f"RD2/{i}"}))
    tests = []
    for i in range(n3):
        tt, a, w, segs = _rd3_sequence(rng, g, truth.lever_arm, rate)
        acc, gyro = distort(truth, a, w, rng, noise, full_scale, lsb)
        tests.append(TossSequence(Recording(tt, acc, gyro, acc_unit=rec.acc_unit,
                                            gyro_unit=rec.gyro_unit,
                                            metadata={"segment": f"RD3/{i}"}), segs))
    return {"recording": rec, "segments": segments, "truth": truth, "weightless": wl,
            "tests": tests, "noise": noise,
            "options": {"n1": n1, "n2": n2, "n3": n3, "t1": t1, "t2": t2, "t_init": t_init,
                        "rate": rate}}


