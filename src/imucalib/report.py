"""Plots where a person would rather look than read: a calibration's fit, a sensor's Allan deviation.

:func:`plot_fit` draws one figure, three panels over the recording used for the calibration:

1. the norm of the calibrated accelerometer against ``g``, the static intervals shaded;
2. ``‖a_k‖ − g`` per static pose [mm/s²] (the ``fit.accelerometer_residual_rms`` terms);
3. the angle between measured and gyro-predicted gravity per transition [deg]
   (the ``fit.gyroscope_angle_error_*`` terms).

:func:`plot_allan` draws the Allan deviation of both sensors at rest (log–log, one
curve per axis) with the noise terms read from it (Ru 2022, §2.2; IEEE Std 952).

matplotlib is an optional dependency (the ``plot`` extra: ``pip install ".[plot]"``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .calibration import Calibration
from .metrics import gravity_direction_errors, gravity_residuals
from .recording import Interval, Recording

__all__ = ["plot_allan", "plot_fit"]


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ValueError('plots need matplotlib: pip install ".[plot]" (or matplotlib)') from None
    return plt


def plot_fit(calibration: Calibration, recording: Recording, intervals: Sequence[Interval],
             path: str | Path) -> Path:
    """Write the fit figure (PNG, SVG or PDF by the file's suffix) and return its path."""
    plt = _pyplot()
    intervals = [iv for iv in intervals if iv.kind == "static"]
    out = calibration.apply(recording)
    g = calibration.gravity
    t = recording.t - recording.t[0]
    res = gravity_residuals(calibration, recording, intervals) * 1e3
    ang = np.degrees(gravity_direction_errors(calibration, recording, intervals)) if len(intervals) > 1 \
        else np.array([])
    fig, axes = plt.subplots(3, 1, figsize=(10, 8.5), constrained_layout=True)
    ax = axes[0]
    ax.plot(t, np.linalg.norm(out.acc, axis=1), lw=0.6, color="tab:blue", label="‖a‖ calibrated")
    ax.axhline(g, color="k", lw=0.8, ls="--", label=f"g = {g:.5g} m/s²")
    for k, iv in enumerate(intervals):
        ax.axvspan(t[iv.start], t[iv.stop - 1], color="tab:green", alpha=0.15,
                   label="static intervals" if k == 0 else None)
    ax.set_ylabel("‖a‖ [m/s²]")
    ax.set_xlabel("time [s]")
    ax.set_title(f"{calibration.method} ({calibration.model}): {len(intervals)} static poses")
    ax.legend(loc="upper right", fontsize=8)
    ax = axes[1]
    ax.bar(np.arange(len(res)), res, color="tab:blue")
    rms = float(np.sqrt(np.mean((res / 1e3) ** 2)))
    ax.set_ylabel("‖a‖ − g [mm/s²]")
    ax.set_xlabel("static pose")
    ax.set_title(f"gravity-norm residual per pose (RMS {rms:.3g} m/s²)")
    ax = axes[2]
    if ang.size:
        ax.bar(np.arange(1, len(ang) + 1), ang, color="tab:orange")
        ax.set_title(f"gravity direction predicted by the gyroscope (mean {ang.mean():.3g}°, "
                     f"max {ang.max():.3g}°)")
    ax.set_ylabel("angle error [deg]")
    ax.set_xlabel("transition to pose")
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_allan(recording: Recording, path: str | Path) -> Path:
    """Write the Allan-deviation figure of a recording at rest and return its path.

    Each panel shows the overlapping Allan deviation per axis
    (:func:`imucalib.noise.allan_deviation`), the white-noise line
    ``N/√τ`` and, where reached, the random-walk line ``K√(τ/3)`` read by
    :func:`imucalib.noise.noise_parameters`, and the bias-instability floor
    ``0.664 B``.
    """
    from .noise import allan_deviation, noise_parameters

    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    colors = ("tab:red", "tab:green", "tab:blue")
    for ax, name, x, unit in ((axes[0], "accelerometer", recording.acc, recording.acc_unit),
                              (axes[1], "gyroscope", recording.gyro, recording.gyro_unit)):
        taus, adev = allan_deviation(x, recording.rate)
        p = noise_parameters(x, recording.rate)
        for j, axis in enumerate("xyz"):
            c = colors[j]
            ax.loglog(taus, adev[:, j], color=c, lw=1.4, label=f"{axis}: N {p['white_noise_density'][j]:.3g}, "
                      f"B {p['bias_instability'][j]:.3g}")
            ax.loglog(taus, p["white_noise_density"][j] / np.sqrt(taus), color=c, lw=0.7, ls="--")
            ax.axhline(0.664 * p["bias_instability"][j], color=c, lw=0.7, ls=":")
            if np.isfinite(p["random_walk"][j]):
                ax.loglog(taus, p["random_walk"][j] * np.sqrt(taus / 3), color=c, lw=0.7, ls="-.")
        ax.set_xlabel("cluster time τ [s]")
        ax.set_ylabel(f"Allan deviation [{unit}]")
        ax.set_title(name)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="lower left")
    fig.suptitle(f"Allan deviation over {recording.duration:.1f} s at rest ({len(recording)} samples); "
                 "dashed: white noise N/√τ, dotted: bias instability 0.664·B, dash-dot: random walk K√(τ/3)",
                 fontsize=10)
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
