"""Recordings made of blocks: one file per pose, or rows cut into blocks by prompt lines.

No motion was recorded between the blocks, but a block may hold some: the hand that lifts the sensor onto
its next face, or sets it down and lets it settle, while the logger already runs. Only the still part of a
block is its pose (:func:`still_blocks`); a block that is never still for the shortest hold is left out.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..presets import BLOCK_MULTIPLIER, MIN_HOLD, hold_settings
from ..recording import ImucalibWarning, Interval, Recording
from .windows import odd_window, runs, variance_norm

__all__ = ["BlockPoses", "pose_blocks", "still_blocks"]


def pose_blocks(recording: Recording) -> list[Interval] | None:
    """The blocks of a recording whose poses were recorded apart (``metadata["blocks"]``), one pose each; else None.

    A logger that pauses between poses writes its rows in blocks separated by prompt lines, or one file per
    pose (:func:`imucalib.io.read`): no motion was recorded between the blocks, so each block holds one
    static pose (its still part: :func:`still_blocks`).
    """
    blocks = recording.metadata.get("blocks")
    if not blocks:
        return None
    out = [Interval(int(a), int(b), "static") for a, b in blocks if int(b) - int(a) >= 2]
    if not out or out[-1].stop > len(recording):
        return None
    return out


@dataclass(frozen=True)
class BlockPoses:
    """The poses of a recording made of blocks.

    ``blocks`` are the blocks as recorded; ``poses`` the still part of each block kept, in order (the first is
    the initial rest); ``kept[i]`` the block of ``poses[i]``; ``left_out`` block index → why it holds no pose.
    """

    blocks: list[Interval]
    poses: list[Interval]
    kept: list[int]
    left_out: dict[int, str] = field(default_factory=dict)


def _block_name(recording: Recording, k: int, n: int) -> str:
    """``block k+1`` with its file's name when the blocks are files."""
    source = recording.metadata.get("source")
    if isinstance(source, list | tuple) and len(source) == n:
        return f"block {k + 1} ({str(source[k]).replace(chr(92), '/').rsplit('/', 1)[-1]})"
    return f"block {k + 1}"


def _quantum_level(signal: np.ndarray) -> float:
    """The statistic of readings that only flip by their resolution: ``√3 q²/12``, three axes of the variance of
    rounding to a step ``q`` (the smallest step between successive readings). A sensor quantised so coarsely
    that its readings stand still for whole windows would otherwise give a zero level, and its first flip by
    one step would look like motion."""
    steps = np.abs(np.diff(np.asarray(signal, dtype=np.float64), axis=0))
    steps = steps[steps > 0]
    return float(np.sqrt(3.0) * steps.min() ** 2 / 12.0) if steps.size else np.finfo(float).tiny


def still_blocks(recording: Recording, *, min_hold: float = MIN_HOLD, multiplier: float = BLOCK_MULTIPLIER,
                 warn: bool = True) -> BlockPoses | None:
    """The still part of each block of a recording made of blocks (:func:`pose_blocks`); None without blocks.

    Each sensor's statistic is the Tedaldi 2014 detector's (the norm of the per-axis variance over a centred
    window, :func:`imucalib.segment.variance_norm`), formed block by block so that no window reaches across
    a join, with the window of :func:`imucalib.presets.hold_settings`. No block is known to be at rest, so its
    level is robust instead: the median over the blocks of each block's median statistic (a block held still
    for most of its length has the sensor's noise as its median; one moving throughout cannot move the
    median of the blocks), at least the level of rounding to the readings' resolution
    (:func:`_quantum_level`). A sample is still where every sensor's statistic is below ``multiplier`` × its
    level; the pose of a block is its longest still run, at least the shortest run of ``min_hold`` (a block
    shorter than ``min_hold`` is judged with a window of half its length, and its run may be what that window
    leaves of it). A block without one is left out, and named in an
    :class:`~imucalib.recording.ImucalibWarning` when ``warn``.
    """
    blocks = pose_blocks(recording)
    if blocks is None:
        return None
    window, run = hold_settings(min_hold)
    rate = recording.rate
    win = odd_window(window, rate)
    min_len = max(int(round(run * rate)), 2)
    # a block shorter than the hold is judged with a window of half its length, and its run is what that
    # window leaves of it: the logger's block is all the hold there is
    wins = [min(win, max((len(b) // 2) | 1, 3)) for b in blocks]
    min_lens = [min(min_len, max(len(b) - w + 1, 2)) for b, w in zip(blocks, wins, strict=True)]
    still = [np.ones(len(b), dtype=bool) for b in blocks]
    for signal in (recording.acc, recording.gyro):
        if signal is None:
            continue
        stats = [variance_norm(signal[b.slice], w) for b, w in zip(blocks, wins, strict=True)]
        level = max(float(np.median([np.median(s) for s in stats])), _quantum_level(signal))
        for mask, s in zip(still, stats, strict=True):
            mask &= s < multiplier * level
    poses, kept, left_out = [], [], {}
    for k, (b, mask) in enumerate(zip(blocks, still, strict=True)):
        found = runs(mask, min_lens[k])
        if not found:
            left_out[k] = (f"{_block_name(recording, k, len(blocks))} is never still for {min_hold:g} s (the sensor "
                           f"moves in all of its {len(b) / rate:.3g} s): left out")
            continue
        best = max(found, key=len)
        poses.append(Interval(b.start + best.start, b.start + best.stop, "static"))
        kept.append(k)
    if warn:
        for why in left_out.values():
            warnings.warn(why, ImucalibWarning, stacklevel=3)
    return BlockPoses(blocks=blocks, poses=poses, kept=kept, left_out=left_out)
