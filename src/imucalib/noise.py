"""Allan deviation and the noise parameters read from it (Ru 2022, §2.2; IEEE Std 952).

For a rate signal ``x`` sampled at ``f_s`` and cluster time ``τ = m/f_s``, the
overlapping Allan variance is computed from the integrated signal
``θ_k = Σ_{i<k} x_i / f_s``::

    σ²(τ) = Σ_k (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2 τ² (N − 2m))

On a log–log plot, white noise (angle/velocity random walk ``N``) has slope
−½ with ``σ(τ) = N/√τ`` (read at ``τ = 1`` s), bias instability ``B`` is the flat
minimum, ``σ_min ≈ 0.664 B``, and rate random walk ``K`` has slope +½ with
``σ(τ) = K √(τ/3)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .recording import Recording

__all__ = ["allan_deviation", "kalibr_noise", "kalibr_yaml", "noise_parameters", "noise_summary", "random_walk_bound"]


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
    np.cumsum((x - x.mean(axis=0)).T, axis=1, out=theta[:, 1:])
    theta /= rate
    out = np.empty((m.size, x.shape[1]))
    for j, th in enumerate(theta):
        for i, mm in enumerate(m):
            d = th[2 * mm :] - th[mm:-mm]  # θ_{k+2m} − 2θ_{k+m} + θ_k
            d -= th[mm:-mm]
            d += th[: -2 * mm]
            tau = mm / rate
            out[i, j] = np.sqrt(np.einsum("i,i->", d, d) / (2 * tau**2 * d.size))
    taus_used = m / rate
    return taus_used, (out[:, 0] if squeeze else out)


def noise_parameters(x: np.ndarray, rate: float) -> dict[str, np.ndarray]:
    """White noise density, bias instability and random walk per column, from the Allan deviation.

    Returns ``{"white_noise_density": N [unit·√s], "bias_instability": B [unit],
    "random_walk": K [unit/√s], "white_noise_per_sample": σ [unit]}``; ``N`` is
    read from the −½ slope fitted over cluster times up to 1 s, ``K`` from the
    longest cluster times where the slope is +½ (NaN when not reached).
    """
    taus, adev = allan_deviation(x, rate)
    adev = adev if adev.ndim == 2 else adev[:, None]
    short = taus <= max(1.0, taus[min(3, taus.size - 1)])
    white = np.sqrt(np.mean((adev[short] * np.sqrt(taus[short])[:, None]) ** 2, axis=0))  # σ√τ
    bias = adev.min(axis=0) / 0.664
    slope = np.diff(np.log(adev), axis=0) / np.diff(np.log(taus))[:, None]
    k = np.full(adev.shape[1], np.nan)
    for j in range(adev.shape[1]):
        rising = np.nonzero(slope[:, j] > 0.3)[0]
        if rising.size:
            i = rising[-1] + 1
            k[j] = adev[i, j] / np.sqrt(taus[i] / 3)
    return {"white_noise_density": white, "bias_instability": bias, "random_walk": k,
            "white_noise_per_sample": white * np.sqrt(rate)}


def random_walk_bound(x: np.ndarray, rate: float) -> np.ndarray:
    """Upper bound of the rate random walk ``K`` per column when the record is too short to show it.

    A rate random walk adds ``K√(τ/3)`` to the Allan deviation, so the
    deviation at the longest cluster time ``τ_max`` bounds it:
    ``K ≤ σ(τ_max)·√(3/τ_max)``.
    """
    taus, adev = allan_deviation(x, rate)
    adev = adev if adev.ndim == 2 else adev[:, None]
    return adev[-1] * np.sqrt(3.0 / taus[-1])


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
        :func:`noise_parameters` per axis and the :func:`random_walk_bound`,
        as lists (JSON-ready; :func:`kalibr_yaml` takes them as they are).
    """
    out = {"seconds": recording.duration, "samples": len(recording), "rate_hz": recording.rate}
    for name, x, unit in (("accelerometer", recording.acc, recording.acc_unit),
                          ("gyroscope", recording.gyro, recording.gyro_unit)):
        if x is None:
            continue
        p = noise_parameters(x, recording.rate)
        out[name] = {"unit": unit, **{k: v.tolist() for k, v in p.items()},
                     "random_walk_bound": random_walk_bound(x, recording.rate).tolist()}
    return out


def kalibr_noise(acc: dict, gyro: dict) -> tuple[dict[str, float], list[str]]:
    """The four noise entries of Kalibr's IMU model from SI noise parameters, and notes.

    ``acc`` and ``gyro`` hold ``white_noise_density`` and ``random_walk``
    per axis (:func:`noise_parameters`, in m/s² and rad/s, optionally
    ``random_walk_bound`` where the record was too short); each entry takes the
    largest axis. Returns ``{"accelerometer_noise_density", "accelerometer_random_walk",
    "gyroscope_noise_density", "gyroscope_random_walk"}`` and notes on what was
    bounded rather than measured.
    """
    notes = []

    def pick(d, name):
        n = float(np.max(d["white_noise_density"]))
        k = np.asarray(d["random_walk"], dtype=float)
        if np.all(np.isfinite(k)):
            return n, float(np.max(k))
        axes = ", ".join(a for a, v in zip("xyz", k, strict=True) if not np.isfinite(v))
        notes.append(f"{name} {axes}: the record is too short to show the bias random walk; the file uses its "
                     "upper bound from the longest cluster time (record a longer rest for the value)")
        return n, float(np.max(np.where(np.isfinite(k), k, d["random_walk_bound"])))

    na, ka = pick(acc, "accelerometer")
    ng, kg = pick(gyro, "gyroscope")
    return {"accelerometer_noise_density": na, "accelerometer_random_walk": ka,
            "gyroscope_noise_density": ng, "gyroscope_random_walk": kg}, notes


def kalibr_yaml(acc: dict, gyro: dict, rate: float, *, topic: str = "/imu0") -> tuple[str, list[str]]:
    """The IMU noise file of Kalibr / OpenVINS / VINS (``imu.yaml``) from SI noise parameters.

    The entries of :func:`kalibr_noise` (largest axis of each), the topic and
    the rate. Returns the text and notes on what was bounded rather than measured.
    """
    v, notes = kalibr_noise(acc, gyro)
    text = "\n".join([
        "# IMU noise from the Allan deviation of a rest (imucalib noise), largest axis; Kalibr's format",
        f"accelerometer_noise_density: {v['accelerometer_noise_density']:.6e}   "
        "# [ m / s^2 / sqrt(Hz) ]   ( accel \"white noise\" )",
        f"accelerometer_random_walk: {v['accelerometer_random_walk']:.6e}     "
        "# [ m / s^3 / sqrt(Hz) ]   ( accel bias diffusion )",
        f"gyroscope_noise_density: {v['gyroscope_noise_density']:.6e}       "
        "# [ rad / s / sqrt(Hz) ]   ( gyro \"white noise\" )",
        f"gyroscope_random_walk: {v['gyroscope_random_walk']:.6e}         "
        "# [ rad / s^2 / sqrt(Hz) ] ( gyro bias diffusion )",
        f"rostopic: {topic}",
        f"update_rate: {rate:.6g}   # [ Hz ]",
        "",
    ])
    return text, notes
