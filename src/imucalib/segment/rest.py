"""The initial rest that starts a calibration recording, and the blocks of a recording made of blocks.

The rest's noise level sets every detector threshold (Tedaldi 2014, as summarised in the static/dynamic
interval detection fragment, §2: an initial rest of ``T_init`` seconds).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..presets import (
    MIN_HOLD,
    REST_FACTOR,
    REST_MIN_SECONDS,
    REST_SHORTEST_SECONDS,
    REST_TAP_DEG,
    REST_TAP_HORIZON,
    REST_TAP_SECONDS,
    REST_WINDOW,
)
from ..recording import ImucalibWarning, Interval, Recording
from .blocks import still_blocks
from .windows import column_means, odd_window, runs, variance_norm, variance_norm_rows

__all__ = ["PREFERRED_REST", "SHORTEST_REST", "TapRest", "find_initial_rest", "first_motion", "initial_rest",
           "moves_within", "rest_after_taps"]


#: the initial rest the detector would like [s]: its noise level is the median statistic over this much rest
PREFERRED_REST = REST_MIN_SECONDS
#: the shortest initial rest found automatically [s]; a rest between this and :data:`PREFERRED_REST` gets a note
SHORTEST_REST = REST_SHORTEST_SECONDS


def find_initial_rest(
    recording: Recording,
    *,
    window_seconds: float = REST_WINDOW,
    factor: float = REST_FACTOR,
    min_seconds: float = PREFERRED_REST,
    shortest: float = SHORTEST_REST,
    statistic: np.ndarray | None = None,
    taps: bool = True,
) -> Interval:
    """Locate the initial rest period that starts a calibration recording.

    For the accelerometer and the gyroscope alike, the noise level is the
    median detector statistic (:func:`variance_norm`) over the first
    ``min_seconds``; the rest ends where either statistic first exceeds
    ``factor`` times its level (the first movement: the gyroscope catches a
    turn about the vertical, which leaves the accelerometer still), less half
    a window. A recording with no gyroscope is judged by its accelerometer.

    A short rest fools that level (its first ``min_seconds`` hold motion), so
    the start is first looked at with a window of ``shortest / 2`` seconds and
    the level over its first ``shortest / 4`` seconds: when that finds the
    first movement (plus half its window) before ``min_seconds``, the rest is
    that long; at least ``shortest`` seconds of it are taken (less half the
    short window) with an :class:`ImucalibWarning` saying that its noise level
    rests on fewer samples than the detector would like, and anything shorter
    is an error. The short look also gives the rest where the first look
    leaves less than ``min_seconds`` after its margin of a full window.

    With ``taps``, a rest that this finds shorter than ``min_seconds`` (or
    none) may have been cut by a tap: a movement of at most
    :data:`~imucalib.presets.REST_TAP_SECONDS` after which the sensor lies as
    before (:func:`rest_after_taps`). The longest still stretch between such
    taps is then the rest, when it is longer, with an :class:`ImucalibWarning`
    that says where the sensor moved; the rest then starts after sample 0.

    Parameters
    ----------
    recording : Recording
    window_seconds, factor, min_seconds, shortest : float
        As above.
    taps : bool
        Look past taps, as above.
    statistic : (N,) ndarray, optional
        The accelerometer's statistic over the whole recording with the window
        of ``window_seconds`` (``variance_norm(recording.acc, win)``), when the
        caller has formed it: read rather than formed again (the same numbers).

    Returns
    -------
    Interval
        The initial rest, from sample 0 unless a tap cut it.

    Raises
    ------
    ValueError
        If the recording does not start with at least ``shortest`` seconds of rest.

    Examples
    --------
    A simulated session that starts with 10 s on a table; the rest found ends at 9 s, where the
    detector's statistic first sees the hand:

    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import find_initial_rest
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> rest = find_initial_rest(sim.recording)
    >>> rest, round(float(sim.recording.t[rest.stop]), 1)
    (Interval(start=0, stop=897, kind='static'), 9.0)

    A recording cut 0.5 s before the first turn has too short a rest:

    >>> find_initial_rest(sim.recording[950:])
    Traceback (most recent call last):
        ...
    ValueError: no initial rest found: the sensor moves 0.46 s after the start; ...
    """
    rate = recording.rate
    n0 = int(round(min_seconds * rate))
    if n0 >= len(recording):
        raise ValueError(
            f"the recording is {recording.duration:.3g} s long: too short for an initial rest of {min_seconds} s (a "
            "session is a rest, then poses held a few seconds each; `imucalib simulate -o session` writes one)")
    try:
        rest, note = _rest_at_start(recording, window_seconds, factor, min_seconds, shortest, statistic)
    except ValueError as error:
        rest, note, failed = None, None, error
    if taps and (rest is None or len(rest) < n0):
        found = rest_after_taps(recording, factor=factor, shortest=shortest)
        if found is not None and len(found.rest) > (0 if rest is None else len(rest)):
            warnings.warn(found.describe(rate), ImucalibWarning, stacklevel=2)
            return found.rest
    if rest is None:
        raise failed
    _check_still(recording, rest, window_seconds)
    if note:
        warnings.warn(note, ImucalibWarning, stacklevel=2)
    return rest


#: a rest's windowed variance (:func:`variance_norm`) over its 5th percentile, at the median, beyond which the
#: "rest" holds motion: a still sensor's statistic stays within a few times its lowest (its noise; ≤ 2 in the
#: simulated and the public sessions, 7 on the shortest public rest), a recording that starts moving and
#: then holds a pose mixes the two (8–190 in the hand-held simulations started mid-turn)
REST_MIXED = 10.0


def _check_still(recording: Recording, rest: Interval, window_seconds: float) -> None:
    """Refuse a rest found from sample 0 whose variance ranges over more than :data:`REST_MIXED` (the level
    the rest's end was judged by was set by motion: the recording started moving)."""
    win = odd_window(window_seconds, recording.rate)
    if len(rest) <= 2 * win:
        return
    for name, signal in (("accelerometer", recording.acc), ("gyroscope", recording.gyro)):
        if signal is None:
            continue
        stat = variance_norm(signal[rest.start:rest.stop], win)[win // 2: len(rest) - win // 2]
        spread = float(np.median(stat) / max(float(np.percentile(stat, 5)), np.finfo(float).tiny))
        if spread > REST_MIXED:
            raise ValueError(
                f"no initial rest found: the first {len(rest) / recording.rate:.3g} s are not still (the "
                f"{name}'s variance ranges over {spread:.0f}× within them: the recording starts while the sensor "
                "moves); start recording with the sensor lying still for a few seconds, or give the rest's "
                "length with --init-static SECONDS")


@dataclass(frozen=True)
class TapRest:
    """An initial rest cut by taps (:func:`rest_after_taps`): the longest still stretch, and the taps [samples]
    (where the statistic saw them, less half its window either side)."""

    rest: Interval
    taps: list[Interval]

    def describe(self, rate: float) -> str:
        """The note that says where the sensor moved and which stretch is the rest."""
        where = ", ".join(f"{iv.start / rate:.3g}-{iv.stop / rate:.3g} s" for iv in self.taps)
        return (f"the initial rest is cut by {len(self.taps)} short movement{'s' if len(self.taps) > 1 else ''} "
                f"after which the sensor lay as before (a tap or a knock: {where}); its noise level is taken from "
                f"the still stretch {self.rest.start / rate:.3g}-{self.rest.stop / rate:.3g} s")


def _moving(recording: Recording, win: int, factor: float, level_quantile: float | None) -> np.ndarray:
    """Samples (N,) where the accelerometer's or the gyroscope's statistic (:func:`variance_norm`, window ``win``)
    exceeds ``factor`` × its level: its median over the recording, or its ``level_quantile`` quantile."""
    moving = np.zeros(len(recording), dtype=bool)
    for signal in (recording.acc, recording.gyro):
        if signal is None:
            continue
        stat = variance_norm(signal, win)
        level = float(np.median(stat) if level_quantile is None else np.quantile(stat, level_quantile))
        moving |= stat > factor * max(level, np.finfo(float).tiny)
    return moving


def rest_after_taps(recording: Recording, *, factor: float = REST_FACTOR, shortest: float = SHORTEST_REST,
                    tap: float = REST_TAP_SECONDS, tilt: float = REST_TAP_DEG,
                    horizon: float = REST_TAP_HORIZON) -> TapRest | None:
    """The initial rest of a recording whose start is cut by taps, or None when no tap cuts it.

    Over the first ``horizon`` seconds, a sample moves where the accelerometer's or gyroscope's statistic
    (:func:`variance_norm` over half of ``shortest``, the short look of :func:`find_initial_rest`) exceeds
    ``factor`` × its level, here its 10th percentile (no stretch is known to be still: the noise of the
    still tenth). From the start, still stretches follow each other across movements of at most ``tap``
    seconds (their statistic spans the movement and a window) whose mean accelerometer direction after is
    within ``tilt`` degrees of the one before; the first longer movement, or one that leaves the sensor in
    another pose, ends the search. The longest of those stretches is the rest, when it lasts ``shortest``
    seconds or more.
    """
    rate = recording.rate
    win = max(int(round(0.5 * shortest * rate)) | 1, 3)
    head = recording[: min(len(recording), int(round(horizon * rate)))]
    still = runs(~_moving(head, win, factor, 0.1))
    longest_tap = int(round(tap * rate)) + win
    if not still or still[0].start > longest_tap:
        return None
    pieces = [still[0]]
    for run in still[1:]:
        if run.start - pieces[-1].stop > longest_tap:
            break
        a, b = head.acc[pieces[-1].slice].mean(axis=0), head.acc[run.slice].mean(axis=0)
        cos = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
        if np.degrees(np.arccos(min(max(cos, -1.0), 1.0))) > tilt:
            break
        pieces.append(run)
    half = win // 2  # a still stretch ends half a window before the movement, and starts half a window after it
    taps = ([Interval(0, max(pieces[0].start - half, 1), "motion")] if pieces[0].start else []) + [
        Interval(x.stop + half, max(y.start - half, x.stop + half + 1), "motion")
        for x, y in zip(pieces[:-1], pieces[1:], strict=True)]
    best = max(pieces, key=len)
    if not taps or len(best) < shortest * rate:
        return None
    return TapRest(rest=Interval(best.start, best.stop, "static"), taps=taps)


def _rest_at_start(recording: Recording, window_seconds: float, factor: float, min_seconds: float, shortest: float,
                   statistic: np.ndarray | None) -> tuple[Interval, str | None]:
    """:func:`find_initial_rest` without taps: the rest from sample 0, and the note a short one gets."""
    rate = recording.rate
    win = odd_window(window_seconds, rate)
    n0 = int(round(min_seconds * rate))
    short_win = max(int(round(0.5 * shortest * rate)) | 1, 3)
    head = recording[: min(n0 + win + short_win, len(recording))]  # the short look reads the start only
    short_end = first_motion(head, short_win, short_win // 2 + 1, factor)
    short_end = len(recording) if short_end == len(head) else short_end
    moves = (short_end + short_win // 2) / rate  # where the short look sees the first movement [s]
    if moves < min_seconds and shortest < min_seconds:
        if moves < shortest:
            raise ValueError(_no_rest(moves, shortest))
        return Interval(0, short_end, "static"), (
            f"the initial rest is about {moves:.2g} s, shorter than the {min_seconds:g} s the detector would like: "
            f"the noise level that sets its threshold rests on the first {short_end / rate:.2g} s (record a longer "
            "rest at the start, or give its length with --init-static SECONDS)")
    moved = first_motion(recording, win, max(n0, win), factor, acc_statistic=statistic)
    end = max(moved - win // 2, 0) if moved < len(recording) else len(recording)
    if end >= n0:
        return Interval(0, end, "static"), None
    if shortest < min_seconds and short_end < len(recording):
        return Interval(0, short_end, "static"), None
    raise ValueError(_no_rest(end / rate, min_seconds))


def first_motion(recording: Recording, win: int, n_level: int, factor: float,
                  acc_statistic: np.ndarray | None = None) -> int:
    """The first sample whose statistic (window ``win``) exceeds ``factor`` × its median over ``n_level`` samples.

    ``acc_statistic``: the accelerometer's statistic over the whole recording
    (:func:`variance_norm` with ``win``), read instead of formed when given.
    """
    first = len(recording)
    for signal in (recording.acc, recording.gyro):
        if signal is None:
            continue
        if signal is recording.acc and acc_statistic is not None:
            threshold = factor * max(float(np.median(acc_statistic[:n_level])), np.finfo(float).tiny)
            moving = acc_statistic > threshold
            first = int(np.argmax(moving)) if moving.any() else first
            continue
        # the statistic of :func:`variance_norm`, formed span by span (the same numbers) only as far as the
        # search reads it: the level's samples, then spans of doubling length up to the first movement (the
        # other sensor's, when that is near: nothing after it can change the answer)
        x = np.asarray(signal, dtype=np.float64)
        x = x[:, None] if x.ndim == 1 else x
        half, centre = max(int(win) // 2, 1), column_means(x)
        stat = np.empty(x.shape[0])
        a, b = 0, min(max(n_level, 1), x.shape[0])
        if min(x.shape[0], first) - b <= 2 * max(b, 4096):  # the end, or the other sensor's movement, is near
            b = max(b, min(x.shape[0], first))
        variance_norm_rows(x, centre, half, a, b, stat[a:b])
        threshold = factor * max(float(np.median(stat[:n_level])), np.finfo(float).tiny)
        while True:
            moving = np.nonzero(stat[a:b] > threshold)[0]
            if moving.size:
                first = min(first, a + int(moving[0]))
                break
            if b >= min(x.shape[0], first):  # the end, or past the first movement the other sensor showed
                break
            step = max(b, 4096)  # each span costs its whole prefix within its block: reach a known end at once
            a, b = b, min(x.shape[0], first if first - b <= 2 * step else b + step)
            variance_norm_rows(x, centre, half, a, b, stat[a:b])
    return first


def _no_rest(moves: float, seconds: float) -> str:
    return (f"no initial rest found: the sensor moves {moves:.3g} s after the start; a recording must begin with "
            f"at least {seconds:g} s at rest (or pass --init-static SECONDS)")


def initial_rest(recording: Recording, init_static: float | None = None, *, min_hold: float = MIN_HOLD
                 ) -> Interval:
    """The initial rest: ``init_static`` seconds when given, else the still part of the first block of a
    recording in blocks that has one (:func:`imucalib.segment.blocks.still_blocks`), else found by
    :func:`find_initial_rest`."""
    blocks = still_blocks(recording, min_hold=min_hold, warn=False) if init_static is None else None
    if blocks and blocks.poses:
        return blocks.poses[0]
    if init_static is None:
        return find_initial_rest(recording)
    n = int(round(init_static * recording.rate))
    if not 1 < n < len(recording):
        raise ValueError(f"--init-static {init_static} s does not fit the {recording.duration:.3g} s recording")
    moved = moves_within(recording, n)
    if moved is not None:
        rate = recording.rate
        still = moved.start / rate
        raise ValueError(
            f"--init-static {init_static:g} s: the sensor is not still over those seconds, it moves at "
            f"{moved.start / rate:.3g}-{moved.stop / rate:.3g} s; give the length of the rest before it"
            + (f" (--init-static {math.floor(10 * still) / 10:g})" if still >= SHORTEST_REST else "")
            + ", or leave --init-static out to find the rest automatically")
    return Interval(0, n, "static")


def moves_within(recording: Recording, n: int, *, factor: float = REST_FACTOR,
                 shortest: float = SHORTEST_REST) -> Interval | None:
    """Where the sensor moves in its first ``n`` samples (the first movement's samples), or None when still.

    The statistic of the short look of :func:`find_initial_rest` (:func:`variance_norm` over half of
    ``shortest``, windows cut at sample ``n`` so that nothing after it counts) against ``factor`` × its
    median over those samples, for the accelerometer and the gyroscope: what the rest's own noise cannot
    explain.
    """
    win = max(int(round(0.5 * shortest * recording.rate)) | 1, 3)
    if n < 2 * win:  # too short to tell a movement from its own noise
        return None
    moving = runs(_moving(recording[:n], win, factor, None))
    return Interval(moving[0].start, moving[0].stop, "motion") if moving else None
