"""Physical constants and unit factors shared by methods and scenarios."""

from __future__ import annotations

import numpy as np

from .recording import STANDARD_GRAVITY

G0 = STANDARD_GRAVITY  # m/s² per g
EARTH_RATE = 7.292115e-5  # rad/s, the Earth's rotation rate (WGS 84)
MICRO_G = 1e-6 * G0
DEG = np.pi / 180
DEG_PER_HOUR = DEG / 3600
