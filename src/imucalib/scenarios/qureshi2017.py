"""The Qureshi 2017 §IV session: 18 orientations, per-axis turns, validation on fresh orientations.

Its Monte Carlo is :mod:`imucalib.experiments.qureshi2017`.
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..conventions import from_qureshi
from ..models import TriadModel
from ..recording import STANDARD_GRAVITY
from .base import noise_levels, pose_session, turns_between

__all__ = ["QURESHI_NOISE", "qureshi_orientations", "qureshi_session", "qureshi_truth", "qureshi_validation"]


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
    noise = QURESHI_NOISE if noise is None else noise_levels(noise)
    d = rng.normal(size=(n, 3))
    a = truth.gravity * d / np.linalg.norm(d, axis=1, keepdims=True)
    raw = truth.accelerometer.inverse(a)
    sigma = noise["accelerometer"] / truth.accelerometer.scale / np.sqrt(samples)
    return raw + rng.normal(size=raw.shape) * sigma
