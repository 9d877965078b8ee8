"""The accelerometer's sign convention: specific force, +g on the axis that points up.

imucalib's calibrations, its simulated sessions and every export take the
accelerometer to measure specific force ``f = a − g``: at rest it reads the
gravity's magnitude on the axis that points *up* (``+g`` up, as MEMS
accelerometers' datasheets specify: +1 g on z lying flat, face up). Some
drivers and phone frameworks report the other sign (``−g`` up, the gravity
vector itself).

No fit can tell the two apart: negating an accelerometer's three axes maps
every motion onto a valid one (gravity reversed, the path mirrored, the
rotations unchanged: ``(−a) × (−b) = a × b``, so the gyroscope's turns move
the negated readings exactly as they move the true ones), and the gravity
norm is the same. A mirrored accelerometer (one or two axes negated against
the gyroscope) is a different matter: the turns expose it, and the gyroscope
fit's axes check (:func:`imucalib.fit.gyroscope.axes_disagreement`) names it.

What is left is the rest: a session starts lying still on a table, usually
face up (z up). :func:`inverted_rest_note` says when the calibrated initial
rest reads ``−g`` along z instead: the sensor lay face down, or it reports
the other convention, in which case every calibrated reading is negated.
"""

from __future__ import annotations

import numpy as np

from .calibration import Calibration

__all__ = ["inverted_rest_note", "rest_force"]

#: the rest counts as lying flat when its calibrated force is within this angle of the z axis [deg]
FLAT_DEG = 25.0


def rest_force(calibration: Calibration, recording, interval) -> np.ndarray:
    """The calibrated specific force [m/s²] averaged over ``interval`` (``start``, ``stop``) of ``recording``."""
    start, stop = (interval.start, interval.stop) if hasattr(interval, "start") else interval[:2]
    raw = recording.acc[int(start):int(stop)]
    return np.mean(calibration.accelerometer_si(raw), axis=0)


def inverted_rest_note(calibration: Calibration, recording, interval) -> str | None:
    """A note when the calibrated initial rest ``interval`` lies flat with ``−g`` along z, else None."""
    try:
        f = rest_force(calibration, recording, interval)
    except (ValueError, IndexError):
        return None
    norm = float(np.linalg.norm(f))
    if not np.isfinite(norm) or norm == 0 or abs(f[2]) < norm * np.cos(np.radians(FLAT_DEG)) or f[2] > 0:
        return None
    return (f"the initial rest reads {f[2]:+.3g} m/s^2 on z: the sensor lay face down, or its accelerometer "
            "reports -g up (the gravity vector) instead of specific force (+g up, the convention of imucalib's "
            "calibrations, exports and sensors' datasheets); if it lay face up, every calibrated reading is "
            "negated: negate the accelerometer's readings (or the driver's sign) and calibrate again")
