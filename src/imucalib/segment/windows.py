r"""The windowed statistics the segmentation stages share, block by block over any recording's length.

Runs of a mask, the moving variance and its norm (the statistic of the Tedaldi 2014 detector, offline and
sample by sample) and the moving mean.

Over the window ``W_i = [max(i − h, 0), min(i + h + 1, N))`` of ``|W_i|`` samples centred on sample ``i``
(``h`` the half window; truncated at the record's ends), from running sums ``C`` of the samples less a centre
``c`` (``C_0 = 0``, ``C_j = Σ_{l<j} (x_l − c)``), the moving mean and the population variance, and the norm of
the per-axis variance that is the statistic (D1) of :mod:`imucalib.segment.detect`:

.. math::

    \bar x_i = c + \frac{C_{\max W_i + 1} - C_{\min W_i}}{|W_i|} \qquad \text{(W1)}

    \mathrm{var}_i(x) = \mathrm E_{W_i}\bigl[(x - c)^2\bigr] - \mathrm E_{W_i}[x - c]^2 \qquad \text{(W2)}

    \varsigma_i = \bigl\lVert \bigl(\mathrm{var}_i(x_1), \mathrm{var}_i(x_2), \mathrm{var}_i(x_3)\bigr)
    \bigr\rVert \qquad \text{(D1)}
"""

from __future__ import annotations

import numpy as np

from ..recording import Interval

__all__ = ["BLOCK", "SCREEN_MARGIN", "TRANSPOSE_BYTES", "VarianceNormStream", "block_variance", "column_means",
           "moving_mean", "moving_mean_rows", "moving_variance", "odd_window", "pose_means", "runs",
           "variance_norm", "variance_norm_rows", "window_blocks", "window_bounds", "window_diff"]


def odd_window(seconds: float, rate: float) -> int:
    """The odd window length [samples] of the variance detectors, at least 3."""
    return max(int(round(seconds * rate)) | 1, 3)


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


def window_blocks(n: int, half: int):
    """Blocks ``[a, b)`` of samples with the span ``[lo, hi)`` their centred windows of ``±half`` samples read."""
    for a in range(0, n, BLOCK):
        b = min(a + BLOCK, n)
        yield a, b, max(a - half, 0), min(b + half, n)


def column_means(x: np.ndarray) -> np.ndarray:
    """``x.mean(axis=0)`` of an (N, K) array, bit for bit, in about two thirds of its time.

    A reduction over the first axis of a C-ordered float64 array with two or
    more columns adds its rows one after the other (one short inner loop per
    row); a running sum down each column does the same additions in the same
    order with long inner loops, :data:`BLOCK` samples at a time (each block's
    running sum starts from the previous block's total). Any other array is
    reduced by ``mean`` itself.

    Kept below the 10 % a speed trick is to earn: it is 6.5–7 % of calibrating
    imu_tk's Xsens session (``benchmarks/bench_tedaldi2014.py`` in turns, two
    invocations: 0.1225 s with it, 0.131 s without; 0.1135 s and 0.1214 s),
    and without it that calibration would be slower than before the plain forms
    that replaced the other tricks.
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


def window_bounds(a: int, b: int, lo: int, half: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Window ``[lo_i, hi_i)`` of each sample ``i`` of ``[a, b)`` (truncated at the record's ends), from ``lo``."""
    idx = np.arange(a, b)
    return np.maximum(idx - half, 0) - lo, np.minimum(idx + half + 1, n) - lo


def window_diff(c: np.ndarray, a: int, b: int, lo: int, half: int, n: int, out: np.ndarray | None = None,
                 mean: bool = False) -> np.ndarray:
    """``c[whi] − c[wlo]`` for the windows of :func:`window_bounds` (running sums ``c`` from sample ``lo``).

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
    np.subtract(c[m0 + half + 1 - lo : m1 + half + 1 - lo], c[m0 - half - lo : m1 - half - lo], out=inner)  # eq. (W1)
    if mean:
        inner /= float(2 * half + 1)
    for s, e in ((a, m0), (m1, b)):
        if e > s:
            wlo, whi = window_bounds(s, e, lo, half, n)
            edge = c[whi] - c[wlo]
            if mean:
                edge /= (whi - wlo).reshape((-1,) + (1,) * (c.ndim - 1))
            out[s - a : e - a] = edge
    return out


def block_variance(x: np.ndarray, centre: np.ndarray, a: int, b: int, lo: int, hi: int, half: int) -> np.ndarray:
    """Population variance over the centred window of each sample of ``[a, b)``, per column (running sums).

    Three buffers of the block's size: the centred samples (then their
    squares, then the window means), and the two running sums (the first
    then holds the variance).
    """
    seg = x[lo:hi] - centre  # centred for a numerically safe running sum of squares
    c1 = np.empty((seg.shape[0] + 1, seg.shape[1]))
    c2 = np.empty_like(c1)
    c1[0] = c2[0] = 0.0
    np.cumsum(seg, axis=0, out=c1[1:])
    np.square(seg, out=seg)
    np.cumsum(seg, axis=0, out=c2[1:])
    n = x.shape[0]
    mean = window_diff(c1, a, b, lo, half, n, out=seg[: b - a], mean=True)  # eq. (W2): E[x] (seg is done with)
    var = window_diff(c2, a, b, lo, half, n, out=c1[: b - a], mean=True)  # eq. (W2): E[x²] (c1 is done with)
    var -= np.multiply(mean, mean, out=mean)  # eq. (W2)
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
    centre = column_means(x)
    out = np.empty(x.shape)
    for a, b, lo, hi in window_blocks(n, half):
        out[a:b] = block_variance(x, centre, a, b, lo, hi, half)
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
    variance_norm_rows(x, column_means(x), half, 0, x.shape[0], out)
    return out


def variance_norm_rows(x: np.ndarray, centre: np.ndarray, half: int, a: int, b: int, out: np.ndarray) -> None:
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
        var = block_variance(x, centre, s, e, max(anchor - half, 0), min(e + half, n), half)
        out[s - a:e - a] = np.sqrt(np.einsum("ij,ij->i", var, var))  # eq. (D1)
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
            variance_norm_rows(self._x[: self.n], self.centre, self.half, start, stop, self._stat[start:stop])
            self.final = stop
        return stop - start


def moving_mean(x: np.ndarray, window: int) -> np.ndarray:
    """Mean over a centred window of ``window`` samples, per column (truncated at the ends), :data:`BLOCK` at a time."""
    x = np.asarray(x, dtype=np.float64)
    return moving_mean_rows(x, max(int(window) // 2, 0), 0, x.shape[0])


def moving_mean_rows(x: np.ndarray, half: int, a: int, b: int, keep: np.ndarray | None = None,
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
        np.cumsum(x[lo:hi] - ref, axis=0, out=c[1:])
        if keep is None:
            part = window_diff(c, s, e, lo, half, n, out=out[s - a:e - a], mean=True)  # eq. (W1)
        else:
            rows = np.nonzero(keep[s - a:e - a])[0] + s
            wlo, whi = np.maximum(rows - half, 0) - lo, np.minimum(rows + half + 1, n) - lo
            part = out[done:done + rows.size]
            np.subtract(c[whi], c[wlo], out=part)  # eq. (W1)
            part /= (whi - wlo)[:, None]
            done += rows.size
        if not shifted:
            np.add(part, ref, out=part)
    return out


def pose_means(x: np.ndarray, intervals: list[Interval], columns: np.ndarray | None = None) -> np.ndarray:
    """:func:`imucalib.metrics.interval_means` bit for bit, with two array operations per interval, not six.

    Part of the scan's means: kept under the 10 % bar with the other means of the threshold scan and the
    models' per-axis form: without the four, calibrating the Xsens session took 0.141 s against 0.125 s before
    (benchmarks/bench_tedaldi2014.py and a profile, in turns).

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


#: a pose whose screened edge tilt (:func:`_tilt_screen`) is below ``(1 − SCREEN_MARGIN) ×`` its screened limit is
#: steady: the screen's sums differ from the per-pose ones by rounding (1e-12 relative at most), far inside it
SCREEN_MARGIN = 1e-6
