"""The six-position method (Ru 2022, §3.1, eqs. 8–9).

Each accelerometer axis is held along gravity, up and then down; with the raw
readings ``u_up`` and ``u_down`` of that axis::

    b = (u_up + u_down) / 2                          (eq. 8)
    s = (u_up − u_down) / (2 g)   (raw per m/s²)     (eq. 9)

so the canonical scale is ``k1 = 1/s`` and the bias ``b``; the method ignores
misalignment (``T_a = I``) and nonlinearity. The six faces are found
automatically among the static poses: after a sphere fit centres the data, the
pose whose direction is closest to ``+x`` (``−x``, …) is that face, and it must
lie within ``max_tilt`` degrees of the axis — otherwise the recording does not
hold that face and the method says which faces are missing. The gyroscope bias
is the mean of the initial rest; its scale and misalignment come from the
rotations between poses as in Tedaldi 2014 (the review calibrates gyroscopes on
a rate table, which free-hand data does not have).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..metrics import fit_summary, interval_means
from ..models import TriadModel
from .ellipsoid import fit_sphere
from .tedaldi2014 import detect_intervals, fit_gyroscope

__all__ = ["calibrate", "find_faces"]

FACE_NAMES = ("+x", "+y", "+z", "-x", "-y", "-z")


def find_faces(raw_means: np.ndarray, gravity: float, *, max_tilt: float = 15.0) -> np.ndarray:
    """Indices of the poses nearest to +x, +y, +z, −x, −y, −z (raises if one is missing)."""
    if raw_means.shape[0] < 6:
        raise ValueError(f"this method needs the six faces as static poses; got {raw_means.shape[0]} poses")
    centre = fit_sphere(raw_means, gravity).bias if raw_means.shape[0] >= 4 else raw_means.mean(axis=0)
    d = raw_means - centre
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    targets = np.vstack([np.eye(3), -np.eye(3)])
    cos = d @ targets.T  # (M, 6)
    best = np.argmax(cos, axis=0)
    tilt = np.degrees(np.arccos(np.clip(cos[best, np.arange(6)], -1, 1)))
    missing = [f"{FACE_NAMES[j]} ({tilt[j]:.0f}° off)" for j in range(6) if tilt[j] > max_tilt]
    if missing:
        raise ValueError(
            "this method needs the six faces, each axis up and down within "
            f"{max_tilt:g}° of gravity; the poses lack {', '.join(missing)}: record those faces"
        )
    return best


def calibrate(recording, *, gravity: float, intervals=None, max_tilt: float = 15.0,
              init_static: float | None = None) -> Calibration:
    """Six-position accelerometer calibration (eqs. 8–9) with the Tedaldi 2014 gyroscope fit."""
    if intervals is None:
        intervals = detect_intervals(recording, gravity, init_static=init_static)[0]
    intervals = [iv for iv in intervals if iv.kind == "static"]
    means = interval_means(recording.acc, intervals)
    faces = find_faces(means, gravity, max_tilt=max_tilt)
    up = means[faces[:3], np.arange(3)]
    down = means[faces[3:], np.arange(3)]
    b = (up + down) / 2  # eq. (8)
    s = (up - down) / (2 * gravity)  # eq. (9), raw per m/s²
    acc = TriadModel(scale=1.0 / s, bias=b, shape="upper")
    gyro, gyro_errors = fit_gyroscope(recording, intervals, acc, recording.gyro[intervals[0].slice].mean(axis=0),
                                       False)
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="six_position",
                      model="linear",
                      units={"accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"},
                             "gyroscope": {"raw": recording.gyro_unit, "calibrated": "rad/s"}})
    fit = fit_summary(cal, recording, intervals, gravity)
    fit["faces"] = {name: int(i) for name, i in zip(FACE_NAMES, faces, strict=True)}
    fit["uncertainty"] = gyro_errors
    fit["uncertainty_unavailable"] = ("accelerometer: the six faces determine its six parameters exactly "
                                      "(eqs. 8-9), which leaves no residual to estimate the noise from")
    return cal.with_(fit=fit)
