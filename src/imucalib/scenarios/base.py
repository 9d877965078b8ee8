"""What every simulated session shares: the distortion by a true calibration, pose plans.

The session records and their directory format are :mod:`imucalib.sessions`.

Raw readings are made by distorting true signals with a true
:class:`~imucalib.calibration.Calibration` (Zhang 2021, eqs. 31–32: the exact
inverse of the canonical model), then Gaussian noise, quantisation and
saturation. Everything is deterministic for a given seed.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..calibration import Calibration
from ..kinematics import integrate, quat_from_rotvec, quat_to_matrix
from ..recording import ImucalibWarning, Interval, Recording
from ..sessions import Session, TossSequence, read_session, write_session

__all__ = ["DEFAULT_NOISE", "Session", "TossSequence", "attitude_with_up", "distort", "noise_levels",
           "pose_session", "read_session", "turns_between", "write_session"]

#: default per-sample noise: σ_a [m/s²], σ_g [rad/s] (ICM-42605-like at 100 Hz)
DEFAULT_NOISE = {"accelerometer": 0.005, "gyroscope": 0.0005}


# ------------------------------------------------------------ distortion
def noise_levels(noise) -> dict:
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


def distort(truth: Calibration, a: np.ndarray, w: np.ndarray, rng, noise: dict,
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
    noise = noise_levels(noise)
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
    acc, gyro = distort(truth, a, w, rng, noise, None, None)
    units = truth.units
    return Recording(t, acc, gyro, acc_unit=units["accelerometer"]["raw"],
                     gyro_unit=units["gyroscope"]["raw"]), intervals


