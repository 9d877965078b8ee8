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
hold that face and the method says which faces are missing. A face a few
degrees off its axis is corrected for its tilt (measured by the
directions the calibration gives, to a fixed point;
:func:`imucalib.fit.accelerometer.six_position`), which eq. 9 as
printed is not; ``fit["faces_tilt_deg"]`` says by how much. The gyroscope
comes from the static poses and the rotations between them together
(:func:`imucalib.fit.gyroscope.fit_gyroscope`: the poses' means fix the bias,
the rotations' gravity directions the scales and misalignment; the review
calibrates gyroscopes on a rate table, which free-hand data does not have).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration, units_of
from ..fit.accelerometer import six_position
from ..fit.gyroscope import fit_gyroscope
from ..methodinfo import MethodInfo, Option
from ..metrics import fit_summary, interval_means
from ..segment import FACE_NAMES, find_faces, pose_blocks, static_poses, unreliable_transitions

METHOD = MethodInfo(
    name="six_position",
    summary="accelerometer biases and scales from each axis up and down (no misalignment); gyroscope on the "
            "poses and rotations",
    needs=("static poses", "six faces", "rotations"),
    models=("linear",),
    options=(
        Option("intervals", None, "samples", "static intervals given instead of found"),
        Option("max_tilt", 15.0, "deg", "largest tilt of a face from its axis"),
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
    ),
    paper="ru2022_mems_calibration_review.md (Ru 2022), §3.1, eqs. 8–9",
    accelerometer_only=True,
)

__all__ = ["calibrate"]


def calibrate(recording, *, gravity: float, intervals=None, max_tilt: float = 15.0,
              init_static: float | None = None) -> Calibration:
    """Six-position accelerometer calibration (eqs. 8–9) with the gravity-direction gyroscope fit."""
    intervals = static_poses(recording, gravity, intervals, init_static=init_static)
    means = interval_means(recording.acc, intervals)
    faces = find_faces(means, gravity, max_tilt=max_tilt)
    up, down = means[faces[:3], np.arange(3)], means[faces[3:], np.arange(3)]
    acc = six_position(up, down, gravity)  # eqs. (8)-(9)
    for _ in range(5):  # each face's tilt from its axis by the calibrated direction, then eqs. (8)-(9) for it
        d = acc.forward(means)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        cos_up, cos_down = d[faces[:3], np.arange(3)], -d[faces[3:], np.arange(3)]
        acc = six_position(up, down, gravity, cos_up=cos_up, cos_down=cos_down)
    blocks = pose_blocks(recording) is not None
    gyro_fit = None if recording.gyro is None or blocks else fit_gyroscope(  # none without rotations recorded
        recording, intervals, acc, exclude=unreliable_transitions(recording, intervals))
    gyro, gyro_errors = (gyro_fit.model, gyro_fit.errors) if gyro_fit is not None else (None, {})
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="six_position",
                      model="linear", units=units_of(recording))
    fit = fit_summary(cal, recording, intervals, gravity)
    if gyro_fit is not None:
        fit |= gyro_fit.summary()
    if blocks and recording.gyro is not None:
        fit["gyroscope_not_calibrated"] = ("the poses were recorded as separate blocks, with no motion between them: "
                                           "the rotations that calibrate the gyroscope were not recorded")
    fit["faces"] = {name: int(i) for name, i in zip(FACE_NAMES, faces, strict=True)}
    fit["faces_tilt_deg"] = {name: float(np.degrees(np.arccos(np.clip(c, -1, 1))))
                             for name, c in zip(FACE_NAMES, np.concatenate([cos_up, cos_down]), strict=True)}
    fit["uncertainty"] = gyro_errors
    fit["uncertainty_unavailable"] = ("accelerometer: the six faces determine its six parameters exactly "
                                      "(eqs. 8-9), which leaves no residual to estimate the noise from")
    return cal.with_(fit=fit)
