"""A small Tedaldi-style session generator for tests (poses + smooth rotations)."""

import numpy as np

from imucalib import kinematics as kin
from imucalib.calibration import Calibration
from imucalib.models import TriadModel
from imucalib.recording import Interval, Recording
from imucalib.scenarios import table1_truth  # noqa: F401  (re-exported for the tests)

G = 9.80665


def _noise(rng, sigma_si, model, shape):
    """Gaussian noise given in SI units, expressed in the model's raw units."""
    return rng.normal(scale=sigma_si, size=shape) / model.scale


def _units(truth):
    return {"acc_unit": truth.units["accelerometer"]["raw"], "gyro_unit": truth.units["gyroscope"]["raw"]}


def linear_truth() -> Calibration:
    acc = TriadModel(
        misalignment=[[1, 0.012, -0.008], [0, 1, 0.021], [0, 0, 1]],
        scale=[9.81 / 2048 * 1.01, 9.81 / 2048 * 0.985, 9.81 / 2048 * 1.02],
        bias=[31.0, -54.0, 12.5],
        shape="upper",
    )
    gyro = TriadModel(
        misalignment=[[1, 0.006, -0.011], [0.009, 1, 0.014], [-0.005, 0.02, 1]],
        scale=[np.radians(1 / 16.4) * 1.02, np.radians(1 / 16.4) * 0.97, np.radians(1 / 16.4) * 1.005],
        bias=[8.0, -3.5, 5.25],
        shape="full",
    )
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=G)


def tedaldi_session(truth=None, *, seed=0, poses=24, rest=8.0, hold=2.0, move=1.5,
                    rate=100.0, noise_acc=0.0, noise_gyro=0.0, directions=None):
    """Initial rest, then ``poses`` static holds joined by smooth rotations.

    The gravity direction at every pose is the RK4 integration of the sampled
    true rates, so the gyroscope residual is exactly zero at the truth.

    ``directions`` (body-frame unit gravity directions, the first one for the
    rest) replaces the random turns by the shortest turns between them.

    Returns (recording in raw counts, truth, static intervals).
    """
    truth = truth or linear_truth()
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    n_rest, n_hold, n_move = int(rest * rate), int(hold * rate), int(move * rate)
    blocks, intervals, pos = [], [Interval(0, n_rest)], n_rest
    blocks.append(np.zeros((n_rest, 3)))
    tau = (np.arange(n_move) + 0.5) / n_move
    bump = np.sin(np.pi * tau) ** 2  # smooth start and stop
    turns = []
    if directions is None:
        for _ in range(poses):
            axis = rng.normal(size=3)
            turns.append((axis / np.linalg.norm(axis), rng.uniform(np.radians(60), np.radians(150))))
    else:
        d = np.asarray(directions, dtype=float)
        for a0, a1 in zip(d[:-1], d[1:], strict=True):
            axis = np.cross(a0, a1)
            if np.linalg.norm(axis) < 1e-9:  # opposite faces: any perpendicular axis
                axis = np.cross(a0, [1.0, 0, 0] if abs(a0[0]) < 0.9 else [0, 1.0, 0])
            angle = np.arctan2(np.linalg.norm(np.cross(a0, a1)), a0 @ a1)
            turns.append((-axis / np.linalg.norm(axis), angle))  # body rate turning g_b a0 → a1
    for axis, angle in turns:
        w = np.outer(bump / bump.sum() * angle / dt, axis)
        blocks += [w, np.zeros((n_hold, 3))]
        intervals.append(Interval(pos + n_move, pos + n_move + n_hold))
        pos += n_move + n_hold
    w_true = np.concatenate(blocks)
    t = np.arange(w_true.shape[0]) * dt
    if directions is None:
        q0 = kin.quat_from_rotvec(rng.normal(size=3))
    else:  # start with the body's directions[0] pointing up
        d0 = np.asarray(directions[0], dtype=float)
        axis = np.cross(d0, [0, 0, 1.0])
        ang = np.arctan2(np.linalg.norm(axis), d0[2])
        q0 = kin.quat_from_rotvec(axis / max(np.linalg.norm(axis), 1e-300) * ang if ang > 1e-12
                                  else np.zeros(3))
    q = kin.integrate(t, w_true, q0)
    g_world = np.array([0.0, 0.0, truth.gravity])
    acc_true = np.einsum("nji,j->ni", kin.quat_to_matrix(q), g_world)  # Rᵀ g
    acc_raw = truth.accelerometer.inverse(acc_true) + _noise(rng, noise_acc, truth.accelerometer, acc_true.shape)
    gyro_raw = truth.gyroscope.inverse(w_true, acc_true) + _noise(rng, noise_gyro, truth.gyroscope, w_true.shape)
    rec = Recording(t=t, acc=acc_raw, gyro=gyro_raw, **_units(truth))
    return rec, truth, intervals


def weightless_segments(truth, *, n=100, seed=0, rate=100.0, noise_acc=0.0, noise_gyro=0.0):
    """Spinning free-fall segments, 1 s each (Zhang 2021, eqs. 17, 18, 33), via the simulator's parts."""
    from imucalib.scenarios.zhang2021 import _spin, _weightless_force

    rng = np.random.default_rng(seed)
    t = np.arange(int(rate)) / rate
    out = []
    for i in range(n):
        w, wd = _spin(rng, t)
        a = _weightless_force(w, wd, truth.lever_arm)
        acc_raw = truth.accelerometer.inverse(a) + _noise(rng, noise_acc, truth.accelerometer, a.shape)
        gyro_raw = truth.gyroscope.inverse(w, a) + _noise(rng, noise_gyro, truth.gyroscope, w.shape)
        out.append(Recording(t=t + 1000.0 * i, acc=acc_raw, gyro=gyro_raw, **_units(truth)))
    return out
