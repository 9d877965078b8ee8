"""The Ferraris procedure on simulation: six faces and a known-angle turn about each axis."""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from .base import pose_session, turns_between

__all__ = ["ferraris_session"]


def ferraris_session(truth: Calibration, rng=None, *, noise=None, angle: float = 360.0):
    """Six faces and a known-angle turn about each axis while it is vertical (Ferraris 1995).

    Poses: +z (rest), +z after a turn about z, −z, +x, +x after a turn about x,
    −x, +y, +y after a turn about y, −y. Returns ``(recording, static intervals,
    layout)`` with ``layout = {"faces": {"+x": k, …}, "turns": {"x": k, …}}``
    (``k`` the index of the static interval ending the motion).
    """
    e = np.eye(3)
    th = np.radians(angle)
    turns = [(e[2], th)]
    turns += turns_between([e[2], -e[2], e[0]])
    turns += [(e[0], th)]
    turns += turns_between([e[0], -e[0], e[1]])
    turns += [(e[1], th)]
    turns += turns_between([e[1], -e[1]])
    rec, intervals = pose_session(truth, turns, rng=rng, noise=noise, hold=2.0, move=3.0)
    layout = {"faces": {"+z": 0, "-z": 2, "+x": 3, "-x": 5, "+y": 6, "-y": 8},
              "turns": {"z": 1, "x": 4, "y": 7}}
    return rec, intervals, layout
