"""Poses and motions: every segmentation stage the methods share.

* :mod:`.windows` — the windowed statistics (moving variance and its norm, moving mean, runs of a mask);
* :mod:`.rest` — :func:`find_initial_rest`, the rest that starts a session (past taps, :func:`rest_after_taps`),
  and :func:`moves_within`, the check of a rest given by its length;
* :mod:`.blocks` — :func:`pose_blocks`, the blocks of a recording made of blocks, and :func:`still_blocks`, the
  still part of each;
* :mod:`.detect` — :func:`detect_static` and :func:`detect_intervals`, the accelerometer variance detector of
  Tedaldi 2014 with its threshold-multiplier scan; :class:`StillDetector`, the same detector sample by sample
  for a live recording (:mod:`imucalib.record`); :func:`detect_static_gyro`, the gyroscope-norm detector
  (Zhang 2021, eq. 22);
* :mod:`.still` — :func:`gyro_still`, where the gyroscope says the sensor is still;
* :mod:`.poses` — :func:`find_faces` (the six faces), :func:`find_turns` (turns about one axis between rests in
  the same pose), and the checks of poses and rotations (:func:`unsteady_poses`,
  :func:`unreliable_transitions`).
"""

from __future__ import annotations

from ..presets import MIN_INTERVALS
from .blocks import BlockPoses, pose_blocks, still_blocks
from .detect import (
    StillDetector,
    detect_intervals,
    detect_static,
    detect_static_gyro,
    gyro_norm_variance,
    motion_between,
    static_at,
    static_poses,
)
from .poses import (
    FACE_NAMES,
    Turn,
    find_faces,
    find_turns,
    no_usable_rotations,
    pose_scatter,
    saturated,
    spikes,
    unreliable_transitions,
    unsteady_poses,
)
from .rest import SHORTEST_REST, TapRest, find_initial_rest, initial_rest, moves_within, rest_after_taps
from .still import gyro_still, still_intervals
from .windows import BLOCK, VarianceNormStream, moving_mean, moving_variance, runs, variance_norm

__all__ = [
    "SHORTEST_REST",
    "moving_variance",
    "runs",
    "variance_norm",
    "VarianceNormStream",
    "StillDetector",
    "find_initial_rest",
    "pose_blocks",
    "gyro_norm_variance",
    "detect_static",
    "detect_static_gyro",
    "detect_intervals",
    "find_faces",
    "find_turns",
    "Turn",
    "saturated",
    "spikes",
    "unreliable_transitions",
    "no_usable_rotations",
    "unsteady_poses",
    "pose_scatter",
    "initial_rest",
    "motion_between",
    "static_poses",
    "static_at",
    "gyro_still",
    "moving_mean",
    "still_intervals",
    "FACE_NAMES",
    "MIN_INTERVALS",
    "BLOCK",
    "BlockPoses",
    "still_blocks",
    "TapRest",
    "moves_within",
    "rest_after_taps",
]
