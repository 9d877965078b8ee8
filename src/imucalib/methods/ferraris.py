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

from ..calibration import Calibration
from ..kinematics import angle_between
from ..metrics import fit_summary, interval_means, transition_bounds
from ..models import TriadModel
from ..recording import Interval
from ..segment import detect_static_gyro, find_initial_rest
from .six_position import find_faces

__all__ = ["calibrate", "find_turns"]


def find_turns(recording, intervals, bias: np.ndarray, *, angle: float = 2 * np.pi,
               same_pose: float = 5.0) -> dict[int, list[tuple[int, int, int]]]:
    """Turns about each axis: ``{axis: [(start, stop, sign), …]}`` between consecutive poses."""
    acc = interval_means(recording.acc, intervals)
    dirs = acc - np.mean(acc, axis=0)  # rough centring is enough to compare directions
    starts, stops = transition_bounds(intervals)
    out: dict[int, list[tuple[int, int, int]]] = {0: [], 1: [], 2: []}
    raw = recording.gyro - bias
    c = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (raw[1:] + raw[:-1]) * np.diff(recording.t)[:, None],
                                                   axis=0)])
    for k, (s0, s1) in enumerate(zip(starts, stops, strict=True)):
        if np.degrees(angle_between(dirs[k], dirs[k + 1])) > same_pose:
            continue
        phi = c[s1] - c[s0]
        i = int(np.argmax(np.abs(phi)))
        if abs(phi[i]) < 0.8 * np.linalg.norm(phi):  # not about one axis
            continue
        out[i].append((int(s0), int(s1), int(np.sign(phi[i]))))
    return out


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
            rest = (find_initial_rest(recording) if init_static is None
                    else Interval(0, int(round(init_static * recording.rate)), "static"))
            intervals = detect_static_gyro(recording, rest, window=1.0)
        intervals = [iv for iv in intervals if iv.kind == "static"]
        means = interval_means(recording.acc, intervals)
        idx = find_faces(means, gravity, max_tilt=max_tilt)
        faces = [intervals[j] for j in idx]
    else:
        faces, turns = sections
        intervals = list(faces)
    acc_f = interval_means(recording.acc, faces)
    gyr_f = interval_means(recording.gyro, faces)
    s_a = (acc_f[:3] - acc_f[3:]).T / (2 * gravity)  # columns S_a e_i
    b_a = acc_f.mean(axis=0)
    m_a = np.linalg.inv(s_a)
    k_a = np.diag(m_a).copy()
    t_a = m_a / k_a[None, :]
    np.fill_diagonal(t_a, 1.0)  # m_ii / m_ii, exactly one
    acc = TriadModel(misalignment=t_a, scale=k_a, bias=b_a, shape="full")
    g_sens = (gyr_f[:3] - gyr_f[3:]).T / (2 * gravity)  # raw per m/s²
    b_g = gyr_f.mean(axis=0)
    if sections is None:
        turns = find_turns(recording, intervals, b_g, angle=theta)
    missing = [("x", "y", "z")[i] for i in range(3) if not turns.get(i)]
    if missing:
        raise ValueError(f"no turn about the {', '.join(missing)} axis found: turn the sensor by "
                         f"{angle:g}° about each axis while that axis is vertical, resting before "
                         "and after")
    s_g = np.empty((3, 3))
    a_cal = acc.forward(recording.acc)
    for i in range(3):
        cols = []
        for s0, s1, sign in turns[i]:
            t = recording.t[s0 : s1 + 1]
            u = recording.gyro[s0 : s1 + 1] - b_g - a_cal[s0 : s1 + 1] @ g_sens.T
            cols.append(sign * np.trapezoid(u, t, axis=0) / theta)
        s_g[:, i] = np.mean(cols, axis=0)
    m_g = np.linalg.inv(s_g)
    k_g = np.diag(m_g).copy()
    t_g = m_g / k_g[None, :]
    np.fill_diagonal(t_g, 1.0)
    gyro = TriadModel(misalignment=t_g, scale=k_g, bias=b_g, g_sensitivity=g_sens, shape="full")
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="ferraris",
                      model="linear",
                      units={"accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"},
                             "gyroscope": {"raw": recording.gyro_unit, "calibrated": "rad/s"}})
    fit = fit_summary(cal, recording, intervals, gravity) if sections is None else {}
    fit["turns"] = {("x", "y", "z")[i]: len(turns[i]) for i in range(3)}
    fit["uncertainty_unavailable"] = ("the closed form determines every parameter exactly from the six faces "
                                      "and the turns, which leaves no residual to estimate the noise from")
    return cal.with_(fit=fit)
