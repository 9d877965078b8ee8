"""What people add to a simulated session after the fact: a tap during the initial rest, and a recording
made of blocks (one file per pose) whose blocks hold the lift onto the pose.

Both take a :class:`~imucalib.sessions.Session` (e.g. ``session("handheld", rng=...)``) and return a new one
with the same truth; the segments stay the truth (``"static"`` the holds as the sensor lay still).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..recording import Interval, Recording
from ..sessions import Session

__all__ = ["in_blocks", "with_tap"]


def _is_counts(x: np.ndarray) -> bool:
    return bool(np.all(x == np.round(x)))


def with_tap(sim: Session, at: float, *, acc_peak: float = 3.0, rate_peak: float = 20.0, duration: float = 0.15,
             frequency: float = 25.0, rng=None) -> Session:
    """The session with a tap on the sensor ``at`` seconds after the start (inside its initial rest).

    A tap rings the board: a damped oscillation of ``frequency`` Hz over ``duration`` s, ``acc_peak`` m/s²
    along a random direction on the accelerometer and ``rate_peak`` °/s about a random axis on the gyroscope;
    the board comes back to where it lay (no change of attitude). It is added to the raw readings through
    the truth's scale factors (``Δu = Δf / k``, axis by axis), rounded to counts when the readings are
    counts.
    """
    rng = np.random.default_rng(rng)
    rec = sim.recording
    t = rec.t - rec.t[0]
    tau = np.clip((t - at) / duration, 0.0, None)
    inside = (t >= at) & (t <= at + duration)
    wave = np.where(inside, np.sin(2 * np.pi * frequency * (t - at)) * np.exp(-4.0 * tau), 0.0)
    d_acc = rng.normal(size=3)
    d_gyro = rng.normal(size=3)
    acc = rec.acc + np.outer(wave * acc_peak, d_acc / np.linalg.norm(d_acc)) / sim.truth.accelerometer.scale
    gyro = rec.gyro
    if gyro is not None and sim.truth.gyroscope is not None:
        gyro = gyro + (np.outer(wave * math.radians(rate_peak), d_gyro / np.linalg.norm(d_gyro))
                       / sim.truth.gyroscope.scale)
        gyro = np.round(gyro) if _is_counts(rec.gyro) else gyro
    acc = np.round(acc) if _is_counts(rec.acc) else acc
    tapped = dataclasses.replace(rec, acc=acc, gyro=gyro)
    span = np.flatnonzero(inside)
    options = {**sim.options, "tap": {"at_s": float(at), "samples": [int(span[0]), int(span[-1]) + 1]}}
    return dataclasses.replace(sim, recording=tapped, options=options)


def in_blocks(sim: Session, *, lead=(0.5, 1.5), moving: tuple[int, ...] = (), rng=None) -> Session:
    """The session as a recording made of blocks, one per hold, each starting ``lead`` s before its hold.

    Block ``k`` holds the last ``lead`` seconds (uniform in the range) of the motion that brings the sensor
    to hold ``k`` (the lift and set-down a person records when the logger runs before the sensor lies still),
    then the hold; the first block is the initial rest. Each block index in ``moving`` is replaced by a
    block of motion alone (the motion before that hold, without the hold: a block never still). The rows
    between blocks are dropped; ``metadata["blocks"]`` marks the blocks as the readers do
    (:func:`imucalib.io.read`), the segments are the holds in the new sample indices.
    """
    rng = np.random.default_rng(rng)
    lo, hi = (lead, lead) if np.isscalar(lead) else lead
    rec = sim.recording
    holds = [iv for iv in sim.segments if iv.kind == "static"]
    rows, blocks, segments, start = [], [], [], 0
    for k, hold in enumerate(holds):
        before = holds[k - 1].stop if k else hold.start
        if k in moving:
            a, b, still = before, hold.start, None
        else:
            n_lead = min(int(round(rng.uniform(lo, hi) * rec.rate)), hold.start - before)
            a, b, still = hold.start - n_lead, hold.stop, hold
        if b - a < 2:
            continue
        rows.append(np.arange(a, b))
        blocks.append([start, start + b - a])
        if still is not None:
            segments.append(Interval(start + still.start - a, start + still.stop - a, "static"))
        start += b - a
    idx = np.concatenate(rows)
    cut = Recording(rec.t[idx], rec.acc[idx], None if rec.gyro is None else rec.gyro[idx], acc_unit=rec.acc_unit,
                    gyro_unit=rec.gyro_unit, metadata={**rec.metadata, "blocks": blocks},
                    mag=None if rec.mag is None else rec.mag[idx], mag_unit=rec.mag_unit,
                    temperature=None if rec.temperature is None else rec.temperature[idx])
    options = {**sim.options, "blocks": {"lead_s": [float(lo), float(hi)], "moving": list(moving)}}
    return dataclasses.replace(sim, recording=cut, segments=segments, options=options)
