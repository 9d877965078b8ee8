"""A small Tedaldi-style session generator for tests (poses + smooth rotations)."""

import numpy as np

from imucalib import kinematics as kin
from imucalib.calibration import Calibration
from imucalib.models import TriadModel
from imucalib.recording import Interval, Recording

G = 9.80665


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
                    rate=100.0, noise_acc=0.0, noise_gyro=0.0):
    """Initial rest, then ``poses`` static holds joined by smooth rotations.

    The gravity direction at every pose is the RK4 integration of the sampled
    true rates, so the gyroscope residual is exactly zero at the truth.

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
    for _ in range(poses):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = rng.uniform(np.radians(60), np.radians(150))
        w = np.outer(bump / bump.sum() * angle / dt, axis)
        blocks += [w, np.zeros((n_hold, 3))]
        intervals.append(Interval(pos + n_move, pos + n_move + n_hold))
        pos += n_move + n_hold
    w_true = np.concatenate(blocks)
    t = np.arange(w_true.shape[0]) * dt
    q = kin.integrate(t, w_true, kin.quat_from_rotvec(rng.normal(size=3)))
    g_world = np.array([0.0, 0.0, truth.gravity])
    acc_true = np.einsum("nji,j->ni", kin.quat_to_matrix(q), g_world)  # Rᵀ g
    acc_raw = truth.accelerometer.inverse(acc_true) + rng.normal(scale=noise_acc, size=acc_true.shape) / truth.accelerometer.scale
    gyro_raw = truth.gyroscope.inverse(w_true, acc_true) + rng.normal(scale=noise_gyro, size=w_true.shape) / truth.gyroscope.scale
    rec = Recording(t=t, acc=acc_raw, gyro=gyro_raw)
    return rec, truth, intervals


def table1_truth() -> Calibration:
    """Zhang 2021 Table I set values in the canonical convention (raw acc in g)."""
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
    return Calibration(accelerometer=acc, gyroscope=gyro, lever_arm=[0.07, 0.07, 0.07], gravity=G)


def weightless_segments(truth, *, n=100, seed=0, rate=100.0, noise_acc=0.0, noise_gyro=0.0):
    """Spinning free-fall segments, 1 s each (Zhang 2021, eqs. 17, 18, 33)."""
    rng = np.random.default_rng(seed)
    r = truth.lever_arm
    t = np.arange(int(rate)) / rate
    out = []
    for _ in range(n):
        rq = kin.quat_to_matrix(kin.quat_normalize(rng.normal(size=4)))
        w_set = abs(2 * np.pi * (0.25 * rng.normal() + 0.75) * 7)
        psi = 0.8 * t + 2 * np.pi * rng.normal()
        s = w_set / np.hypot(w_set, 80.0)
        w = np.column_stack([np.sin(psi) * w_set, np.cos(psi) * w_set, np.full_like(t, 80.0)]) @ rq.T * s
        wd = np.column_stack([np.cos(psi) * 0.8 * w_set, -np.sin(psi) * 0.8 * w_set, 0 * t]) @ rq.T * s
        a = np.cross(w, np.cross(r, w)) + np.cross(r, wd)  # = f_C + f_E
        acc_raw = truth.accelerometer.inverse(a) + rng.normal(scale=noise_acc, size=a.shape) / truth.accelerometer.scale
        gyro_raw = truth.gyroscope.inverse(w, a) + rng.normal(scale=noise_gyro, size=w.shape) / truth.gyroscope.scale
        out.append(Recording(t=t + 1000.0 * len(out), acc=acc_raw, gyro=gyro_raw))
    return out
