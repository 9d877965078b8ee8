"""Poses and motions: every segmentation stage the methods share.

* :func:`find_initial_rest` — the rest that starts a session;
* :func:`detect_static` and :func:`detect_intervals` — the accelerometer
  variance detector of Tedaldi 2014 with its threshold-multiplier scan;
* :class:`VarianceNormStream` and :class:`StillDetector` — the same statistic
  and detector sample by sample, for a live recording (:mod:`imucalib.record`);
* :func:`detect_static_gyro` — the gyroscope-norm detector (Zhang 2021, eq. 22);
* :func:`find_faces` — the six faces (each axis up and down);
* :func:`find_turns` — turns about one axis between rests in the same pose.

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

import warnings
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from .fit.accelerometer import fit_determined, fit_gravity_norm, fit_sphere
from .metrics import interval_means, rowwise, transition_bounds
from .models import TriadModel
from .presets import (
    GYRO_MULTIPLIER,
    GYRO_VARIANCE_WINDOW,
    MIN_INTERVAL,
    MIN_INTERVALS,
    MULTIPLIERS,
    REST_FACTOR,
    REST_MIN_SECONDS,
    REST_SHORTEST_SECONDS,
    REST_WINDOW,
    STILL_N_SIGMA,
    STILL_RATE,
    STILL_WINDOW,
    VARIANCE_WINDOW,
)
from .recording import STANDARD_GRAVITY, ImucalibWarning, Interval, Recording

__all__ = [
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
]

#: the six faces in the order :func:`find_faces` returns them
FACE_NAMES = ("+x", "+y", "+z", "-x", "-y", "-z")


def runs(mask: np.ndarray, min_length: int = 1, kind: str = "static") -> list[Interval]:
    """Intervals ``[start, stop)`` of the True runs of a boolean mask at least ``min_length`` long."""
    padded = np.zeros(np.shape(mask)[0] + 2, dtype=bool)
    padded[1:-1] = mask
    change = np.flatnonzero(padded[1:] != padded[:-1])  # False → True, True → False, … in turn
    starts, stops = change[0::2], change[1::2]
    keep = stops - starts >= min_length
    return [Interval(a, b, kind) for a, b in zip(starts[keep].tolist(), stops[keep].tolist(), strict=True)]


#: samples per block of the windowed statistics: their temporaries stay a few MB, whatever the recording's length
BLOCK = 1 << 16


def _blocks(n: int, half: int):
    """Blocks ``[a, b)`` of samples with the span ``[lo, hi)`` their centred windows of ``±half`` samples read."""
    for a in range(0, n, BLOCK):
        b = min(a + BLOCK, n)
        yield a, b, max(a - half, 0), min(b + half, n)


def _column_means(x: np.ndarray) -> np.ndarray:
    """``x.mean(axis=0)`` of an (N, K) array, bit for bit, in about two thirds of its time.

    A reduction over the first axis of a C-ordered float64 array with two or
    more columns adds its rows one after the other (one short inner loop per
    row); a running sum down each column does the same additions in the same
    order with long inner loops, :data:`BLOCK` samples at a time (each block's
    running sum starts from the previous block's total). Any other array is
    reduced by ``mean`` itself.
    """
    n = x.shape[0]
    if x.ndim != 2 or x.shape[1] < 2 or n < 2 or x.dtype != np.float64 or not x.flags.c_contiguous:
        return x.mean(axis=0)
    out = np.empty(x.shape[1])
    buf = np.empty(min(n, BLOCK) + 1)
    for j in range(x.shape[1]):
        total = None
        for a in range(0, n, BLOCK):
            col = x[a:a + BLOCK, j]
            if total is None:
                run = np.add.accumulate(col, out=buf[: col.shape[0]])
            else:
                buf[0] = total
                buf[1:col.shape[0] + 1] = col
                run = np.add.accumulate(buf[: col.shape[0] + 1], out=buf[: col.shape[0] + 1])
            total = run[-1]
        out[j] = total
    return out / n


def _medians(rows: np.ndarray) -> np.ndarray:
    """``np.median(rows, axis=1)`` of a (K, n) array of finite numbers, bit for bit, partitioning ``rows`` in place.

    The median is the middle order statistic, or the mean of the two middle
    ones (their sum halved, as ``np.median``'s mean forms it); a partition at
    those ranks finds the same numbers as ``np.median``'s, without the extra
    rank it partitions at to look for NaN. Only a zero median may differ, in
    its sign, where −0 and +0 tie (the callers square it or take magnitudes).
    """
    n = rows.shape[1]
    h = n // 2
    if n % 2:
        rows.partition(h, axis=1)
        return rows[:, h].copy()
    rows.partition([h - 1, h], axis=1)
    return (rows[:, h - 1] + rows[:, h]) / 2.0


def _window_bounds(a: int, b: int, lo: int, half: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Window ``[lo_i, hi_i)`` of each sample ``i`` of ``[a, b)`` (truncated at the record's ends), from ``lo``."""
    idx = np.arange(a, b)
    return np.maximum(idx - half, 0) - lo, np.minimum(idx + half + 1, n) - lo


def _window_diff(c: np.ndarray, a: int, b: int, lo: int, half: int, n: int, out: np.ndarray | None = None,
                 mean: bool = False) -> np.ndarray:
    """``c[whi] − c[wlo]`` for the windows of :func:`_window_bounds` (running sums ``c`` from sample ``lo``).

    The rows whose window is not truncated are one subtraction of two slices
    (no gathered copies of ``c``); the few at the record's ends are gathered.
    With ``mean``, each row is divided by its window's length (``2·half + 1``
    inside the record, as a scalar: the same quotient as from an array of
    lengths). ``out`` (``b − a`` rows) receives the result when given.
    """
    if out is None:
        out = np.empty((b - a,) + c.shape[1:])
    m0, m1 = max(a, half), min(b, n - half)  # samples whose window lies inside the record
    if m1 <= m0:
        m0 = m1 = b
    inner = out[m0 - a : m1 - a]
    np.subtract(c[m0 + half + 1 - lo : m1 + half + 1 - lo], c[m0 - half - lo : m1 - half - lo], out=inner)
    if mean:
        inner /= float(2 * half + 1)
    for s, e in ((a, m0), (m1, b)):
        if e > s:
            wlo, whi = _window_bounds(s, e, lo, half, n)
            edge = c[whi] - c[wlo]
            if mean:
                edge /= (whi - wlo).reshape((-1,) + (1,) * (c.ndim - 1))
            out[s - a : e - a] = edge
    return out


def _block_variance(x: np.ndarray, centre: np.ndarray, a: int, b: int, lo: int, hi: int, half: int) -> np.ndarray:
    """Population variance over the centred window of each sample of ``[a, b)``, per column (running sums).

    Three buffers of the block's size: the centred samples (then their
    squares, then the window means), and the two running sums (the first
    then holds the variance).
    """
    seg = rowwise(np.subtract, x[lo:hi], centre)  # centred for a numerically safe running sum of squares
    c1 = np.empty((seg.shape[0] + 1, seg.shape[1]))
    c2 = np.empty_like(c1)
    c1[0] = c2[0] = 0.0
    np.cumsum(seg, axis=0, out=c1[1:])
    np.square(seg, out=seg)
    np.cumsum(seg, axis=0, out=c2[1:])
    n = x.shape[0]
    mean = _window_diff(c1, a, b, lo, half, n, out=seg[: b - a], mean=True)  # E[x] (seg is done with)
    var = _window_diff(c2, a, b, lo, half, n, out=c1[: b - a], mean=True)  # E[x²] (c1 is done with)
    var -= np.multiply(mean, mean, out=mean)
    return np.maximum(var, 0.0, out=var)


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
        window is shortened (truncated) at the ends of the record. Computed
        :data:`BLOCK` samples at a time from running sums of the centred
        samples (``var = E[x²] − E[x]²`` over the window).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[0]
    half = max(int(window) // 2, 1)
    centre = _column_means(x)
    out = np.empty(x.shape)
    for a, b, lo, hi in _blocks(n, half):
        out[a:b] = _block_variance(x, centre, a, b, lo, hi, half)
    return out


def variance_norm(acc: np.ndarray, window: int) -> np.ndarray:
    """Norm of the per-axis moving variance vector (Tedaldi 2014 detector statistic), (N,).

    Block by block as :func:`moving_variance`, without its (N, 3) result; the
    same core as the incremental :class:`VarianceNormStream`.
    """
    x = np.asarray(acc, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    half = max(int(window) // 2, 1)
    out = np.empty(x.shape[0])
    _variance_norm_rows(x, _column_means(x), half, 0, x.shape[0], out)
    return out


def _variance_norm_rows(x: np.ndarray, centre: np.ndarray, half: int, a: int, b: int, out: np.ndarray) -> None:
    """The detector statistic of rows ``[a, b)`` of ``x`` into ``out[: b − a]``, windows truncated at ``len(x)``.

    The running sums start at the blocks of :data:`BLOCK` samples counted from
    sample 0 whatever ``a`` is, so any split of a record into spans gives the
    statistic of the whole-record pass bit for bit; they stop at the last
    window the span reads (a running sum's first terms do not depend on where
    it stops), so a span costs what lies between its block's start and its end.
    """
    n = x.shape[0]
    s = a
    while s < b:
        anchor = s - s % BLOCK
        e = min(anchor + BLOCK, b)
        var = _block_variance(x, centre, s, e, max(anchor - half, 0), min(e + half, n), half)
        out[s - a:e - a] = np.sqrt(np.einsum("ij,ij->i", var, var))
        s = e


class VarianceNormStream:
    """:func:`variance_norm` sample by sample as a recording arrives (the same core, the same numbers).

    Parameters
    ----------
    window : int
        Window length [samples], as for :func:`variance_norm`.
    centre : (3,) array_like
        Subtracted before the running sums (:func:`variance_norm` takes the
        record's mean; a live recording, the initial rest's). With the record's
        mean, :attr:`statistic` after :meth:`close` equals
        ``variance_norm(x, window)`` bit for bit, however ``x`` was split.

    A sample's statistic is final once the ``window // 2`` samples after it
    have arrived (:attr:`final`); :meth:`close` finishes the last ones with
    the window truncated at the end, as the offline pass does.
    """

    def __init__(self, window: int, centre) -> None:
        self.half = max(int(window) // 2, 1)
        self.centre = np.asarray(centre, dtype=np.float64).reshape(1, -1)
        self._x = np.empty((1024, self.centre.shape[1]))
        self._stat = np.empty(1024)
        self.n = 0  # samples received
        self.final = 0  # samples whose statistic is final
        self.closed = False

    @property
    def samples(self) -> np.ndarray:
        """The samples received, (n, K)."""
        return self._x[: self.n]

    @property
    def statistic(self) -> np.ndarray:
        """The final statistic of the first :attr:`final` samples."""
        return self._stat[: self.final]

    def push(self, x) -> int:
        """Append samples (M, K); returns how many statistics became final."""
        if self.closed:
            raise ValueError("this stream is closed: no samples can be added")
        x = np.asarray(x, dtype=np.float64).reshape(-1, self.centre.shape[1])
        need = self.n + x.shape[0]
        if need > self._x.shape[0]:
            size = max(need, 2 * self._x.shape[0])
            self._x = np.concatenate([self._x[: self.n], np.empty((size - self.n, self._x.shape[1]))])
            self._stat = np.concatenate([self._stat[: self.final], np.empty(size - self.final)])
        self._x[self.n:need] = x
        self.n = need
        return self._advance(max(self.n - self.half, self.final))

    def close(self) -> int:
        """The last ``window // 2`` statistics, windows truncated at the end; returns how many."""
        self.closed = True
        return self._advance(self.n)

    def _advance(self, stop: int) -> int:
        start = self.final
        if stop > start:
            _variance_norm_rows(self._x[: self.n], self.centre, self.half, start, stop, self._stat[start:stop])
            self.final = stop
        return stop - start


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
    win = _window(window_seconds, rate)
    n0 = int(round(min_seconds * rate))
    if n0 >= len(recording):
        raise ValueError(
            f"the recording is {recording.duration:.3g} s long: too short for an initial rest of {min_seconds} s (a "
            "session is a rest, then poses held a few seconds each; `imucalib simulate -o session` writes one)")
    short_win = max(int(round(0.5 * shortest * rate)) | 1, 3)
    head = recording[: min(n0 + win + short_win, len(recording))]  # the short look reads the start only
    short_end = _first_motion(head, short_win, short_win // 2 + 1, factor)
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
    first_motion = _first_motion(recording, win, max(n0, win), factor, acc_statistic=statistic)
    end = max(first_motion - win // 2, 0) if first_motion < len(recording) else len(recording)
    if end >= n0:
        return Interval(0, end, "static")
    if shortest < min_seconds and short_end < len(recording):
        return Interval(0, short_end, "static")
    raise ValueError(_no_rest(end / rate, min_seconds))


def _first_motion(recording: Recording, win: int, n_level: int, factor: float,
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
        half, centre = max(int(win) // 2, 1), _column_means(x)
        stat = np.empty(x.shape[0])
        a, b = 0, min(max(n_level, 1), x.shape[0])
        if min(x.shape[0], first) - b <= 2 * max(b, 4096):  # the end, or the other sensor's movement, is near
            b = max(b, min(x.shape[0], first))
        _variance_norm_rows(x, centre, half, a, b, stat[a:b])
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
            _variance_norm_rows(x, centre, half, a, b, stat[a:b])
    return first


def _no_rest(moves: float, seconds: float) -> str:
    return (f"no initial rest found: the sensor moves {moves:.3g} s after the start; a recording must begin with "
            f"at least {seconds:g} s at rest (or pass --init-static SECONDS)")


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
    window: float = GYRO_VARIANCE_WINDOW,
    multiplier: float = GYRO_MULTIPLIER,
    min_interval: float = MIN_INTERVAL,
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


def pose_blocks(recording: Recording) -> list[Interval] | None:
    """The blocks of a recording whose poses were recorded apart (``metadata["blocks"]``), one pose each; else None.

    A logger that pauses between poses writes its rows in blocks separated by prompt lines, or one file per
    pose (:func:`imucalib.io.read`): no motion was recorded between the blocks, so each block is a static pose
    and nothing needs detecting.
    """
    blocks = recording.metadata.get("blocks")
    if not blocks:
        return None
    out = [Interval(int(a), int(b), "static") for a, b in blocks if int(b) - int(a) >= 2]
    if not out or out[-1].stop > len(recording):
        return None
    return out


def initial_rest(recording: Recording, init_static: float | None = None) -> Interval:
    """The initial rest: ``init_static`` seconds when given, else the first block of a recording in blocks
    (:func:`pose_blocks`), else found by :func:`find_initial_rest`."""
    blocks = pose_blocks(recording) if init_static is None else None
    if blocks:
        return blocks[0]
    if init_static is None:
        return find_initial_rest(recording)
    n = int(round(init_static * recording.rate))
    if not 1 < n < len(recording):
        raise ValueError(f"--init-static {init_static} s does not fit the {recording.duration:.3g} s recording")
    return Interval(0, n, "static")


def moving_mean(x: np.ndarray, window: int) -> np.ndarray:
    """Mean over a centred window of ``window`` samples, per column (truncated at the ends), :data:`BLOCK` at a time."""
    x = np.asarray(x, dtype=np.float64)
    return _moving_mean_rows(x, max(int(window) // 2, 0), 0, x.shape[0])


def _moving_mean_rows(x: np.ndarray, half: int, a: int, b: int, keep: np.ndarray | None = None,
                      out: np.ndarray | None = None, shifted: bool = False) -> np.ndarray:
    """:func:`moving_mean` (window ``±half``) of rows ``[a, b)`` of ``x`` only, :data:`BLOCK` rows at a time.

    With ``keep`` (a mask over ``[a, b)``), only the rows it selects, in order:
    the same running sums (from the same first sample), so the same numbers.
    ``out`` receives the result when given; with ``shifted``, the means less
    ``x[0]`` (which the running sums subtract), before it is added back.
    """
    n = x.shape[0]
    ref = x[0]  # subtracted to keep the running sums accurate
    if out is None:
        out = np.empty((b - a if keep is None else int(np.count_nonzero(keep)), x.shape[1]))
    done = 0
    for s in range(a, b, BLOCK):
        e = min(s + BLOCK, b)
        lo, hi = max(s - half, 0), min(e + half, n)
        c = np.empty((hi - lo + 1, x.shape[1]))
        c[0] = 0.0
        np.cumsum(rowwise(np.subtract, x[lo:hi], ref), axis=0, out=c[1:])
        if keep is None:
            part = _window_diff(c, s, e, lo, half, n, out=out[s - a:e - a], mean=True)
        else:
            rows = np.nonzero(keep[s - a:e - a])[0] + s
            wlo, whi = np.maximum(rows - half, 0) - lo, np.minimum(rows + half + 1, n) - lo
            part = out[done:done + rows.size]
            np.subtract(c[whi], c[wlo], out=part)
            part /= (whi - wlo)[:, None]
            done += rows.size
        if not shifted:
            rowwise(np.add, part, ref, out=part)
    return out


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
    and those inside are judged apart (:func:`_still_outside`,
    :func:`_still_inside`), with the same numbers.
    """
    gyro = np.asarray(recording.gyro, dtype=np.float64)
    settings = _still_settings(recording, rest, scale, rate_limit, window, n_sigma)
    still = np.empty(gyro.shape[0], dtype=bool)
    _still_outside(gyro, settings, intervals or [], still)
    _still_inside(gyro, settings, intervals or [], still, offset_factor)
    return still


def _still_settings(recording: Recording, rest: Interval, scale: float, rate_limit: float, window: float,
                    n_sigma: float) -> tuple[int, np.ndarray, float]:
    """:func:`gyro_still`'s half window [samples], bias (the rest's mean) and ``limit`` [raw units].

    The rest's mean and standard deviation are ``mean(axis=0)`` and
    ``std(axis=0)`` formed as numpy forms them (:func:`_column_means` of the
    samples, then of their squared deviations from it): the same numbers.
    """
    n = max(int(round(window * recording.rate)), 1)
    raw = np.asarray(recording.gyro[rest.slice], dtype=np.float64)
    bias = _column_means(raw)
    dev = rowwise(np.subtract, raw, bias)
    std = np.sqrt(_column_means(np.multiply(dev, dev, out=dev)))
    noise = float(np.linalg.norm(std)) / np.sqrt(n)
    return n // 2, bias, max(rate_limit / abs(scale), n_sigma * noise)


def _still_outside(gyro: np.ndarray, settings: tuple, intervals: list[Interval], still: np.ndarray) -> None:
    """:func:`gyro_still` on the samples outside ``intervals`` (``|m| < limit``), into ``still``."""
    half, bias, limit = settings
    outside = np.ones(gyro.shape[0], dtype=bool)  # the samples no interval judges
    for iv in intervals:
        outside[iv.slice] = False
    for a in range(0, gyro.shape[0], BLOCK):  # block by block: no (N, 3) moving mean is kept
        b = min(a + BLOCK, gyro.shape[0])
        m = rowwise(np.subtract, _moving_mean_rows(gyro, half, a, b, keep=outside[a:b]), bias)
        still[a:b][outside[a:b]] = np.sqrt(np.einsum("ij,ij->i", m, m)) < limit


def _still_inside(gyro: np.ndarray, settings: tuple, intervals: list[Interval], still: np.ndarray,
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
    shifted = rowwise(np.subtract, gyro, gyro[0]) if intervals and gyro.nbytes <= TRANSPOSE_BYTES else None
    every, k = True, 0
    while k < len(intervals):
        j, rows = k + 1, len(intervals[k])
        while j < len(intervals) and rows + len(intervals[j]) <= STILL_ROWS:
            rows += len(intervals[j])
            j += 1
        every &= _still_group(gyro, shifted, settings, intervals[k:j], still, offset_factor)
        k = j
    return every


#: samples whose moving means :func:`_still_inside` holds at once
STILL_ROWS = 4 * BLOCK


def _still_group(gyro: np.ndarray, shifted: np.ndarray | None, settings: tuple, intervals: list[Interval],
                 still: np.ndarray, offset_factor: float) -> bool:
    """:func:`_still_inside` on a group of non-empty ``intervals``; ``shifted``: ``gyro − gyro[0]`` or None."""
    half, bias, limit = settings
    lengths = np.array([len(iv) for iv in intervals])
    first = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    m = np.empty((int(lengths.sum()), gyro.shape[1]))
    n, ref, width = gyro.shape[0], gyro[0], 2 * half + 1
    for iv, o in zip(intervals, first.tolist(), strict=True):
        s, e = iv.start, iv.stop
        if s < half or e + half > n or e - s > BLOCK:  # a window truncated at an end, or more than one block
            _moving_mean_rows(gyro, half, s, e, out=m[o:o + e - s], shifted=True)
            continue
        # _moving_mean_rows of one block whose windows all lie inside the record, its operations inline
        c = np.empty((e - s + width, gyro.shape[1]))
        c[0] = 0.0
        seg = shifted[s - half:e + half] if shifted is not None else rowwise(np.subtract, gyro[s - half:e + half], ref)
        np.cumsum(seg, axis=0, out=c[1:])
        part = np.subtract(c[width:], c[: e - s], out=m[o:o + e - s])
        part /= float(width)
    rowwise(np.add, m, ref, out=m)  # the first sample back, as _moving_mean_rows adds it, then the bias off
    rowwise(np.subtract, m, bias, out=m)
    ok = np.sqrt(np.einsum("ij,ij->i", m, m)) < offset_factor * limit
    box = np.maximum.reduceat(m, first, axis=0) - np.minimum.reduceat(m, first, axis=0)
    inside = np.sqrt(np.einsum("ij,ij->i", box, box)) < (1.0 - SCREEN_MARGIN) * limit
    for k in np.flatnonzero(~inside).tolist():
        mk = m[first[k]:first[k] + lengths[k]]
        ok[first[k]:first[k] + lengths[k]] &= np.linalg.norm(mk - _medians(mk.T.copy()), axis=1) < limit
    for iv, o in zip(intervals, first.tolist(), strict=True):
        still[iv.slice] = ok[o:o + len(iv)]
    return bool(ok.all())


def still_intervals(intervals: list[Interval], still: np.ndarray, min_length: int) -> list[Interval]:
    """Each interval cut to its runs of ``still`` samples at least ``min_length`` long."""
    out = []
    for iv in intervals:
        out += [Interval(iv.start + r.start, iv.start + r.stop, iv.kind)
                for r in runs(still[iv.slice], min_length)]
    return out


def detect_intervals(
    recording: Recording,
    gravity: float,
    *,
    init_static: float | None = None,
    multipliers: Iterable[float] = MULTIPLIERS,
    window: float = VARIANCE_WINDOW,
    min_interval: float = MIN_INTERVAL,
    gyro_gate: bool = True,
) -> tuple[list[Interval], float, Interval, TriadModel]:
    """Static intervals by the Tedaldi 2014 detector with the multiplier scan, still for the gyroscope too.

    The accelerometer variance detector with the multiplier scan (Tedaldi 2014,
    as summarised in the interval-detection fragment, §2) runs first; with
    ``gyro_gate``, its intervals give a rough gyroscope scale, the samples where
    the gyroscope is not still (:func:`gyro_still`) are taken out of the
    detector statistic and the scan runs again, so a turn about the vertical or
    a slow settle after a flip is never averaged into a pose.

    When the gate leaves fewer than :data:`MIN_INTERVALS` poses at every
    threshold (hand-held poses that wobble), the intervals before the gate are
    kept for the accelerometer, its model fitted with each pose weighted by
    ``1/σ_k`` (:func:`pose_scatter`); :func:`unreliable_transitions` leaves the
    rotations into and out of the poses the gyroscope finds unsteady out of the
    gyroscope's fit.

    A recording in blocks (:func:`pose_blocks`) needs no detecting: its blocks
    are the intervals, the first one the rest, and the multiplier NaN. When no
    threshold gives :data:`MIN_INTERVALS` intervals, the scan takes the one
    that gives the most for which an accelerometer model is determined
    (:func:`imucalib.fit.accelerometer.fit_determined`).

    Returns the intervals, the chosen multiplier, the initial rest and the
    accelerometer model calibrated on those intervals.
    """
    blocks = pose_blocks(recording) if init_static is None else None
    if blocks:
        return blocks, float("nan"), blocks[0], fit_determined(interval_means(recording.acc, blocks), gravity)[0]
    win = _window(window, recording.rate)
    stat = variance_norm(recording.acc, win)  # formed once: the initial rest's search reads it too
    if init_static is None and win == _window(REST_WINDOW, recording.rate):
        rest = find_initial_rest(recording, statistic=stat)
    else:
        rest = initial_rest(recording, init_static)
    multipliers = list(multipliers)
    detector = _detector(recording, rest, window, min_interval, statistic=stat)
    intervals, mult, model = _scan(detector, gravity, recording, multipliers, min_interval, None)
    if gyro_gate and recording.gyro is not None:  # an accelerometer-only recording has no gate
        from .fit.gyroscope import axes_disagreement, rough_scale

        bias = _column_means(recording.gyro[rest.slice])  # recording.gyro[rest.slice].mean(axis=0), bit for bit
        try:
            scale = rough_scale(recording, intervals, model, bias)
        except ValueError:
            # the accelerometer found the poses but the gyroscope does not confirm them: say why when its
            # rotations disagree with the accelerometer's (axes swapped or reversed on one sensor)
            hint = axes_disagreement(recording, intervals, model, bias)
            if hint is not None:
                raise ValueError(hint) from None
            raise
        base, win, min_len, stat = detector
        widest = detect_static(None, max(multipliers) * base, window=win, min_length=min_len, statistic=stat)
        # gyro_still(recording, rest, scale, widest), its samples outside the intervals judged only when needed
        gyro = np.asarray(recording.gyro, dtype=np.float64)
        settings = _still_settings(recording, rest, scale, STILL_RATE, STILL_WINDOW, STILL_N_SIGMA)
        still = np.empty(gyro.shape[0], dtype=bool)
        if not _still_inside(gyro, settings, widest, still, STILL_OFFSET):  # else the scan would find the same again
            _still_outside(gyro, settings, widest, still)
            try:
                gated = _scan(detector, gravity, recording, multipliers, min_interval, still, reduce=False)
            except ValueError:
                hint = axes_disagreement(recording, intervals, model, bias)
                if hint is not None:
                    raise ValueError(hint) from None
                # the gate leaves too few poses (hand-held poses that wobble): they are kept for the accelerometer,
                # weighted by their scatter, and unreliable_transitions leaves their rotations out of the gyroscope
                weights = 1.0 / pose_scatter(recording.acc, intervals)
                model = fit_determined(interval_means(recording.acc, intervals), gravity, weights=weights)[0]
            else:
                intervals, mult, model = gated
    return intervals, mult, rest, model


def static_at(recording: Recording, rest: Interval, multiplier: float, *, window: float = VARIANCE_WINDOW,
              min_interval: float = MIN_INTERVAL) -> list[Interval]:
    """Static intervals of the accelerometer variance detector at one threshold, ``multiplier`` × the rest's.

    Tedaldi 2014's detector without the scan (nothing is fitted): where the norm
    of the per-axis variance over ``window`` seconds stays below the threshold
    for at least ``min_interval`` seconds.
    """
    base, win, min_len, stat = _detector(recording, rest, window, min_interval)
    return detect_static(None, multiplier * base, window=win, min_length=min_len, statistic=stat)


def _detector(recording: Recording, rest: Interval, window: float, min_interval: float,
              statistic: np.ndarray | None = None):
    """The detector's settings (:func:`_detector_settings`) and its statistic (``statistic`` when formed already)."""
    base, win, min_len = _detector_settings(recording.acc[rest.slice], recording.rate, window, min_interval)
    return base, win, min_len, variance_norm(recording.acc, win) if statistic is None else statistic


def _window(seconds: float, rate: float) -> int:
    """The odd window length [samples] of the variance detectors, at least 3."""
    return max(int(round(seconds * rate)) | 1, 3)


def _detector_settings(rest_acc: np.ndarray, rate: float, window: float, min_interval: float):
    """The accelerometer detector's base level (the rest's variance norm), window and shortest run [samples]."""
    base = float(np.linalg.norm(np.var(rest_acc, axis=0)))
    if base <= 0:
        raise ValueError(
            "the initial rest has zero accelerometer variance (quantised or synthetic "
            "noise-free data?): the detector threshold cannot be set from it"
        )
    win = _window(window, rate)
    min_len = max(int(round(min_interval * rate)), 2)
    return base, win, min_len


class StillDetector:
    """The accelerometer detector of :func:`static_at` run as the samples arrive, for a live recording.

    The same settings (:func:`_detector_settings`: the rest's variance norm,
    the window, the shortest run), the same statistic
    (:class:`VarianceNormStream`) and the same runs (:func:`detect_static`)
    as the offline detector at one ``multiplier``: a static interval is
    reported once it has ended (its statistic rose above the threshold); at
    :meth:`close` a run still open at the end is reported too. The stream's
    centre is the rest's mean rather than the record's, which changes the
    statistic by rounding only.

    Parameters
    ----------
    rest_acc : (M, 3) array_like
        The initial rest's accelerometer samples (the samples ``[0, M)`` of the record).
    rate : float
        Sampling rate [Hz].
    multiplier, window, min_interval
        As for :func:`static_at`.
    """

    def __init__(self, rest_acc, rate: float, *, multiplier: float = 6.0, window: float = 1.0,
                 min_interval: float = 1.0) -> None:
        rest_acc = np.asarray(rest_acc, dtype=np.float64)
        self.base, self.window, self.min_length = _detector_settings(rest_acc, rate, window, min_interval)
        self.threshold = multiplier * self.base
        self.stream = VarianceNormStream(self.window, rest_acc.mean(axis=0))
        self.intervals: list[Interval] = []  # the static intervals ended so far, in time order

    def push(self, acc) -> list[Interval]:
        """Add accelerometer samples; returns the static intervals that ended with them."""
        self.stream.push(acc)
        return self._update(open_end=False)

    def close(self) -> list[Interval]:
        """Finish the record; returns the static intervals that end with it."""
        self.stream.close()
        return self._update(open_end=True)

    def current(self) -> Interval | None:
        """The static run the final statistic is in at its last sample (None when moving)."""
        stat = self.stream.statistic
        if stat.size == 0 or stat[-1] >= self.threshold:
            return None
        below = np.nonzero(stat >= self.threshold)[0]
        start = int(below[-1]) + 1 if below.size else 0
        return Interval(start, stat.size, "static")

    def _update(self, open_end: bool) -> list[Interval]:
        stat = self.stream.statistic
        start = self.intervals[-1].stop if self.intervals else 0
        found = detect_static(None, self.threshold, window=self.window, min_length=self.min_length,
                              statistic=stat[start:])
        new = [Interval(start + iv.start, start + iv.stop, iv.kind) for iv in found
               if open_end or start + iv.stop < stat.size]
        self.intervals += new
        return new


def _interval_means(x: np.ndarray, intervals: list[Interval], columns: np.ndarray | None = None) -> np.ndarray:
    """:func:`imucalib.metrics.interval_means` bit for bit, with two array operations per interval, not six.

    Each interval's samples less its first one are laid out one column per
    row, ``(K, n)``, and summed along the rows: a reduction along the last
    axis sums each row as the one-column reduction does (pairwise, in the
    same blocks), so each sum is the same number; the division by ``n`` and
    the first sample added back are the same operations on all the intervals
    at once. ``columns``: ``x`` transposed into C order, (K, N), when the
    caller has it (the rows are then sliced from it, not transposed one by one).
    """
    x = np.asarray(x, dtype=np.float64)
    sums = np.empty((len(intervals), x.shape[1]))
    counts = np.empty(len(intervals))
    add = np.add.reduce
    for k, iv in enumerate(intervals):
        if columns is not None:
            seg = columns[:, iv.start:iv.stop]
            rows = seg - seg[:, :1]
        else:
            seg = x[iv.start:iv.stop]
            rows = np.subtract(seg.T, seg[0][:, None], out=np.empty((x.shape[1], seg.shape[0])))
        add(rows, axis=1, out=sums[k])
        counts[k] = iv.stop - iv.start
    ref = x[[iv.start for iv in intervals]] if intervals else np.empty((0, x.shape[1]))
    return sums / counts[:, None] + ref


#: the largest recording [bytes] whose accelerometer a scan transposes once for its interval means (and whose
#: gyroscope the gate shifts once for its moving means)
TRANSPOSE_BYTES = 1 << 23


class _IntervalMeans:
    """:func:`imucalib.metrics.interval_means` of ``x`` that forms each interval's mean once (the same numbers:
    each interval's mean is its own sum), for the thresholds of a scan whose intervals mostly recur."""

    def __init__(self, x: np.ndarray) -> None:
        self.x = np.asarray(x, dtype=np.float64)
        self.columns = np.ascontiguousarray(self.x.T) if self.x.nbytes <= TRANSPOSE_BYTES else None
        self.known: dict[tuple[int, int], np.ndarray] = {}

    def __call__(self, intervals: list[Interval]) -> np.ndarray:
        new = [iv for iv in intervals if (iv.start, iv.stop) not in self.known]
        if new:
            for iv, row in zip(new, _interval_means(self.x, new, self.columns), strict=True):
                self.known[iv.start, iv.stop] = row
        return np.array([self.known[iv.start, iv.stop] for iv in intervals])


def _static_runs(stat: np.ndarray, thresholds: list[float], min_length: int) -> list[list[Interval]]:
    """``detect_static(None, t, …, min_length=min_length, statistic=stat)`` for each threshold ``t``, in one pass.

    Each sample's level is how many of the (sorted, distinct) ``L``
    thresholds its statistic is not below, ``L`` less the count of those it
    is below: it is static at the ``i``-th threshold exactly when its level
    is at most ``i`` (``stat < t_i``). The runs of every threshold start and
    stop where the level, padded with a level no threshold reaches, crosses
    ``i``: among the few places where it changes.
    """
    levels_at = np.array(sorted(set(thresholds)))
    kind = np.int16 if levels_at.size < 1 << 14 else np.intp
    below = np.zeros(stat.shape[0], dtype=kind)
    for t in levels_at:
        below += stat < t
    padded = np.full(stat.shape[0] + 2, levels_at.size + 1, dtype=kind)
    np.subtract(levels_at.size, below, out=padded[1:-1])
    change = np.flatnonzero(padded[1:] != padded[:-1])
    before, after = padded[change], padded[change + 1]
    out = []
    for t in thresholds:
        i = int(np.searchsorted(levels_at, t))
        edges = change[(before <= i) != (after <= i)]  # False → True, True → False, … in turn
        starts, stops = edges[0::2], edges[1::2]
        keep = stops - starts >= min_length
        out.append([Interval(a, b, "static") for a, b in zip(starts[keep].tolist(), stops[keep].tolist(),
                                                             strict=True)])
    return out


def _scan(detector: tuple, gravity: float, recording: Recording, multipliers: Iterable[float], min_interval: float,
          still: np.ndarray | None, *, reduce: bool = True) -> tuple[list[Interval], float, TriadModel]:
    """The Tedaldi 2014 multiplier scan over the accelerometer variance (samples outside ``still`` excluded);
    with ``reduce``, fewer than :data:`MIN_INTERVALS` intervals at every threshold give the most that determine
    a model (:func:`imucalib.fit.accelerometer.fit_determined`), else an error."""
    base, win, min_len, stat = detector
    if still is not None:
        stat = np.where(still, stat, np.inf)
    best = None
    tried = []
    means = _IntervalMeans(recording.acc)
    fits: dict[tuple, tuple | None] = {}  # thresholds that give the same intervals give the same fit
    multipliers = list(multipliers)
    found = _static_runs(stat, [mult * base for mult in multipliers], min_len)
    for mult, intervals in zip(multipliers, found, strict=True):
        tried.append((mult, len(intervals)))
        if len(intervals) < MIN_INTERVALS:
            continue
        key = tuple((iv.start, iv.stop) for iv in intervals)
        if key not in fits:
            try:
                model, res = fit_gravity_norm(means(intervals), gravity)
            except ValueError:
                fits[key] = None
            else:
                fits[key] = (float(res @ res) / len(res), model)  # the score: per residual
        if fits[key] is None:
            continue
        score, model = fits[key]
        if best is None or score < best[0]:
            best = (score, mult, intervals, model)
    if best is None:
        # fewer intervals than the full model wants at every threshold: the most that determine a model
        for mult, _ in sorted(tried, key=lambda mc: -mc[1]) if reduce else []:
            intervals = detect_static(None, mult * base, window=win, min_length=min_len, statistic=stat)
            try:
                model = fit_determined(means(intervals), gravity)[0]
            except ValueError:
                continue
            return intervals, float(mult), model
        counts = ", ".join(f"×{m}: {c}" for m, c in tried)
        raise ValueError(
            "too few static intervals for a calibration at every detector threshold "
            f"({counts}; at least 4 in spread directions determine a model, {MIN_INTERVALS} the full one): hold "
            f"the sensor still for at least {min_interval} s in each of many poses"
        )
    _, mult, intervals, model = best
    return intervals, float(mult), model


def static_poses(recording: Recording, gravity: float, intervals: list[Interval] | None = None, *,
                 init_static: float | None = None) -> list[Interval]:
    """The static intervals given, or those :func:`detect_intervals` finds (a recording's blocks,
    :func:`pose_blocks`); the first is the initial rest."""
    if intervals is None:
        intervals = detect_intervals(recording, gravity, init_static=init_static)[0]
    return [iv for iv in intervals if iv.kind == "static"]


def find_faces(raw_means: np.ndarray, gravity: float, *, max_tilt: float = 15.0) -> np.ndarray:
    """Indices of the poses nearest to +x, +y, +z, −x, −y, −z (raises if one is missing)."""
    if raw_means.shape[0] < 6:
        raise ValueError(f"this method needs the six faces as static poses; got {raw_means.shape[0]} poses")
    centre = fit_sphere(raw_means, gravity).bias if raw_means.shape[0] >= 4 else raw_means.mean(axis=0)
    d = raw_means - centre
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    targets = np.vstack([np.eye(3), -np.eye(3)])
    cos = d @ targets.T  # (M, 6)
    best = np.argmax(cos, axis=0)
    tilt = np.degrees(np.arccos(np.clip(cos[best, np.arange(6)], -1, 1)))
    missing = [f"{FACE_NAMES[j]} ({tilt[j]:.0f}° off)" for j in range(6) if tilt[j] > max_tilt]
    if missing:
        raise ValueError(
            "this method needs the six faces, each axis up and down within "
            f"{max_tilt:g}° of gravity; the poses lack {', '.join(missing)}: record those faces"
        )
    return best


@dataclass(frozen=True)
class Turn:
    """A turn about one body axis between two rests in the same pose.

    ``start``/``stop`` are the samples the integration runs over (the last of
    the rest before, the first of the rest after); ``sign`` the direction of
    the raw rate about ``axis``; ``angle_deg`` its angle by the rough scale
    it was found with; ``matches`` whether that is within the tolerance of
    the known angle.
    """

    axis: int
    start: int
    stop: int
    sign: int
    angle_deg: float
    matches: bool

    def to_dict(self) -> dict:
        return {"axis": self.axis, "start": self.start, "stop": self.stop, "sign": self.sign,
                "measured_deg": self.angle_deg, "matches": self.matches}


def find_turns(recording: Recording, intervals: list[Interval], bias: np.ndarray, scale: float, *,
               angle: float = 2 * np.pi, same_pose: float = 5.0, tolerance: float = 0.2,
               min_angle: float = np.radians(45)) -> dict[int, list[Turn]]:
    """Turns by a known angle about each axis, each a chain of motions between rests in one pose.

    A hand turns a board by 360° as several quarter turns; where it pauses
    long enough the detector sees rests in between, all in the same pose (a
    turn about the vertical leaves gravity where it is). Every run of
    consecutive motions whose rests all hold one axis at the same tilt from
    gravity (within ``same_pose`` degrees, the axis within 30° of vertical) is
    a candidate, and so is each contiguous part of it; a candidate whose
    integrated raw rate ``Φ = ∫(u − b) dt`` lies along that axis (≥ 0.8 of its
    norm) turns by ``scale·|Φ|``. Per axis, the
    candidates within ``tolerance`` of ``angle`` are taken, closest first and
    without overlap; where none is, the closest one above ``min_angle`` is
    taken with ``matches=False`` so the verdict can reject the calibration
    (a 13° nudge is never a 360° turn). ``scale`` is the rough gyroscope
    scale (:func:`imucalib.fit.gyroscope.rough_scale`).
    """
    acc = interval_means(recording.acc, intervals)
    dirs = acc - np.mean(acc, axis=0)  # rough centring is enough to compare directions
    starts, stops = transition_bounds(intervals)
    raw = recording.gyro - bias
    c = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (raw[1:] + raw[:-1]) * np.diff(recording.t)[:, None],
                                                   axis=0)])
    u = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    candidates = set()  # (axis, first transition, last transition, angle, sign)
    for axis in range(3):
        # a turn about an axis a few degrees off vertical moves gravity round a cone about it: the rests of
        # one turn share the axis's tilt from gravity, not the gravity direction itself
        tilt = np.degrees(np.arccos(np.clip(u[:, axis], -1, 1)))  # from +axis: a flip changes it by 180°
        same = (np.abs(np.diff(tilt)) <= same_pose) & (np.minimum(tilt, 180 - tilt)[:-1] <= 30)
        for run in runs(same):
            for a in range(run.start, run.stop):
                for b in range(a, run.stop):
                    phi = c[stops[b]] - c[starts[a]]
                    i = int(np.argmax(np.abs(phi)))
                    if i != axis or abs(phi[i]) < 0.8 * np.linalg.norm(phi):  # not about this axis alone
                        continue
                    candidates.add((i, a, b, abs(scale) * abs(phi[i]), int(np.sign(phi[i]))))
    out: dict[int, list[Turn]] = {0: [], 1: [], 2: []}
    for axis in range(3):
        mine = sorted((cd for cd in candidates if cd[0] == axis), key=lambda cd: abs(cd[3] / angle - 1))
        used: set[int] = set()
        for _, a, b, ang, sign in mine:
            ok = abs(ang / angle - 1) <= tolerance
            if not ok and (out[axis] or ang < min_angle):
                continue
            if used & set(range(a, b + 1)):
                continue
            used |= set(range(a, b + 1))
            out[axis].append(Turn(axis, int(starts[a]), int(stops[b]), sign, float(np.degrees(ang)), ok))
            if not ok:
                break
    return out


def saturated(x: np.ndarray, *, run: int = 3) -> np.ndarray:
    """Samples (N,) where a channel sits at its recorded extreme for ``run`` or more samples in a row.

    A saturated sensor reports its full scale, so its clipped stretches are flat
    at the largest (or smallest) value the channel ever reads; a natural peak
    repeats its extreme value at most once or twice.
    """
    x = np.asarray(x, dtype=np.float64)
    out = np.zeros(x.shape[0], dtype=bool)
    for col in x.T:
        span = float(col.max() - col.min())
        if span <= 0:
            continue
        for extreme in (col.max(), col.min()):
            at = np.abs(col - extreme) <= 1e-9 * span
            for r in runs(at, run):
                out[r.slice] = True
    return out


def spikes(x: np.ndarray, *, factor: float = 20.0, isolation: float = 4.0) -> np.ndarray:
    """Single-sample outliers (N,): a jump out and straight back that nothing around it explains.

    Sample ``i`` is a spike on a channel when both steps ``x_i − x_{i−1}`` and
    ``x_{i+1} − x_i`` have opposite signs, exceed ``factor`` times the channel's
    median absolute step and ``isolation`` times the steps just before and after
    (``x_{i−1} − x_{i−2}``, ``x_{i+2} − x_{i+1}``: a fast but smooth turnaround of
    the hand has steps of the same size around it), and its neighbours agree with
    each other to a quarter of the jump.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[0]
    out = np.zeros(n, dtype=bool)
    if n < 5:
        return out
    steps = np.diff(x.T, axis=1)  # one channel a row
    scale = _medians(np.abs(steps, out=steps))  # the median absolute step of each channel
    scale = np.where(scale > 0, scale, np.finfo(float).tiny)
    limit = factor * scale
    for a in range(2, n - 2, BLOCK):  # samples a … b−1, each read with two neighbours either side
        b = min(a + BLOCK, n - 2)
        xb = x[a - 2:b + 2]
        d = np.diff(xb, axis=0)  # d[i + 1], d[i + 2]: the steps into and out of sample a + i
        ad = np.abs(d)
        jump = np.minimum(ad[1:-2], ad[2:-1])
        i, j = np.nonzero(jump > limit)  # the big jumps (few): the other conditions only there
        ok = ((np.sign(d[i + 1, j]) != np.sign(d[i + 2, j]))
              & (jump[i, j] > isolation * np.maximum(ad[i, j], ad[i + 3, j]))
              & (np.abs(xb[i + 3, j] - xb[i + 1, j]) < 0.25 * ad[i + 1, j]))
        out[a + i[ok]] = True
    return out


def pose_scatter(acc: np.ndarray, intervals: list[Interval]) -> np.ndarray:
    """The standard error of each pose's mean accelerometer reading (M,), in its raw unit.

    ``σ_k = sqrt(tr Cov(u) / n_k)`` over the pose's ``n_k`` samples: the noise,
    and the hand's tremor where it holds the sensor, that its mean keeps; the
    weight ``1/σ_k`` of a pose in the gravity-norm fit. A pose whose samples do
    not vary at all (quantised, noise below one count) is given the smallest
    non-zero scatter of the others (or 1).
    """
    acc = np.asarray(acc, dtype=np.float64)
    s = np.array([np.sqrt(np.sum(np.var(acc[iv.slice], axis=0)) / len(iv)) for iv in intervals])
    floor = s[s > 0].min() if np.any(s > 0) else 1.0
    return np.maximum(s, floor)


#: a pose's edges may tilt this far [deg] from its mean direction before its rotations are left out: twice the
#: verdict's acceptable gravity-direction error of the gyroscope (a hand's tremor tilts a pose's edges by 0.1-0.4°,
#: a settling hand by about 1°)
EDGE_TILT_DEG = 0.5


def unsteady_poses(recording: Recording, intervals: list[Interval], *, edge: float = STILL_WINDOW, n_sigma: float = 4.0
                   ) -> dict[int, str]:
    """Poses whose first or last ``edge`` seconds tilt away from the pose's mean direction: ``{k: why}``.

    The gyroscope's fit (Zhang 2021, eq. 14) compares the gravity direction a
    rotation ends at with the mean direction of the pose that follows, and
    starts the next rotation from that same mean: a hand that creeps or
    settles while it holds a pose makes its edges differ from its mean and
    biases every rotation that touches it. A hand's tremor scatters the
    samples about the mean but leaves the edges' means on it. So a pose is
    unsteady when the angle between the mean of its first or last ``edge``
    seconds and its mean, in the directions of the accelerometer model the
    poses determine (:func:`imucalib.fit.accelerometer.fit_determined`),
    exceeds :data:`EDGE_TILT_DEG` and ``n_sigma`` times that edge mean's own
    scatter (the pose's samples, tremor included, over √n). Its mean is
    still good for the accelerometer. Empty without a gyroscope or with fewer
    than 4 poses.

    The poses are screened together (:func:`_tilt_screen`): the model applied
    to many poses' samples at once, their sums in one pass. Only a pose whose
    screened tilt comes within :data:`SCREEN_MARGIN` of its limit is judged by
    the per-pose computation above, so the poses found and their reasons are
    those of that computation, number for number.
    """
    if recording.gyro is None or len(intervals) < 4:
        return {}
    means = _interval_means(recording.acc, intervals)
    try:
        model = fit_determined(means, STANDARD_GRAVITY)[0]
    except ValueError:
        return {}
    n_edge = max(int(round(edge * recording.rate)), 2)
    tilt_floor = np.radians(EDGE_TILT_DEG)
    poses = [(k, iv) for k, iv in enumerate(intervals[1:], 1) if len(iv) >= 3 * n_edge]
    if model.is_linear and not np.any(model.g_sensitivity):  # the poses well inside the floor need no more
        near = _floor_screen(model, recording.acc, means[[k for k, _ in poses]], [iv for _, iv in poses], n_edge,
                             tilt_floor)
        poses = [p for p, check in zip(poses, near, strict=True) if check]
    near = _tilt_screen(model, recording.acc, [iv for _, iv in poses], n_edge, tilt_floor, n_sigma)
    out = {}
    for (k, iv), check in zip(poses, near, strict=True):
        if not check:
            continue
        tilts, limit = _edge_tilts(model.forward(recording.acc[iv.slice]), n_edge, tilt_floor, n_sigma)
        if max(tilts) > limit:
            where = "start" if tilts[0] > tilts[1] else "end"
            out[k] = (f"pose {k + 1} tilts {np.degrees(max(tilts)):.2g}° at its {where} from its mean (limit "
                      f"{np.degrees(limit):.2g}°: the hand moved while holding it)")
    return out


#: a pose whose screened edge tilt (:func:`_tilt_screen`) is below ``(1 − SCREEN_MARGIN) ×`` its screened limit is
#: steady: the screen's sums differ from the per-pose ones by rounding (1e-12 relative at most), far inside it
SCREEN_MARGIN = 1e-6


def _edge_tilts(a: np.ndarray, n_edge: int, tilt_floor: float, n_sigma: float) -> tuple[list[float], float]:
    """The tilts [rad] of a pose's first and last ``n_edge`` calibrated samples ``a`` from its mean, and the limit."""
    mean = a.mean(axis=0)
    size = np.linalg.norm(mean)
    sigma = np.sqrt(np.sum(np.var(a, axis=0)) / n_edge) / size  # [rad], the edge mean's scatter
    limit = max(tilt_floor, n_sigma * sigma)
    tilts = [float(np.arccos(min(max(float(e @ mean / (np.linalg.norm(e) * size)), -1.0), 1.0)))
             for e in (a[:n_edge].mean(axis=0), a[-n_edge:].mean(axis=0))]
    return tilts, limit


def _floor_screen(model: TriadModel, acc: np.ndarray, means: np.ndarray, poses: list[Interval], n_edge: int,
                  tilt_floor: float) -> np.ndarray:
    """Which ``poses`` may tilt at an edge beyond the floor of their limit, from their raw means: a mask (M,).

    A linear model without g-sensitivity is affine, so the calibrated mean of
    a pose or of its edge is the model applied to its raw mean (to rounding):
    the pose is steady when the larger angle between the calibrated edge means
    and pose mean is below ``(1 − SCREEN_MARGIN) × tilt_floor``, which no
    limit of :func:`_edge_tilts` is below. ``means``: the poses' raw means.
    """
    if not poses:
        return np.zeros(0, dtype=bool)
    ramp = np.arange(n_edge)
    rows = np.stack([[iv.start for iv in poses], [iv.stop - n_edge for iv in poses]], axis=1)[:, :, None] + ramp
    edges = model.forward(acc[rows.ravel()].reshape(-1, n_edge, acc.shape[1]).mean(axis=1)).reshape(len(poses), 2, -1)
    centre = model.forward(means)
    cos = np.einsum("ijk,ik->ij", edges, centre) / (np.linalg.norm(edges, axis=2)
                                                      * np.linalg.norm(centre, axis=1)[:, None])
    tilt = np.arccos(np.clip(cos, -1.0, 1.0)).max(axis=1)
    return ~(tilt < (1.0 - SCREEN_MARGIN) * tilt_floor)  # NaN: screened further


def _tilt_screen(model: TriadModel, acc: np.ndarray, poses: list[Interval], n_edge: int, tilt_floor: float,
                 n_sigma: float) -> np.ndarray:
    """Which ``poses`` may tilt at an edge (:func:`_edge_tilts`), screened many poses at a time: a mask (M,).

    The poses' samples are calibrated together, at most about :data:`BLOCK`
    at a time; each pose's first ``n_edge``, middle and last ``n_edge``
    samples are summed in one ``reduceat`` and its squared deviations from
    its mean in another. A pose is kept for the exact judgement unless its
    larger edge tilt is below ``(1 − SCREEN_MARGIN)`` × its limit.
    """
    near = np.ones(len(poses), dtype=bool)
    k = 0
    while k < len(poses):
        j, rows = k + 1, len(poses[k])
        while j < len(poses) and rows + len(poses[j]) <= BLOCK:
            rows += len(poses[j])
            j += 1
        group = poses[k:j]
        n = np.array([len(iv) for iv in group])
        first = np.concatenate([[0], np.cumsum(n)[:-1]])
        a = model.forward(np.concatenate([acc[iv.slice] for iv in group]))
        parts = np.add.reduceat(a, np.stack([first, first + n_edge, first + n - n_edge], axis=1).ravel(), axis=0)
        head, middle, tail = parts[0::3], parts[1::3], parts[2::3]
        mean = (head + middle + tail) / n[:, None]
        dev = a - np.repeat(mean, n, axis=0)
        var = np.add.reduceat(dev * dev, first, axis=0) / n[:, None]
        size = np.linalg.norm(mean, axis=1)
        limit = np.maximum(tilt_floor, n_sigma * np.sqrt(var.sum(axis=1) / n_edge) / size)
        tilt = np.zeros(len(group))
        for e in (head / n_edge, tail / n_edge):
            cos = np.einsum("ij,ij->i", e, mean) / (np.linalg.norm(e, axis=1) * size)
            tilt = np.maximum(tilt, np.arccos(np.clip(cos, -1.0, 1.0)))
        near[k:j] = ~(tilt < (1.0 - SCREEN_MARGIN) * limit)  # NaN: judged exactly
        k = j
    return near


def unreliable_transitions(recording: Recording, intervals: list[Interval], *,
                           gap_factor: float = 2.5) -> dict[int, str]:
    """Rotations between consecutive poses whose integration cannot be trusted: ``{k: why}``.

    Rotation ``k`` runs from pose ``k`` to pose ``k+1``. It is unreliable when
    it holds saturated gyroscope samples (:func:`saturated`: the rate beyond
    full scale is lost), spikes (:func:`spikes`) or a sampling gap longer than
    ``gap_factor`` × the median step (the attitude is integrated sample to
    sample, Zhang 2021 eq. 23; across a gap the rate is only interpolated).
    Such rotations are left out of the gyroscope fit, not fitted; so are the
    rotations into and out of a pose the gyroscope finds unsteady
    (:func:`unsteady_poses`): its accelerometer mean is kept, not its edges.
    """
    if len(intervals) < 2 or recording.gyro is None:
        return {}
    starts, stops = transition_bounds(intervals)
    sat = np.nonzero(saturated(recording.gyro))[0]
    spk = np.nonzero(spikes(recording.gyro))[0]
    dt = np.diff(recording.t)
    gaps = np.nonzero(dt > gap_factor * _medians(dt[None, :].copy())[0])[0] if dt.size else np.zeros(0, int)
    # per rotation [a, b]: the saturated samples and spikes in a … b, the gaps that start in a … b − 1 (sorted indices)
    n_sat = np.maximum(np.searchsorted(sat, stops, "right") - np.searchsorted(sat, starts, "left"), 0)
    n_spk = np.maximum(np.searchsorted(spk, stops, "right") - np.searchsorted(spk, starts, "left"), 0)
    first_gap, end_gap = np.searchsorted(gaps, starts, "left"), np.searchsorted(gaps, stops, "left")
    out = {}
    for k in np.flatnonzero(n_sat | n_spk | (end_gap > first_gap)).tolist():
        why = []
        if n_sat[k]:
            why.append(f"{n_sat[k]} saturated gyroscope sample(s)")
        if n_spk[k]:
            why.append(f"{n_spk[k]} spike(s) in the gyroscope")
        inside = gaps[first_gap[k]:end_gap[k]]
        if inside.size:
            why.append(f"{inside.size} sampling gap(s), the longest {dt[inside].max():.3g} s")
        out[k] = " and ".join(why)
    for k, why in unsteady_poses(recording, intervals).items():  # rotation k−1 ends at pose k, rotation k leaves it
        for j in (k - 1, k):
            if 0 <= j < len(starts):
                out[j] = f"{out[j]} and {why}" if j in out else why
    return out


def no_usable_rotations(intervals: list[Interval], left_out: dict[int, str]) -> str | None:
    """Why the rotations between ``intervals`` leave nothing to fit a gyroscope to, or None.

    The gyroscope fit (:func:`imucalib.fit.gyroscope.fit_gyroscope`) needs
    :data:`~imucalib.fit.gyroscope.MIN_POSES` static poses and at least one
    rotation between them that is not ``left_out`` (index ``k``: from pose
    ``k`` to ``k+1`` → why, :func:`unreliable_transitions`). Without them a
    method that calibrates both sensors calibrates the accelerometer alone and
    says why (``fit["gyroscope_not_calibrated"]``); a fit on a few rotations
    runs, and its verdict judges whether they determine the gyroscope.
    """
    from .fit.gyroscope import MIN_POSES

    n = max(len(intervals) - 1, 0)
    if len(intervals) < MIN_POSES:
        return (f"the gyroscope was not calibrated: {len(intervals)} static pose{'' if len(intervals) == 1 else 's'} "
                f"found, and its calibration needs at least {MIN_POSES} with rotations between them")
    if len(left_out) < n:
        return None
    k, why = min(left_out.items())
    return (f"the gyroscope was not calibrated: all {n} rotations between poses were left out as unreliable (the "
            f"first, from pose {k + 1} to {k + 2}: {why}); record again with rotations slower than the gyroscope's "
            "range, without gaps")
