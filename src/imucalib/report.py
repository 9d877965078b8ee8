"""Plots where a person would rather look than read: a calibration's fit, a sensor's Allan deviation.

:func:`plot_fit` draws one figure, three panels over the recording used for the calibration:

1. the norm of the calibrated accelerometer against ``g``, the static intervals shaded;
2. ``‖a_k‖ − g`` per static pose [mm/s²] (the ``fit.accelerometer_residual_rms`` terms),
   with ± the white-noise floor (``fit.accelerometer_noise_floor``);
3. the angle between measured and gyro-predicted gravity per transition [deg]
   (the ``fit.gyroscope_angle_error_*`` terms), with the verdict's acceptable and
   rejecting angles (:data:`imucalib.verdict.THRESHOLDS`) and what the noise alone predicts; drawn only
   where there are rotations to score (none for an accelerometer-only session).

Time gaps (between the blocks of a recording, or a pause) break the plotted lines rather than being crossed.

:func:`plot_allan` draws the Allan deviation of both sensors at rest (log–log, one
curve per axis) with the noise terms read from it (Ru 2022, §2.2; IEEE Std 952).

matplotlib is an optional dependency (the ``plot`` extra: ``pip install ".[plot]"``).
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .calibration import Calibration
from .fitreport import FitReport
from .io.atomic import atomic_path, atomic_write
from .metrics import gravity_direction_errors, gravity_residuals, interval_means
from .noise import allan_deviation, noise_parameters
from .plans import describe_direction
from .recording import Interval, Recording

__all__ = ["coverage_svg", "fit_figure", "html_report", "magnetometer_figure", "parameter_unit", "plot_allan",
           "plot_fit", "plot_thermal", "reference_levels", "thermal_figure"]


def _pyplot():
    try:
        import matplotlib  # optional: pip install imucalib[plot]

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt  # optional: pip install imucalib[plot]
    except ImportError:
        raise ValueError('plots need matplotlib: pip install ".[plot]" (or matplotlib)') from None
    return plt


def plot_fit(calibration: Calibration, recording: Recording, intervals: Sequence[Interval],
             path) -> Path:
    """Write the fit figure (PNG, SVG or PDF by the file's suffix, or PNG into a binary file object)."""
    plt = _pyplot()
    return _save(fit_figure(calibration, recording, intervals), path, plt)


def reference_levels(calibration: Calibration) -> dict:
    """The reference lines of the fit figure, from the fit and :data:`imucalib.verdict.THRESHOLDS`.

    ``{"noise_floor": ±m/s² or None, "angle_acceptable_deg", "angle_rejected_deg",
    "angle_predicted_deg": or None}``: the gravity-norm residual white noise alone
    leaves (``fit.accelerometer_noise_floor``); the mean gravity-direction error
    below which the verdict never calls the gyroscope suspect, and above which
    (with an error beyond the noise) it rejects it; what the noise alone predicts.
    """
    from .verdict import THRESHOLDS  # imucalib.verdict costs 37 ms at start-up

    fit = calibration.fit
    acceptable, rejected = THRESHOLDS["gyro_error_floor_deg"]
    return {"noise_floor": fit.accelerometer.noise_floor, "angle_acceptable_deg": acceptable,
            "angle_rejected_deg": rejected, "angle_predicted_deg": fit.gyroscope.angle_error_predicted_deg}


def _broken_at_gaps(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``t, y`` with a NaN where time jumps by more than 5 sample periods or goes back (between the blocks of a
    recording, or across a pause), so that a plotted line stops there rather than crossing the gap."""
    dt = np.diff(t)
    if dt.size == 0:
        return t, y
    cut = np.flatnonzero((dt > 5 * np.median(dt)) | (dt <= 0)) + 1
    return np.insert(t.astype(float), cut, np.nan), np.insert(y.astype(float), cut, np.nan)


def fit_figure(calibration: Calibration, recording: Recording, intervals: Sequence[Interval]):
    """The fit figure as a matplotlib Figure (three panels, module docstring), with reference lines.

    The gyroscope's panel is drawn only when there are rotations to score (a calibrated gyroscope, its
    readings and two poses or more): an accelerometer-only session gets the two accelerometer panels.

    The residual panel shows ± the white-noise floor, the angle panel the
    verdict's acceptable and rejecting angles (:func:`reference_levels`) and
    colours each bar by where it falls, on an axis that always reaches the
    rejecting angle: a 140° failure cannot look like a 1° success.
    """
    plt = _pyplot()
    intervals = [iv for iv in intervals if iv.kind == "static"]
    ref = reference_levels(calibration)
    out = calibration.apply(recording)
    g = calibration.gravity
    t = recording.t - recording.t[0]
    res = gravity_residuals(calibration, recording, intervals) * 1e3
    ang = np.degrees(gravity_direction_errors(calibration, recording, intervals)) \
        if len(intervals) > 1 and calibration.gyroscope is not None and recording.gyro is not None \
        else np.array([])
    gyro_panel = bool(ang.size)  # no empty panel for an accelerometer-only recording or calibration
    fig, axes = plt.subplots(3 if gyro_panel else 2, 1, figsize=(10, 8.5 if gyro_panel else 5.8),
                             constrained_layout=True)
    ax = axes[0]
    ax.plot(*_broken_at_gaps(t, np.linalg.norm(out.acc, axis=1)), lw=0.6, color="tab:blue", label="‖a‖ calibrated")
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
    if ref["noise_floor"]:
        floor = ref["noise_floor"] * 1e3
        ax.axhline(floor, color="tab:green", lw=1.0, ls="--", label=f"± noise floor {floor:.3g} mm/s²")
        ax.axhline(-floor, color="tab:green", lw=1.0, ls="--")
        ax.legend(loc="upper right", fontsize=8)
    rms = float(np.sqrt(np.mean((res / 1e3) ** 2)))
    ax.set_ylabel("‖a‖ − g [mm/s²]")
    ax.set_xlabel("static pose")
    ax.set_title(f"gravity-norm residual per pose (RMS {rms:.3g} m/s²)")
    if not gyro_panel:
        return fig
    ax = axes[2]
    ok, bad = ref["angle_acceptable_deg"], ref["angle_rejected_deg"]
    if ang.size:
        colours = np.where(ang <= ok, "tab:green", np.where(ang <= bad, "tab:orange", "tab:red"))
        ax.bar(np.arange(1, len(ang) + 1), ang, color=colours)
        ax.set_title(f"gravity direction predicted by the gyroscope (mean {ang.mean():.3g}°, "
                     f"max {ang.max():.3g}°)")
    ax.axhline(ok, color="tab:green", lw=1.0, ls="--", label=f"{ok:g}°: acceptable")
    ax.axhline(bad, color="tab:red", lw=1.0, ls="--", label=f"{bad:g}°: rejected (beyond the noise)")
    if ref["angle_predicted_deg"]:
        ax.axhline(ref["angle_predicted_deg"], color="k", lw=0.8, ls=":",
                   label=f"noise alone: {ref['angle_predicted_deg']:.3g}°")
    ax.set_ylim(0, max(1.25 * bad, 1.05 * float(ang.max()) if ang.size else 0.0))
    ax.legend(loc="upper right", fontsize=8)
    ax.set_ylabel("angle error [deg]")
    ax.set_xlabel("transition to pose")
    return fig


def _save(fig, target, plt):
    """Save to a path (format by its suffix; through a temporary file) or to a binary file object (PNG)."""
    try:
        if hasattr(target, "write"):
            fig.savefig(target, format="png", dpi=110)
            return target
        target = Path(target)
        fmt = target.suffix[1:] or plt.rcParams["savefig.format"]  # the target's, not the temporary name's
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=fmt, dpi=110)
        return target
    finally:
        plt.close(fig)


def plot_allan(recording: Recording, path: str | Path) -> Path:
    """Write the Allan-deviation figure of a recording at rest and return its path.

    Each panel shows the overlapping Allan deviation per axis
    (:func:`imucalib.noise.allan_deviation`), the white-noise line
    ``N/√τ``, the bias-instability floor ``0.664 B`` and the random-walk line
    ``K√(τ/3)`` where the curve shows them (:func:`imucalib.noise.noise_parameters`;
    the legend gives '<bound' for the others).
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    colors = ("tab:red", "tab:green", "tab:blue")
    for ax, name, x, unit in ((axes[0], "accelerometer", recording.acc, recording.acc_unit),
                              (axes[1], "gyroscope", recording.gyro, recording.gyro_unit)):
        if x is None:  # an accelerometer-only recording
            ax.set_title(f"{name}: none in this recording")
            ax.axis("off")
            continue
        taus, adev = allan_deviation(x, recording.rate)
        p = noise_parameters(x, recording.rate)
        for j, axis in enumerate("xyz"):
            c = colors[j]
            ax.loglog(taus, adev[:, j], color=c, lw=1.4, label=f"{axis}: N {_figure(p, 'white_noise_density', j)}, "
                      f"B {_figure(p, 'bias_instability', j)}")
            if np.isfinite(p["white_noise_density"][j]):
                ax.loglog(taus, p["white_noise_density"][j] / np.sqrt(taus), color=c, lw=0.7, ls="--")
            if np.isfinite(p["bias_instability"][j]):
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
    return _save(fig, path, plt)


def _figure(p: dict, key: str, j: int) -> str:
    """A noise figure of :func:`imucalib.noise.noise_parameters`, '<bound' where the curve does not show it."""
    v = p[key][j]
    return f"{v:.3g}" if np.isfinite(v) else f"<{p[key + '_bound'][j]:.3g}" if np.isfinite(p[key + "_bound"][j]) \
        else "const"


def _unit_text(unit: str) -> str:
    return {"m/s^2": "m/s²"}.get(unit, unit)


def parameter_unit(name: str, calibration: Calibration) -> str:
    """The unit of a named parameter (``gyroscope.scale.x`` …) of this calibration, for a person.

    Misalignments are pure numbers (``1``); ``k1`` is calibrated per raw unit,
    ``k2``, ``k3`` per raw unit² and ³; biases are raw units, the output bias
    calibrated units; ``G`` raw gyroscope units per m/s²; the lever arm metres.
    """
    if name.startswith("lever_arm."):
        return "m"
    sensor, key = name.split(".")[:2]
    raw = _unit_text(calibration.units[sensor]["raw"])
    out = _unit_text(calibration.units[sensor]["calibrated"])
    if sensor == "magnetometer":
        return {"bias": raw, "soft_iron": f"1 per {raw}", "alignment": "1", "field": out}.get(key, "")
    return {"misalignment": "1", "scale": f"{out} per {raw}", "scale_quadratic": f"{out} per {raw}²",
            "scale_cubic": f"{out} per {raw}³", "bias": raw, "output_bias": out,
            "g_sensitivity": f"{raw} per m/s²"}.get(key, "")


def magnetometer_figure(calibration: Calibration):
    """The calibrated field's norm and its dip to gravity per pose, with the verdict's limits (a Figure).

    Both must be the same in every pose (fit/magnetometer.py, eqs. M2 and M3): the dashed lines are
    the mean ± the spread at which the verdict calls the calibration suspect.
    """
    from .verdict import THRESHOLDS  # imucalib.verdict costs 37 ms at start-up

    plt = _pyplot()
    fit = calibration.fit
    norms = np.asarray(fit.magnetometer.field_norms or [], float)
    dips = np.asarray(fit.magnetometer.dips_deg or [], float)
    if norms.size == 0:
        raise ValueError("this calibration has no magnetometer figures per pose")
    unit = calibration.magnetometer.unit if calibration.magnetometer is not None else "normalised"
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    poses = np.arange(norms.size)
    for ax, values, limit, label in ((ax1, norms, THRESHOLDS["mag_norm_spread"][0] * norms.mean(),
                                      f"|m| [{'µT' if unit == 'uT' else unit}]"),
                                     (ax2, dips, THRESHOLDS["mag_dip_spread_deg"][0], "dip below horizontal [deg]")):
        ax.plot(poses, values, "o", ms=4)
        mean = float(values.mean())
        for level in (mean - limit, mean + limit):
            ax.axhline(level, color="#b26a00", ls="--", lw=1)
        ax.axhline(mean, color="0.5", lw=0.8)
        ax.set_ylabel(label)
    ax1.set_title("magnetometer per pose: dashed, the spread the verdict calls suspect")
    ax2.set_xlabel("static pose")
    fig.tight_layout()
    return fig


def plot_thermal(calibration: Calibration, path) -> Path:
    """Write :func:`thermal_figure` (PNG, SVG or PDF by the file's suffix, or PNG into a binary file object)."""
    plt = _pyplot()
    return _save(thermal_figure(calibration), path, plt)


def thermal_figure(calibration: Calibration):
    """Each temperature-dependent bias against temperature: the model ± its 1σ and the calibration points."""
    plt = _pyplot()
    model = calibration.thermal
    if model is None:
        raise ValueError("this calibration does not follow temperature")
    names = [n for n in model.coefficients if ".bias." in n] or list(model.coefficients)
    sensors = sorted({n.split(".")[0] for n in names})
    fig, axes = plt.subplots(1, len(sensors), figsize=(5 * len(sensors), 3.8), squeeze=False)
    lo, hi = model.range_c
    temps = np.linspace(lo - 2.0, hi + 2.0, 100)
    values = calibration.parameters()
    for ax, sensor in zip(axes[0], sensors, strict=True):
        for n in (n for n in names if n.startswith(sensor + ".")):
            curve = values[n] + model.deltas(temps)[n]
            sd = np.array([model.sigma(n, t) for t in temps])
            line, = ax.plot(temps, curve, label=n.split(".", 1)[1])
            ax.fill_between(temps, curve - sd, curve + sd, color=line.get_color(), alpha=0.2)
            pts = [(p["temperature_c"], p["values"].get(n), (p.get("sigmas") or {}).get(n)) for p in model.points]
            pts = [(t, v, s or 0.0) for t, v, s in pts if v is not None]
            if pts:
                t, v, s = np.array(pts, dtype=float).T
                ax.errorbar(t, v, yerr=s, fmt="o", color=line.get_color(), ms=4, capsize=2)
        ax.axvspan(lo, hi, color="0.9", zorder=0)
        ax.set_xlabel("temperature [°C]")
        ax.set_ylabel(f"{sensor} bias [{_unit_text(calibration.units[sensor]['raw'])}]")
        ax.legend(fontsize=8)
    fig.suptitle(f"biases against temperature ({model.source}; grey: the calibrated range)")
    fig.tight_layout()
    return fig


#: background and text/border colour of the verdict banner: green, amber, red
_VERDICT_COLOURS = {"accepted": ("#e6f4ea", "#1e7e34"), "suspect": ("#fff4e0", "#b26a00"),
                    "rejected": ("#fdecea", "#c62828")}


def _verdict_banner(fit: FitReport) -> str:
    """The verdict and its reasons (then notes) as a coloured block; empty for a file without a verdict."""
    verdict = fit.verdict.level
    if verdict not in _VERDICT_COLOURS:
        return ""
    reasons = "".join(f"<li>{html.escape(r)}</li>" for r in fit.verdict.reasons or [])
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in fit.verdict.notes or [])
    what = {"accepted": "no check found a problem", "suspect": "usable, but look at the reasons",
            "rejected": "do not use it: imucalib apply and export refuse it without --force"}[verdict]
    return (f"<div class='verdict verdict-{verdict}'><h2>Verdict: {verdict.upper()}</h2><p>{what}</p>"
            + (f"<ul>{reasons}</ul>" if reasons else "")
            + (f"<p>Notes:</p><ul>{notes}</ul>" if notes else "") + "</div>")


def coverage_svg(up: np.ndarray | None, next_poses=(), *, size: int = 220) -> str:
    """The pose directions on the sphere as inline SVG: two discs, the z-up and the z-down half.

    Each disc is a Lambert azimuthal equal-area view about its pole (radius
    ``√2 sin(θ/2)`` for the angle ``θ`` from the pole, 1 at the equator), seen
    from above the sensor's +z for the upper half and from below for the lower
    (so x keeps pointing right and y flips). ``up`` (M, 3) are the recorded
    poses' up-directions (blue), ``next_poses`` the suggested ones (red,
    numbered). A direction on the equator shows on both discs.
    """
    r = size * 0.42
    parts = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{2 * size}' height='{size + 20}' "
             f"viewBox='0 0 {2 * size} {size + 20}' class='coverage-sphere' font-family='sans-serif' font-size='12'>"]
    for k, (label, sign) in enumerate((("z up half", 1.0), ("z down half", -1.0))):
        cx, cy = size * (k + 0.5), size / 2 + 10
        parts.append(f"<circle cx='{cx:.1f}' cy='{cy:.1f}' r='{r:.1f}' fill='#f8f8f8' stroke='#888'/>"
                     f"<text x='{cx:.1f}' y='{size + 14}' text-anchor='middle'>{label}</text>"
                     f"<text x='{cx + r + 3:.1f}' y='{cy + 4:.1f}'>x</text>"
                     f"<text x='{cx - 3:.1f}' y='{cy - sign * (r + 4) + (4 if sign < 0 else 0):.1f}'>y</text>")

        def place(u, cx=cx, cy=cy, sign=sign):
            u = np.asarray(u, dtype=float) / np.linalg.norm(u)
            if sign * u[2] < -1e-9:
                return None
            theta = np.arccos(np.clip(sign * u[2], -1, 1))
            rho = np.sqrt(2) * np.sin(theta / 2) * r
            h = np.hypot(u[0], u[1])
            c, s = (u[0] / h, u[1] / h) if h > 0 else (0.0, 0.0)
            return cx + rho * c, cy - sign * rho * s  # svg y grows downwards; the lower half is seen from below

        for u in [] if up is None else np.asarray(up, dtype=float):
            p = place(u)
            if p is not None:
                parts.append(f"<circle cx='{p[0]:.1f}' cy='{p[1]:.1f}' r='4' fill='#1565c0' fill-opacity='0.7'/>")
        for j, u in enumerate(next_poses, 1):
            p = place(u)
            if p is not None:
                parts.append(f"<circle cx='{p[0]:.1f}' cy='{p[1]:.1f}' r='8' fill='none' stroke='#c62828' "
                             f"stroke-width='2'/><text x='{p[0] + 9:.1f}' y='{p[1] - 6:.1f}' fill='#c62828' "
                             f"font-weight='bold'>{j}</text>")
    parts.append("</svg>")
    return "".join(parts)


def html_report(calibration: Calibration, path: str | Path, *, recording: Recording | None = None,
                intervals: Sequence[Interval] | None = None, notes: Sequence[str] = (),
                title: str | None = None) -> Path:
    """Write a self-contained HTML page about one calibration and return its path.

    The page holds what a person checks before trusting a calibration: its
    verdict at the top (a green, amber or red banner with the reasons), the
    method and units, the fit figures (``docs/architecture.rst``), every parameter with
    its 1σ error and relative error where the method gives one, the reasons
    when it cannot, the warnings of the run (``notes``), and the fit figure
    of :func:`plot_fit` embedded as PNG when matplotlib and the recording
    are at hand. No external files or scripts.
    """
    cal = calibration
    title = title or f"imucalib calibration: {cal.method} ({cal.model})"
    parts = [_html_head(title), f"<h1>{html.escape(title)}</h1>", _verdict_banner(cal.fit)]
    parts += _html_summary(cal, recording)
    parts += _html_quality(cal)
    parts += _html_coverage(cal, recording, intervals)
    parts += [f"<p class='warn'>{html.escape(n)}</p>" for n in _html_notes(cal, notes)]
    parts += _html_parameters(cal)
    parts += _html_figures(cal, recording, intervals)
    parts.append("<p><small>written by imucalib; the calibration file (JSON) holds the same numbers.</small></p>"
                 "</body></html>")
    path = Path(path)
    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(parts))
    return path


def _html_head(title: str) -> str:
    """The page's head: its title and style."""
    esc = html.escape
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(title)}</title><style>"
            "body{font-family:system-ui,sans-serif;margin:2em;max-width:70em}"
            "table{border-collapse:collapse;margin:1em 0}td,th{padding:.25em .8em;border-bottom:1px solid #ddd;"
            "text-align:right;font-variant-numeric:tabular-nums}th{background:#f4f4f4}td:first-child,"
            "th:first-child{text-align:left}.warn{background:#fff4e0;padding:.5em 1em;border-left:4px solid #e90}"
            "img{max-width:100%}tr.sigma-large td{background:#fdecea}.sigma-large-mark{color:#c62828;"
            "font-weight:bold}.verdict{padding:.6em 1.2em;border-left:8px solid;margin:1em 0}"
            ".verdict h2{margin:.2em 0}" + "".join(f".verdict-{k}{{background:{bg};border-color:{fg}}}"
                                                  f".verdict-{k} h2{{color:{fg}}}"
                                                  for k, (bg, fg) in _VERDICT_COLOURS.items())
            + "</style></head><body>")


def _html_summary(cal: Calibration, recording: Recording | None) -> list[str]:
    """The table of the method, gravity, units and the recording."""
    esc, parts = html.escape, []
    units = cal.units
    fit_why = cal.fit.gyroscope.not_calibrated or "an accelerometer-only recording"
    parts.append("<table><tr><th>item</th><th>value</th></tr>"
                 f"<tr><td>method / model</td><td>{esc(cal.method)} / {esc(cal.model)}</td></tr>"
                 f"<tr><td>gravity</td><td>{cal.gravity:.6g} m/s²</td></tr>"
                 f"<tr><td>accelerometer units</td><td>{esc(units['accelerometer']['raw'])} → "
                 f"{esc(units['accelerometer']['calibrated'])}</td></tr>"
                 + (f"<tr><td>gyroscope units</td><td>{esc(units['gyroscope']['raw'])} → "
                    f"{esc(units['gyroscope']['calibrated'])}</td></tr>" if cal.gyroscope is not None else
                    f"<tr><td>gyroscope</td><td>none ({esc(fit_why)})</td></tr>"))
    if recording is not None:
        src = recording.metadata.get("source")
        parts.append(f"<tr><td>recording</td><td>{esc(', '.join(src) if isinstance(src, list) else str(src or '-'))}"
                     f": {len(recording)} samples, {recording.duration:.1f} s at {recording.rate:.4g} Hz</td></tr>")
    parts.append("</table>")
    return parts


def _html_quality(cal: Calibration) -> list[str]:
    """The fit's figures (``docs/architecture.rst``), as a table."""
    esc, fit, parts = html.escape, cal.fit, []
    quality = [("static poses", fit.poses.static_intervals, "{:d}"),
               ("‖a‖ − g RMS over the poses [m/s²]", fit.accelerometer.residual_rms, "{:.3g}"),
               ("… its white-noise floor [m/s²]", fit.accelerometer.noise_floor, "{:.3g}"),
               ("… residual / noise floor (≈ 1: only noise left)", fit.accelerometer.residual_to_noise,
                "{:.2f}"),
               ("gyroscope angle error, mean [deg]", fit.gyroscope.angle_error_mean_deg, "{:.3g}"),
               ("gyroscope angle error, max [deg]", fit.gyroscope.angle_error_max_deg, "{:.3g}")]
    if fit.thermal.temperature_c:
        quality.append(("temperature min / mean / max [°C]", fit.thermal.temperature_c,
                        "{0[0]:.1f} / {0[1]:.1f} / {0[2]:.1f}"))
    if cal.magnetometer is not None:
        quality += [("magnetometer: field norm spread over the poses", fit.magnetometer.norm_spread,
                     "{:.2%}"),
                    ("magnetometer: dip [deg]", fit.magnetometer.dip_deg, "{:.2f}"),
                    ("magnetometer: dip spread over the poses [deg]", fit.magnetometer.dip_spread_deg,
                     "{:.3g}"),
                    ("magnetometer: direction error between poses, mean [deg]",
                     fit.magnetometer.direction_error_mean_deg, "{:.3g}"),
                    ("magnetometer axes (accelerometer x, y, z =)", " ".join(cal.magnetometer.axes()[0]), "{}")]
    rows = "".join(f"<tr><td>{esc(k)}</td><td>{esc(f.format(v))}</td></tr>" for k, v, f in quality if v is not None)
    if rows:
        parts.append(f"<h2>Fit</h2><table><tr><th>figure</th><th>value</th></tr>{rows}</table>")
    return parts


def _html_coverage(cal: Calibration, recording: Recording | None, intervals: Sequence[Interval] | None) -> list[str]:
    """The poses' coverage of the directions, the poses on the sphere and the poses to record next."""
    esc, fit, parts = html.escape, cal.fit, []
    coverage = fit.poses.pose_coverage
    if isinstance(coverage, dict) and coverage:
        cells = "".join(f"<tr><td>{esc(axis)}</td><td>{lo:+.2f}</td><td>{hi:+.2f}</td>"
                        f"<td>{'yes' if hi >= 0.5 and lo <= -0.5 else 'NO'}</td></tr>"
                        for axis, (lo, hi) in coverage.items())
        parts.append("<h3>Pose coverage</h3><p>Per axis, the gravity direction's component over the static poses "
                     "(+1: the axis straight up, −1: straight down); each axis should be held both up and down "
                     "(within 60°).</p><table class='coverage'><tr><th>axis</th><th>min</th><th>max</th>"
                     f"<th>up and down</th></tr>{cells}</table>")
    nxt = fit.verdict.next_poses or []
    up = None
    if recording is not None and intervals:
        up = cal.accelerometer_si(interval_means(recording.acc, intervals))
    if up is not None or nxt:
        said = "".join(f"<li>{esc(describe_direction(u))}</li>" for u in nxt)
        parts.append(coverage_svg(up, nxt) + "<p class='caption'>The up-direction of every pose in the sensor "
                     "frame (blue dots; equal-area views of the z-up and z-down halves of the sphere)"
                     + (", and the poses that would most shrink the worst 1σ, numbered in the order to record "
                        f"them (red):</p><ol>{said}</ol>" if nxt else ".</p>"))
    return parts


def _html_notes(cal: Calibration, notes: Sequence[str]) -> list[str]:
    """The run's warnings, the quality flags, why errors are missing, the model selection."""
    fit = cal.fit
    all_notes = list(notes) + [f"quality flag: {f}" for f in fit.poses.quality_flags or []]
    if fit.uncertainty.unavailable:
        all_notes.append(f"errors not available: {fit.uncertainty.unavailable}")
    if isinstance(fit.method.model_selection, dict):
        sel = fit.method.model_selection
        all_notes.append(f"model selection ({sel.get('criterion')}): requested {sel.get('requested')}, "
                         f"returned {sel.get('selected')}")
    return all_notes


def _html_parameters(cal: Calibration) -> list[str]:
    """Every parameter estimated or not zero, with its unit and 1σ error."""
    esc, unc, parts = html.escape, cal.fit.uncertainty.sigma or {}, []
    parts.append("<h2>Parameters</h2><p>The model's terms that were estimated or are not zero. A 1σ error "
                 "larger than the value itself (marked <span class='sigma-large-mark'>σ &gt; |value|</span>) means "
                 "the data did not determine the term.</p><table><tr><th>parameter</th><th>value</th>"
                 "<th>unit</th><th>± 1σ</th><th>σ / |value|</th><th></th></tr>")

    def row(name, value, s, fmt):
        known = s is not None and np.isfinite(s)
        rel = f"{abs(s / value):.2g}" if known and value != 0 else "-"
        large = known and s > abs(value)
        mark = "<span class='sigma-large-mark'>σ &gt; |value|</span>" if large else ""
        tr = "<tr class='sigma-large'>" if large else "<tr>"
        return (f"{tr}<td>{esc(name)}</td><td>{value:{fmt}}</td>"
                f"<td>{esc(parameter_unit(name, cal))}</td><td>{f'{s:.2g}' if known else '-'}</td>"
                f"<td>{rel}</td><td>{mark}</td></tr>")

    for name, value in cal.parameters().items():
        s = unc.get(name)
        if s is None and value == 0:
            continue  # a term of the model family this calibration does not use
        parts.append(row(name, value, s, ".8g"))
    if cal.lever_arm is not None:
        for axis, v in zip("xyz", cal.lever_arm, strict=True):
            parts.append(row(f"lever_arm.{axis}", float(v), unc.get(f"lever_arm.{axis}"), ".6g"))
    parts.append("</table>")
    return parts


def _html_figures(cal: Calibration, recording: Recording | None, intervals: Sequence[Interval] | None) -> list[str]:
    """The fit figure (with the recording), the magnetometer's and the temperature model's, embedded as PNG."""

    esc, fit, parts = html.escape, cal.fit, []
    if recording is not None and intervals:
        try:
            buf = io.BytesIO()
            plot_fit(cal, recording, intervals, buf)
            data = base64.b64encode(buf.getvalue()).decode("ascii")
            ref = reference_levels(cal)
            floor = f"± the white-noise floor {ref['noise_floor']:.3g} m/s² (dashed)" if ref["noise_floor"] \
                else "no noise floor (the fit has none)"
            predicted = (f"; dotted: {ref['angle_predicted_deg']:.3g}°, what the noise alone predicts"
                         if ref["angle_predicted_deg"] else "")
            parts.append(f"<h2>Figure</h2><img alt='fit' src='data:image/png;base64,{data}'>"
                         f"<p class='caption'>Reference lines. Residual per pose: {floor}. Gravity direction per "
                         f"transition: {ref['angle_acceptable_deg']:g}° acceptable (green, dashed) and "
                         f"{ref['angle_rejected_deg']:g}° rejected when beyond the noise (red, dashed), the "
                         f"verdict's limits{predicted}; bars green, amber, red by where they fall.</p>")
        except ValueError as exc:  # matplotlib missing
            parts.append(f"<p class='warn'>{esc(str(exc))}</p>")
    for heading, draw, ok in (("Magnetometer", magnetometer_figure, cal.magnetometer is not None
                               and bool(fit.magnetometer.field_norms)),
                              ("Temperature", thermal_figure, cal.thermal is not None)):
        if not ok:
            continue
        try:
            buf = io.BytesIO()
            _save(draw(cal), buf, _pyplot())
            data = base64.b64encode(buf.getvalue()).decode("ascii")
            parts.append(f"<h2>{heading}</h2><img alt='{heading.lower()}' src='data:image/png;base64,{data}'>")
        except ValueError as exc:  # matplotlib missing
            parts.append(f"<p class='warn'>{esc(str(exc))}</p>")
    return parts

