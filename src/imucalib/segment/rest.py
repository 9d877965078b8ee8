"""The initial rest that starts a calibration recording, and the blocks of a recording made of blocks.

The rest's noise level sets every detector threshold (Tedaldi 2014, as summarised in the static/dynamic
interval detection fragment, §2: an initial rest of ``T_init`` seconds).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..presets import MIN_HOLD, REST_FACTOR, REST_MIN_SECONDS, REST_SHORTEST_SECONDS, REST_WINDOW
from ..recording import ImucalibWarning, Interval, Recording
from .blocks import still_blocks
from .windows import column_means, odd_window, variance_norm_rows

__all__ = ["PREFERRED_REST", "SHORTEST_REST", "find_initial_rest", "first_motion", "initial_rest"]


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

    Parameters
    ----------
    recording : Recording
    window_seconds, factor, min_seconds, shortest : float
        As above.
    statistic : (N,) ndarray, optional
        The accelerometer's statistic over the whole recording with the window
        of ``window_seconds`` (``variance_norm(recording.acc, win)``), when the
        caller has formed it: read rather than formed again (the same numbers).

    Returns
    -------
    Interval
        The initial rest, from sample 0.

    Raises
    ------
    ValueError
        If the recording does not start with at least ``shortest`` seconds of rest.
    """
    rate = recording.rate
    win = odd_window(window_seconds, rate)
    n0 = int(round(min_seconds * rate))
    if n0 >= len(recording):
        raise ValueError(
            f"the recording is {recording.duration:.3g} s long: too short for an initial "
            f"rest of {min_seconds} s"
        )
    short_win = max(int(round(0.5 * shortest * rate)) | 1, 3)
    head = recording[: min(n0 + win + short_win, len(recording))]  # the short look reads the start only
    short_end = first_motion(head, short_win, short_win // 2 + 1, factor)
    short_end = len(recording) if short_end == len(head) else short_end
    moves = (short_end + short_win // 2) / rate  # where the short look sees the first movement [s]
    if moves < min_seconds and shortest < min_seconds:
        if moves < shortest:
            raise ValueError(_no_rest(moves, shortest))
        warnings.warn(f"the initial rest is about {moves:.2g} s, shorter than the {min_seconds:g} s the detector "
                      f"would like: the noise level that sets its threshold rests on the first "
                      f"{short_end / rate:.2g} s (record a longer rest at the start, or give its length with "
                      "--init-static SECONDS)", ImucalibWarning, stacklevel=2)
        return Interval(0, short_end, "static")
    moved = first_motion(recording, win, max(n0, win), factor, acc_statistic=statistic)
    end = max(moved - win // 2, 0) if moved < len(recording) else len(recording)
    if end >= n0:
        return Interval(0, end, "static")
    if shortest < min_seconds and short_end < len(recording):
        return Interval(0, short_end, "static")
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
    return Interval(0, n, "static")
