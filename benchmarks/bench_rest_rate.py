"""The calibrated gyroscope at rest, and between poses, for every method that fits a gyroscope; prints JSON.

A calibration's gyroscope should read zero wherever the sensor is still. Per
method and session this measures, per axis in °/s, with the calibration as
stored (a constant bias):

* ``rest_rate_mean``: the mean calibrated rate over the static poses (each pose
  one weight, the initial rest included) — the bias error the poses see;
* ``rest_rate_max``: the largest ``|pose mean|`` over the poses (white noise,
  tremor and drift included: compare with ``pose_se``, one pose mean's
  standard error from its samples);
* ``initial_rest`` and ``final_rest``: the mean calibrated rate over the
  initial rest and over the last pose, read through ``Calibration.apply`` on
  the recording the calibration was made from (``bias_drift="auto"``: the
  drifting bias ``b + d (t − t_ref)`` where the fit found a drift), and
  ``initial_rest_constant`` / ``final_rest_constant`` the same with
  ``bias_drift="off"`` (the stored bias, the poses' average: a bias that
  drifts reads ``d (t_rest − t_ref)`` there); ``drift_applied`` what apply
  did; on simulations ``initial_rest_z``, the initial rest's error over its
  1σ from the fit's bias and drift errors and the rest's own noise. The
  initial rest lies on a table; the last pose of a hand-held session is held
  in the hand, so ``final_rest`` there carries the tremor's mean over the
  pose as well (tens of m°/s: compare ``rest_rate_max``) and is a bias figure
  only on the Ferraris procedure and the shared session;
* the gyroscope's gravity-direction error between poses (mean and max, deg)
  and, on simulations, the same of the true parameters on the same poses and
  the ratio fitted/true of the means.

Sessions: the shared Xsens recording (``--reader imutk``, gravity 9.81744) and
``--runs`` hand-held simulations (``imucalib.scenarios.session("handheld")``,
default knobs: bias drift 0.01 °/s/min, random walk, tremor 0.15 °/s; more
with ``--scenario-knobs``), and as many of its Ferraris procedure (six faces and
turns) for the methods that need the faces (``--ferraris-methods``). The summary
per method: the worst ``|rest_rate_mean|`` over axes and seeds, how many
sessions exceed ``--limit`` (0.02 °/s), the same of the initial and final
rests through apply (and with the constant bias), the median and max of the worst
``rest_rate_max``, the median fitted/true gyroscope error, the verdicts and the
errors of methods that cannot run on a session.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from functools import partial

import numpy as np
from _common import DATA

from imucalib.io import read
from imucalib.methodinfo import declared
from imucalib.methods import calibrate
from imucalib.metrics import gravity_direction_errors
from imucalib.recording import Interval
from imucalib.scenarios import session

#: the methods that calibrate a gyroscope from a free-hand recording
METHODS = tuple(sorted(n for n, info in declared().items() if "turntable aggregates" not in info.needs))
XSENS_GRAVITY = 9.81744


def rest_figures(cal, rec) -> dict:
    """Per-axis rest figures [°/s] of ``cal`` on its own static poses (see the module docstring)."""
    intervals = [Interval(int(a), int(b), "static") for a, b in cal.fit["intervals"]]
    means, se = [], []
    for iv in intervals:
        w = np.degrees(cal.gyroscope_si(rec.gyro[iv.slice], rec.acc[iv.slice]))
        means.append(w.mean(axis=0))
        se.append(w.std(axis=0) / np.sqrt(max(len(iv) - 1, 1)))
    means = np.array(means)
    out = {"rest_rate_mean": means.mean(axis=0).tolist(),
           "rest_rate_max": np.abs(means).max(axis=0).tolist(),
           "pose_se_median": np.median(np.array(se), axis=0).tolist(),
           "pose_scatter": means.std(axis=0, ddof=1).tolist()}
    auto, constant = cal.apply(rec), cal.apply(rec, bias_drift="off")  # the user's path, not a side computation
    for name, iv in (("initial_rest", intervals[0]), ("final_rest", intervals[-1])):
        out[name] = np.degrees(auto.gyro[iv.slice].mean(axis=0)).tolist()
        out[f"{name}_constant"] = np.degrees(constant.gyro[iv.slice].mean(axis=0)).tolist()
    out["drift_applied"] = auto.metadata["gyroscope_bias_drift"] == "applied"
    return out


def rest_sigma(cal, rec) -> np.ndarray:
    """1σ [°/s] of the calibrated initial rest's mean from the fit: bias and drift errors, the rest's noise.

    ``M (σ_b² + (t − t_ref)² σ_d²)^½`` per axis with ``M = T diag(k1)`` taken
    on its diagonal (the cross terms are a few per cent), plus the white noise
    of the rest's mean (its samples' scatter over their number).
    """
    fit, g = cal.fit, cal.gyroscope
    unc = fit.get("uncertainty") or {}
    sb = np.array([unc.get(f"gyroscope.bias.{a}", np.nan) for a in "xyz"])
    iv = Interval(*(int(v) for v in fit["intervals"][0]))
    tau = float(np.mean(rec.t[iv.slice])) - float(fit.get("gyroscope_bias_time_s", 0.0))
    sd = np.asarray(fit.get("gyroscope_bias_drift_se_per_s", [0.0] * 3), dtype=float)
    k = np.abs(np.diag(g.misalignment) * g.scale)
    noise = np.degrees(cal.gyroscope_si(rec.gyro[iv.slice], rec.acc[iv.slice])).std(axis=0) / np.sqrt(len(iv))
    return np.sqrt((np.degrees(k) ** 2) * (sb**2 + (tau * sd) ** 2) + noise**2)


def one(rec, name: str, gravity: float, truth=None) -> dict:
    """Calibrate ``rec`` with ``name`` and measure it (``truth``: the simulation's, for the ratio)."""
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cal = calibrate(rec, method=name, gravity=gravity)
    except Exception as exc:  # a method that cannot calibrate this session says why
        return {"error": f"{type(exc).__name__}: {exc}"}
    fit = cal.fit
    out = {"verdict": fit["verdict"], "seconds": round(time.perf_counter() - t0, 2),
           "bias_source": fit.get("gyroscope_bias_source"),
           "gyro_error_mean_deg": fit.get("gyroscope_angle_error_mean_deg"),
           "gyro_error_max_deg": fit.get("gyroscope_angle_error_max_deg"),
           **rest_figures(cal, rec)}
    rate = cal.drift_rate()
    if rate is not None:
        out["drift_deg_s_per_min"] = (60 * np.degrees(rate)).tolist()
        out["drift_over_session_deg_s"] = fit.get("gyroscope_bias_drift_over_session_deg_s")
    if truth is not None:
        intervals = [Interval(int(a), int(b), "static") for a, b in fit["intervals"]]
        true_err = float(np.degrees(np.mean(gravity_direction_errors(truth, rec, intervals))))
        out["true_gyro_error_mean_deg"] = true_err
        out["gyro_error_ratio"] = out["gyro_error_mean_deg"] / true_err if true_err > 0 else None
        out["initial_rest_z"] = (np.asarray(out["initial_rest"]) / rest_sigma(cal, rec)).tolist()
    return out


def run_seed(seed: int, methods: list[str], knobs: dict) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = session("handheld", rng=seed, **knobs)
    return {"seed": seed, "methods": {m: one(sim.recording, m, sim.truth.gravity, sim.truth) for m in methods}}


def _r(x, digits: int = 4):
    return None if x is None or not np.isfinite(x) else float(f"{x:.{digits}g}")


def summarise(rows: list[dict], methods: list[str], limit: float) -> dict:
    out = {}
    for m in methods:
        ok = [(r["seed"], r["methods"][m]) for r in rows if "error" not in r["methods"][m]]
        errors = {str(r["seed"]): r["methods"][m]["error"] for r in rows if "error" in r["methods"][m]}
        if not ok:
            out[m] = {"runs": 0, "errors": len(errors), "first_error": next(iter(errors.values()), None)}
            continue
        worst_mean = [max(abs(v) for v in r["rest_rate_mean"]) for _, r in ok]
        worst_rest = {k: [max(abs(v) for v in r[k]) for _, r in ok]
                      for k in ("initial_rest", "initial_rest_constant", "final_rest", "final_rest_constant")}
        z = [max(abs(v) for v in r["initial_rest_z"]) for _, r in ok if "initial_rest_z" in r]
        worst_max = [max(r["rest_rate_max"]) for _, r in ok]
        ratios = [r["gyro_error_ratio"] for _, r in ok if r.get("gyro_error_ratio") is not None]
        out[m] = {
            "runs": len(ok), "errors": len(errors),
            "first_error": next(iter(errors.values()), None),
            "verdicts": {lvl: sum(r["verdict"] == lvl for _, r in ok) for lvl in ("accepted", "suspect", "rejected")},
            "rest_rate_mean_worst_deg_s": _r(max(worst_mean)),
            "rest_rate_mean_median_deg_s": _r(statistics.median(worst_mean)),
            "sessions_over_limit": sum(v > limit for v in worst_mean),
            "worst_seed": int(ok[int(np.argmax(worst_mean))][0]),
            **{f"{k}_worst_deg_s": _r(max(v)) for k, v in worst_rest.items()},
            **{f"{k}_over_limit": sum(x > limit for x in v) for k, v in worst_rest.items()},
            "initial_rest_worst_seed": int(ok[int(np.argmax(worst_rest["initial_rest"]))][0]),
            "initial_rest_z_worst": _r(max(z)) if z else None,
            "drift_found": sum("drift_deg_s_per_min" in r for _, r in ok),
            "drift_applied": sum(bool(r["drift_applied"]) for _, r in ok),
            "rest_rate_max_median_deg_s": _r(statistics.median(worst_max)),
            "rest_rate_max_worst_deg_s": _r(max(worst_max)),
            "pose_se_median_deg_s": _r(statistics.median(max(r["pose_se_median"]) for _, r in ok)),
            "gyro_error_ratio_median": _r(statistics.median(ratios)) if ratios else None,
            "gyro_error_ratio_max": _r(max(ratios)) if ratios else None,
            "gyro_error_mean_deg_median": _r(statistics.median(r["gyro_error_mean_deg"] for _, r in ok)),
            "bias_sources": sorted({str(r["bias_source"]) for _, r in ok}),
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--ferraris-methods", default="six_position,ferraris",
                        help="methods also run on hand-held sessions of the Ferraris procedure (six faces, turns)")
    parser.add_argument("--scenario-knobs", default="{}", help="JSON object of handheld scenario knobs")
    parser.add_argument("--limit", type=float, default=0.02, help="the rest-rate limit [°/s] counted against")
    parser.add_argument("--per-run", action="store_true", help="also print every session's figures")
    args = parser.parse_args()
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    knobs = json.loads(args.scenario_knobs)
    t0 = time.perf_counter()
    doc: dict = {"benchmark": "bench_rest_rate", "limit_deg_s": args.limit, "knobs": knobs}
    xsens = DATA / "xsens_imu_tk"
    if xsens.is_dir():
        rec = read([xsens / "xsens_acc.mat", xsens / "xsens_gyro.mat"], reader="imutk")
        doc["xsens"] = {m: {k: (np.round(v, 5).tolist() if isinstance(v, list) else v)
                            for k, v in one(rec, m, XSENS_GRAVITY).items()} for m in methods}
    else:
        doc["xsens"] = {"skipped": f"{xsens} not present"}
    seeds = list(range(args.first_seed, args.first_seed + args.runs))
    job = partial(run_seed, methods=methods, knobs=knobs)
    if args.workers > 1 and len(seeds) > 1:
        with ProcessPoolExecutor(args.workers) as ex:
            rows = list(ex.map(job, seeds))
    else:
        rows = [job(s) for s in seeds]
    doc["handheld"] = {"runs": len(seeds), "seeds": [seeds[0], seeds[-1]] if seeds else [],
                       "methods": summarise(rows, methods, args.limit)}
    fmethods = [m.strip() for m in args.ferraris_methods.split(",") if m.strip()]
    frows = []
    if fmethods:
        job = partial(run_seed, methods=fmethods, knobs={**knobs, "procedure": "ferraris"})
        if args.workers > 1 and len(seeds) > 1:
            with ProcessPoolExecutor(args.workers) as ex:
                frows = list(ex.map(job, seeds))
        else:
            frows = [job(s) for s in seeds]
        doc["handheld_ferraris"] = {"runs": len(seeds), "methods": summarise(frows, fmethods, args.limit)}
    if args.per_run:
        doc["per_run"] = rows
        doc["per_run_ferraris"] = frows
    doc["wall_s"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(doc))


if __name__ == "__main__":
    main()
