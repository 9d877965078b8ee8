"""Monte Carlo of the verdict on the hand-held scenario: figures against thresholds, honesty of the 1σ; prints JSON.

For ``--runs`` seeds of ``imucalib.scenarios.session("handheld", ...)`` (knobs from
``--scenario-knobs``) each method of ``--methods`` (``name`` or ``name:model``)
calibrates ``session.recording`` with the declared gravity, and per run and method
this records

* the verdict and its reasons;
* every figure a verdict threshold (:data:`imucalib.verdict.THRESHOLDS`) acts on:
  the gyroscope's gravity-direction error (mean, predicted, ratio), its rest
  rate (the mean over the poses, largest axis) against the poses' scatter, the
  gravity-norm residual against the noise floor (and normalised for an over-fit),
  poses per accelerometer parameter, cross-axis terms, the relative 1σ of the
  scales and the 1σ of the misalignments, the turn speed between poses;
* the gyroscope gravity-direction error of the *true* calibration on the same
  intervals the method used (:func:`imucalib.metrics.gravity_direction_errors`)
  and the ratio fitted/true of the means;
* the normalised errors ``(estimate − truth)/σ`` of every parameter with a
  finite σ in ``fit.uncertainty.sigma``; the gyroscope bias also against the bias
  the session had on average over the static intervals (the truth is the bias at
  the start, and the bias drifts: the drift comes from a twin session of the same
  seed with the drift knobs at zero, which draws the same random numbers).

Printed: verdict counts per method; per figure the max / 95th percentile (min /
5th percentile for lower limits) over the *good* runs (fitted/true gyroscope error
≤ 1.2 and every scale within 1 % of the truth) next to the suspect threshold, with
the margin; median and max of the fitted/true ratio; RMS of the normalised errors
per method and sensor (≈ 1: honest 1σ) and per parameter group; the runs that were
not accepted and the bad runs that were.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from functools import partial

import numpy as np

from ..methods import calibrate
from ..metrics import gravity_direction_errors, interval_means
from ..recording import Interval
from ..scenarios import session
from ..verdict import THRESHOLDS, turn_speed

DEFAULT_METHODS = "tedaldi2014,zhang2021,ellipsoid"
#: a run is good when the fitted gyroscope error is at most this many times the true parameters' …
GOOD_GYRO_RATIO = 1.2
#: … and every linear scale factor is within this relative error of the truth
GOOD_SCALE_REL = 0.01

#: figure → (threshold key, which side is bad: "high" or "low")
FIGURES = {
    "gyroscope_error_to_noise": ("gyro_error_to_noise", "high"),
    "gyroscope_angle_error_mean_deg": ("gyro_error_floor_deg", "high"),
    "accelerometer_residual_to_noise": ("residual_to_noise_high", "high"),
    "accelerometer_unvisited_sigma_to_noise": ("residual_to_noise_high", "high"),
    "residual_to_noise_normalised": ("residual_to_noise_low", "low"),
    "poses_per_parameter": ("poses_per_parameter", "low"),
    "acc_cross_axis_deg": ("cross_axis_deg", "high"),
    "gyro_cross_axis_deg": ("gyro_cross_axis_deg", "high"),
    "scale_sigma_rel_max": ("scale_sigma_rel", "high"),
    "misalignment_sigma_deg_max": ("misalignment_sigma_deg", "high"),
    "turn_speed_deg_s": ("turn_speed_deg_s", "both"),
    "gyroscope_rest_rate_to_scatter": ("rest_rate_to_scatter", "high"),
    "gyroscope_rest_rate_max_deg_s": ("rest_rate_floor_deg_s", "high"),
}


def _nan(value):
    """``value``, or NaN for a figure the fit did not give."""
    return float("nan") if value is None else value


def _parameter_count(cal) -> int:
    """Accelerometer parameters as the verdict counts them (biases, scales, misalignment, nonlinear terms)."""
    acc = cal.accelerometer
    n = 6 + {"upper": 3, "lower": 3, "full": 6, "diagonal": 0}.get(acc.shape, 3)
    return n + 3 * int(np.any(acc.scale_quadratic)) + 3 * int(np.any(acc.scale_cubic))


def _cross_axis_deg(misalignment: np.ndarray) -> float:
    off = np.abs(misalignment - np.diag(np.diag(misalignment)))
    return float(np.degrees(np.arctan(off.max())))


def _sigma_figures(cal) -> dict:
    unc = cal.fit.uncertainty.sigma or {}
    params = cal.parameters()
    rel, mis = [], []
    for name, s in unc.items():
        if s is None or not np.isfinite(s) or name not in params:
            continue
        group = name.split(".")[1]
        if group == "scale" and params[name]:
            rel.append(s / abs(params[name]))
        elif group == "misalignment":
            mis.append(float(np.degrees(s)))
    return {"scale_sigma_rel_max": max(rel, default=float("nan")),
            "misalignment_sigma_deg_max": max(mis, default=float("nan")),
            "undetermined": sorted(k for k, s in unc.items() if s is None or not np.isfinite(s))}


def _mean_drift(sim, twin, intervals: list[Interval]) -> np.ndarray:
    """Gyroscope bias drift [raw] averaged over the static intervals, one equal weight per interval."""
    diff = sim.recording.gyro - twin.recording.gyro
    return interval_means(diff, intervals).mean(axis=0)


def run_one(seed: int, methods: list[str], knobs: dict) -> dict:
    """Simulate one session and calibrate it with every method; the per-run figures (JSON-ready)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = session("handheld", rng=seed, **knobs)
        twin = session("handheld", rng=seed, **{**knobs, "gyro_drift": 0.0, "gyro_rw": 0.0})
    rec, truth = sim.recording, sim.truth
    tp = truth.parameters()
    out: dict = {"seed": seed, "duration_s": sim.options["duration_s"], "methods": {}}
    for spec in methods:
        name, _, model = spec.partition(":")
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                cal = calibrate(rec, method=name, model=model or None, gravity=truth.gravity)
        except Exception as exc:  # a method that cannot calibrate this session says why
            out["methods"][spec] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        fit = cal.fit
        intervals = [Interval(int(a), int(b), "static") for a, b in fit.poses.intervals]
        m, p = len(intervals), _parameter_count(cal)
        ratio = _nan(fit.accelerometer.residual_to_noise)
        true_err = float(np.degrees(np.mean(gravity_direction_errors(truth, rec, intervals))))
        fitted_err = _nan(fit.gyroscope.angle_error_mean_deg)
        est = cal.parameters()
        scale_rel = {k: abs(est[k] / tp[k] - 1) for k in tp if ".scale." in k and "_" not in k.split(".")[1]}
        drift = _mean_drift(sim, twin, intervals)
        z, z_drift = {}, {}
        for k, s in (fit.uncertainty.sigma or {}).items():
            if s is None or not np.isfinite(s) or s <= 0 or k not in tp or k not in est:
                continue
            z[k] = (est[k] - tp[k]) / s
            ref = tp[k]
            if k.startswith("gyroscope.bias."):
                ref += float(drift["xyz".index(k[-1])])
            z_drift[k] = (est[k] - ref) / s
        rec_m = {
            "verdict": fit.verdict.level, "reasons": fit.verdict.reasons, "converged": fit.method.converged,
            "seconds": time.perf_counter() - t0,
            "static_intervals": m,
            "gyroscope_error_to_noise": _nan(fit.gyroscope.error_to_noise),
            "gyroscope_angle_error_mean_deg": fitted_err,
            "gyroscope_angle_error_max_deg": _nan(fit.gyroscope.angle_error_max_deg),
            "gyroscope_angle_error_predicted_deg": _nan(fit.gyroscope.angle_error_predicted_deg),
            "gyroscope_rest_rate_to_scatter": _nan(fit.gyroscope.rest_rate_to_scatter),
            "gyroscope_rest_rate_max_deg_s": float(np.max(np.abs(_nan(fit.gyroscope.rest_rate_deg_s)))),
            "accelerometer_residual_to_noise": ratio,
            "accelerometer_unvisited_sigma_to_noise": _nan(fit.accelerometer.unvisited_sigma_to_noise),
            "residual_to_noise_normalised": ratio / np.sqrt((m - p) / m) if m > p else float("nan"),
            "poses_per_parameter": m / p,
            "acc_cross_axis_deg": _cross_axis_deg(cal.accelerometer.misalignment),
            "gyro_cross_axis_deg": _cross_axis_deg(cal.gyroscope.misalignment),
            "turn_speed_deg_s": turn_speed(cal, rec, intervals) if m >= 2 else float("nan"),
            **_sigma_figures(cal),
            "true_gyroscope_angle_error_mean_deg": true_err,
            "gyro_error_ratio": fitted_err / true_err if true_err > 0 else float("nan"),
            "scale_error_rel_max": max(scale_rel.values(), default=float("nan")),
            "z": z, "z_drift_adjusted": z_drift,
        }
        rec_m["good"] = bool(rec_m["gyro_error_ratio"] <= GOOD_GYRO_RATIO
                             and rec_m["scale_error_rel_max"] <= GOOD_SCALE_REL)
        out["methods"][spec] = rec_m
    return out


def _rms(values: list[float]) -> float | None:
    return float(np.sqrt(np.mean(np.square(values)))) if values else None


def _r(x, digits: int = 4):
    if x is None:
        return None
    x = float(x)
    return None if not np.isfinite(x) else float(f"{x:.{digits}g}")


def _figure_summary(runs: list[dict]) -> dict:
    out = {}
    for fig, (key, side) in FIGURES.items():
        vals = np.array([r[fig] for r in runs], dtype=float)
        vals = vals[np.isfinite(vals)]
        lim = THRESHOLDS[key]
        suspect = lim if np.isscalar(lim) else lim[0]
        entry: dict = {"threshold": lim, "n": int(vals.size)}
        if vals.size:
            if side in ("high", "both"):
                hi = lim[1] if side == "both" else suspect
                entry.update(max=_r(vals.max()), p95=_r(np.percentile(vals, 95)),
                             margin_high=_r(hi / vals.max()) if vals.max() > 0 else None)
            if side in ("low", "both"):
                lo = lim[0] if side == "both" else suspect
                entry.update(min=_r(vals.min()), p5=_r(np.percentile(vals, 5)),
                             margin_low=_r(vals.min() / lo))
            entry["median"] = _r(np.median(vals))
        out[fig] = entry
    return out


def _z_summary(runs: list[dict], key: str) -> dict:
    by_sensor: dict[str, list[float]] = {}
    by_group: dict[str, list[float]] = {}
    by_param: dict[str, list[float]] = {}
    for r in runs:
        for name, z in r[key].items():
            sensor, group = name.split(".")[:2]
            by_sensor.setdefault(sensor, []).append(z)
            by_group.setdefault(f"{sensor}.{group}", []).append(z)
            by_param.setdefault(name, []).append(z)
    worst = sorted(((_rms(v), k) for k, v in by_param.items()), reverse=True)[:5]
    return {"rms_by_sensor": {k: _r(_rms(v), 3) for k, v in by_sensor.items()},
            "n_by_sensor": {k: len(v) for k, v in by_sensor.items()},
            "rms_by_group": {k: _r(_rms(v), 3) for k, v in sorted(by_group.items())},
            "worst_parameters": {k: _r(v, 3) for v, k in worst}}


def summarise(results: list[dict], methods: list[str]) -> dict:
    """The aggregate figures per method (see the module docstring)."""
    out: dict = {}
    for spec in methods:
        rows = [(res["seed"], res["methods"][spec]) for res in results]
        errors = {seed: r["error"] for seed, r in rows if "error" in r}
        ok = [(seed, r) for seed, r in rows if "error" not in r]
        counts = {lvl: sum(r["verdict"] == lvl for _, r in ok) for lvl in ("accepted", "suspect", "rejected")}
        good = [r for _, r in ok if r["good"]]
        ratios = np.array([r["gyro_error_ratio"] for _, r in ok], dtype=float)
        ratios = ratios[np.isfinite(ratios)]
        out[spec] = {
            "verdicts": counts, "errors": errors,
            "good_runs": len(good), "runs": len(rows),
            "median_seconds": _r(np.median([r["seconds"] for _, r in ok])) if ok else None,
            "figures_over_good_runs": _figure_summary(good),
            "gyro_error_ratio": {"median": _r(np.median(ratios)) if ratios.size else None,
                                 "max": _r(ratios.max()) if ratios.size else None,
                                 "worst_seed": int(ok[int(np.nanargmax([r["gyro_error_ratio"] for _, r in ok]))][0])
                                 if ratios.size else None},
            "true_gyroscope_angle_error_mean_deg_median": _r(np.median(
                [r["true_gyroscope_angle_error_mean_deg"] for _, r in ok])) if ok else None,
            "scale_error_rel_max": _r(max((r["scale_error_rel_max"] for _, r in ok), default=float("nan"))),
            "normalised_errors": _z_summary([r for _, r in ok], "z"),
            "normalised_errors_drift_adjusted_bias": _z_summary([r for _, r in ok], "z_drift_adjusted"),
            "not_accepted": {str(seed): r["reasons"] for seed, r in ok if r["verdict"] != "accepted"},
            "bad_but_accepted": {str(seed): {"gyro_error_ratio": _r(r["gyro_error_ratio"]),
                                             "scale_error_rel_max": _r(r["scale_error_rel_max"])}
                                 for seed, r in ok if r["verdict"] == "accepted" and not r["good"]},
        }
    return out


def scenario_knobs(text: str, parser: argparse.ArgumentParser) -> dict:
    """The hand-held scenario's knobs from ``--scenario-knobs`` (a JSON object), or the parser's error."""
    try:
        knobs = json.loads(text)
    except json.JSONDecodeError as exc:
        parser.error(f"--scenario-knobs is not JSON: {exc}")
    if not isinstance(knobs, dict):
        parser.error("--scenario-knobs must be a JSON object")
    return knobs


def over_seeds(run_one, seeds: list[int], workers: int, **options) -> list:
    """``run_one(seed, **options)`` for every seed, in ``workers`` processes (in this one for 1), in order."""
    job = partial(run_one, **options)
    if workers > 1:
        with ProcessPoolExecutor(workers) as ex:
            return list(ex.map(job, seeds))
    return [job(s) for s in seeds]


def main(argv: list[str] | None = None) -> None:
    """Run the study and print its JSON (``python -m imucalib.experiments.verdict_thresholds --help``)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=30, help="number of seeds (0 … runs−1 from --first-seed)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--methods", default=DEFAULT_METHODS, help="comma-separated, each 'name' or 'name:model'")
    parser.add_argument("--scenario-knobs", default="{}", help="JSON object of handheld scenario knobs")
    parser.add_argument("--per-run", action="store_true", help="also print every run's figures")
    args = parser.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    knobs = scenario_knobs(args.scenario_knobs, parser)
    seeds = list(range(args.first_seed, args.first_seed + args.runs))
    t0 = time.perf_counter()
    results = over_seeds(run_one, seeds, args.workers, methods=methods, knobs=knobs)
    doc = {
        "benchmark": "verdict_thresholds",
        "scenario": "handheld", "knobs": knobs, "runs": args.runs, "seeds": [seeds[0], seeds[-1]],
        "good_run": {"gyro_error_ratio_max": GOOD_GYRO_RATIO, "scale_error_rel_max": GOOD_SCALE_REL},
        "wall_s": round(time.perf_counter() - t0, 1),
        "methods": summarise(results, methods),
    }
    if args.per_run:
        doc["per_run"] = [{**res, "methods": {k: {kk: vv for kk, vv in v.items() if not kk.startswith("z")}
                                              for k, v in res["methods"].items()}} for res in results]
    print(json.dumps(doc, default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o)))


if __name__ == "__main__":
    main()
