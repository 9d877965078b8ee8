"""What a person holding the sensor is told: poses in words, what was already held, what is still missing.

Pure functions of the poses so far (their raw accelerometer means) and the
turns between them (the gyroscope integrated over each motion):

* :func:`up_directions`: the up-direction of each pose, from the last trial
  calibration when there is one, else from a sphere fit as soon as there are
  four poses (:func:`imucalib.fit.accelerometer.fit_sphere`: ``‖u − b‖² = ρ²``,
  its centre ``b`` removed), else from the raw means;
* :func:`held_before`: an earlier pose within :data:`SAME_POSE_DEG` of this one;
* :func:`turn_vector`: the rotation of a motion, the gyroscope's rate
  integrated over it (the small-angle sum ``θ = Σ ω Δt``, exact for a turn
  about one fixed axis, which is what the checklist asks for);
* :func:`checklist`: the faces and corners of the cube held, and the body
  axes turned about, with what is missing in words.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["FACE_DEG", "SAME_POSE_DEG", "TURN_DEG", "Checklist", "angle_deg", "checklist", "held_before",
           "turn_vector", "up_directions"]

#: a face or corner of the cube is held when a pose's up-direction is within this angle of it [deg]
FACE_DEG = 20.0
#: a pose within this angle of an earlier one adds little: it was already held [deg]
SAME_POSE_DEG = 15.0
#: a body axis is turned about when a motion's rotation about it reaches this [deg]
TURN_DEG = 60.0
#: a sphere fit is trusted when its radii scatter less than this fraction of the radius and its centre is
#: nearer the origin than the radius (an offset of more than 1 g is no sensor's)
SPHERE_SCATTER = 0.1

_AXES = "xyz"
FACES = [(f"{a} {s}", v * np.eye(3)[i]) for i, a in enumerate(_AXES) for s, v in (("up", 1.0), ("down", -1.0))]
CORNERS = [np.array([sx, sy, sz]) / np.sqrt(3.0) for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)]


def angle_deg(u, v) -> float:
    """The angle between two directions [deg]."""
    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    c = float(u @ v / (np.linalg.norm(u) * np.linalg.norm(v)))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def up_directions(means: np.ndarray, *, gravity: float, trial=None) -> tuple[np.ndarray, str]:
    """Unit up-directions of the poses' raw accelerometer means (M, 3), and what they come from.

    ``"calibration"`` (the trial calibration's accelerometer), ``"sphere fit"``
    (four poses or more whose sphere fit is sound), or ``"raw"`` (the counts
    as they are: an offset of 0.4 g turns a direction by up to 25°).
    """
    means = np.asarray(means, dtype=float).reshape(-1, 3)
    if trial is not None:
        a = trial.accelerometer_si(means)
        return a / np.linalg.norm(a, axis=1, keepdims=True), "calibration"
    if means.shape[0] >= 4:
        from ..fit.accelerometer import fit_sphere  # imucalib.fit.accelerometer costs 26 ms at start-up

        try:
            model = fit_sphere(means, gravity)
        except (ValueError, np.linalg.LinAlgError):
            model = None
        if model is not None:
            d = means - model.bias
            r = np.linalg.norm(d, axis=1)
            rho = gravity / float(model.scale[0])
            if (np.all(np.isfinite(r)) and np.std(r) < SPHERE_SCATTER * rho
                    and np.linalg.norm(model.bias) < rho and np.all(r > 0)):
                return d / r[:, None], "sphere fit"
    return means / np.linalg.norm(means, axis=1, keepdims=True), "raw"


def held_before(u, directions: np.ndarray) -> int | None:
    """The index of the first of ``directions`` within :data:`SAME_POSE_DEG` of ``u``, or None."""
    for k, d in enumerate(np.asarray(directions).reshape(-1, 3)):
        if angle_deg(u, d) <= SAME_POSE_DEG:
            return k
    return None


def turn_vector(gyro: np.ndarray, dt: np.ndarray, bias: np.ndarray, scale: float) -> np.ndarray:
    """The rotation of a motion [rad, body axes]: ``Σ (ω − b) Δt`` with ``ω`` in rad/s (raw × ``scale``)."""
    g = np.asarray(gyro, dtype=float) - bias
    return (g * np.asarray(dt, dtype=float)[:, None]).sum(axis=0) * scale


@dataclass
class Checklist:
    """What the poses and turns so far hold, and what is still missing (in words)."""

    faces: dict[str, bool]
    corners: int
    turned: dict[str, bool]
    missing: list[str] = field(default_factory=list)

    def as_event(self) -> dict:
        return {"faces": dict(self.faces), "corners": self.corners, "turned": dict(self.turned),
                "missing": list(self.missing)}


def checklist(directions: np.ndarray, turns: list[np.ndarray] | None, *, corners: bool = True) -> Checklist:
    """The six faces held (within :data:`FACE_DEG`), the corners held, the axes turned about (≥ :data:`TURN_DEG`).

    ``turns``: each motion's rotation vector (:func:`turn_vector`), or None when
    the gyroscope's scale is not known yet (the axes are then not listed as
    missing). ``corners``: whether the method uses poses between the faces.
    """
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    faces = {name: bool(d.size) and any(angle_deg(u, f) <= FACE_DEG for u in d) for name, f in FACES}
    held_corners = sum(1 for c in CORNERS if d.size and any(angle_deg(u, c) <= FACE_DEG for u in d))
    turned = {a: False for a in _AXES}
    if turns:
        t = np.abs(np.asarray(turns, dtype=float).reshape(-1, 3))
        for i, a in enumerate(_AXES):
            turned[a] = bool(np.any(t[:, i] >= np.radians(TURN_DEG)))
    missing = [name for name, ok in faces.items() if not ok]
    if corners and held_corners < 4:
        missing.append(f"{4 - held_corners} more corner{'s' if 4 - held_corners > 1 else ''} (two axes or "
                       "three tilted together)")
    if turns is not None:
        missing += [f"a turn about {a}" for a, ok in turned.items() if not ok]
    return Checklist(faces=faces, corners=held_corners, turned=turned, missing=missing)
