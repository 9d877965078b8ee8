"""Physical constants and unit factors, each with its source: the one place they are written.

Standard gravity and the plausible range of gravity on the Earth's surface are used by the readers,
the methods, the verdict and the command line alike; :data:`GRAVITY_RANGE` is the one range they
all check a declared gravity against.
"""

from __future__ import annotations

import math

__all__ = ["DEG", "DEG_PER_HOUR", "EARTH_GRAVITY", "EARTH_RATE", "G0", "GRAVITY_RANGE", "MICRO_G", "STANDARD_GRAVITY",
           "earth_gravity_text"]

#: m/s², standard gravity g_n, the conventional value of the 3rd CGPM (1901), exact by definition
STANDARD_GRAVITY = 9.80665
G0 = STANDARD_GRAVITY  # m/s² per g
#: (low, high) m/s², gravity anywhere on the Earth's surface, with a margin. WGS 84 normal gravity is
#: 9.7803 m/s² at the equator and 9.8322 m/s² at the poles (NIMA TR8350.2, 3rd ed., eq. 4-1, Somigliana's
#: formula); the free-air gradient (−3.086·10⁻⁶ s⁻² per metre) takes up to 0.027 m/s² off on the highest
#: summits, and anomalies are a few 10⁻³ m/s². Below 9.74 or above 9.87 a declared gravity is a typo or a
#: value in g, not a place.
GRAVITY_RANGE = (9.74, 9.87)
#: (equator, poles) m/s², WGS 84 normal gravity on the ellipsoid (NIMA TR8350.2, 3rd ed., eq. 4-1)
EARTH_GRAVITY = (9.7803, 9.8322)
EARTH_RATE = 7.292115e-5  # rad/s, the Earth's rotation rate (WGS 84)
MICRO_G = 1e-6 * G0
DEG = math.pi / 180
DEG_PER_HOUR = DEG / 3600


def earth_gravity_text() -> str:
    """The Earth's gravity range in words for messages: ``"9.78-9.83"`` (m/s², :data:`EARTH_GRAVITY`)."""
    return f"{EARTH_GRAVITY[0]:.2f}-{EARTH_GRAVITY[1]:.2f}"
