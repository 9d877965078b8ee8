"""The hand's motions of the ``handheld`` scenario (:mod:`imucalib.scenarios.handheld`, "The motion" and
"Procedures" there): true body rates built block by block on the sensor's clock, the two procedures and the tremor.

:class:`Timeline` holds the sampled rates, their derivatives, the hand's translation and the layout of the holds;
:func:`poses_procedure` and :func:`ferraris_procedure` fill one as users do the Tedaldi 2014 and the Ferraris 1995
procedures; :func:`tremor_noise` is the hand's tremor, added afterwards.
"""

from __future__ import annotations

import math

import numpy as np

from ..kinematics import (
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    quat_normalize,
    quat_to_matrix,
    quat_to_rotvec,
)

__all__ = ["UP", "Timeline", "ferraris_procedure", "poses_procedure", "tremor_noise", "unit_vector"]

_E = np.eye(3)
#: the world's up (z): gravity's reaction points along it
UP = np.array([0.0, 0.0, 1.0])


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


def unit_vector(v: np.ndarray) -> np.ndarray:
    """``v`` divided by its length."""
    return v / np.linalg.norm(v)


def _perpendicular(rng, v: np.ndarray) -> np.ndarray:
    """A random unit vector perpendicular to ``v`` (any unit vector when ``v`` is zero)."""
    if np.linalg.norm(v) < 1e-12:
        return unit_vector(rng.normal(size=3))
    while True:
        c = np.cross(v, rng.normal(size=3))
        if np.linalg.norm(c) > 1e-3:
            return unit_vector(c)


class Timeline:
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
        return quat_to_matrix(self.q).T @ UP

    def regrip(self) -> None:
        """A new grasp: a new sensor position from the hand's rotation centre, ``lever`` m away."""
        self.grip = self.lever * unit_vector(self.rng.normal(size=3)) if self.lever else np.zeros(3)

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
        acc = _min_jerk_acc(n, peak, unit_vector(self.rng.normal(size=3))) if peak > 0 else np.zeros((n, 3))
        self.q = quat_normalize(quat_multiply(self.q, quat_from_rotvec(rotvec)))
        return self._append(w, wd, acc)

    def hold(self, duration: float, *, creep: bool = False) -> int:
        """A static pose; with ``creep`` it starts by settling ~1° as a hand lets go."""
        start = self.n
        if creep:
            # a tilt about a horizontal world axis, 0.8–1.2° over 0.5–1 s (1–2.4 °/s), fast then slow
            angle = math.radians(self.rng.uniform(0.8, 1.2))
            span = self.rng.uniform(0.5, 1.0)
            h = quat_to_matrix(self.q).T @ np.array([*unit_vector(self.rng.normal(size=2)), 0.0])
            s0, s1 = self.rotate(h * angle, span, translate=0.0, shape=(1.2, 2.5))
            self.creeps.append({"static": len(self.static), "range": [s0, s1],
                                "angle_deg": math.degrees(angle)})
            duration = max(duration - span, self.dt)
        self.still(duration)
        self.static.append((start, self.n))
        return len(self.static) - 1

    def arrays(self) -> tuple[np.ndarray, ...]:
        return tuple(np.concatenate(x) for x in (self.w, self.wd, self.acc, self.rho, self.level))


def _regrasp(tl: Timeline, rng, k: dict, *, degrees: tuple[float, float] | None = None) -> None:
    """A re-grasp: tilt by a few to tens of degrees and back by the same angle ±5 %, with short pauses."""
    lo, hi = degrees or k["regrasp_deg"]
    axis = _perpendicular(rng, tl.up())
    phi = math.radians(rng.uniform(lo, hi))
    tl.rotate(axis * phi, rng.uniform(0.4, 1.0), translate=0.5)
    tl.pause(rng.uniform(0.2, 0.6))
    tl.rotate(-axis * phi * (1 + 0.05 * rng.normal()), rng.uniform(0.4, 1.0), translate=0.5)
    tl.pause(rng.uniform(0.1, 0.4))


def _move(tl: Timeline, rng, k: dict, target: np.ndarray, *, twist: bool = True) -> None:
    """Rotate so that the body vector ``target`` points up, with a random twist about it.

    The body turns by ``θ`` about ``n = −u × v / |u × v|`` (``u`` the body up
    vector now; ``base.turns_between``), then by ``ψ`` about ``v``; both are
    joined into one fixed-axis rotation, or split in two sub-moves about
    different axes with a hesitation between them.
    """
    u, v = tl.up(), unit_vector(target)
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


def _vertical_turn(tl: Timeline, rng, k: dict) -> dict:
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


def poses_procedure(tl: Timeline, rng, k: dict) -> dict:
    """The ``"poses"`` procedure after the rest: ``k["n_poses"]`` holds at directions spread over the sphere, each
    reached by a hand rotation or a turn about the vertical, with re-grasps and creep as ``k`` says; its facts."""
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


def _to_face(tl: Timeline, rng, k: dict, target: np.ndarray, *, twist: bool = True) -> None:
    """Turn to put ``target`` up; a re-grasp (set down again) when it is up already or with ``reposition``."""
    far = np.degrees(np.arccos(np.clip(tl.up() @ target, -1, 1))) > 5
    if far:
        _move(tl, rng, k, target, twist=twist)
    if not far or rng.random() < k["reposition"]:
        _regrasp(tl, rng, k)


def ferraris_procedure(tl: Timeline, rng, k: dict) -> dict:
    """The ``"ferraris"`` procedure after the rest: six faces held, then four quarter-turns about each axis, with
    re-grasps as ``k`` says; its facts (``sections``, ``turn_signs``, ``face_order``, in true sample indices)."""
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


def tremor_noise(rng, n: int, rate: float) -> np.ndarray:
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
