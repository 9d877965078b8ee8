r"""Allan deviation and the noise parameters read from it (Ru 2022, §2.2; IEEE Std 952).

The definitions are the standard ones of IEEE Std 952 (Annex C, the Allan
variance and its noise terms), labelled (A1)–(A4) here. For a rate signal
``x`` of ``N`` samples at ``f_s`` and cluster time ``τ = m/f_s``, the
overlapping Allan variance is computed from the integrated signal (its mean
taken out first, which the second differences cancel):

.. math::

    \theta_k = \frac{1}{f_s} \sum_{i<k} x_i, \qquad
    \sigma^2(\tau) = \frac{1}{2 \tau^2 (N + 1 - 2m)} \sum_{k=0}^{N-2m}
    \bigl(\theta_{k+2m} - 2\theta_{k+m} + \theta_k\bigr)^2 \qquad \text{(A1)}

(``θ_0 … θ_N``: the sum has ``N + 1 − 2m`` terms).

On a log–log plot, white noise (angle/velocity random walk ``N``) has slope
−½ with ``σ(τ) = N/√τ`` (read at ``τ = 1`` s), bias instability ``B`` is the flat
minimum, ``σ_min ≈ 0.664 B``, and rate random walk ``K`` has slope +½ with
``σ(τ) = K √(τ/3)``; the three together:

.. math::

    \sigma^2(\tau) = \frac{N^2}{\tau} + \frac{2 \ln 2}{\pi} B^2 + \frac{K^2 \tau}{3} \qquad \text{(A2)}

The relative 1σ of a deviation from ``K_c = N/m`` clusters, and the χ²
confidence interval of one from ``ν`` degrees of freedom (IEEE Std 952,
Annex C; NIST SP 1065, §5.3):

.. math::

    \delta(\tau) = \frac{1}{\sqrt{2 (K_c - 1)}} \qquad \text{(A3)}, \qquad
    \hat\sigma^2 \sim \sigma^2 \chi^2_\nu / \nu \qquad \text{(A4)}

A term is a figure only where the curve shows its slope within the
confidence its number of clusters gives, and only when the clusters there
read it within ``FIGURE_PRECISION`` (:func:`noise_parameters`); elsewhere
only its upper bound holds, and the files written from it say so
(:func:`kalibr_yaml`). A bump of the curve (a vibration, a filter's
ringing) therefore never becomes a random walk.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .recording import STANDARD_GRAVITY

if TYPE_CHECKING:
    from .recording import Recording

__all__ = ["BOUND_MARK", "allan_confidence", "allan_deviation", "allan_dof", "check_rest", "chi2_limits",
           "kalibr_noise", "kalibr_yaml", "local_slopes", "noise_parameters", "noise_summary", "random_walk_bound"]


def allan_deviation(x: np.ndarray, rate: float, taus: np.ndarray | None = None,
                    *, points: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of each column of ``x`` (N,) or (N, K).

    Parameters
    ----------
    x : array_like
        Rate samples (any unit).
    rate : float
        Sampling rate [Hz].
    taus : array_like, optional
        Cluster times [s]; default ``points`` log-spaced values from one sample
        to a tenth of the record.

    Returns
    -------
    taus : (T,) ndarray
        The cluster times actually used (rounded to whole samples) [s].
    adev : (T,) or (T, K) ndarray
        Allan deviation in the unit of ``x``.
    """
    x = np.asarray(x, dtype=np.float64)
    squeeze = x.ndim == 1
    if squeeze:
        x = x[:, None]
    n = x.shape[0]
    if n < 8:
        raise ValueError(f"an Allan deviation needs at least 8 samples; got {n}")
    if taus is None:
        m = np.unique(np.round(np.geomspace(1, max(n // 10, 2), points)).astype(int))
    else:
        m = np.unique(np.round(np.asarray(taus, dtype=float) * rate).astype(int))
        m = m[(m >= 1) & (m <= (n - 1) // 2)]
        if m.size == 0:
            raise ValueError("no cluster time fits the record: use shorter taus or a longer record")
    # θ per column as one contiguous row: the second differences then run over 1-D arrays that stay in
    # the cache, in place, and are squared and summed by einsum rather than a BLAS dot product, whose
    # threads only contend on a shared machine (benchmarks/bench_allan.py)
    theta = np.zeros((x.shape[1], n + 1))
    np.cumsum((x - x.mean(axis=0)).T, axis=1, out=theta[:, 1:])  # eq. (A1): θ_k
    theta /= rate
    out = np.empty((m.size, x.shape[1]))
    for j, th in enumerate(theta):
        for i, mm in enumerate(m):
            d = th[2 * mm :] - th[mm:-mm]  # eq. (A1): θ_{k+2m} − 2θ_{k+m} + θ_k
            d -= th[mm:-mm]
            d += th[: -2 * mm]
            tau = mm / rate
            out[i, j] = np.sqrt(np.einsum("i,i->", d, d) / (2 * tau**2 * d.size))  # eq. (A1)
    taus_used = m / rate
    return taus_used, (out[:, 0] if squeeze else out)


#: a term is read from the curve only where its slope holds over this factor of cluster times (half a decade)
SLOPE_SPAN = 10**0.5
#: confidence multiplier of the slope and bound tests (about 95 % on either side)
CONFIDENCE = 2.0
#: the slope may differ from the term's own by this much beyond its confidence (the neighbouring terms' share)
SLOPE_TOLERANCE = 0.1
#: σ(τ) of bias instability on its flat floor, ``σ = √(2 ln 2 / π) B`` (IEEE Std 952, Table C.1)
FLOOR = np.sqrt(2 * np.log(2) / np.pi)  # eq. (A2): 0.664

#: a term's figure is stated only when, at ``CONFIDENCE``, it lies within this fraction of the truth
FIGURE_PRECISION = 0.2

#: log-log slope of each term (IEEE Std 952, Annex C): white noise −½, bias instability 0, random walk +½
_SLOPES = {"white_noise_density": -0.5, "bias_instability": 0.0, "random_walk": 0.5}


def allan_confidence(taus: np.ndarray, rate: float, samples: int) -> np.ndarray:
    """Relative 1σ error of each Allan deviation from the number of clusters it averages.

    ``δ(τ) = 1 / √(2 (K − 1))`` with ``K = N / m`` clusters of ``m = τ f_s``
    samples (IEEE Std 952, Annex C, the percentage error of an Allan
    deviation; Hou 2004, cited as ref. 49 by Ru 2022). The overlapping
    estimator does a little better on white noise and the same on random walk
    (tests/test_noise.py compares it with allantools' equivalent degrees of
    freedom), so ``δ`` is on the safe side.
    """
    clusters = samples / np.maximum(np.round(np.asarray(taus, dtype=float) * rate), 1)
    return 1 / np.sqrt(2 * np.maximum(clusters - 1, 1e-12))  # eq. (A3)


def allan_dof(taus: np.ndarray, rate: float, samples: int, term: str) -> np.ndarray:
    """Equivalent degrees of freedom of the overlapping Allan variance at each cluster time, for one noise term.

    The approximations of NIST SP 1065 (Riley 2008, Table 5, after Howe,
    Allan and Barnes 1981), with ``M = samples + 1`` integrated points and
    ``m = τ f_s``:

    * white noise (white frequency noise, the −½ slope):
      ``ν = (3(M−1)/(2m) − 2(M−2)/M) · 4m²/(4m² + 5)``;
    * bias instability (flicker frequency noise, flat):
      ``ν = 5M² / (4m(M + 3m))``;
    * random walk (random-walk frequency noise, the +½ slope):
      ``ν = (M−2)/m · ((M−1)² − 3m(M−1) + 4m²)/(M−3)²``.

    The variance estimate is then distributed as ``σ² χ²_ν / ν``
    (:func:`chi2_limits`). Over the cluster times a term is read at (tens of
    samples and more) these agree with Greenhall's algorithm to a few per cent
    (tests/test_noise.py compares them with allantools' ``edf_greenhall``).

    Parameters
    ----------
    taus : array_like
        Cluster times [s].
    rate : float
        Sampling rate [Hz].
    samples : int
        Number of rate samples.
    term : {"white_noise_density", "bias_instability", "random_walk"}
        The noise term whose statistics apply.

    Returns
    -------
    ndarray
        ``ν`` per cluster time (at least 1).
    """
    m = np.maximum(np.round(np.asarray(taus, dtype=float) * rate), 1)
    big = float(samples) + 1
    if term == "white_noise_density":
        nu = (3 * (big - 1) / (2 * m) - 2 * (big - 2) / big) * 4 * m**2 / (4 * m**2 + 5)
    elif term == "bias_instability":
        nu = 5 * big**2 / (4 * m * (big + 3 * m))
    elif term == "random_walk":
        nu = (big - 2) / m * ((big - 1) ** 2 - 3 * m * (big - 1) + 4 * m**2) / (big - 3) ** 2
    else:
        raise ValueError(f"unknown noise term {term!r}")
    return np.maximum(nu, 1.0)


def chi2_limits(dof: np.ndarray, confidence: float = CONFIDENCE) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper confidence limits of a deviation over its estimate, from its degrees of freedom.

    A variance estimated with ``ν`` degrees of freedom is distributed as
    ``σ² χ²_ν / ν`` (IEEE Std 952, Annex C; NIST SP 1065, §5.3), so the
    deviation lies between ``σ̂ √(ν / χ²_ν(1 − p))`` and ``σ̂ √(ν / χ²_ν(p))`` with
    ``p`` the normal tail beyond ``confidence`` standard deviations (2: 2.3 %
    each side). With few clusters the upper limit is well above the linear
    ``1 + confidence·δ``: a long cluster time's low reading is likely.

    Returns
    -------
    lower, upper : ndarray
        The factors that multiply the estimate.
    """
    from scipy.stats import chi2, norm  # scipy.stats costs 880 ms at start-up

    dof = np.asarray(dof, dtype=float)
    p = norm.sf(confidence)
    return np.sqrt(dof / chi2.isf(p, dof)), np.sqrt(dof / chi2.ppf(p, dof))  # eq. (A4)


def local_slopes(taus: np.ndarray, adev: np.ndarray, delta: np.ndarray,
                 span: float = SLOPE_SPAN) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Log-log slope of the Allan deviation from each cluster time to the one ``span`` times longer.

    Returns ``(end, slope, sigma)`` per starting point ``i`` (entries of the
    points with no end inside the curve are NaN, ``end`` −1): ``end[i]`` the
    index of the first ``τ_j ≥ span τ_i``, ``slope = ln(σ_j/σ_i) / ln(τ_j/τ_i)``
    and its 1σ ``√(δ_i² + δ_j²) / ln(τ_j/τ_i)`` from the confidences ``δ``
    (:func:`allan_confidence`; the two ends share data, which only makes this
    larger than the truth).
    """
    adev = adev if adev.ndim == 2 else adev[:, None]
    end = np.searchsorted(taus, taus * span * (1 - 1e-9))
    ok = end < taus.size
    end = np.where(ok, end, -1)
    slope = np.full(adev.shape, np.nan)
    sigma = np.full(taus.shape, np.nan)
    i = np.nonzero(ok)[0]
    j = end[ok]
    lever = np.log(taus[j] / taus[i])
    with np.errstate(divide="ignore", invalid="ignore"):
        slope[i] = np.log(adev[j] / adev[i]) / lever[:, None]
    sigma[i] = np.hypot(delta[i], delta[j]) / lever
    return end, slope, sigma


def _shown(slope: np.ndarray, sigma: np.ndarray, p: float) -> np.ndarray:
    """Where a local slope shows the term of slope ``p``: within its confidence (and the tolerance) of ``p``
    and, with that confidence, apart from the neighbouring terms' slopes ``p ± ½``."""
    off = np.abs(slope - p)
    z = CONFIDENCE * sigma
    with np.errstate(invalid="ignore"):
        return (off <= z + SLOPE_TOLERANCE) & (off < 0.5 - z) & (off <= 0.25)


def _bounds(taus: np.ndarray, adev: np.ndarray, delta: np.ndarray, rate: float, n: int, k: int) -> tuple:
    """Each term's relative 1σ per cluster time, and :func:`noise_parameters`' output with the three upper
    bounds and the figures still NaN."""
    # each term's own degrees of freedom per cluster time, or the clusters' K − 1 where fewer (the safe side;
    # a bound is the least over many cluster times): the 1σ of its reading and the χ² upper limit of σ
    dof = {name: np.minimum(allan_dof(taus, rate, n, name), 0.5 / delta**2) for name in _SLOPES}
    rel = {name: 1 / np.sqrt(2 * nu) for name, nu in dof.items()}
    upper = {name: adev * chi2_limits(nu)[1][:, None] for name, nu in dof.items()}  # eq. (A4)
    out = {name: np.full(k, np.nan) for name in _SLOPES}
    # eq. (A2): N ≤ σ⁺ √τ
    out["white_noise_density_bound"] = np.min(upper["white_noise_density"] * np.sqrt(taus)[:, None], axis=0)
    out["bias_instability_bound"] = np.min(upper["bias_instability"], axis=0) / FLOOR  # eq. (A2): B ≤ σ⁺ / 0.664
    # eq. (A2): K ≤ σ⁺ √(3/τ)
    out["random_walk_bound"] = np.min(upper["random_walk"] * np.sqrt(3 / taus)[:, None], axis=0)
    return rel, out


def _regions(end: np.ndarray, slope: np.ndarray, sigma: np.ndarray, size: int) -> dict[str, np.ndarray]:
    """Per term, the cluster times of one column's curve that show its slope (every point of every half
    decade that does)."""
    region = {}
    for name, p in _SLOPES.items():
        idx = np.nonzero(_shown(slope, sigma, p))[0]
        pts = np.zeros(size, dtype=bool)
        for i in idx:  # every point of every half decade that shows the slope
            pts[i : end[i] + 1] = True
        region[name] = pts
    return region


def _read_column(out: dict, j: int, taus: np.ndarray, adev: np.ndarray, delta: np.ndarray, rel: dict,
                 region: dict) -> None:
    """The three figures of column ``j`` (Allan deviation ``adev``) written into ``out``, each read over its
    ``region`` as :func:`noise_parameters` says."""
    s2 = adev ** 2
    spread = {}
    # two passes: each term read with the other's share taken out once that one is known
    for _ in range(2):
        kk = np.nan_to_num(out["random_walk"][j])
        nn = np.nan_to_num(out["white_noise_density"][j])
        own = {"white_noise_density": s2 - kk**2 * taus / 3, "random_walk": s2 - nn**2 / taus}  # eq. (A2)
        for name, scale in (("white_noise_density", taus), ("random_walk", 3 / taus)):
            r = region[name] & (own[name] > 0)
            if not r.any():
                continue
            # the term's share of σ² carries all of the scatter of σ²: its relative 1σ is δ / share
            spread_r = rel[name][r] * s2[r] / own[name][r]
            out[name][j] = np.sqrt(np.average(scale[r] * own[name][r], weights=spread_r**-2))
            spread[name] = float(np.min(spread_r))
    read = {name: float(np.nan_to_num(out[name][j])) for name in ("white_noise_density", "random_walk")}
    for name, d in spread.items():
        # the region's cluster times share their data: the figure is about as precise as its best one, and
        # is stated only when it lies within FIGURE_PRECISION of the truth at CONFIDENCE: the truth over the
        # figure between 1/(1 + P) and 1/(1 − P)
        lower, upper_f = chi2_limits(1 / (2 * d**2))
        if lower < 1 / (1 + FIGURE_PRECISION) or upper_f > 1 / (1 - FIGURE_PRECISION):
            out[name][j] = np.nan
    if region["bias_instability"].any():
        # the floor is a term of its own only where it stands out of the other two beyond its confidence
        # (white noise meeting a random walk also has a flat minimum, of (2NK/√3)^½)
        r = np.nonzero(region["bias_instability"])[0]
        i = r[np.argmin(adev[r])]
        nn, kk = read["white_noise_density"], read["random_walk"]  # their shares, stated or not
        floor2 = s2[i] - nn**2 / taus[i] - kk**2 * taus[i] / 3  # eq. (A2)
        if floor2 > 2 * CONFIDENCE * delta[i] * s2[i]:  # the relative 1σ of σ² is 2δ
            out["bias_instability"][j] = np.sqrt(floor2) / FLOOR


def noise_parameters(x: np.ndarray, rate: float) -> dict[str, np.ndarray]:
    """White noise density, bias instability and random walk per column, each read where the curve shows it.

    The Allan deviation ``σ(τ)`` (:func:`allan_deviation`) of a sum of the three
    terms is ``σ² = N²/τ + (0.664 B)² + K² τ/3`` (IEEE Std 952, Annex C). Each
    term is a *figure* only over the cluster times where the curve has its
    slope (−½, 0, +½): the local slope over half a decade
    (:func:`local_slopes`) must agree with it within ``CONFIDENCE`` times its
    1σ from the number of clusters (:func:`allan_confidence`) and be told
    apart from the neighbouring slopes with the same confidence. There

    * ``N² = τ σ² − K² τ²/3`` (the random walk subtracted where it is a figure),
    * ``K² = 3 (σ² − N²/τ) / τ`` (the white noise subtracted where it is a figure),
    * ``B = √(σ² − N²/τ − K²τ/3) / 0.664`` at the minimum of the flat region, a
      figure only when that floor exceeds the confidence of ``σ²`` (``4δσ²``).

    N and K are averaged over their region with weights ``1/δ_t²``, where
    ``δ_t = δ σ²/σ_t²`` is the relative 1σ of the term read at that cluster
    time: ``δ = 1/√(2ν)`` with ν the term's degrees of freedom
    (:func:`allan_dof`) or the clusters' ``K − 1`` where fewer (the safe
    side, :func:`allan_confidence`), magnified by the share ``σ_t²/σ²`` of the curve the
    term holds there (at the short end of a random walk's region the white
    noise still holds most of ``σ²`` and all of its scatter). The region's
    cluster times share their data, so a figure is about as precise as its
    best cluster time, ``min δ_t``; it is stated only when its χ² confidence
    interval (:func:`chi2_limits`, at ``CONFIDENCE``) puts it within
    ``FIGURE_PRECISION`` of the truth. A region that shows the slope only at
    the longest cluster times, with ten to forty clusters, therefore gives a
    bound: a reading there is off by a fifth one time in twenty.

    Elsewhere (and where B or K would exceed its own bound) the figure is NaN
    and only its upper bound holds, from every cluster time: each term alone
    cannot exceed the whole curve, so with ``σ⁺`` the χ² upper limit of ``σ``
    at ``CONFIDENCE`` for that term's degrees of freedom,
    ``N ≤ min σ⁺ √τ``, ``B ≤ min σ⁺ / 0.664`` and ``K ≤ min σ⁺ √(3/τ)``.

    Parameters
    ----------
    x : (N,) or (N, K) array_like
        Rate samples at rest (any unit).
    rate : float
        Sampling rate [Hz].

    Returns
    -------
    dict
        Per column: ``white_noise_density`` N [unit·√s], ``bias_instability``
        B [unit], ``random_walk`` K [unit/√s] (NaN where the curve does not
        show the term), their ``*_bound`` (upper bounds, always finite),
        ``white_noise_per_sample`` ``N √f_s`` [unit], ``resolution`` (the
        smallest step between the values of a quantised column, whose values
        repeat; NaN for continuous values and for a constant column)
        and ``constant`` (True where every sample is the same: the noise is
        below the resolution and every figure and bound is NaN).
    """
    x = np.asarray(x, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    n, k = x.shape
    taus, adev = allan_deviation(x, rate)
    adev = adev if adev.ndim == 2 else adev[:, None]
    delta = allan_confidence(taus, rate, n)
    end, slope, sigma = local_slopes(taus, adev, delta)
    rel, out = _bounds(taus, adev, delta, rate, n, k)
    constant = np.ptp(x, axis=0) == 0
    for j in range(k):
        if constant[j]:
            continue
        _read_column(out, j, taus, adev[:, j], delta, rel, _regions(end, slope[:, j], sigma, taus.size))
    for name in _SLOPES:
        out[name + "_bound"][constant] = np.nan
    for name in ("bias_instability", "random_walk"):
        # a figure above what every cluster time allows is not that term's: the curve only looked like it (the
        # white noise's bound comes from the very cluster times its figure is read at, to their scatter)
        out[name][out[name] > out[name + "_bound"]] = np.nan
    out["white_noise_per_sample"] = out["white_noise_density"] * np.sqrt(rate)
    out["resolution"] = np.array([_resolution(x[:, j]) for j in range(k)])
    out["constant"] = constant
    return out


def _resolution(column: np.ndarray) -> float:
    """The smallest step between distinct values of a quantised column (values repeat), else NaN."""
    part = column[:200_000]
    values = np.unique(part)
    if values.size < 2 or values.size > part.size / 4:  # continuous values: no resolution to speak of
        return float("nan")
    return float(np.min(np.diff(values)))


def random_walk_bound(x: np.ndarray, rate: float) -> np.ndarray:
    """Upper bound of the rate random walk ``K`` per column, from every cluster time.

    A rate random walk adds ``K²τ/3`` to the Allan variance and nothing
    subtracts from it, so ``K ≤ σ(τ)·√(3/τ)`` at every ``τ``; with ``σ`` raised
    by twice its relative error (:func:`allan_confidence`) the smallest of
    these is the bound (:func:`noise_parameters`).
    """
    return noise_parameters(x, rate)["random_walk_bound"]


#: the comment that marks a noise entry as an upper bound rather than a measured value (files read it back)
BOUND_MARK = "upper bound, not measured"

#: |a| at rest against gravity with physical units: the relative difference that warns, and that refuses
REST_NORM_REL = (0.05, 0.15)
#: above this rate [Hz] a time column read in microseconds is worth a second look (IMUs rarely record faster)
HIGH_RATE_HZ = 2000.0


def check_rest(recording: Recording, gravity: float = STANDARD_GRAVITY) -> list[str]:
    """The checks ``calibrate`` makes of its input, for a rest whose noise is measured; warnings to show.

    * the sampling rate must be one an IMU records at
      (:func:`imucalib.verdict.check_rate`); above :data:`HIGH_RATE_HZ`, a
      warning names the time-unit mix-up that would explain it (Arduino
      ``millis()`` stamps read as microseconds make 62.5 Hz look like
      62.5 kHz and every density √1000 too small);
    * with the accelerometer in ``g`` or ``m/s^2``, ``|a|`` at rest must be
      gravity: off by :data:`REST_NORM_REL` it warns, beyond the second limit it
      refuses (the unit is wrong, and every figure with it).

    Raises
    ------
    ValueError
        At a rate no IMU records at, or an ``|a|`` at rest no unit mix-up short
        of a wrong unit explains.
    """
    from .verdict import check_rate, time_unit_hint  # imucalib.verdict costs 96 ms at start-up

    check_rate(recording)
    out = []
    if recording.rate > HIGH_RATE_HZ and recording.metadata.get("time_unit") in ("us", "ns"):
        out.append(f"the sampling rate is {recording.rate:.4g} Hz, high for an IMU: if it is not, "
                   f"{time_unit_hint(recording)}; every noise density scales with it")
    unit = recording.acc_unit
    if unit in ("g", "m/s^2") and len(recording):
        norm = float(np.linalg.norm(np.mean(recording.acc, axis=0))) * (gravity if unit == "g" else 1.0)
        rel = abs(norm / gravity - 1)
        if rel > REST_NORM_REL[0]:
            other = norm / gravity if unit == "g" else norm * gravity
            likely = " (the data look like m/s^2)" if unit == "g" and abs(other / gravity - 1) < REST_NORM_REL[0] \
                else " (the data look like g)" if unit == "m/s^2" and abs(norm - 1) < REST_NORM_REL[0] else ""
            text = (f"|a| at rest is {norm:.4g} m/s² read as {unit}, {100 * rel:.0f} % from gravity "
                    f"{gravity:.5g} m/s²{likely}: check --acc-unit")
            if rel > REST_NORM_REL[1]:
                raise ValueError(text + "; the noise figures would be in the wrong unit")
            out.append(text)
    return out


def noise_summary(recording: Recording) -> dict:
    """The noise parameters of both sensors of a recording at rest (``imucalib noise``).

    Parameters
    ----------
    recording : Recording
        Samples of the sensor at rest, e.g. the initial rest
        (``recording[find_initial_rest(recording)]``); any units.

    Returns
    -------
    dict
        ``{"seconds", "samples", "rate_hz", "accelerometer": {...},
        "gyroscope": {...}}`` (no ``"gyroscope"`` for an accelerometer-only
        recording); each sensor's entry holds its ``unit``, the
        :func:`noise_parameters` per axis (figures NaN where the curve does not
        show them, their bounds beside), ``notes`` on constant and quantised
        columns and ``bounds``, which terms are only bounds and why, as lists
        (JSON-ready; :func:`kalibr_yaml` takes them as they are).
    """
    out = {"seconds": recording.duration, "samples": len(recording), "rate_hz": recording.rate}
    for name, x, unit in (("accelerometer", recording.acc, recording.acc_unit),
                          ("gyroscope", recording.gyro, recording.gyro_unit)):
        if x is None:
            continue
        p = noise_parameters(x, recording.rate)
        notes, bounds = _notes(name, p, unit)
        out[name] = {"unit": unit, **{k: v.tolist() for k, v in p.items()}, "notes": notes, "bounds": bounds}
    return out


def _notes(name: str, p: dict, unit: str) -> tuple[list[str], list[str]]:
    """Notes on the columns (constant, at the resolution), and on the terms that are only bounds."""
    notes, bounds = [], []
    for j, axis in enumerate("xyz"[: p["constant"].size]):
        if p["constant"][j]:
            notes.append(f"{name} {axis} is constant over the rest: its noise is below the resolution (no figure)")
    live = ~p["constant"]
    for j, axis in enumerate("xyz"[: live.size]):
        q = p["resolution"][j]
        white = p["white_noise_per_sample"][j]
        if live[j] and np.isfinite(q) and (not np.isfinite(white) or white < q):
            notes.append(f"{name} {axis}: the noise per sample is below one step of the resolution ({q:.3g} {unit}): "
                         "the figures describe the quantisation as much as the sensor")
    terms = (("white_noise_density", "white noise", "−½", f"{unit}·√s"),
             ("bias_instability", "bias instability", "flat", unit),
             ("random_walk", "random walk", "+½", f"{unit}/√s"))
    for key, what, slope, u in terms:
        missing = [a for j, a in enumerate("xyz"[: live.size]) if live[j] and not np.isfinite(p[key][j])]
        if missing:
            bound = ", ".join(f"{p[key + '_bound'][j]:.3g}" for j, a in enumerate("xyz") if a in missing)
            bounds.append(f"{name} {', '.join(missing)}: the Allan curve shows no {slope} slope of the {what} "
                          f"within its confidence, or over too few clusters to read it within "
                          f"{100 * FIGURE_PRECISION:.0f} %: only its upper bound {bound} {u}")
    return notes, bounds


def kalibr_noise(acc: dict, gyro: dict) -> tuple[dict[str, float], list[str]]:
    """The four noise entries of Kalibr's IMU model from SI noise parameters, and notes.

    ``acc`` and ``gyro`` hold ``white_noise_density`` and ``random_walk``
    per axis (:func:`noise_parameters`, in m/s² and rad/s; NaN or None where the
    Allan curve does not show the term) and optionally their upper bounds
    ``white_noise_density_bound`` and ``random_walk_bound``; each entry takes the
    largest axis, the bound where an axis has no figure. Returns
    ``{"accelerometer_noise_density", "accelerometer_random_walk",
    "gyroscope_noise_density", "gyroscope_random_walk", "bounded"}`` (``bounded``
    lists the entries that are upper bounds) and notes on what was bounded
    rather than measured.

    Raises
    ------
    ValueError
        When an axis has neither a figure nor a bound of an entry (every sample
        the same: the noise is below the resolution).
    """
    notes, bounded = [], []

    def pick(d, name, key, what):
        v = np.array([np.nan if a is None else a for a in d[key]], dtype=float)
        if np.all(np.isfinite(v)):
            return float(np.max(v))
        bound = np.array([np.nan if a is None else a for a in d.get(key + "_bound", [None] * v.size)], dtype=float)
        take = np.where(np.isfinite(v), v, bound)
        missing = [a for a, f in zip("xyz", v, strict=True) if not np.isfinite(f)]
        if not np.all(np.isfinite(take)):
            raise ValueError(f"{name} {', '.join(missing)}: no {what} and no bound of it (a constant column: the "
                             "noise is below the resolution); the file cannot hold a value")
        notes.append(f"{name} {', '.join(missing)}: the Allan curve does not show the {what} (too short a rest, or "
                     "another term dominates): the file takes its upper bound, not a measured value (record a "
                     "longer rest for the value)")
        bounded.append(f"{name}_{'noise_density' if key == 'white_noise_density' else 'random_walk'}")
        return float(np.max(take))

    na = pick(acc, "accelerometer", "white_noise_density", "white noise")
    ka = pick(acc, "accelerometer", "random_walk", "bias random walk")
    ng = pick(gyro, "gyroscope", "white_noise_density", "white noise")
    kg = pick(gyro, "gyroscope", "random_walk", "bias random walk")
    return {"accelerometer_noise_density": na, "accelerometer_random_walk": ka,
            "gyroscope_noise_density": ng, "gyroscope_random_walk": kg, "bounded": bounded}, notes


def kalibr_yaml(acc: dict, gyro: dict, rate: float, *, topic: str = "/imu0") -> tuple[str, list[str]]:
    """The IMU noise file of Kalibr / OpenVINS / VINS (``imu.yaml``) from SI noise parameters.

    The entries of :func:`kalibr_noise` (largest axis of each), the topic and
    the rate; each entry that is an upper bound rather than a measured value
    says so in a comment line. Returns the text and notes on what was bounded
    rather than measured.
    """
    v, notes = kalibr_noise(acc, gyro)

    def mark(key):
        return f" {BOUND_MARK}" if key in v["bounded"] else ""

    text = "\n".join([
        "# IMU noise from the Allan deviation of a rest (imucalib noise), largest axis; Kalibr's format",
        *[f"# {n}" for n in notes],
        f"accelerometer_noise_density: {v['accelerometer_noise_density']:.6e}   "
        f"# [ m / s^2 / sqrt(Hz) ]   ( accel \"white noise\" ){mark('accelerometer_noise_density')}",
        f"accelerometer_random_walk: {v['accelerometer_random_walk']:.6e}     "
        f"# [ m / s^3 / sqrt(Hz) ]   ( accel bias diffusion ){mark('accelerometer_random_walk')}",
        f"gyroscope_noise_density: {v['gyroscope_noise_density']:.6e}       "
        f"# [ rad / s / sqrt(Hz) ]   ( gyro \"white noise\" ){mark('gyroscope_noise_density')}",
        f"gyroscope_random_walk: {v['gyroscope_random_walk']:.6e}         "
        f"# [ rad / s^2 / sqrt(Hz) ] ( gyro bias diffusion ){mark('gyroscope_random_walk')}",
        f"rostopic: {topic}",
        f"update_rate: {rate:.6g}   # [ Hz ]",
        "",
    ])
    return text, notes
