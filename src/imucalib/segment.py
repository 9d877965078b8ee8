"""Static / motion segmentation of a recording.

The accelerometer detector follows Tedaldi et al. (ICRA 2014) as summarised
in the static/dynamic interval detection fragment (§2): an initial rest of
``T_init`` seconds gives the noise level; a sliding window computes the
per-axis variance of the accelerometer and the norm of that variance vector;
samples whose norm is below ``multiplier × (variance norm of the initial
rest)`` are static; static runs shorter than a minimum length are dropped.
The initial rest is found automatically (:func:`find_initial_rest`) unless
given.
"""

from __future__ import annotations

import numpy as np

from .recording import Interval, Recording

__all__ = [
    "moving_variance",
    "runs",
    "variance_norm",
    "find_initial_rest",
    "gyro_norm_variance",
    "detect_static",
    "motion_between",
]


def runs(mask: np.ndarray, min_length: int = 1, kind: str = "static") -> list[Interval]:
    """Intervals ``[start, stop)`` of the True runs of a boolean mask at least ``min_length`` long."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask).astype(np.int8), [0]]))
    starts = np.nonzero(edges == 1)[0]
    stops = np.nonzero(edges == -1)[0]
    return [Interval(int(a), int(b), kind) for a, b in zip(starts, stops, strict=True)
            if b - a >= min_length]


def moving_variance(x: np.ndarray, window: int) -> np.ndarray:
    """Variance over a centred window of ``window`` samples, per column.

    Parameters
    ----------
    x : (N, K) array_like
    window : int
        Odd window length (an even one is made odd by adding one).

    Returns
    -------
    (N, K) ndarray
        Population variance of the window centred on each sample; the
        window is shortened (truncated) at the ends of the record.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[0]
    half = max(int(window) // 2, 1)
    # centre each column for a numerically safe running sum of squares
    xc = x - x.mean(axis=0)
    c1 = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(xc, axis=0)])
    c2 = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(xc * xc, axis=0)])
    idx = np.arange(n)
    lo = np.clip(idx - half, 0, n)
    hi = np.clip(idx + half + 1, 0, n)
    cnt = (hi - lo)[:, None].astype(np.float64)
    mean = (c1[hi] - c1[lo]) / cnt
    var = (c2[hi] - c2[lo]) / cnt - mean * mean
    return np.maximum(var, 0.0)


def variance_norm(acc: np.ndarray, window: int) -> np.ndarray:
    """Norm of the per-axis moving variance vector (Tedaldi 2014 detector statistic)."""
    return np.linalg.norm(moving_variance(acc, window), axis=1)


def find_initial_rest(
    recording: Recording,
    *,
    window_seconds: float = 1.0,
    factor: float = 30.0,
    min_seconds: float = 2.0,
) -> Interval:
    """Locate the initial rest period that starts a calibration recording.

    For the accelerometer and the gyroscope alike, the noise level is the
    median detector statistic (:func:`variance_norm`) over the first
    ``min_seconds``; the rest ends where either statistic first exceeds
    ``factor`` times its level (the first movement: the gyroscope catches a
    turn about the vertical, which leaves the accelerometer still), less half
    a window.

    Raises
    ------
    ValueError
        If the recording does not start with at least ``min_seconds`` of rest.
    """
    rate = recording.rate
    win = max(int(round(window_seconds * rate)) | 1, 3)
    n0 = int(round(min_seconds * rate))
    if n0 >= len(recording):
        raise ValueError(
            f"the recording is {recording.duration:.3g} s long: too short for an initial "
            f"rest of {min_seconds} s"
        )
    first_motion = len(recording)
    for signal in (recording.acc, recording.gyro):
        stat = variance_norm(signal, win)
        level = float(np.median(stat[: max(n0, win)]))
        moving = np.nonzero(stat > factor * max(level, np.finfo(float).tiny))[0]
        if moving.size:
            first_motion = min(first_motion, int(moving[0]))
    end = max(first_motion - win // 2, 0) if first_motion < len(recording) else len(recording)
    if end < n0:
        raise ValueError(
            f"no initial rest found: the sensor moves {end / rate:.3g} s after the start; "
            f"a recording must begin with at least {min_seconds} s at rest (or pass "
            "--init-static SECONDS)"
        )
    return Interval(0, end, "static")


def detect_static(
    acc: np.ndarray | None,
    threshold: float,
    *,
    window: int,
    min_length: int,
    statistic: np.ndarray | None = None,
) -> list[Interval]:
    """Static intervals: runs where the variance norm is below ``threshold``.

    Parameters
    ----------
    acc : (N, 3) array_like
        Accelerometer samples (any unit); unused when ``statistic`` is given.
    threshold : float
        Variance-norm threshold (the unit of ``acc`` squared).
    window : int
        Sliding-window length [samples].
    min_length : int
        Shortest static run kept [samples].
    statistic : (N,) ndarray, optional
        The precomputed :func:`variance_norm` (to scan many thresholds).

    Returns
    -------
    list of Interval
        Non-overlapping static intervals in time order.
    """
    stat = variance_norm(acc, window) if statistic is None else statistic
    return runs(stat < threshold, min_length)


def motion_between(static: list[Interval]) -> list[Interval]:
    """The motion intervals between consecutive static intervals."""
    return [
        Interval(a.stop, b.start, "motion")
        for a, b in zip(static[:-1], static[1:], strict=True)
        if b.start > a.stop
    ]


def gyro_norm_variance(recording: Recording, rest: Interval, window: float) -> tuple[np.ndarray, np.ndarray]:
    """The statistic of Zhang 2021, eq. (22): ``ζ(t) = var_{t_w}(‖u_g − b‖)``.

    Returns the bias-free raw gyroscope norm (bias = mean of ``rest``) and its
    variance over a centred window of ``window`` seconds.
    """
    bias = recording.gyro[rest.slice].mean(axis=0)
    norm = np.linalg.norm(recording.gyro - bias, axis=1)
    win = max(int(round(window * recording.rate)) | 1, 3)
    return norm, moving_variance(norm, win)[:, 0]


def detect_static_gyro(
    recording: Recording,
    rest: Interval,
    *,
    window: float = 2.0,
    multiplier: float = 6.0,
    min_interval: float = 1.0,
) -> list[Interval]:
    """Static intervals by the gyroscope detector of Zhang 2021, eq. (22).

    ``ζ(t) = var_{t_w}(‖u_g − b‖)``, the variance of the bias-free raw
    gyroscope norm over a centred window of ``window`` seconds, is compared
    with ``multiplier × ζ_init`` (ζ over the initial rest; the paper uses
    ``t_w = 2`` s and ``n = 6`` for RD1); a centred window that reaches into
    a motion already exceeds it, so the runs stop short of the motions. Runs
    shorter than ``min_interval`` seconds are dropped. Like the paper's, this
    detector would take a perfectly steady turn for rest; the accelerometer
    detector (:func:`detect_static`) would not.
    """
    rate = recording.rate
    norm, zeta = gyro_norm_variance(recording, rest, window)  # eq. (22)
    zeta_init = float(np.var(norm[rest.slice]))
    if zeta_init <= 0:
        raise ValueError("the initial rest has zero gyroscope noise: eq. (22) cannot set a threshold")
    return runs(zeta < multiplier * zeta_init, max(int(round(min_interval * rate)), 2))
