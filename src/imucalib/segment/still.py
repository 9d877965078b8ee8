r"""Where the gyroscope says the sensor is still: the gate that keeps turns about the vertical and settling
hands out of the poses the accelerometer finds.

The gate is this project's (neither Tedaldi 2014 nor the interval-detection fragment has one; derived here).
With ``u`` the raw gyroscope readings, ``b`` and ``σ`` their mean and per-axis standard deviation over the
initial rest, ``m(t)`` the mean of ``u − b`` over the centred window of ``n`` samples, ``s`` a rough scale
[rad/s per raw unit] and ``r`` the rate limit [rad/s]:

.. math::

    \ell = \max\Bigl(\frac{r}{|s|},\; n_\sigma \frac{\lVert \boldsymbol\sigma \rVert}{\sqrt n}\Bigr)
    \qquad \text{(G1)}

    \text{outside the candidate poses:} \quad \lVert \mathbf m(t) \rVert < \ell \qquad \text{(G2)}

    \text{inside pose } P: \quad \lVert \mathbf m(t) - \operatorname{med}_{P} \mathbf m \rVert < \ell
    \ \text{ and } \ \lVert \mathbf m(t) \rVert < c\, \ell \qquad \text{(G3)}

and two consecutive poses, the last sample of the first at ``t_a`` and the first of the second at ``t_b``
(``T = t_b − t_a``), are one when the mean rate between them is small (trapezoidal rule):

.. math::

    \frac{1}{T} \Bigl\lVert \int_{t_a}^{t_b} (\mathbf u - \mathbf b)\, dt \Bigr\rVert < f\, \ell
    \qquad \text{(G4)}
"""

from __future__ import annotations

import numpy as np

from ..presets import STILL_N_SIGMA, STILL_RATE, STILL_WINDOW
from ..recording import Interval, Recording
from .windows import BLOCK, SCREEN_MARGIN, TRANSPOSE_BYTES, column_means, moving_mean_rows, runs

__all__ = ["BLIP_FACTOR", "BLIP_SECONDS", "STILL_OFFSET", "STILL_ROWS", "gyro_still", "join_blips", "still_inside",
           "still_intervals", "still_outside", "still_settings"]


#: the longest moment of tremor inside a hold that :func:`join_blips` joins [s]: two of gyro_still's windows
BLIP_SECONDS = 2 * STILL_WINDOW
#: … when the mean rate over it stays below this many times the gate's limit (over 0.5 s at the 0.7 °/s limit:
#: 0.7°, where a hand's turn about the vertical turns by tens of degrees)
BLIP_FACTOR = 2.0
#: a pose's moving mean rate may stay this many times :func:`gyro_still`'s limit from zero (bias drift, g-sensitivity)
STILL_OFFSET = 4.0


def gyro_still(recording: Recording, rest: Interval, scale: float, intervals: list[Interval] | None = None, *,
               rate_limit: float = STILL_RATE, window: float = STILL_WINDOW, n_sigma: float = STILL_N_SIGMA,
               offset_factor: float = STILL_OFFSET) -> np.ndarray:
    """Samples where the gyroscope says the sensor is still: a mask (N,).

    The accelerometer alone cannot tell a still pose from a turn about the
    vertical, or from a slow creep after the hand lets go (Tedaldi 2014 and
    imu_tk look at it alone). With ``m`` the gyroscope's mean over a centred
    ``window`` (bias = mean of ``rest``), a sample inside one of ``intervals``
    (candidate poses) is still when ``m`` stays within ``limit`` of the
    interval's median — a pose's own constant offset is bias drift or
    g-sensitivity, not motion — and within ``offset_factor × limit`` of zero;
    elsewhere when ``|m| < limit``. ``limit = max(rate_limit, n_sigma × the
    noise of m)``; ``scale`` [rad/s per raw unit] is a rough gyroscope scale
    (:func:`imucalib.fit.gyroscope.rough_scale`) that puts ``rate_limit`` in
    raw units, the noise is the rest's. The samples outside ``intervals``
    and those inside are judged apart (:func:`still_outside`,
    :func:`still_inside`), with the same numbers.
    """
    gyro = np.asarray(recording.gyro, dtype=np.float64)
    settings = still_settings(recording, rest, scale, rate_limit, window, n_sigma)
    still = np.empty(gyro.shape[0], dtype=bool)
    still_outside(gyro, settings, intervals or [], still)
    still_inside(gyro, settings, intervals or [], still, offset_factor)
    return still


def still_settings(recording: Recording, rest: Interval, scale: float, rate_limit: float, window: float,
                    n_sigma: float) -> tuple[int, np.ndarray, float]:
    """:func:`gyro_still`'s half window [samples], bias (the rest's mean) and ``limit`` [raw units].

    The rest's mean and standard deviation are ``mean(axis=0)`` and
    ``std(axis=0)`` formed as numpy forms them (:func:`column_means` of the
    samples, then of their squared deviations from it): the same numbers.
    """
    n = max(int(round(window * recording.rate)), 1)
    raw = np.asarray(recording.gyro[rest.slice], dtype=np.float64)
    bias = column_means(raw)
    dev = raw - bias
    std = np.sqrt(column_means(np.multiply(dev, dev, out=dev)))
    noise = float(np.linalg.norm(std)) / np.sqrt(n)  # eq. (G1): ‖σ‖ / √n
    return n // 2, bias, max(rate_limit / abs(scale), n_sigma * noise)  # eq. (G1)


def still_outside(gyro: np.ndarray, settings: tuple, intervals: list[Interval], still: np.ndarray) -> None:
    """:func:`gyro_still` on the samples outside ``intervals`` (``|m| < limit``), into ``still``."""
    half, bias, limit = settings
    outside = np.ones(gyro.shape[0], dtype=bool)  # the samples no interval judges
    for iv in intervals:
        outside[iv.slice] = False
    for a in range(0, gyro.shape[0], BLOCK):  # block by block: no (N, 3) moving mean is kept
        b = min(a + BLOCK, gyro.shape[0])
        m = moving_mean_rows(gyro, half, a, b, keep=outside[a:b]) - bias
        still[a:b][outside[a:b]] = np.sqrt(np.einsum("ij,ij->i", m, m)) < limit  # eq. (G2)


def still_inside(gyro: np.ndarray, settings: tuple, intervals: list[Interval], still: np.ndarray,
                  offset_factor: float) -> bool:
    """:func:`gyro_still` on the samples of each of ``intervals`` (its local and overall tests), into ``still``.

    Returns whether every sample of every interval is still. The moving means
    of many intervals (about :data:`STILL_ROWS` samples at a time) are formed
    into one array (each from its own running sums: the same numbers) and
    their overall test made in one pass. The local test needs an interval's
    median only when the box its moving means span is not inside the limit:
    every mean lies within the box's diagonal of the median (which lies in
    the box, axis by axis), so a diagonal below ``(1 − SCREEN_MARGIN) ×
    limit`` passes every sample, as the computed distances (a few roundings
    from the exact ones) do too.
    """
    intervals = [iv for iv in intervals if len(iv)]
    # the samples less the first one, as every running sum reads them (once, where that copy is small)
    shifted = gyro - gyro[0] if intervals and gyro.nbytes <= TRANSPOSE_BYTES else None
    every, k = True, 0
    while k < len(intervals):
        j, rows = k + 1, len(intervals[k])
        while j < len(intervals) and rows + len(intervals[j]) <= STILL_ROWS:
            rows += len(intervals[j])
            j += 1
        every &= _still_group(gyro, shifted, settings, intervals[k:j], still, offset_factor)
        k = j
    return every


#: samples whose moving means :func:`still_inside` holds at once
STILL_ROWS = 4 * BLOCK


def _still_group(gyro: np.ndarray, shifted: np.ndarray | None, settings: tuple, intervals: list[Interval],
                 still: np.ndarray, offset_factor: float) -> bool:
    """:func:`still_inside` on a group of non-empty ``intervals``; ``shifted``: ``gyro − gyro[0]`` or None."""
    half, bias, limit = settings
    lengths = np.array([len(iv) for iv in intervals])
    first = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    m = np.empty((int(lengths.sum()), gyro.shape[1]))
    n, ref, width = gyro.shape[0], gyro[0], 2 * half + 1
    for iv, o in zip(intervals, first.tolist(), strict=True):
        s, e = iv.start, iv.stop
        if s < half or e + half > n or e - s > BLOCK:  # a window truncated at an end, or more than one block
            moving_mean_rows(gyro, half, s, e, out=m[o:o + e - s], shifted=True)
            continue
        # moving_mean_rows of one block whose windows all lie inside the record, its operations inline
        c = np.empty((e - s + width, gyro.shape[1]))
        c[0] = 0.0
        seg = shifted[s - half:e + half] if shifted is not None else gyro[s - half:e + half] - ref
        np.cumsum(seg, axis=0, out=c[1:])
        part = np.subtract(c[width:], c[: e - s], out=m[o:o + e - s])
        part /= float(width)
    np.add(m, ref, out=m)  # the first sample back, as moving_mean_rows adds it, then the bias off
    np.subtract(m, bias, out=m)
    ok = np.sqrt(np.einsum("ij,ij->i", m, m)) < offset_factor * limit  # eq. (G3): ‖m‖ < c ℓ
    box = np.maximum.reduceat(m, first, axis=0) - np.minimum.reduceat(m, first, axis=0)
    inside = np.sqrt(np.einsum("ij,ij->i", box, box)) < (1.0 - SCREEN_MARGIN) * limit
    for k in np.flatnonzero(~inside).tolist():
        mk = m[first[k]:first[k] + lengths[k]]
        ok[first[k]:first[k] + lengths[k]] &= np.linalg.norm(mk - np.median(mk, axis=0), axis=1) < limit  # eq. (G3)
    for iv, o in zip(intervals, first.tolist(), strict=True):
        still[iv.slice] = ok[o:o + len(iv)]
    return bool(ok.all())


def join_blips(recording: Recording, intervals: list[Interval], settings: tuple, *,
               longest: float = BLIP_SECONDS, factor: float = BLIP_FACTOR) -> list[Interval]:
    """Consecutive poses joined into one where only a moment of tremor parted them.

    A hand's tremor lifts :func:`gyro_still`'s moving mean over its limit for a moment inside a hold; with a
    shortest run well under a second, the two sides of that moment are found as two poses with a "rotation"
    of nothing between them. Two consecutive ``intervals`` at most ``longest`` seconds apart are one pose
    when the mean raw rate between them, ``|∫(u − b) dt| / T`` from the last sample of the first to the
    first sample of the second, stays below ``factor`` × the gate's limit (``settings``:
    :func:`still_settings`, bias and limit in raw units): over at most half a second that turns the sensor by
    a fraction of a degree, where a turn about the vertical, however quick, turns it by tens. The joined
    pose spans both and the moment between them.
    """
    if len(intervals) < 2:
        return list(intervals)
    _, bias, limit = settings
    gyro, t = recording.gyro, recording.t
    out = [intervals[0]]
    for iv in intervals[1:]:
        last = out[-1]
        a, b = last.stop - 1, iv.start
        span = float(t[b] - t[a])
        if span <= longest and b > a:
            u = np.asarray(gyro[a:b + 1], dtype=np.float64) - bias
            turned = np.linalg.norm(0.5 * (u[1:] + u[:-1]).T @ np.diff(t[a:b + 1]))  # eq. (G4): trapezoidal rule
            if turned < factor * limit * span:  # eq. (G4)
                out[-1] = Interval(last.start, iv.stop, last.kind)
                continue
        out.append(iv)
    return out


def still_intervals(intervals: list[Interval], still: np.ndarray, min_length: int) -> list[Interval]:
    """Each interval cut to its runs of ``still`` samples at least ``min_length`` long."""
    out = []
    for iv in intervals:
        out += [Interval(iv.start + r.start, iv.start + r.stop, iv.kind)
                for r in runs(still[iv.slice], min_length)]
    return out
