"""Simulated calibration sessions with known truth (Zhang 2021, §IV-A).

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

import json
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .calibration import Calibration
from .kinematics import integrate, quat_from_rotvec, quat_normalize, quat_to_matrix
from .models import TriadModel
from .recording import STANDARD_GRAVITY, ImucalibWarning, Interval, Recording

__all__ = [
    "DEFAULT_NOISE",
    "attitude_with_up",
    "ferraris_session",
    "pose_session",
    "qureshi_orientations",
    "qureshi_session",
    "qureshi_truth",
    "qureshi_validation",
    "turns_between",
    "SCENARIOS",
    "Session",
    "TossSequence",
    "random_truth",
    "read_session",
    "session",
    "table1_truth",
    "write_session",
]

#: default per-sample noise: σ_a [m/s²], σ_g [rad/s] (ICM-42605-like at 100 Hz)
DEFAULT_NOISE = {"accelerometer": 0.005, "gyroscope": 0.0005}


@dataclass
class TossSequence:
    """One RD3 toss: the raw recording and its segments (static, motion, weightless)."""

    recording: Recording
    segments: list[Interval]


@dataclass
class Session:
    """A simulated session: raw recordings, the truth and the segment layout."""

    scenario: str
    seed: int | None
    recording: Recording
    segments: list[Interval]
    truth: Calibration
    weightless: list[Recording] = field(default_factory=list)
    tests: list[TossSequence] = field(default_factory=list)
    noise: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)


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


# ------------------------------------------------------------ distortion
def _noise_levels(noise) -> dict:
    if noise is None:
        return dict(DEFAULT_NOISE)
    if isinstance(noise, int | float):
        return {"accelerometer": float(noise), "gyroscope": float(noise)}
    unknown = set(noise) - {"accelerometer", "gyroscope"}
    if unknown:
        raise ValueError(f"noise keys must be 'accelerometer' and 'gyroscope'; got {sorted(unknown)}")
    out = dict(DEFAULT_NOISE)
    out.update({k: float(v) for k, v in noise.items()})
    if any(v < 0 for v in out.values()):
        raise ValueError(f"noise levels must be ≥ 0; got {out}")
    return out


def _distort(truth: Calibration, a: np.ndarray, w: np.ndarray, rng, noise: dict,
             full_scale: dict | None, lsb: dict | None) -> tuple[np.ndarray, np.ndarray]:
    """Raw readings from true specific force and rate (Zhang 2021, eqs. 31–32)."""
    acc = truth.accelerometer.inverse(a)  # eq. (31)
    gyro = truth.gyroscope.inverse(w, a)  # eq. (32): includes G·a
    if noise["accelerometer"]:
        acc = acc + rng.normal(size=acc.shape) * (noise["accelerometer"] / truth.accelerometer.scale)
    if noise["gyroscope"]:
        gyro = gyro + rng.normal(size=gyro.shape) * (noise["gyroscope"] / truth.gyroscope.scale)
    for name, arr in (("accelerometer", acc), ("gyroscope", gyro)):
        if lsb and lsb.get(name):
            arr[:] = np.round(arr / lsb[name]) * lsb[name]
        if full_scale and full_scale.get(name) is not None:
            limit = float(full_scale[name])
            clipped = int(np.count_nonzero(np.abs(arr) > limit))
            if clipped:
                np.clip(arr, -limit, limit, out=arr)
                warnings.warn(f"{clipped} {name} values beyond ±{limit:g} (raw) were clipped, "
                              "as a saturated sensor would report them", ImucalibWarning,
                              stacklevel=3)
    return acc, gyro


# --------------------------------------------------------------- scenarios
def _zhang2021(rng, *, truth: Calibration | None, noise, n1: int = 40, n2: int = 100,
               n3: int = 10, t1: float = 3.0, t2: float = 2.0, t_init: float = 10.0,
               rate: float = 100.0, full_scale: dict | None = None,
               lsb: dict | None = None) -> dict:
    truth = truth or table1_truth()
    if truth.lever_arm is None:
        raise ValueError("the zhang2021 scenario needs a truth with a lever arm")
    g = truth.gravity
    noise = _noise_levels(noise)
    units = truth.units
    a1, w1, segments = _rd1(rng, g, n1=n1, t1=t1, t2=t2, t_init=t_init, rate=rate)
    t = np.arange(a1.shape[0]) / rate
    acc, gyro = _distort(truth, a1, w1, rng, noise, full_scale, lsb)
    rec = Recording(t, acc, gyro, acc_unit=units["accelerometer"]["raw"],
                    gyro_unit=units["gyroscope"]["raw"], metadata={"segment": "RD1"})
    wl = []
    t_spin = np.arange(int(round(rate))) / rate
    for i in range(n2):
        w, wd = _spin(rng, t_spin)
        a = _weightless_force(w, wd, truth.lever_arm)
        acc, gyro = _distort(truth, a, w, rng, noise, full_scale, lsb)
        wl.append(Recording(t_spin + 2.0 * i, acc, gyro, acc_unit=rec.acc_unit,
                            gyro_unit=rec.gyro_unit, metadata={"segment": f"RD2/{i}"}))
    tests = []
    for i in range(n3):
        tt, a, w, segs = _rd3_sequence(rng, g, truth.lever_arm, rate)
        acc, gyro = _distort(truth, a, w, rng, noise, full_scale, lsb)
        tests.append(TossSequence(Recording(tt, acc, gyro, acc_unit=rec.acc_unit,
                                            gyro_unit=rec.gyro_unit,
                                            metadata={"segment": f"RD3/{i}"}), segs))
    return {"recording": rec, "segments": segments, "truth": truth, "weightless": wl,
            "tests": tests, "noise": noise,
            "options": {"n1": n1, "n2": n2, "n3": n3, "t1": t1, "t2": t2, "t_init": t_init,
                        "rate": rate}}


#: scenario name → generator(rng, *, truth, noise, **options) → dict of Session fields
SCENARIOS: dict[str, Callable[..., dict]] = {"zhang2021": _zhang2021}


def session(scenario: str = "zhang2021", *, rng=None, truth: Calibration | None = None,
            noise=None, **options) -> Session:
    """Simulate a session.

    Parameters
    ----------
    scenario : str
        One of :data:`SCENARIOS`.
    rng : int or numpy.random.Generator
        Seed or generator; the same seed gives the same session.
    truth : Calibration, optional
        True parameters (default: the scenario's, e.g. Zhang 2021 Table I).
    noise : dict or float, optional
        ``{"accelerometer": σ_a [m/s²], "gyroscope": σ_g [rad/s]}`` per sample
        (default :data:`DEFAULT_NOISE`; 0 for noise-free).
    **options
        Scenario options (counts, durations, ``rate``, ``full_scale`` and
        ``lsb`` dicts in raw units for saturation and quantisation).
    """
    try:
        gen = SCENARIOS[scenario]
    except KeyError:
        raise ValueError(f"unknown scenario {scenario!r}; choose one of {', '.join(SCENARIOS)}") from None
    seed = rng if isinstance(rng, int | np.integer) else None
    fields = gen(np.random.default_rng(rng), truth=truth, noise=noise, **options)
    return Session(scenario=scenario, seed=None if seed is None else int(seed), **fields)


# ------------------------------------------------------------------ files
def _write_rec(path: Path, rec: Recording) -> None:
    data = np.column_stack([rec.t, rec.acc, rec.gyro])
    np.savetxt(path, data, delimiter=",", fmt="%.17g", header="t,ax,ay,az,gx,gy,gz", comments="")


def _read_rec(path: Path, units: dict) -> Recording:
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return Recording(data[:, 0], data[:, 1:4], data[:, 4:7], acc_unit=units["accelerometer"],
                     gyro_unit=units["gyroscope"], metadata={"source": [str(path)]})


def write_session(sim: Session, directory: str | Path) -> Path:
    """Write ``recording.csv``, ``weightless_NNN.csv``, ``test_NN.csv``, ``truth.json``, ``session.json``."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    _write_rec(d / "recording.csv", sim.recording)
    for i, w in enumerate(sim.weightless):
        _write_rec(d / f"weightless_{i:03d}.csv", w)
    for i, ts in enumerate(sim.tests):
        _write_rec(d / f"test_{i:02d}.csv", ts.recording)
    sim.truth.save(d / "truth.json")
    meta = {
        "format": "imucalib.session", "format_version": 1,
        "scenario": sim.scenario, "seed": sim.seed, "noise": sim.noise, "options": sim.options,
        "units": {"accelerometer": sim.recording.acc_unit, "gyroscope": sim.recording.gyro_unit},
        "files": {
            "recording.csv": [s.to_dict() for s in sim.segments],
            **{f"weightless_{i:03d}.csv": [{"start": 0, "stop": len(w), "kind": "weightless"}]
               for i, w in enumerate(sim.weightless)},
            **{f"test_{i:02d}.csv": [s.to_dict() for s in ts.segments]
               for i, ts in enumerate(sim.tests)},
        },
    }
    (d / "session.json").write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return d


def read_session(directory: str | Path):
    """Read a directory written by :func:`write_session` (or a wang2019 one by ``imucalib simulate``)."""
    d = Path(directory)
    meta_path = d / "session.json"
    if not meta_path.is_file():
        raise ValueError(f"{d}: not a simulated session directory (no session.json)")
    meta = json.loads(meta_path.read_text(encoding="utf-8"))
    if meta.get("format") != "imucalib.session":
        raise ValueError(f"{meta_path}: not an imucalib session file")
    if meta.get("scenario") == "wang2019":  # turntable aggregates, not recordings
        from .scenarios_wang2019 import WangSession

        pos = np.loadtxt(d / "positions.csv", delimiter=",", skiprows=1, ndmin=2)
        turns = np.loadtxt(d / "turns.csv", delimiter=",", skiprows=1, ndmin=2)
        truth = Calibration.load(d / "truth.json") if (d / "truth.json").is_file() else None
        return WangSession(positions_acc=pos[:, :3], positions_gyro=pos[:, 3:6], turn_sum=turns[:, :3],
                           turn_sum2=turns[:, 3:6], turn_angle=turns[:, 6], truth=truth,
                           latitude_deg=meta.get("latitude_deg", 0.0),
                           turntable_error=meta.get("turntable_error", ""), options=meta.get("options", {}))
    units = meta["units"]
    files = meta["files"]

    def segs(name):
        return [Interval(s["start"], s["stop"], s["kind"]) for s in files[name]]

    rec = _read_rec(d / "recording.csv", units)
    weightless = [_read_rec(d / n, units) for n in sorted(files) if n.startswith("weightless_")]
    tests = [TossSequence(_read_rec(d / n, units), segs(n))
             for n in sorted(files) if n.startswith("test_")]
    truth = Calibration.load(d / "truth.json") if (d / "truth.json").is_file() else None
    return Session(scenario=meta["scenario"], seed=meta.get("seed"), recording=rec,
                   segments=segs("recording.csv"), truth=truth, weightless=weightless,
                   tests=tests, noise=meta.get("noise", {}), options=meta.get("options", {}))


# ------------------------------------------------------- pose/turn sessions
def turns_between(directions: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Body-frame turns (unit axis, angle [rad]) carrying gravity through ``directions``.

    A body turning by ``θ`` about ``n`` sees a fixed vector turn by ``−θ``, so the
    shortest turn from body gravity direction ``a₀`` to ``a₁`` is ``−θ`` about
    ``a₀ × a₁`` (any perpendicular axis for opposite directions).
    """
    d = np.asarray(directions, dtype=float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    out = []
    for a0, a1 in zip(d[:-1], d[1:], strict=True):
        axis = np.cross(a0, a1)
        if np.linalg.norm(axis) < 1e-12:
            axis = np.cross(a0, [1.0, 0, 0] if abs(a0[0]) < 0.9 else [0, 1.0, 0])
        angle = float(np.arctan2(np.linalg.norm(np.cross(a0, a1)), a0 @ a1))
        out.append((-axis / np.linalg.norm(axis), angle))
    return out


def attitude_with_up(direction: np.ndarray) -> np.ndarray:
    """Quaternion of an attitude whose body vector ``direction`` points up (world +z)."""
    d0 = np.asarray(direction, dtype=float)
    d0 = d0 / np.linalg.norm(d0)
    axis = np.cross(d0, [0.0, 0.0, 1.0])
    angle = np.arctan2(np.linalg.norm(axis), d0[2])
    if np.linalg.norm(axis) < 1e-12:
        return quat_from_rotvec(np.array([np.pi if d0[2] < 0 else 0.0, 0.0, 0.0]))
    return quat_from_rotvec(axis / np.linalg.norm(axis) * angle)


def pose_session(truth: Calibration, turns, *, rng=None, up: np.ndarray | None = None,
                 rest: float = 5.0, hold: float = 2.0, move: float = 1.5, rate: float = 100.0,
                 noise=None) -> tuple[Recording, list[Interval]]:
    """A rest, then static holds joined by smooth body-frame turns.

    Each turn ``(axis, angle)`` is a rotation about the body axis with a
    ``sin²`` rate profile over ``move`` seconds; the attitude is the RK4
    integral of the sampled rates, so noise-free gravity directions and gyro
    integration agree exactly. Returns the raw recording and the static
    intervals (the rest first).
    """
    rng = np.random.default_rng(rng)
    noise = _noise_levels(noise)
    dt = 1.0 / rate
    n_rest, n_hold, n_move = int(round(rest * rate)), int(round(hold * rate)), int(round(move * rate))
    blocks = [np.zeros((n_rest, 3))]
    intervals = [Interval(0, n_rest, "static")]
    pos = n_rest
    tau = (np.arange(n_move) + 0.5) / n_move
    bump = np.sin(np.pi * tau) ** 2
    for axis, angle in turns:
        axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
        blocks += [np.outer(bump / bump.sum() * angle / dt, axis), np.zeros((n_hold, 3))]
        intervals.append(Interval(pos + n_move, pos + n_move + n_hold, "static"))
        pos += n_move + n_hold
    w = np.concatenate(blocks)
    t = np.arange(w.shape[0]) * dt
    q0 = attitude_with_up(np.array([0.0, 0.0, 1.0]) if up is None else up)
    q = integrate(t, w, q0)
    a = np.einsum("nji,j->ni", quat_to_matrix(q), np.array([0.0, 0.0, truth.gravity]))  # Rᵀ g
    acc, gyro = _distort(truth, a, w, rng, noise, None, None)
    units = truth.units
    return Recording(t, acc, gyro, acc_unit=units["accelerometer"]["raw"],
                     gyro_unit=units["gyroscope"]["raw"]), intervals


# ------------------------------------------------------------ Qureshi 2017
def qureshi_orientations() -> np.ndarray:
    """The 18 orientations of Qureshi 2017 §IV-B: 6 cube faces and 12 edges at 45° (gravity, body frame)."""
    faces = np.vstack([np.eye(3), -np.eye(3)])
    edges = []
    for i, j in ((0, 1), (0, 2), (1, 2)):
        for si in (1, -1):
            for sj in (1, -1):
                v = np.zeros(3)
                v[i], v[j] = si, sj
                edges.append(v / np.sqrt(2))
    return np.vstack([faces, edges])


def qureshi_truth(gravity: float = STANDARD_GRAVITY) -> Calibration:
    """A truth like Qureshi 2017, Table II (accelerometer) and Table III (gyroscope scales, biases).

    Raw accelerometer unit g, raw gyroscope unit °/s (nominal), so the canonical
    scales are ``g·k`` and ``k·π/180``.
    """
    from .conventions import from_qureshi

    acc = from_qureshi(np.array([0.0097, -0.0367, -0.0101, 1.0061 * gravity, 1.0067 * gravity,
                                 0.9831 * gravity, -0.0122 * gravity, 0.0188 * gravity,
                                 0.0005 * gravity]))
    gyro = TriadModel(scale=np.radians([0.9754, 0.9830, 0.9747]), bias=[-0.0482, 0.0644, 0.0554],
                      shape="full")
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="truth",
                       model="linear",
                       units={"accelerometer": {"raw": "g", "calibrated": "m/s^2"},
                              "gyroscope": {"raw": "counts", "calibrated": "rad/s"}})


#: BNO055-class noise per sample at 100 Hz: 150 µg/√Hz over ~45 Hz ≈ 0.01 m/s²; 0.1 °/s
QURESHI_NOISE = {"accelerometer": 0.01, "gyroscope": float(np.radians(0.1))}


def qureshi_session(rng=None, *, truth: Calibration | None = None, noise=None, hold: float = 2.0):
    """The 18 orientations (2 s each at 100 Hz) then the per-axis rotations of Qureshi 2017, Fig. 2.

    After the orientations the sensor returns to z up and is turned about x
    (+60°, −120°, +60°) and about y (the same), then 90° about y, which puts
    z horizontal, and about z (the same): every measured turn is about a
    horizontal axis, so the accelerometer sees its angle. Returns
    ``(recording, static intervals, truth)``.
    """
    truth = truth or qureshi_truth()
    d = qureshi_orientations()
    dirs = np.vstack([[0.0, 0.0, 1.0], d, [0.0, 0.0, 1.0]])
    turns = turns_between(dirs)
    seq = [60, -120, 60]
    for axis in (np.array([1.0, 0, 0]), np.array([0, 1.0, 0])):
        turns += [(axis, np.radians(a)) for a in seq]
    turns.append((np.array([0, 1.0, 0]), np.radians(90)))
    turns += [(np.array([0, 0, 1.0]), np.radians(a)) for a in seq]
    rec, intervals = pose_session(truth, turns, rng=rng, hold=hold, move=1.5, rest=5.0,
                                  noise=QURESHI_NOISE if noise is None else noise)
    return rec, intervals, truth


def qureshi_validation(truth: Calibration, rng=None, *, n: int = 92, samples: int = 200,
                       noise=None) -> np.ndarray:
    """Raw accelerometer means of ``n`` fresh random static orientations (for §IV-B's check)."""
    rng = np.random.default_rng(rng)
    noise = QURESHI_NOISE if noise is None else _noise_levels(noise)
    d = rng.normal(size=(n, 3))
    a = truth.gravity * d / np.linalg.norm(d, axis=1, keepdims=True)
    raw = truth.accelerometer.inverse(a)
    sigma = noise["accelerometer"] / truth.accelerometer.scale / np.sqrt(samples)
    return raw + rng.normal(size=raw.shape) * sigma


def ferraris_session(truth: Calibration, rng=None, *, noise=None, angle: float = 360.0):
    """Six faces and a known-angle turn about each axis while it is vertical (Ferraris 1995).

    Poses: +z (rest), +z after a turn about z, −z, +x, +x after a turn about x,
    −x, +y, +y after a turn about y, −y. Returns ``(recording, static intervals,
    layout)`` with ``layout = {"faces": {"+x": k, …}, "turns": {"x": k, …}}``
    (``k`` the index of the static interval ending the motion).
    """
    e = np.eye(3)
    th = np.radians(angle)
    turns = [(e[2], th)]
    turns += turns_between([e[2], -e[2], e[0]])
    turns += [(e[0], th)]
    turns += turns_between([e[0], -e[0], e[1]])
    turns += [(e[1], th)]
    turns += turns_between([e[1], -e[1]])
    rec, intervals = pose_session(truth, turns, rng=rng, noise=noise, hold=2.0, move=3.0)
    layout = {"faces": {"+z": 0, "-z": 2, "+x": 3, "-x": 5, "+y": 6, "-y": 8},
              "turns": {"z": 1, "x": 4, "y": 7}}
    return rec, intervals, layout
