r"""Static intervals: the accelerometer variance detector of Tedaldi 2014 with its threshold-multiplier scan,
gated by the gyroscope, and the gyroscope-norm detector of Zhang 2021 (eq. 22).

The accelerometer detector follows Tedaldi et al. (ICRA 2014) as summarised in the static/dynamic interval
detection fragment (§2): an initial rest of ``T_init`` seconds gives the noise level; a sliding window computes
the per-axis variance of the accelerometer and the norm of that variance vector; samples whose norm is below
``multiplier × (variance norm of the initial rest)`` are static; static runs shorter than a minimum length are
dropped. Neither the fragment nor this project's papers number these equations; they are written here, with
``var_{t_w}`` the population variance over the window of ``t_w`` seconds centred on ``t`` (truncated at the
record's ends, :func:`imucalib.segment.windows.moving_variance`) and ``k`` the threshold multiplier:

.. math::

    \varsigma(t) = \bigl\lVert \bigl(\mathrm{var}_{t_w}(u_x), \mathrm{var}_{t_w}(u_y),
    \mathrm{var}_{t_w}(u_z)\bigr) \bigr\rVert, \qquad
    \varsigma_\mathrm{init} = \bigl\lVert \mathrm{var}_{T_\mathrm{init}}(\mathbf u) \bigr\rVert
    \qquad \text{(D1)}

    t \text{ static} \iff \varsigma(t) < k\, \varsigma_\mathrm{init} \qquad \text{(D2)}

Tedaldi 2014's scan runs (D2) at each ``k`` of a list and keeps the one whose intervals the accelerometer's
gravity-norm model fits best, the mean squared residual of :func:`imucalib.fit.accelerometer.fit_gravity_norm`
over the ``M_k`` intervals found at ``k``:

.. math::

    k^\ast = \arg\min_k \frac{1}{M_k} \sum_{i=1}^{M_k} r_i(k)^2 \qquad \text{(D3)}

The gyroscope detector is Zhang 2021's, eq. (22), with the bias ``b`` the initial rest's mean and the threshold
``n ζ_init`` of its Sec. IV-A (``ζ_init`` the variance of the norm over the initial rest):

.. math::

    \zeta(t) = \mathrm{var}_{t_w}\Bigl(\sqrt{(\omega_x^t)^2 + (\omega_y^t)^2 + (\omega_z^t)^2}\Bigr)
    \quad (22), \qquad t \text{ static} \iff \zeta(t) < n\, \zeta_\mathrm{init}
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ..fit.accelerometer import fit_determined, fit_gravity_norm
from ..fit.gyroscope import axes_disagreement, rough_scale
from ..metrics import interval_means
from ..models import TriadModel
from ..presets import (
    GYRO_MULTIPLIER,
    GYRO_VARIANCE_WINDOW,
    MIN_HOLD,
    MIN_INTERVAL,
    MIN_INTERVALS,
    MULTIPLIERS,
    REST_WINDOW,
    STILL_N_SIGMA,
    STILL_RATE,
    STILL_WINDOW,
    VARIANCE_WINDOW,
    hold_settings,
)
from ..recording import Interval, Recording
from .blocks import still_blocks
from .poses import pose_scatter
from .rest import find_initial_rest, initial_rest
from .still import STILL_OFFSET, join_blips, still_inside, still_outside, still_settings
from .windows import (
    TRANSPOSE_BYTES,
    VarianceNormStream,
    moving_variance,
    odd_window,
    pose_means,
    runs,
    variance_norm,
)

__all__ = ["IntervalMeans", "StillDetector", "detect_intervals", "detect_static", "detect_static_gyro",
           "detector_settings", "gyro_norm_variance", "make_detector", "motion_between", "scan_thresholds",
           "static_at", "static_poses", "static_runs"]


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
    return runs(stat < threshold, min_length)  # eq. (D2)


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
    norm = np.linalg.norm(recording.gyro - bias, axis=1)  # eq. (22): ‖u_g − b‖
    win = max(int(round(window * recording.rate)) | 1, 3)
    return norm, moving_variance(norm, win)[:, 0]  # eq. (22): ζ(t)


def detect_static_gyro(
    recording: Recording,
    rest: Interval,
    *,
    window: float = GYRO_VARIANCE_WINDOW,
    multiplier: float = GYRO_MULTIPLIER,
    min_interval: float = MIN_INTERVAL,
) -> list[Interval]:
    r"""Static intervals by the gyroscope detector of Zhang 2021, eq. (22).

    ``ζ(t) = var_{t_w}(‖u_g − b‖)``, the variance of the bias-free raw
    gyroscope norm over a centred window of ``window`` seconds, is compared
    with ``multiplier × ζ_init`` (ζ over the initial rest; the paper uses
    ``t_w = 2`` s and ``n = 6`` for RD1); a centred window that reaches into
    a motion already exceeds it, so the runs stop short of the motions. Runs
    shorter than ``min_interval`` seconds are dropped. Like the paper's, this
    detector would take a perfectly steady turn for rest; the accelerometer
    detector (:func:`detect_static`) would not.

    Notes
    -----
    Zhang 2021, eq. (22) and the threshold of its Sec. IV-A, with ``u_g`` the
    raw gyroscope readings and ``b`` their mean over the initial rest:

    .. math::

        \zeta(t) = \mathrm{var}_{t_w}\bigl(\lVert \mathbf u_g - \mathbf b \rVert\bigr) \quad (22),
        \qquad t \text{ static} \iff \zeta(t) < n\, \zeta_\mathrm{init}

    Parameters
    ----------
    recording : Recording
        The recording, with a gyroscope (raw units).
    rest : Interval
        Its initial rest: the gyroscope bias ``b`` is its mean and ``ζ_init`` its variance.
    window : float
        ``t_w``, the variance window [s].
    multiplier : float
        ``n``, the threshold as a multiple of ``ζ_init``.
    min_interval : float
        The shortest static run kept [s].

    Returns
    -------
    list of Interval
        The static runs, in time order.

    Raises
    ------
    ValueError
        The initial rest has zero gyroscope noise (no threshold can be set from it).

    Examples
    --------
    Zhang et al.'s simulated session, 40 static poses after an initial rest:

    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_static_gyro, find_initial_rest
    >>> sim = session("zhang2021", rng=1)
    >>> rest = find_initial_rest(sim.recording)
    >>> static = detect_static_gyro(sim.recording, rest)
    >>> len(static), static[1]
    (40, Interval(start=1295, stop=1412, kind='static'))
    """
    rate = recording.rate
    norm, zeta = gyro_norm_variance(recording, rest, window)  # eq. (22)
    zeta_init = float(np.var(norm[rest.slice]))  # Zhang 2021, Sec. IV-A: ζ_init
    if zeta_init <= 0:
        raise ValueError("the initial rest has zero gyroscope noise: eq. (22) cannot set a threshold")
    # Zhang 2021, Sec. IV-A: ζ(t) < n ζ_init
    return runs(zeta < multiplier * zeta_init, max(int(round(min_interval * rate)), 2))


def detect_intervals(
    recording: Recording,
    gravity: float,
    *,
    init_static: float | None = None,
    min_hold: float = MIN_HOLD,
    multipliers: Iterable[float] = MULTIPLIERS,
    window: float | None = None,
    min_interval: float | None = None,
    gyro_gate: bool = True,
) -> tuple[list[Interval], float, Interval, TriadModel]:
    r"""Static intervals by the Tedaldi 2014 detector with the multiplier scan, still for the gyroscope too.

    The accelerometer variance detector with the multiplier scan (Tedaldi 2014,
    as summarised in the interval-detection fragment, §2) runs first; with
    ``gyro_gate``, its intervals give a rough gyroscope scale, the samples where
    the gyroscope is not still (:func:`gyro_still`) are taken out of the
    detector statistic and the scan runs again, so a turn about the vertical or
    a slow settle after a flip is never averaged into a pose. Two poses parted
    only by a moment of tremor are then joined
    (:func:`imucalib.segment.still.join_blips`); when the gate took poses out,
    the gyroscope's axes are checked against the accelerometer's
    (:func:`imucalib.fit.gyroscope.axes_disagreement`).

    When the gate leaves fewer than :data:`MIN_INTERVALS` poses at every
    threshold (hand-held poses that wobble), the intervals before the gate are
    kept for the accelerometer, its model fitted with each pose weighted by
    ``1/σ_k`` (:func:`pose_scatter`); :func:`unreliable_transitions` leaves the
    rotations into and out of the poses the gyroscope finds unsteady out of the
    gyroscope's fit.

    A recording in blocks (:func:`pose_blocks`) has no rotations to scan
    against: the still part of each block is its pose
    (:func:`imucalib.segment.blocks.still_blocks`), the first one the rest,
    and the multiplier NaN; a block never still is left out with a warning. When no
    threshold gives :data:`MIN_INTERVALS` intervals, the scan takes the one
    that gives the most for which an accelerometer model is determined
    (:func:`imucalib.fit.accelerometer.fit_determined`).

    Notes
    -----
    The detector of Tedaldi 2014 (the interval-detection fragment, §2; the
    equations unnumbered there, labelled as in :mod:`imucalib.segment.detect`):
    the norm of the per-axis accelerometer variance over a centred window,
    against ``k`` times its value over the initial rest, at each ``k`` of
    ``multipliers``, keeping the ``k`` whose ``M_k`` intervals the gravity-norm
    model fits best:

    .. math::

        \varsigma(t) = \bigl\lVert \mathrm{var}_{t_w}(\mathbf u) \bigr\rVert \quad \text{(D1)}, \qquad
        t \text{ static} \iff \varsigma(t) < k\, \varsigma_\mathrm{init} \quad \text{(D2)}, \qquad
        k^\ast = \arg\min_k \frac{1}{M_k} \sum_{i=1}^{M_k} r_i(k)^2 \quad \text{(D3)}

    Parameters
    ----------
    recording : Recording
        An initial rest, then static poses with rotations between them (raw units), or poses in blocks.
    gravity : float
        Local gravity [m/s²], the norm the accelerometer model is fitted to.
    init_static : float, optional
        Length of the initial rest [s]; found from the data when omitted.
    min_hold : float
        The shortest hold that is a pose [s]: the detector's window and shortest run follow from it
        (:func:`imucalib.presets.hold_settings`).
    multipliers : iterable of float
        The thresholds scanned, as multiples of the initial rest's variance (Tedaldi 2014: 2 to 10).
    window, min_interval : float, optional
        The detector's window and the shortest static run [s], instead of those ``min_hold`` gives.
    gyro_gate : bool
        Take the samples where the gyroscope turns out of the poses.

    Returns
    -------
    intervals : list of Interval
        The static intervals, the initial rest first.
    multiplier : float
        The threshold multiplier chosen (NaN for a recording in blocks).
    rest : Interval
        The initial rest.
    model : TriadModel
        The accelerometer model calibrated on ``intervals``.

    Raises
    ------
    ValueError
        No threshold gives poses from which an accelerometer model is determined, an initial rest in which
        the sensor moves, or blocks none of which is still for ``min_hold`` seconds; the message says what
        to record or which option to give.

    Examples
    --------
    A simulated session of a 10 s rest and 14 poses:

    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, multiplier, rest, model = detect_intervals(sim.recording, sim.truth.gravity)
    >>> len(intervals), multiplier, rest
    (15, 7.0, Interval(start=0, stop=897, kind='static'))
    """
    window, min_interval = _hold_window(min_hold, window, min_interval)
    blocks = still_blocks(recording, min_hold=min_hold) if init_static is None else None
    if blocks is not None:
        return _block_poses(recording, blocks, gravity, min_hold)
    return _scan(recording, gravity, init_static, list(multipliers), window, min_interval, gyro_gate)


def _block_poses(recording: Recording, blocks, gravity: float,
                 min_hold: float) -> tuple[list[Interval], float, Interval, TriadModel]:
    """:func:`detect_intervals` of a recording in blocks: the still part of each block its pose, the first the
    rest, the multiplier NaN."""
    if not blocks.poses:
        raise ValueError(f"no block of the recording is still for {min_hold:g} s: each pose must be held "
                         "still (or give a shorter hold with --min-hold SECONDS)")
    poses = blocks.poses
    return poses, float("nan"), poses[0], fit_determined(interval_means(recording.acc, poses), gravity)[0]


def _scan(recording: Recording, gravity: float, init_static: float | None, multipliers: list[float], window: float,
          min_interval: float, gyro_gate: bool) -> tuple[list[Interval], float, Interval, TriadModel]:
    """:func:`detect_intervals` of a recording with an initial rest and rotations: the multiplier scan, then
    again with the gyroscope's gate."""
    long_window = max(window, VARIANCE_WINDOW)
    win = odd_window(long_window, recording.rate)
    stat = variance_norm(recording.acc, win)  # eq. (D1): formed once: the initial rest's search reads it too
    if init_static is None and win == odd_window(REST_WINDOW, recording.rate):
        rest = find_initial_rest(recording, statistic=stat)
    else:
        rest = initial_rest(recording, init_static)
    detector = make_detector(recording, rest, window, min_interval, statistic=stat)
    intervals, mult, model = scan_thresholds(detector, gravity, recording, multipliers, window + min_interval, None)
    if gyro_gate and recording.gyro is not None:  # an accelerometer-only recording has no gate
        intervals, mult, model = _gyro_gated(recording, gravity, rest, detector, multipliers,
                                             window + min_interval, (intervals, mult, model))
    return intervals, mult, rest, model


def _gyro_gated(recording: Recording, gravity: float, rest: Interval, detector, multipliers: list[float],
                shortest: float, ungated: tuple) -> tuple[list[Interval], float, TriadModel]:
    """The scan again without the samples where the gyroscope is not still (:func:`detect_intervals`):
    ``(intervals, multiplier, model)``, those of the scan without the gate (``ungated``) when the gate finds
    the same or leaves too few poses."""

    intervals, mult, model = ungated
    bias = recording.gyro[rest.slice].mean(axis=0)
    try:
        scale = rough_scale(recording, intervals, model, bias)
    except ValueError:
        # the accelerometer found the poses but the gyroscope does not confirm them: say why when its
        # rotations disagree with the accelerometer's (axes swapped or reversed on one sensor)
        hint = axes_disagreement(recording, intervals, model, bias)
        if hint is not None:
            raise ValueError(hint) from None
        raise
    widest = detector_runs(detector, [max(multipliers) * detector[0]])[0]
    # gyro_still(recording, rest, scale, widest), its samples outside the intervals judged only when needed
    gyro = np.asarray(recording.gyro, dtype=np.float64)
    settings = still_settings(recording, rest, scale, STILL_RATE, STILL_WINDOW, STILL_N_SIGMA)
    still = np.empty(gyro.shape[0], dtype=bool)
    if still_inside(gyro, settings, widest, still, STILL_OFFSET):  # else the scan would find the same again
        return intervals, mult, model
    still_outside(gyro, settings, widest, still)
    try:
        gated = scan_thresholds(detector, gravity, recording, multipliers, shortest, still, reduce=False)
    except ValueError:
        hint = axes_disagreement(recording, intervals, model, bias)
        if hint is not None:
            raise ValueError(hint) from None
        # the gate leaves too few poses (hand-held poses that wobble): they are kept for the accelerometer,
        # weighted by their scatter, and unreliable_transitions leaves their rotations out of the gyroscope
        weights = 1.0 / pose_scatter(recording.acc, intervals)
        model = fit_determined(interval_means(recording.acc, intervals), gravity, weights=weights)[0]
        return intervals, mult, model
    if len(gated[0]) < len(intervals):  # the gate took poses out: a gyroscope whose axes are not the
        hint = axes_disagreement(recording, intervals, model, bias)  # accelerometer's is not still
        if hint is not None:
            raise ValueError(hint)
    intervals, mult, model = gated
    joined = join_blips(recording, intervals, settings)  # a moment of tremor does not part a hold
    if len(joined) < len(intervals):
        means = interval_means(recording.acc, joined)
        model = (fit_gravity_norm(means, gravity)[0] if len(joined) >= MIN_INTERVALS
                 else fit_determined(means, gravity)[0])
        intervals = joined
    return intervals, mult, model


def _hold_window(min_hold: float, window: float | None, min_interval: float | None) -> tuple[float, float]:
    """The detector's window and shortest run [s]: those given, else those of ``min_hold`` (``hold_settings``)."""
    hold_window, hold_run = hold_settings(min_hold)
    return (hold_window if window is None else float(window)), (hold_run if min_interval is None
                                                               else float(min_interval))


def static_at(recording: Recording, rest: Interval, multiplier: float, *, window: float = VARIANCE_WINDOW,
              min_interval: float = MIN_INTERVAL) -> list[Interval]:
    """Static intervals of the accelerometer variance detector at one threshold, ``multiplier`` × the rest's.

    Tedaldi 2014's detector without the scan (nothing is fitted): where the norm
    of the per-axis variance over ``window`` seconds stays below the threshold
    for at least ``min_interval`` seconds.
    """
    detector = make_detector(recording, rest, window, min_interval)
    return detector_runs(detector, [multiplier * detector[0]])[0]


def make_detector(recording: Recording, rest: Interval, window: float, min_interval: float,
                  statistic: np.ndarray | None = None) -> tuple:
    """The detector: its settings (:func:`detector_settings`) and statistic at the window of Tedaldi 2014
    (:data:`VARIANCE_WINDOW`, or ``window`` when longer; ``statistic`` when formed already), and, for a
    ``window`` shorter than that (one that finds short holds, :func:`imucalib.presets.hold_settings`), the same
    for ``window`` and ``min_interval`` (:func:`detector_runs`)."""
    long_window = max(window, VARIANCE_WINDOW)
    long_run = min_interval if window >= VARIANCE_WINDOW else max(min_interval, MIN_INTERVAL)
    base, win, min_len = detector_settings(recording.acc[rest.slice], recording.rate, long_window, long_run)
    stat = variance_norm(recording.acc, win) if statistic is None else statistic
    short = None
    if window < VARIANCE_WINDOW:
        _, short_win, short_len = detector_settings(recording.acc[rest.slice], recording.rate, window, min_interval)
        short = (short_win, short_len, variance_norm(recording.acc, short_win))
    return base, win, min_len, stat, short


def detector_runs(detector: tuple, thresholds: list[float], still: np.ndarray | None = None) -> list[list[Interval]]:
    """The static intervals of ``detector`` (:func:`make_detector`) at each threshold (samples outside ``still``
    excluded).

    The runs of Tedaldi 2014's window first; with a shorter window for short holds, its runs that overlap none of
    those are added: the holds too short for the long window. A hold long enough for both keeps the long
    window's run, which stops as far from the motions around it as Tedaldi's detector does (a shorter window's
    run reaches closer to them, into the settling of the hand).
    """
    _, _, min_len, stat, short = detector
    if still is not None:
        stat = np.where(still, stat, np.inf)
    found = static_runs(stat, thresholds, min_len)
    if short is None:
        return found
    _, short_len, short_stat = short
    if still is not None:
        short_stat = np.where(still, short_stat, np.inf)
    out = []
    for long_runs, short_runs in zip(found, static_runs(short_stat, thresholds, short_len), strict=True):
        starts = np.array([iv.start for iv in long_runs], dtype=np.int64)
        stops = np.array([iv.stop for iv in long_runs], dtype=np.int64)
        extra = [iv for iv in short_runs if not np.any((starts < iv.stop) & (stops > iv.start))]
        out.append(sorted(long_runs + extra, key=lambda iv: iv.start) if extra else long_runs)
    return out


def detector_settings(rest_acc: np.ndarray, rate: float, window: float, min_interval: float):
    """The accelerometer detector's base level (the rest's variance norm), window and shortest run [samples]."""
    base = float(np.linalg.norm(np.var(rest_acc, axis=0)))  # eq. (D1): ς_init
    if base <= 0:
        raise ValueError(
            "the initial rest has zero accelerometer variance (quantised or synthetic "
            "noise-free data?): the detector threshold cannot be set from it"
        )
    win = odd_window(window, rate)
    min_len = max(int(round(min_interval * rate)), 2)
    return base, win, min_len


class StillDetector:
    """The accelerometer detector of :func:`static_at` run as the samples arrive, for a live recording.

    The same settings (:func:`detector_settings`: the rest's variance norm,
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
        self.base, self.window, self.min_length = detector_settings(rest_acc, rate, window, min_interval)
        self.threshold = multiplier * self.base  # eq. (D2): k ς_init
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

    def _update(self, open_end: bool) -> list[Interval]:
        stat = self.stream.statistic
        start = self.intervals[-1].stop if self.intervals else 0
        found = detect_static(None, self.threshold, window=self.window, min_length=self.min_length,
                              statistic=stat[start:])
        new = [Interval(start + iv.start, start + iv.stop, iv.kind) for iv in found
               if open_end or start + iv.stop < stat.size]
        self.intervals += new
        return new


class IntervalMeans:
    """:func:`imucalib.metrics.interval_means` of ``x`` that forms each interval's mean once (the same numbers:
    each interval's mean is its own sum), for the thresholds of a scan whose intervals mostly recur.

    About 2 % of calibrating the Xsens session; kept under the 10 % bar with the other means of the threshold
    scan and the models' per-axis form: without the four, calibrating the Xsens session took 0.141 s against
    0.125 s before (benchmarks/bench_tedaldi2014.py and a profile, in turns).
    """

    def __init__(self, x: np.ndarray) -> None:
        self.x = np.asarray(x, dtype=np.float64)
        self.columns = np.ascontiguousarray(self.x.T) if self.x.nbytes <= TRANSPOSE_BYTES else None
        self.known: dict[tuple[int, int], np.ndarray] = {}

    def __call__(self, intervals: list[Interval]) -> np.ndarray:
        new = [iv for iv in intervals if (iv.start, iv.stop) not in self.known]
        if new:
            for iv, row in zip(new, pose_means(self.x, new, self.columns), strict=True):
                self.known[iv.start, iv.stop] = row
        return np.array([self.known[iv.start, iv.stop] for iv in intervals])


def static_runs(stat: np.ndarray, thresholds: list[float], min_length: int) -> list[list[Interval]]:
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
        below += stat < t  # eq. (D2) at each threshold
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


def scan_thresholds(detector: tuple, gravity: float, recording: Recording, multipliers: Iterable[float],
                    hold: float, still: np.ndarray | None, *,
                    reduce: bool = True) -> tuple[list[Interval], float, TriadModel]:
    """The Tedaldi 2014 multiplier scan over the accelerometer variance (samples outside ``still`` excluded);
    with ``reduce``, fewer than :data:`MIN_INTERVALS` intervals at every threshold give the most that determine
    a model (:func:`imucalib.fit.accelerometer.fit_determined`), else an error."""
    base = detector[0]
    best = None
    tried = []
    means = IntervalMeans(recording.acc)
    fits: dict[tuple, tuple | None] = {}  # thresholds that give the same intervals give the same fit
    multipliers = list(multipliers)
    found = detector_runs(detector, [mult * base for mult in multipliers], still)  # eq. (D2) at each k
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
                fits[key] = (float(res @ res) / len(res), model)  # eq. (D3): the score: per residual
        if fits[key] is None:
            continue
        score, model = fits[key]
        if best is None or score < best[0]:  # eq. (D3): the k of the least score
            best = (score, mult, intervals, model)
    if best is None:
        # fewer intervals than the full model wants at every threshold: the most that determine a model
        by_mult = dict(zip(multipliers, found, strict=True))
        for mult, _ in sorted(tried, key=lambda mc: -mc[1]) if reduce else []:
            intervals = by_mult[mult]
            try:
                model = fit_determined(means(intervals), gravity)[0]
            except ValueError:
                continue
            return intervals, float(mult), model
        counts = ", ".join(f"×{m}: {c}" for m, c in tried)
        raise ValueError(
            "too few static intervals for a calibration at every detector threshold "
            f"({counts}; at least 4 in spread directions determine a model, {MIN_INTERVALS} the full one): hold "
            f"the sensor still for at least {hold:g} s in each of many poses"
        )
    _, mult, intervals, model = best
    return intervals, float(mult), model


def static_poses(recording: Recording, gravity: float, intervals: list[Interval] | None = None, *,
                 init_static: float | None = None, min_hold: float = MIN_HOLD) -> list[Interval]:
    """The static intervals given, or those :func:`detect_intervals` finds (a recording's blocks,
    :func:`pose_blocks`); the first is the initial rest."""
    if intervals is None:
        intervals = detect_intervals(recording, gravity, init_static=init_static, min_hold=min_hold)[0]
    return [iv for iv in intervals if iv.kind == "static"]
