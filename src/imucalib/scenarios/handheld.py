"""The ``handheld`` scenario: a consumer IMU calibrated by hand, with what real hands add.

Real calibration sessions recorded by people differ from the clean simulations
of the papers (Zhang 2021, §IV-A) in ways that break methods: the "static"
poses shake, some motions are turns about the vertical that the accelerometer
cannot see, the hand settles for a moment after each pose, the logger drops
samples and jitters its timestamps, and the gyroscope bias drifts. This
scenario reproduces them one knob at a time, so that each failure can be
replayed in a test; :data:`CLEAN` switches every one of them off.

The sensor
----------
:func:`consumer_truth` draws an MPU-6050/ICM-20948-class IMU in raw 16-bit
counts from the tolerances of the MPU-6000/MPU-6050 Product Specification
(rev. 3.4, §6.1 gyroscope, §6.2 accelerometer): ±2 g at 16384 counts/g,
±250 °/s at 131 counts/(°/s), ±3 % scale tolerance, ±2 % cross-axis
sensitivity, 0.1 °/s/g linear-acceleration sensitivity. Its noise
(:func:`datasheet_noise`) is the datasheet's spectral densities, 400 µg/√Hz
and 0.005 °/s/√Hz, times √(rate/2) (white noise over the Nyquist band).
Raw readings follow the canonical model inverted (Zhang 2021, eqs. 31–32,
:func:`~imucalib.scenarios.base.distort`), then bias drift, rounding to
integer counts and saturation at the int16 range.

The motion
----------
True body rates are built on the sensor's own uniform sample clock from
fixed-axis rotations with an asymmetric speed profile
``s(τ) ∝ τ^α (1 − τ)^β`` (α, β random in [1.2, 3]: the bell of point-to-point
hand movements, Flash & Hogan 1985, made asymmetric as aiming movements are,
MacKenzie et al. 1987). The attitude is the RK4 integral of those sampled
rates (:func:`~imucalib.kinematics.integrate`, body → world), so the true
gravity directions and the true gyroscope agree as in
:func:`~imucalib.scenarios.base.pose_session`. The specific force in the body
frame is

    f = Rᵀ (g ẑ + p̈) + ω̇ × ρ + ω × (ω × ρ)

with ``g ẑ`` the reaction to gravity in the world frame (z up), ``p̈`` the
hand's translation (a minimum-jerk displacement during each motion, Flash &
Hogan 1985, eq. 2: ``p(τ) = d (10τ³ − 15τ⁴ + 6τ⁵)``) and the last two terms
the rigid-body acceleration of a sensor held at ``ρ`` from the rotation centre
of the hand (Zhang 2021, eqs. 17–18 with ``ρ = −r``). All of it is zero while
the hand is still.

Hand tremor is band-limited rate noise in two bands, postural sway
(0.5–2 Hz) and physiological tremor (8–12 Hz), of equal power: Gaussian noise
through zero-phase 2nd-order Butterworth band-passes, scaled to ``tremor``
°/s RMS (times a per-pose factor in [0.5, 1.5]), added to the body rate and
integrated into the attitude like any motion; its angular acceleration moves
the sensor through the ``ω̇ × ρ`` term. The initial rest lies on a table: no
tremor there.

Procedures
----------
``"poses"`` (Tedaldi 2014 as users do it): an initial rest, then ``n_poses``
holds of ``dwell`` s each, at gravity directions spread over the sphere (a
Fibonacci lattice in random order, each next one 40–140° away when possible),
joined by hand rotations with a random twist about the new vertical; some of
them (``hesitation``) in two sub-moves about different axes with a short
hesitation, some (``vertical_turns``) pure turns about the vertical, some
preceded or followed by a re-grasp (``reposition``): a tilt of
``regrasp_deg`` and back by the same angle ±5 %, with short pauses.

``"ferraris"`` (Ferraris 1995 as users do it): the initial rest (optionally a
``nudge_deg`` turn about the vertical at its end, set down on the same face),
six faces (+z first, the others in random order) held ``face_dwell`` s each
with re-grasps between them, then for each axis in random order: make it point
up, hold, re-grasp (tilt of tens of degrees and back), pause, four hand
quarter-turns of ``quarter`` s about that axis with ``quarter_pause`` s
between them, pause, re-grasp, hold.

Session layout
--------------
``segments`` are the truth in the recorded sample indices (after drops):
``"static"`` for every hold (the initial rest first, creep included as a
user's pose would include it) and ``"motion"`` for everything between (short
pauses included). ``options`` holds every knob and the facts: dropped samples,
creep and pause ranges, turns about the vertical, clipped values, drift, and
for the Ferraris procedure ``sections`` ``x_p, x_a, y_p, y_a, z_p, z_a`` (the
face holds; ``_p`` axis up, ``_a`` axis down) and ``x_rot, y_rot, z_rot`` (the
four quarter-turns with a few still samples either side), all ``[start, stop)``.

The returned ``truth`` is the calibration at the start of the session: the
given (or drawn) truth with its gyroscope bias moved by the turn-on offset.
The bias then drifts linearly and by a random walk; ``options`` records the
slopes and the bias at the end.

References: T. Flash, N. Hogan, "The coordination of arm movements", J.
Neurosci. 5(7), 1985; C. L. MacKenzie et al., "Three-dimensional movement
trajectories in Fitts' task", Q. J. Exp. Psychol. 39A, 1987; F. Ferraris et
al., "Procedure for effortless in-field calibration of three-axial rate gyro
and accelerometers", Sensors and Materials 7(5), 1995.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..calibration import Calibration
from ..kinematics import (
    integrate,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    quat_normalize,
    quat_to_matrix,
    quat_to_rotvec,
)
from ..models import MagnetometerModel, TriadModel
from ..recording import STANDARD_GRAVITY, ImucalibWarning, Interval, Recording
from ..thermal import REFERENCE_C, ThermalModel, decompensate, evaluate
from .base import attitude_with_up, distort

__all__ = ["CLEAN", "COUNTS_RANGE", "MAGNETOMETER", "consumer_truth", "datasheet_noise", "datasheet_thermal",
           "generate",
           "simulate_magnetometer"]

#: MPU-6050 accelerometer sensitivity at AFS_SEL=0 (±2 g) [counts/g] (datasheet §6.2)
ACC_COUNTS_PER_G = 16384.0
#: MPU-6050 gyroscope sensitivity at FS_SEL=0 (±250 °/s) [counts/(°/s)] (datasheet §6.1)
GYRO_COUNTS_PER_DPS = 131.0
#: accelerometer noise power spectral density [g/√Hz] (datasheet §6.2)
ACC_NOISE_DENSITY = 400e-6
#: gyroscope rate noise spectral density [(°/s)/√Hz] (datasheet §6.1)
GYRO_NOISE_DENSITY = 0.005
#: the int16 output registers: readings are clipped to this range
COUNTS_RANGE = (-32768, 32767)

#: knob values that switch every nuisance off (a clean session of the same procedure)
CLEAN: dict = {
    "tremor": 0.0, "creep": 0, "hesitation": 0.0, "reposition": 0.0, "vertical_turns": 0.0,
    "lin_acc": 0.0, "lever": 0.0, "jitter": 0.0, "drop": 0.0, "gap": 0.0, "turn_on": 0.0,
    "gyro_drift": 0.0, "gyro_rw": 0.0, "acc_drift": 0.0, "quantise": False, "full_scale": None,
}

_E = np.eye(3)
_UP = np.array([0.0, 0.0, 1.0])


# ------------------------------------------------------------------ sensor
def consumer_truth(rng=None, gravity: float = STANDARD_GRAVITY) -> Calibration:
    """A random MPU-6050/ICM-20948-class IMU in raw counts (linear model).

    Drawn uniformly within the MPU-6000/MPU-6050 Product Specification (rev.
    3.4) tolerances, narrowed where a factory trim makes real parts better:

    * accelerometer ±2 g, ``k1 = g₀/16384 · (1 ± 3 %)`` (§6.2 "initial
      calibration tolerance ±3 %"), bias within ±25 mg on x, y and ±40 mg on z
      (half the zero-g tolerance of ±50/±80 mg: a few hundred counts),
      upper-triangular misalignment within ±0.015 (cross-axis ±2 %);
    * gyroscope ±250 °/s, ``k1 = (π/180)/131 · (1 ± 3 %)`` (§6.1 "sensitivity
      scale factor tolerance ±3 %"), bias within ±80 counts (±0.6 °/s, a
      trimmed part; the untrimmed ZRO tolerance is ±20 °/s), full misalignment
      within ±0.02 (cross-axis ±2 %), g-sensitivity within ±0.1 °/s/g per
      entry (§6.1 "linear acceleration sensitivity 0.1 °/s/g") in counts per
      m/s².

    Parameters
    ----------
    rng : int or numpy.random.Generator, optional
        Seed or generator; ``None`` gives one fixed representative device.
    gravity : float
        Local gravity [m/s²] stored in the calibration.
    """
    rng = np.random.default_rng(6050 if rng is None else rng)
    g0 = STANDARD_GRAVITY  # the datasheet's g
    k_acc = g0 / ACC_COUNTS_PER_G  # m/s² per count
    k_gyro = math.radians(1.0) / GYRO_COUNTS_PER_DPS  # rad/s per count
    ta = np.eye(3)
    ta[0, 1], ta[0, 2], ta[1, 2] = rng.uniform(-0.015, 0.015, 3)
    tg = np.eye(3)
    for (i, j), v in zip(((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)), rng.uniform(-0.02, 0.02, 6), strict=True):
        tg[i, j] = v
    mg = ACC_COUNTS_PER_G * 1e-3  # counts per mg
    acc = TriadModel(misalignment=ta, scale=k_acc * (1 + rng.uniform(-0.03, 0.03, 3)),
                     bias=rng.uniform(-1, 1, 3) * np.array([25 * mg, 25 * mg, 40 * mg]), shape="upper")
    g_sens = 0.1 * GYRO_COUNTS_PER_DPS / g0  # 0.1 °/s/g → counts per m/s²
    gyro = TriadModel(misalignment=tg, scale=k_gyro * (1 + rng.uniform(-0.03, 0.03, 3)),
                      bias=rng.uniform(-80, 80, 3), g_sensitivity=rng.uniform(-g_sens, g_sens, (3, 3)),
                      shape="full")
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="truth", model="linear",
                       device="MPU-6050-class (simulated)",
                       units={"accelerometer": {"raw": "counts", "calibrated": "m/s^2"},
                              "gyroscope": {"raw": "counts", "calibrated": "rad/s"}})


def datasheet_noise(rate: float) -> dict:
    """Per-sample white-noise σ of an MPU-6050 sampled at ``rate`` [Hz].

    ``σ = density · √(rate/2)``: the datasheet's spectral densities (400 µg/√Hz,
    0.005 °/s/√Hz) over the Nyquist band. At 100 Hz: 0.028 m/s², 0.035 °/s,
    near the datasheet's total RMS figures (4 mg at DLPF 94 Hz; 0.05 °/s at
    DLPF 100 Hz).
    """
    bw = math.sqrt(rate / 2.0)
    return {"accelerometer": ACC_NOISE_DENSITY * STANDARD_GRAVITY * bw,
            "gyroscope": math.radians(GYRO_NOISE_DENSITY) * bw}


def _noise(noise, rate: float) -> dict:
    out = datasheet_noise(rate)
    if noise is None:
        return out
    if isinstance(noise, int | float):
        return {"accelerometer": float(noise), "gyroscope": float(noise)}
    unknown = set(noise) - {"accelerometer", "gyroscope"}
    if unknown:
        raise ValueError(f"noise keys must be 'accelerometer' and 'gyroscope'; got {sorted(unknown)}")
    out.update({k: float(v) for k, v in noise.items()})
    if any(v < 0 for v in out.values()):
        raise ValueError(f"noise levels must be ≥ 0; got {out}")
    return out


# ----------------------------------------------------------------- motions
def _profile(n: int, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """Speed profile ``s(τ) ∝ τ^a (1−τ)^b`` at sample midpoints, mean 1, and ``ds/dτ``."""
    tau = (np.arange(n) + 0.5) / n
    s = tau**a * (1 - tau) ** b
    ds = s * (a / tau - b / (1 - tau))
    c = n / s.sum()
    return s * c, ds * c


def _min_jerk_acc(n: int, peak: float, direction: np.ndarray) -> np.ndarray:
    """Acceleration of a minimum-jerk displacement (Flash & Hogan 1985, eq. 2) with the given peak [m/s²].

    ``p(τ) = d (10τ³ − 15τ⁴ + 6τ⁵)`` gives ``p̈ = d/D² (60τ − 180τ² + 120τ³)``,
    whose largest magnitude is ``10/√3 · d/D²``; zero velocity at both ends.
    """
    tau = (np.arange(n) + 0.5) / n
    shape = (60 * tau - 180 * tau**2 + 120 * tau**3) / (10 / math.sqrt(3))
    return np.outer(peak * shape, direction)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _perpendicular(rng, v: np.ndarray) -> np.ndarray:
    """A random unit vector perpendicular to ``v`` (any unit vector when ``v`` is zero)."""
    if np.linalg.norm(v) < 1e-12:
        return _unit(rng.normal(size=3))
    while True:
        c = np.cross(v, rng.normal(size=3))
        if np.linalg.norm(c) > 1e-3:
            return _unit(c)


class _Timeline:
    """Sampled body rates built block by block, with the planned attitude and the layout (true indices)."""

    def __init__(self, rng, rate: float, q0: np.ndarray, *, max_rate: float | None, lin_acc: float,
                 lever: float) -> None:
        self.rng, self.rate, self.dt = rng, rate, 1.0 / rate
        self.q = q0
        self.max_rate = None if max_rate is None else math.radians(max_rate)
        self.lin_acc, self.lever = lin_acc, lever
        self.w: list[np.ndarray] = []
        self.wd: list[np.ndarray] = []
        self.acc: list[np.ndarray] = []
        self.rho: list[np.ndarray] = []
        self.level: list[np.ndarray] = []
        self.n = 0
        self.tremor = 0.0  # current tremor level [°/s RMS]
        self.grip = np.zeros(3)  # current sensor position from the hand's rotation centre [m]
        self.static: list[tuple[int, int]] = []
        self.pauses: list[tuple[int, int]] = []
        self.creeps: list[dict] = []

    def up(self) -> np.ndarray:
        """Body-frame vector pointing up (planned attitude)."""
        return quat_to_matrix(self.q).T @ _UP

    def regrip(self) -> None:
        """A new grasp: a new sensor position from the hand's rotation centre, ``lever`` m away."""
        self.grip = self.lever * _unit(self.rng.normal(size=3)) if self.lever else np.zeros(3)

    def _append(self, w, wd, acc) -> tuple[int, int]:
        n = w.shape[0]
        self.w.append(w)
        self.wd.append(wd)
        self.acc.append(acc)
        self.rho.append(np.tile(self.grip, (n, 1)))
        self.level.append(np.full(n, self.tremor))
        start = self.n
        self.n += n
        return start, self.n

    def still(self, duration: float) -> tuple[int, int]:
        n = max(1, int(round(duration * self.rate)))
        z = np.zeros((n, 3))
        return self._append(z, z, z)

    def pause(self, duration: float) -> tuple[int, int]:
        """A short still moment inside a motion (recorded in the facts, not a static segment)."""
        rng = self.still(duration)
        self.pauses.append(rng)
        return rng

    def rotate(self, rotvec: np.ndarray, duration: float, *, translate: float = 1.0,
               shape: tuple[float, float] | None = None) -> tuple[int, int]:
        """Rotate about a fixed body axis by ``|rotvec|`` with an asymmetric speed profile.

        The duration is stretched until the peak rate stays within ``max_rate``.
        ``translate`` scales the hand's minimum-jerk translation (peak ``lin_acc``).
        """
        angle = float(np.linalg.norm(rotvec))
        axis = rotvec / angle if angle > 0 else np.array([1.0, 0.0, 0.0])
        a, b = shape if shape is not None else self.rng.uniform(1.2, 3.0, 2)
        n = max(3, int(round(duration * self.rate)))
        s, ds = _profile(n, a, b)
        if self.max_rate is not None:
            for _ in range(3):  # the peak of the sampled profile barely depends on n
                need = int(math.ceil(angle * s.max() / (self.max_rate * self.dt)))
                if need <= n:
                    break
                n = need
                s, ds = _profile(n, a, b)
        span = n * self.dt
        w = np.outer(angle / span * s, axis)  # Σ w dt = angle
        wd = np.outer(angle / span**2 * ds, axis)
        peak = self.lin_acc * translate * self.rng.uniform(0.3, 1.0)
        acc = _min_jerk_acc(n, peak, _unit(self.rng.normal(size=3))) if peak > 0 else np.zeros((n, 3))
        self.q = quat_normalize(quat_multiply(self.q, quat_from_rotvec(rotvec)))
        return self._append(w, wd, acc)

    def hold(self, duration: float, *, creep: bool = False) -> int:
        """A static pose; with ``creep`` it starts by settling ~1° as a hand lets go."""
        start = self.n
        if creep:
            # a tilt about a horizontal world axis, 0.8–1.2° over 0.5–1 s (1–2.4 °/s), fast then slow
            angle = math.radians(self.rng.uniform(0.8, 1.2))
            span = self.rng.uniform(0.5, 1.0)
            h = quat_to_matrix(self.q).T @ np.array([*_unit(self.rng.normal(size=2)), 0.0])
            s0, s1 = self.rotate(h * angle, span, translate=0.0, shape=(1.2, 2.5))
            self.creeps.append({"static": len(self.static), "range": [s0, s1],
                                "angle_deg": math.degrees(angle)})
            duration = max(duration - span, self.dt)
        self.still(duration)
        self.static.append((start, self.n))
        return len(self.static) - 1

    def arrays(self) -> tuple[np.ndarray, ...]:
        return tuple(np.concatenate(x) for x in (self.w, self.wd, self.acc, self.rho, self.level))


def _regrasp(tl: _Timeline, rng, k: dict, *, degrees: tuple[float, float] | None = None) -> None:
    """A re-grasp: tilt by a few to tens of degrees and back by the same angle ±5 %, with short pauses."""
    lo, hi = degrees or k["regrasp_deg"]
    axis = _perpendicular(rng, tl.up())
    phi = math.radians(rng.uniform(lo, hi))
    tl.rotate(axis * phi, rng.uniform(0.4, 1.0), translate=0.5)
    tl.pause(rng.uniform(0.2, 0.6))
    tl.rotate(-axis * phi * (1 + 0.05 * rng.normal()), rng.uniform(0.4, 1.0), translate=0.5)
    tl.pause(rng.uniform(0.1, 0.4))


def _move(tl: _Timeline, rng, k: dict, target: np.ndarray, *, twist: bool = True) -> None:
    """Rotate so that the body vector ``target`` points up, with a random twist about it.

    The body turns by ``θ`` about ``n = −u × v / |u × v|`` (``u`` the body up
    vector now; ``base.turns_between``), then by ``ψ`` about ``v``; both are
    joined into one fixed-axis rotation, or split in two sub-moves about
    different axes with a hesitation between them.
    """
    u, v = tl.up(), _unit(target)
    c = np.cross(u, v)
    theta = float(np.arctan2(np.linalg.norm(c), u @ v))
    n = -c / np.linalg.norm(c) if np.linalg.norm(c) > 1e-9 else _perpendicular(rng, u)
    psi = math.radians(rng.uniform(-60, 60)) if twist else 0.0
    dq = quat_multiply(quat_from_rotvec(n * theta), quat_from_rotvec(v * psi))
    q_target = quat_multiply(tl.q, dq)
    duration = rng.uniform(*k["move"])
    if rng.random() < k["hesitation"]:
        f = rng.uniform(0.4, 0.7)
        rv = quat_to_rotvec(dq)
        tilt = quat_from_rotvec(_perpendicular(rng, rv) * math.radians(rng.uniform(0, 20)))
        first = quat_to_matrix(tilt) @ rv * f  # the first sub-move's axis is off by up to 20°
        tl.rotate(first, duration * f)
        tl.pause(rng.uniform(0.1, 0.4))  # hesitation
        rest = quat_to_rotvec(quat_multiply(quat_conjugate(tl.q), q_target))
        tl.rotate(rest, duration * (1 - f))
    else:
        tl.rotate(quat_to_rotvec(dq), duration)


def _vertical_turn(tl: _Timeline, rng, k: dict) -> dict:
    """A turn by 45–180° about the vertical: the accelerometer stays, the gyroscope reads a large rate."""
    psi = math.radians(rng.uniform(45, 180)) * rng.choice([-1.0, 1.0])
    up = tl.up()
    duration = rng.uniform(*k["move"])
    start = tl.n
    if rng.random() < k["hesitation"]:
        f = rng.uniform(0.4, 0.7)
        tl.rotate(up * psi * f, duration * f)
        tl.pause(rng.uniform(0.1, 0.4))
        tl.rotate(up * psi * (1 - f), duration * (1 - f))
    else:
        tl.rotate(up * psi, duration)
    return {"range": [start, tl.n], "angle_deg": math.degrees(psi)}


def _directions(rng, n: int) -> np.ndarray:
    """``n`` gravity directions spread evenly over the sphere (Fibonacci lattice), randomly rotated."""
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = math.pi * (1 + math.sqrt(5)) * k
    r = np.sqrt(1 - z**2)
    d = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    return d @ quat_to_matrix(quat_normalize(rng.normal(size=4))).T


def _poses(tl: _Timeline, rng, k: dict) -> dict:
    dirs = list(_directions(rng, k["n_poses"]))
    creep = set(rng.choice(k["n_poses"], size=min(k["creep"], k["n_poses"]), replace=False).tolist())
    vertical = []
    for i in range(k["n_poses"]):
        tl.tremor = k["tremor"] * rng.uniform(0.5, 1.5)
        tl.regrip()
        if rng.random() < k["vertical_turns"]:
            vertical.append({**_vertical_turn(tl, rng, k), "static_before": len(tl.static) - 1})
        else:
            u = tl.up()
            ang = np.degrees(np.arccos(np.clip([d @ u for d in dirs], -1, 1)))
            ok = np.nonzero((ang > 40) & (ang < 140))[0]
            j = int(rng.choice(ok)) if ok.size else int(np.argmin(np.abs(ang - 90)))
            target = dirs.pop(j)
            regrasp = rng.random() < k["reposition"]
            after = rng.random() < 0.5
            if regrasp and not after:
                _regrasp(tl, rng, k)
            _move(tl, rng, k, target)
            if regrasp and after:
                _regrasp(tl, rng, k)
        tl.hold(rng.uniform(*k["dwell"]), creep=i in creep)
    return {"vertical_turns": vertical}


def _to_face(tl: _Timeline, rng, k: dict, target: np.ndarray, *, twist: bool = True) -> None:
    """Turn to put ``target`` up; a re-grasp (set down again) when it is up already or with ``reposition``."""
    far = np.degrees(np.arccos(np.clip(tl.up() @ target, -1, 1))) > 5
    if far:
        _move(tl, rng, k, target, twist=twist)
    if not far or rng.random() < k["reposition"]:
        _regrasp(tl, rng, k)


def _ferraris(tl: _Timeline, rng, k: dict) -> dict:
    facts: dict = {"sections": {}, "turn_signs": {}, "face_order": []}
    sections = facts["sections"]
    if k["nudge_deg"]:
        tl.tremor = k["tremor"]
        tl.regrip()
        # a quick nudge about the vertical, set down on the same face
        tl.rotate(tl.up() * math.radians(k["nudge_deg"]) * rng.choice([-1.0, 1.0]), 0.5, shape=(2.0, 2.0))
    faces = [(2, 1.0)] + [((2, 0, 0, 1, 1)[i], (-1.0, 1.0, -1.0, 1.0, -1.0)[i]) for i in rng.permutation(5)]
    creep = set(rng.choice(6, size=min(k["creep"], 6), replace=False).tolist())
    for j, (axis, sign) in enumerate(faces):
        tl.tremor = k["tremor"] * rng.uniform(0.5, 1.5)
        tl.regrip()
        _to_face(tl, rng, k, sign * _E[axis])
        idx = tl.hold(rng.uniform(*k["face_dwell"]), creep=j in creep)
        name = f"{'xyz'[axis]}_{'p' if sign > 0 else 'a'}"
        sections[name] = list(tl.static[idx])
        facts["face_order"].append(name)
    margin = 5  # still samples kept either side of a turn
    for axis in rng.permutation(3).tolist():
        tl.tremor = k["tremor"] * rng.uniform(0.5, 1.5)
        tl.regrip()
        _to_face(tl, rng, k, _E[axis], twist=False)
        tl.hold(rng.uniform(*k["dwell"]))
        if rng.random() < k["reposition"]:
            _regrasp(tl, rng, k, degrees=(10.0, 40.0))
        p0, p1 = tl.pause(rng.uniform(0.3, 1.0))
        start = max(p0, p1 - margin)
        sign = float(rng.choice([-1.0, 1.0]))
        for quarter in range(4):
            tl.rotate(_E[axis] * sign * math.pi / 2, rng.uniform(*k["quarter"]), translate=0.3)
            if quarter < 3:
                tl.pause(rng.uniform(*k["quarter_pause"]))
        p0, p1 = tl.pause(rng.uniform(0.3, 1.0))
        sections[f"{'xyz'[axis]}_rot"] = [start, min(p1, p0 + margin)]
        facts["turn_signs"]["xyz"[axis]] = int(sign)
        if rng.random() < k["reposition"]:
            _regrasp(tl, rng, k, degrees=(10.0, 40.0))
        tl.hold(rng.uniform(*k["dwell"]))
    return facts


def _tremor(rng, n: int, rate: float) -> np.ndarray:
    """Unit-RMS band-limited noise (n, 3): postural sway 0.5–2 Hz and physiological tremor 8–12 Hz, equal power."""
    out = np.zeros((n, 3))
    bands = [(0.5, 2.0), (8.0, min(12.0, 0.45 * rate))]
    bands = [(lo, hi) for lo, hi in bands if hi > lo * 1.2]
    for lo, hi in bands:
        from scipy.signal import butter, sosfiltfilt  # here: scipy.signal takes ~1.5 s to import

        sos = butter(2, [lo, hi], btype="band", fs=rate, output="sos")
        x = sosfiltfilt(sos, rng.normal(size=(n, 3)), axis=0)
        out += x / np.sqrt(np.mean(x**2, axis=0))
    return out / math.sqrt(len(bands))


# ------------------------------------------------------------------ checks
def _range(name: str, v) -> tuple[float, float]:
    lo, hi = (v, v) if isinstance(v, int | float) else v
    if not (0 <= lo <= hi):
        raise ValueError(f"{name} must be a number ≥ 0 or a range (low, high) with 0 ≤ low ≤ high; got {v!r}")
    return float(lo), float(hi)


def _probability(name: str, v: float) -> float:
    if not 0 <= v <= 1:
        raise ValueError(f"{name} is a probability in [0, 1]; got {v!r}")
    return float(v)


def _non_negative(name: str, v: float) -> float:
    if not (np.isfinite(v) and v >= 0):
        raise ValueError(f"{name} must be a finite number ≥ 0; got {v!r}")
    return float(v)


def _plain(x):
    """JSON-ready copy (numpy scalars and arrays to Python)."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    return x


# --------------------------------------------------------------- scenario
def datasheet_thermal(rng, truth: Calibration, quadratic: bool = False) -> dict:
    """Thermal coefficients of an MPU-6050/ICM-20948-class IMU around 25 °C, in raw units (datasheet-like).

    Per axis, 1σ: accelerometer bias 0.5 mg/°C, gyroscope bias 0.03 °/s/°C, scale factors 0.02 %/°C;
    with ``quadratic``, a second-order term of 1 % of the slope per °C.
    """
    out = {}
    for sensor, tri, bias_sd in (("accelerometer", truth.accelerometer, 0.5e-3 * truth.gravity),
                                 ("gyroscope", truth.gyroscope, math.radians(0.03))):
        for i, axis in enumerate("xyz"):
            slope = rng.normal() * bias_sd / abs(tri.scale[i])  # raw per °C
            out[f"{sensor}.bias.{axis}"] = [slope, 0.01 * slope * rng.normal() if quadratic else 0.0]
            out[f"{sensor}.scale.{axis}"] = [rng.normal() * 2e-4 * tri.scale[i], 0.0]
    return out


def _thermometer(rng, temperature: np.ndarray) -> np.ndarray:
    """The temperature sensor's reading: 0.05 °C of noise, 1/340 °C steps (MPU-6050 datasheet §4.18)."""
    return np.round((temperature + rng.normal(size=temperature.shape) * 0.05) * 340.0) / 340.0


#: defaults of the simulated magnetometer (an AK8963-class die beside an MPU-6500-class IMU, as on the MPU-9250)
MAGNETOMETER = {
    "field_uT": 48.0,           # local field magnitude [µT]
    "dip_deg": 60.0,            # inclination below the horizontal (northern hemisphere > 0)
    "resolution_uT": 0.15,      # µT per count
    "noise_uT": 0.4,            # white noise per sample, 1σ [µT]
    "hard_iron_uT": 30.0,       # 1σ per axis of the hard-iron bias [µT]
    "soft_iron": 0.03,          # 1σ of the symmetric soft-iron deviation from the identity
    "misalignment_deg": 1.0,    # 1σ per axis of the die's small rotation [deg]
    # magnetometer axes in terms of the accelerometer's (m_mag = P m_acc): the MPU-9250's x ↔ y, z reversed
    "axes": [[0, 1, 0], [1, 0, 0], [0, 0, -1]],
}


def simulate_magnetometer(rng, body_to_world: np.ndarray, options: dict) -> tuple:
    """Raw magnetometer counts (N, 3) for the attitudes ``body_to_world`` (N, 3, 3), its truth and facts.

    The world field is ``h = F (cos δ · north − sin δ · up)`` with a random north; the die reads
    ``u = b + S⁻¹ Oᵀ (m / F)`` in counts (:class:`~imucalib.models.MagnetometerModel` inverted) with
    ``O = Pᵀ Exp(ε)``, then noise and rounding.
    """
    unknown = set(options) - set(MAGNETOMETER)
    if unknown:
        raise ValueError(f"unknown magnetometer option(s) {sorted(unknown)}; known: {sorted(MAGNETOMETER)}")
    k = {**MAGNETOMETER, **options}
    p = np.asarray(k["axes"], dtype=float)
    if p.shape != (3, 3) or not np.allclose(p @ p.T, np.eye(3)):
        raise ValueError("the magnetometer's axes must be an orthogonal 3×3 matrix (a signed permutation)")
    res = float(k["resolution_uT"])
    field_uT, dip = float(k["field_uT"]), math.radians(float(k["dip_deg"]))
    heading = rng.uniform(-math.pi, math.pi)
    north = np.array([math.cos(heading), math.sin(heading), 0.0])
    h = field_uT * (math.cos(dip) * north - math.sin(dip) * _UP)
    m_body = np.einsum("nji,j->ni", body_to_world, h)  # µT in the accelerometer's frame
    eps = rng.normal(size=3) * math.radians(float(k["misalignment_deg"]))
    o = p.T @ quat_to_matrix(quat_from_rotvec(eps))
    e = rng.normal(size=(3, 3)) * float(k["soft_iron"])
    soft = np.eye(3) + 0.5 * (e + e.T)  # raw µT = soft · (ideal µT); S = soft⁻¹ scaled to the unit sphere
    s = np.linalg.inv(soft) * (res / field_uT)  # counts → unit field: S (u − b) = soft⁻¹ (u − b) res / F
    s = 0.5 * (s + s.T)
    bias = rng.normal(size=3) * float(k["hard_iron_uT"]) / res  # counts
    model = MagnetometerModel(bias=bias, soft_iron=s, alignment=o, field_norm=1.0, unit="normalised")
    raw = model.inverse(m_body / field_uT)
    raw += rng.normal(size=raw.shape) * float(k["noise_uT"]) / res
    raw = np.round(raw)
    facts = {**k, "counts_per_uT": 1.0 / res, "heading_deg": math.degrees(heading)}
    return model, raw, facts


def generate(rng, *, truth: Calibration | None = None, noise=None, procedure: str = "poses",
             rate: float = 100.0, rest: float = 30.0, n_poses: int = 30, dwell=(2.0, 5.0), move=(1.0, 3.0),
             max_rate: float | None = 220.0, hesitation: float = 0.3, reposition: float = 0.4,
             regrasp_deg=(3.0, 30.0), vertical_turns: float = 0.15, tremor: float = 0.15, creep: int = 2,
             lin_acc: float = 1.0, lever: float = 0.05, jitter: float = 0.001, resolution: float = 0.001,
             drop: float = 0.005, gap: float = 0.0, turn_on: float = 0.5, gyro_drift: float = 0.01,
             gyro_rw: float = 1e-4, acc_drift: float = 0.0, quantise: bool = True, full_scale: int | None = 32768,
             face_dwell=(5.0, 7.0), quarter=(0.3, 0.8), quarter_pause=(0.2, 0.4),
             nudge_deg: float = 0.0, magnetometer: bool | dict | None = None, temperature: float | None = None,
             ramp: tuple | None = None, thermal: dict | None = None, vibration: tuple | None = None) -> dict:
    """Simulate a hand-held calibration session of a consumer IMU (see the module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of every random choice; the same seed gives the same session.
    truth : Calibration, optional
        True calibration in raw counts (default: :func:`consumer_truth` drawn from ``rng``).
    noise : dict or float, optional
        Per-sample σ, ``{"accelerometer": m/s², "gyroscope": rad/s}`` (default
        :func:`datasheet_noise` at ``rate``; 0 for noise-free).
    procedure : {"poses", "ferraris"}
        Static poses spread over directions, or the Ferraris six faces and three turns.
    rate : float
        Sample rate [Hz] of the sensor's clock (100).
    rest : float
        Initial rest [s] on a table (30).
    n_poses : int
        Number of hand-held poses after the rest (``"poses"``; 30).
    dwell : float or (low, high)
        Hold of each pose [s], uniform (2–5).
    move : float or (low, high)
        Duration of a hand rotation between poses [s], uniform (1–3).
    max_rate : float or None
        Peak body rate [°/s] a hand rotation may reach: longer rotations are
        slowed down to it (220, below the ±250 °/s range; ``None``: no limit,
        fast hands then saturate the gyroscope).
    hesitation : float
        Probability that a rotation is split in two sub-moves about axes up to
        20° apart with a 0.1–0.4 s hesitation (0.3).
    reposition : float
        Probability of a re-grasp before or after a rotation (0.4).
    regrasp_deg : float or (low, high)
        Tilt of a re-grasp [deg] (3–30).
    vertical_turns : float
        Probability that a pose is reached by a turn of 45–180° about the
        vertical instead (``"poses"``; 0.15).
    tremor : float
        Hand tremor, body-rate RMS [°/s] while held (0.15).
    creep : int
        Number of holds that begin with a settling tilt of 0.8–1.2° over 0.5–1 s (0.8–2.4 °/s) (2).
    lin_acc : float
        Peak translational acceleration of the hand during a rotation [m/s²] (1.0).
    lever : float
        Distance [m] of the sensor from the rotation centre of the hand (0.05).
    jitter : float
        Timestamp jitter [s], uniform in ±jitter (0.001; < half a sample period).
    resolution : float
        Timestamp resolution [s]: recorded times are rounded to it (0.001; 0 keeps them exact).
    drop : float
        Fraction of samples dropped at random (0.005).
    gap : float
        One extra gap [s] of dropped samples at a random time after the rest (0: none).
    turn_on : float
        σ [°/s] of the gyroscope's turn-on bias offset, added to the truth's bias (0.5).
    gyro_drift : float
        σ [°/s per minute] of a linear gyroscope bias drift per axis (0.01; warm-up).
    gyro_rw : float
        Gyroscope bias random walk [°/s/√s] (1e-4, about 20 °/h/√h).
    acc_drift : float
        σ [m/s² per minute] of a linear accelerometer bias drift per axis (0).
    quantise : bool
        Round readings to integer counts (True).
    full_scale : int or None
        Saturation: readings clipped to ``[−full_scale, full_scale − 1]`` counts (32768; ``None``: off).
    face_dwell : float or (low, high)
        Hold of each face [s] (``"ferraris"``; 5–7).
    quarter : float or (low, high)
        Duration of each quarter-turn [s] (``"ferraris"``; 0.3–0.8, stretched to ``max_rate``).
    quarter_pause : float or (low, high)
        Pause between quarter-turns [s] (``"ferraris"``; 0.2–0.4; e.g. 2 makes them separate motions).
    nudge_deg : float
        A 0.5 s turn of this many degrees about the vertical right after the rest (``"ferraris"``; 0: none).
    magnetometer : bool or dict, optional
        Add a magnetometer (True: the defaults of :data:`MAGNETOMETER`; a dict overrides some of them):
        a uniform local field with a dip, hard and soft iron, the die's axes permuted/reflected and
        slightly rotated relative to the accelerometer's, noise and quantisation, in counts. Its truth
        (normalised: ``F = 1``) is the ``magnetometer`` of the returned truth. None/False: no magnetometer,
        and the session is the same as without this option.
    temperature : float, optional
        The sensor's temperature [°C] for the whole session: the truth's parameters are the thermal
        model's at that temperature (:func:`datasheet_thermal` around 25 °C, or ``thermal``), and the
        recording gets a temperature column. The returned truth holds the parameters at ``temperature``.
    ramp : (start, end, tau), optional
        A warm-up instead: the temperature goes from ``start`` to ``end`` [°C] as ``1 − exp(−t/tau)``
        (``tau`` [s]); the returned truth is the model at 25 °C with its thermal model.
    thermal : dict, optional
        Thermal coefficients ``{"gyroscope.bias.x": [c1, c2], …}`` (raw units per °C, per °C²) around
        25 °C (default: drawn by :func:`datasheet_thermal` when ``temperature`` or ``ramp`` is given).
    vibration : (frequency, amplitude), optional
        A vibrating table: the accelerometer's readings alone are shaken along the world vertical by
        ``amplitude · sin(2π · frequency · t)`` [Hz, m/s² peak] for the whole session; the gyroscope
        (its g-sensitivity included) and the attitude are untouched. None: no vibration, and the
        session is the same as without this option (it draws no random number).

    Returns
    -------
    dict
        Fields of :class:`~imucalib.sessions.Session`: ``recording``,
        ``segments``, ``truth``, ``noise``, ``options``.

    Raises
    ------
    ValueError
        For an option out of its range (an unknown ``procedure``, a negative duration, a probability
        outside [0, 1], a jitter of half a sample period or more, ``temperature`` and ``ramp`` together,
        an unknown magnetometer option…), the message naming it.

    Examples
    --------
    :func:`imucalib.scenarios.session` calls it (``session("handheld", ...)``); its fields, for a short
    session of a 10 s rest and 14 poses:

    >>> import numpy as np
    >>> from imucalib.scenarios.handheld import generate
    >>> fields = generate(np.random.default_rng(1), rest=10, n_poses=14)
    >>> sorted(fields), fields["recording"].acc_unit
    (['noise', 'options', 'recording', 'segments', 'truth'], 'counts')
    >>> generate(np.random.default_rng(1), procedure="figure-eight")
    Traceback (most recent call last):
        ...
    ValueError: procedure must be 'poses' or 'ferraris'; got 'figure-eight'
    """
    if procedure not in ("poses", "ferraris"):
        raise ValueError(f"procedure must be 'poses' or 'ferraris'; got {procedure!r}")
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate must be a positive number of Hz; got {rate!r}")
    if int(n_poses) != n_poses or n_poses < 1:
        raise ValueError(f"n_poses must be a positive integer; got {n_poses!r}")
    if int(creep) != creep or creep < 0:
        raise ValueError(f"creep must be an integer ≥ 0 (the number of holds that creep); got {creep!r}")
    if max_rate is not None and not max_rate > 0:
        raise ValueError(f"max_rate must be a positive number of °/s or None; got {max_rate!r}")
    if full_scale is not None and not (int(full_scale) == full_scale and full_scale > 0):
        raise ValueError(f"full_scale must be a positive integer number of counts or None; got {full_scale!r}")
    k = {"procedure": procedure, "rate": float(rate), "rest": _non_negative("rest", rest), "n_poses": int(n_poses),
         "dwell": _range("dwell", dwell), "move": _range("move", move),
         "max_rate": None if max_rate is None else float(max_rate),
         "hesitation": _probability("hesitation", hesitation), "reposition": _probability("reposition", reposition),
         "regrasp_deg": _range("regrasp_deg", regrasp_deg),
         "vertical_turns": _probability("vertical_turns", vertical_turns),
         "tremor": _non_negative("tremor", tremor), "creep": int(creep),
         "lin_acc": _non_negative("lin_acc", lin_acc), "lever": _non_negative("lever", lever),
         "jitter": _non_negative("jitter", jitter), "resolution": _non_negative("resolution", resolution),
         "drop": _non_negative("drop", drop), "gap": _non_negative("gap", gap),
         "turn_on": _non_negative("turn_on", turn_on), "gyro_drift": _non_negative("gyro_drift", gyro_drift),
         "gyro_rw": _non_negative("gyro_rw", gyro_rw), "acc_drift": _non_negative("acc_drift", acc_drift),
         "quantise": bool(quantise), "full_scale": None if full_scale is None else int(full_scale),
         "face_dwell": _range("face_dwell", face_dwell), "quarter": _range("quarter", quarter),
         "quarter_pause": _range("quarter_pause", quarter_pause), "nudge_deg": float(nudge_deg)}
    dt = 1.0 / rate
    if k["jitter"] >= 0.5 * dt:
        raise ValueError(f"jitter must be less than half a sample period ({0.5 * dt:g} s); got {jitter!r}")
    if k["drop"] >= 0.5:
        raise ValueError(f"drop is the fraction of samples lost and must be below 0.5; got {drop!r}")
    if k["dwell"][0] <= 0 or k["face_dwell"][0] <= 0:
        raise ValueError("dwell and face_dwell must be positive: a pose is held for some time")
    if k["rest"] <= 0:
        raise ValueError(f"rest must be a positive number of seconds; got {rest!r}")
    if min(k["move"][0], k["quarter"][0]) <= 0:
        raise ValueError("move and quarter durations must be positive")
    k["quarter_pause"] = (max(k["quarter_pause"][0], dt), max(k["quarter_pause"][1], dt))

    nominal = truth if truth is not None else consumer_truth(rng, STANDARD_GRAVITY)
    raw_units = {nominal.units[name]["raw"] for name in ("accelerometer", "gyroscope")}
    if raw_units != {"counts"} and (k["quantise"] or k["full_scale"] is not None):
        raise ValueError(f"quantise and full_scale work in integer counts, but the truth's raw units are "
                         f"{sorted(raw_units)}: pass quantise=False, full_scale=None, or a truth in counts")
    g = nominal.gravity
    noise = _noise(noise, rate)
    k_gyro, k_acc = nominal.gyroscope.scale, nominal.accelerometer.scale
    temp_profile = None
    if temperature is not None or ramp is not None:
        if temperature is not None and ramp is not None:
            raise ValueError("give the session one temperature or one ramp, not both")
        model = ThermalModel(reference_c=REFERENCE_C, source="simulated",
                             coefficients=thermal if thermal is not None else datasheet_thermal(rng, nominal))
        if temperature is not None:
            if not (np.isfinite(temperature) and -60 <= temperature <= 150):
                raise ValueError(f"temperature must be a sensor temperature in °C (-60 to 150); got {temperature!r}")
            nominal = evaluate(nominal.with_(thermal=model), float(temperature))
            k["temperature"] = float(temperature)
        else:
            t_start, t_end, tau = (float(v) for v in ramp)
            if not tau > 0:
                raise ValueError(f"the ramp's time constant must be positive seconds; got {tau!r}")
            nominal = nominal.with_(thermal=model)
            k["ramp"] = [t_start, t_end, tau]
        k["thermal"] = {name: c.tolist() for name, c in model.coefficients.items()}

    # ---- the session's gyroscope bias: a turn-on offset from the truth's, then drift
    offset = rng.normal(size=3) * math.radians(k["turn_on"]) / k_gyro  # counts
    truth_s = nominal.with_(gyroscope=nominal.gyroscope.with_(bias=nominal.gyroscope.bias + offset))

    # ---- the motion on the sensor's clock
    tilt = math.radians(rng.uniform(0.0, 1.5))  # the table is not quite level
    up0 = np.array([*(_unit(rng.normal(size=2)) * math.sin(tilt)), math.cos(tilt)])
    q0 = quat_multiply(quat_from_rotvec(_UP * rng.uniform(-math.pi, math.pi)), attitude_with_up(up0))
    tl = _Timeline(rng, rate, q0, max_rate=k["max_rate"], lin_acc=k["lin_acc"], lever=k["lever"])
    tl.hold(k["rest"])
    facts = _poses(tl, rng, k) if procedure == "poses" else _ferraris(tl, rng, k)
    w, wd, p_acc, rho, level = tl.arrays()
    n = w.shape[0]
    t = np.arange(n) * dt
    if k["tremor"]:
        box = max(1, int(round(0.3 * rate)))  # the tremor level changes over 0.3 s, not in a step
        env = np.convolve(level, np.ones(box) / box, mode="same")
        w_tr = _tremor(rng, n, rate) * np.radians(env)[:, None]
        w = w + w_tr
        wd = wd + np.gradient(w_tr, dt, axis=0)
    q = integrate(t, w, q0)  # RK4 of the sampled true rates: body → world
    r = quat_to_matrix(q)
    # f = Rᵀ(g ẑ + p̈) + ω̇ × ρ + ω × (ω × ρ)   (rigid body; Zhang 2021, eqs. 17–18 with ρ = −r)
    f = np.einsum("nji,nj->ni", r, g * _UP + p_acc) + np.cross(wd, rho) + np.cross(w, np.cross(w, rho))
    hand = np.linalg.norm(f - np.einsum("nji,j->ni", r, g * _UP), axis=1)
    shake = None
    if vibration is not None:
        freq, amp = (float(v) for v in vibration)
        if not (freq > 0 and amp >= 0 and np.isfinite(freq) and np.isfinite(amp)):
            raise ValueError(f"vibration is (frequency [Hz] > 0, amplitude [m/s²] ≥ 0); got {vibration!r}")
        k["vibration"] = [freq, amp]
        shake = np.einsum("nji,j->ni", r, _UP) * (amp * np.sin(2 * np.pi * freq * t))[:, None]

    # ---- readings: the canonical model inverted (Zhang 2021, eqs. 31–32), noise, drift, counts
    acc, gyro = distort(truth_s.with_(thermal=None), f, w, rng, noise, None, None)
    if shake is not None:  # the accelerometer's readings only: not the gyroscope's g-sensitivity
        model = truth_s.accelerometer
        acc = acc + model.inverse(f + shake) - model.inverse(f)
    if "temperature" in k:
        temp_profile = np.full(n, k["temperature"])
    elif "ramp" in k:
        t_start, t_end, tau = k["ramp"]
        temp_profile = t_end + (t_start - t_end) * np.exp(-t / tau)
        acc, gyro = decompensate(truth_s, (acc, gyro), temp_profile, f)  # the parameters follow it (thermal.py)
    minutes = t / 60.0
    g_slope = rng.normal(size=3) * math.radians(k["gyro_drift"]) / k_gyro  # counts per minute
    g_walk = np.cumsum(rng.normal(size=(n, 3)), axis=0) * (math.radians(k["gyro_rw"]) * math.sqrt(dt) / k_gyro)
    g_walk -= g_walk[0]
    gyro += np.outer(minutes, g_slope) + g_walk
    a_slope = rng.normal(size=3) * k["acc_drift"] / k_acc  # counts per minute
    acc += np.outer(minutes, a_slope)
    if k["quantise"]:
        acc, gyro = np.round(acc), np.round(gyro)
    clipped = {"accelerometer": 0, "gyroscope": 0}
    if k["full_scale"] is not None:
        lo, hi = -k["full_scale"], k["full_scale"] - 1
        for name, arr in (("accelerometer", acc), ("gyroscope", gyro)):
            clipped[name] = int(np.count_nonzero((arr < lo) | (arr > hi)))
            if clipped[name]:
                np.clip(arr, lo, hi, out=arr)
                warnings.warn(f"{clipped[name]} {name} values beyond [{lo}, {hi}] counts were clipped, as the "
                              "saturated sensor reports them", ImucalibWarning, stacklevel=2)

    # ---- the logger: dropped samples, one optional gap, jittered and rounded timestamps
    kept = np.ones(n, dtype=bool)
    n_rest = tl.static[0][1]
    gap_range = None
    if k["gap"]:
        n_gap = int(round(k["gap"] * rate))
        if n - 1 - n_gap > n_rest:
            g0 = int(rng.integers(n_rest, n - 1 - n_gap))
            kept[g0:g0 + n_gap] = False
            gap_range = [float(t[g0]), float(t[g0 + n_gap - 1])]
    if k["drop"]:
        candidates = np.nonzero(kept[1:-1])[0] + 1  # never the first or last sample, nor twice
        lost = rng.choice(candidates, size=min(int(round(k["drop"] * n)), candidates.size), replace=False)
        kept[lost] = False
    stamp = t + rng.uniform(-k["jitter"], k["jitter"], n) if k["jitter"] else t.copy()
    if k["resolution"]:
        stamp = np.round(stamp / k["resolution"]) * k["resolution"]
    stamp = stamp[kept]
    step = k["resolution"] or 1e-9  # a logger never repeats a timestamp: keep them strictly increasing
    idx = np.arange(stamp.size) * step
    stamp = np.maximum.accumulate(stamp - idx) + idx
    cnt = np.concatenate([[0], np.cumsum(kept)])

    def remap(s0: int, s1: int) -> list[int] | None:
        a, b = int(cnt[s0]), int(cnt[s1])
        return [a, b] if b > a else None

    segments, static_map = [], {}
    for j, (s0, s1) in enumerate(tl.static):
        if j:
            m = remap(tl.static[j - 1][1], s0)
            if m:
                segments.append(Interval(*m, "motion"))
        s = remap(s0, s1)
        if s:
            static_map[j] = sum(iv.kind == "static" for iv in segments)
            segments.append(Interval(*s, "static"))
    mag = mag_facts = None
    if magnetometer:  # drawn after everything else: a session with a magnetometer is the same session plus it
        mag_model, mag, mag_facts = simulate_magnetometer(rng, r, {} if magnetometer is True else magnetometer)
        truth_s = truth_s.with_(magnetometer=mag_model,
                                units={**truth_s.units, "magnetometer": {"raw": "counts", "calibrated": "normalised"}})
        mag = mag[kept]
    units = truth_s.units
    rec = Recording(stamp, acc[kept], gyro[kept], acc_unit=units["accelerometer"]["raw"],
                    gyro_unit=units["gyroscope"]["raw"], metadata={"scenario": "handheld", "procedure": procedure},
                    mag=mag, temperature=None if temp_profile is None else _thermometer(rng, temp_profile)[kept])

    # ---- facts, in recorded indices
    options = dict(k)
    options.update({
        "duration_s": float(t[-1]), "samples_simulated": int(n), "samples": int(kept.sum()),
        "dropped": int(n - kept.sum()), "gap_s": gap_range, "static_poses": len(static_map),
        "creep_sections": [{**c, "static": static_map.get(c["static"]), "range": remap(*c["range"])}
                           for c in tl.creeps],
        "pauses": [m for m in (remap(*p) for p in tl.pauses) if m],
        "clipped": clipped,
        "hand_acceleration_max": float(hand.max()),
        "rate_max_deg_s": float(np.degrees(np.linalg.norm(w, axis=1).max())),
        "gyro_bias_nominal": nominal.gyroscope.bias, "gyro_turn_on_offset": offset,
        "gyro_drift_counts_per_min": g_slope,
        "gyro_bias_end": truth_s.gyroscope.bias + g_slope * minutes[-1] + g_walk[-1],
        "acc_drift_counts_per_min": a_slope,
        "acc_bias_end": truth_s.accelerometer.bias + a_slope * minutes[-1],
        "truth": "given" if truth is not None else "consumer_truth",
    })
    if mag_facts is not None:
        options["magnetometer"] = mag_facts
    if procedure == "poses":
        options["vertical_turns"] = [
            {"motion": remap(*v["range"]), "angle_deg": v["angle_deg"],
             "static_before": static_map.get(v["static_before"]),
             "static_after": static_map.get(v["static_before"] + 1)}
            for v in facts["vertical_turns"]]
    else:
        options["sections"] = {name: remap(*rg) for name, rg in facts["sections"].items()}
        options["turn_signs"] = facts["turn_signs"]
        options["face_order"] = facts["face_order"]
    return {"recording": rec, "segments": segments, "truth": truth_s, "noise": noise, "options": _plain(options)}
