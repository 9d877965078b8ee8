"""Ferraris et al. (1995): six static faces and known-angle turns, in closed form.

The method the ``imucal`` package implements, so its users can move over.
With the sensor resting on each face of a cube (axis ``i`` up, then down) and
turned by a known angle ``θ`` (360° by default) about each axis while that
axis is vertical, the linear model ``u = S s + b (+ G a)`` gives, per axis::

    accelerometer   S_a e_i = (ū₊ᵢ − ū₋ᵢ) / (2g),      b_a = mean of the six faces
    gyroscope       b_g + G a: from the same faces,  G e_i = (ū_g₊ᵢ − ū_g₋ᵢ) / (2g)
                    S_g e_i = ± (∫(u_g − b_g) dt − G ā T) / θ   (turn about axis i)

Canonically ``a = T_a k (u − b)`` with ``T_a diag(k) = S_a⁻¹``; the cube's faces
define the frame, so both misalignments are full (``shape="full"``; Ferraris
does not use the accelerometer's own frame). ``G`` is linear g-sensitivity.

Sections are found automatically: static intervals by the gyroscope detector
of Zhang 2021, eq. (22) (a turn about the vertical leaves the accelerometer
still, so its variance cannot separate the poses), the faces as the poses nearest ``±x, ±y, ±z`` (within ``max_tilt``),
and the turns as the motions whose end pose equals the start pose (within 5°)
while the integrated rate has turned through about ``θ`` about one axis. A list
of ``(face_intervals, turn_intervals)`` may be given instead.
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration, units_of
from ..fit.accelerometer import faces_full
from ..fit.gyroscope import fit_known_turns
from ..metrics import fit_summary, interval_means
from ..segment import detect_static_gyro, find_faces, find_turns, initial_rest

__all__ = ["calibrate"]


def calibrate(recording, *, gravity: float, intervals=None, angle: float = 360.0,
              max_tilt: float = 15.0, init_static: float | None = None,
              sections: tuple | None = None) -> Calibration:
    """Ferraris calibration in closed form.

    Parameters
    ----------
    angle : float
        The known turn angle [deg] (360 by default).
    sections : (faces, turns), optional
        ``faces``: six Intervals in the order +x, +y, +z, −x, −y, −z;
        ``turns``: ``{axis: [(start, stop, sign), …]}`` — instead of finding them.
    """
    theta = np.radians(angle)
    if sections is None:
        if intervals is None:
            # turns about the vertical leave the accelerometer still: detect rest with the
            # gyroscope (Zhang 2021, eq. 22)
            intervals = detect_static_gyro(recording, initial_rest(recording, init_static), window=1.0)
        intervals = [iv for iv in intervals if iv.kind == "static"]
        idx = find_faces(interval_means(recording.acc, intervals), gravity, max_tilt=max_tilt)
        faces = [intervals[j] for j in idx]
    else:
        faces, turns = sections
        intervals = list(faces)
    acc = faces_full(interval_means(recording.acc, faces), gravity)
    gyr_f = interval_means(recording.gyro, faces)
    g_sens = (gyr_f[:3] - gyr_f[3:]).T / (2 * gravity)  # G e_i, raw per m/s²
    b_g = gyr_f.mean(axis=0)
    if sections is None:
        turns = find_turns(recording, intervals, b_g, angle=theta)
    missing = [("x", "y", "z")[i] for i in range(3) if not turns.get(i)]
    if missing:
        raise ValueError(f"no turn about the {', '.join(missing)} axis found: turn the sensor by "
                         f"{angle:g}° about each axis while that axis is vertical, resting before "
                         "and after")
    gyro = fit_known_turns(recording, turns, theta, b_g, g_sens, acc.forward(recording.acc))
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="ferraris",
                      model="linear", units=units_of(recording))
    fit = fit_summary(cal, recording, intervals, gravity) if sections is None else {}
    fit["turns"] = {("x", "y", "z")[i]: len(turns[i]) for i in range(3)}
    fit["uncertainty_unavailable"] = ("the closed form determines every parameter exactly from the six faces "
                                      "and the turns, which leaves no residual to estimate the noise from")
    return cal.with_(fit=fit)
