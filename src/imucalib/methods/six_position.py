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

from ..calibration import Calibration, units_of
from ..fit.accelerometer import six_position
from ..fit.gyroscope import fit_gravity_direction
from ..metrics import fit_summary, interval_means
from ..segment import FACE_NAMES, find_faces, static_poses

__all__ = ["calibrate"]


def calibrate(recording, *, gravity: float, intervals=None, max_tilt: float = 15.0,
              init_static: float | None = None) -> Calibration:
    """Six-position accelerometer calibration (eqs. 8–9) with the gravity-direction gyroscope fit."""
    intervals = static_poses(recording, gravity, intervals, init_static=init_static)
    means = interval_means(recording.acc, intervals)
    faces = find_faces(means, gravity, max_tilt=max_tilt)
    acc = six_position(means[faces[:3], np.arange(3)], means[faces[3:], np.arange(3)], gravity)  # eqs. (8)-(9)
    gyro, gyro_errors = fit_gravity_direction(recording, intervals, acc,
                                              recording.gyro[intervals[0].slice].mean(axis=0), False)
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="six_position",
                      model="linear", units=units_of(recording))
    fit = fit_summary(cal, recording, intervals, gravity)
    fit["faces"] = {name: int(i) for name, i in zip(FACE_NAMES, faces, strict=True)}
    fit["uncertainty"] = gyro_errors
    fit["uncertainty_unavailable"] = ("accelerometer: the six faces determine its six parameters exactly "
                                      "(eqs. 8-9), which leaves no residual to estimate the noise from")
    return cal.with_(fit=fit)
