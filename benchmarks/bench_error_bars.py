"""Honesty of the reported 1σ errors on the hand-held scenario, per method and parameter group; prints JSON.

For ``--runs`` seeds of ``imucalib.scenarios.session("handheld", ...)`` each
method of ``--methods`` (``procedure/name`` or ``procedure/name:model``, the
procedure ``poses`` or ``ferraris`` of the scenario) calibrates the recording
with the declared gravity. For every parameter with a finite, positive 1σ in
``fit["uncertainty"]`` and a true value, ``z = (estimate − truth)/1σ``; per
method and parameter group (``accelerometer.bias``, ``gyroscope.scale``, …)
the table gives the RMS of ``z`` (1 for an honest 1σ; the goal is 0.8–1.25),
the share of ``|z| > 3`` (0.27 % for a Gaussian) and how many values went in.

The truth of a drifting gyroscope bias: the scenario's truth holds the bias at
the start of the session, and the bias then drifts (linearly and by a random
walk). A fit's bias holds at its reference time ``fit["gyroscope_bias_time_s"]``
(or, where the fit stores none, the mean of its static poses' mean times, the
same definition): the truth is the session's bias at that time, the start's
plus the drift there. The drift comes from a twin session of the same seed with
the drift knobs at zero (it draws the same random numbers), as the difference of
the two recordings' gyroscope readings averaged over ``±DRIFT_WINDOW_S`` around
the reference time (quantisation leaves each difference a count off at most).

The procedure ``tosses`` is the ``zhang2021`` scenario instead (Zhang 2021,
§IV-A: 40 poses and spinning weightless tosses, no drift): ``tosses/zhang2021``
calibrates it with its tosses (the eq. 21 joint fit and the lever arm).

``real_halves``: the shared Xsens session (``../shared/data/xsens_imu_tk``,
skipped where absent) cut in two at ``--split-s`` (in the middle of a pose,
so that each half has poses with gravity along ±x, ±y and ±z and a rest to
start from), each half calibrated by every method of ``--real-methods``; per
parameter with a 1σ in both, ``z = (p₁ − p₂)/√(σ₁² + σ₂²)`` (the two halves'
errors are independent; honest error bars give ``|z| < 2`` in 95 % of
them). The table: per method and group the RMS ``z``, the largest ``|z|``,
the share of ``|z| > 2`` and each half's poses and verdict. The gyroscope bias
is compared as each fit states it (at its own time: where a half shows no
drift, the bias is taken to be constant).
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
from _common import DATA

from imucalib.experiments.verdict_thresholds import over_seeds, scenario_knobs
from imucalib.methods import calibrate
from imucalib.scenarios import session

DEFAULT_METHODS = ("poses/tedaldi2014,poses/ellipsoid,poses/zhang2021:linear,poses/zhang2021,poses/zhang2021:all,"
                   "ferraris/six_position,ferraris/ferraris,tosses/zhang2021")
#: the procedures: the hand-held scenario's two, and the zhang2021 scenario with its tosses
PROCEDURES = ("poses", "ferraris", "tosses")
#: methods calibrated on each half of the shared session
REAL_METHODS = "tedaldi2014,ellipsoid,zhang2021:linear,zhang2021"
#: where the shared session is cut [s from its start]: the middle of the pose held from 244.9 to 251.3 s
SPLIT_S = 248.1
#: the shared session's local gravity [m/s²] (imu_tk's test app)
XSENS_GRAVITY = 9.81744
#: the goal for every group's RMS z
GOAL = (0.8, 1.25)
#: half-width [s] of the window over which the twin sessions' difference gives the bias drift at a time
DRIFT_WINDOW_S = 1.0


def bias_reference_time(recording, fit: dict) -> float:
    """The time [s] at which a fit's gyroscope bias holds: its own, else the mean of its poses' mean times."""
    t_ref = fit.get("gyroscope_bias_time_s")
    if t_ref is not None:
        return float(t_ref)
    return float(np.mean([np.mean(recording.t[int(a):int(b)]) for a, b in fit["intervals"]]))


def drift_at(sim, twin, t_ref: float) -> np.ndarray:
    """The gyroscope bias's drift [raw] at ``t_ref`` since the start: ``sim − twin`` averaged near ``t_ref``."""
    t = sim.recording.t
    near = np.abs(t - t_ref) <= DRIFT_WINDOW_S
    if not np.any(near):
        near = np.argmin(np.abs(t - t_ref))
    return np.atleast_2d(sim.recording.gyro[near] - twin.recording.gyro[near]).mean(axis=0)


def normalised_errors(cal, truth, sim, twin) -> dict[str, float]:
    """``(estimate − truth)/1σ`` of every parameter with a finite 1σ and a true value, the bias at its time."""
    fit = cal.fit
    tp, est = truth.parameters(), cal.parameters()
    drift = None
    z = {}
    for k, s in (fit.get("uncertainty") or {}).items():
        if s is None or not np.isfinite(s) or s <= 0 or k not in tp or k not in est:
            continue
        ref = tp[k]
        if k.startswith("gyroscope.bias.") and twin is not None:
            if drift is None:
                drift = drift_at(sim, twin, bias_reference_time(sim.recording, fit))
            ref = ref + float(drift["xyz".index(k[-1])])
        z[k] = float((est[k] - ref) / s)
    return z


def run_one(seed: int, methods: list[str], knobs: dict) -> dict:
    """One seed: each procedure's session and its twin without drift, every method's normalised errors."""
    out: dict = {"seed": seed, "methods": {}}
    sims = {}
    for spec in methods:
        proc, _, rest = spec.partition("/")
        name, _, model = rest.partition(":")
        if proc not in sims:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if proc == "tosses":  # no drift in this scenario: no twin
                    sims[proc] = (session("zhang2021", rng=seed), None)
                else:
                    sims[proc] = (session("handheld", rng=seed, procedure=proc, **knobs),
                                  session("handheld", rng=seed, procedure=proc,
                                          **{**knobs, "gyro_drift": 0.0, "gyro_rw": 0.0}))
        sim, twin = sims[proc]
        extra = {"weightless": sim.weightless} if proc == "tosses" else {}
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                cal = calibrate(sim.recording, method=name, model=model or None, gravity=sim.truth.gravity, **extra)
        except Exception as exc:  # a method that cannot calibrate this session says why
            out["methods"][spec] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        out["methods"][spec] = {"model": cal.model, "verdict": cal.fit.get("verdict"),
                                "z": normalised_errors(cal, sim.truth, sim, twin)}
    return out


def real_halves(methods: list[str], split_s: float) -> dict:
    """The shared session cut at ``split_s``: each method on both halves, ``z`` of their difference per group."""
    from imucalib.io import read
    from imucalib.recording import Interval

    path = DATA / "xsens_imu_tk"
    if not (path / "xsens_acc.mat").is_file():
        return {"skipped": f"{path} not present (needs ../shared/data)"}
    rec = read([path / "xsens_acc.mat", path / "xsens_gyro.mat"], reader="imutk")
    k = int(np.searchsorted(rec.t - rec.t[0], split_s))
    halves = [rec[Interval(0, k)], rec[Interval(k, len(rec))]]
    out: dict = {"session": "xsens_imu_tk", "split_s": split_s, "gravity": XSENS_GRAVITY,
                 "samples": [len(h) for h in halves], "methods": {}}
    for spec in methods:
        name, _, model = spec.partition(":")
        cals = []
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                cals = [calibrate(h, method=name, model=model or None, gravity=XSENS_GRAVITY) for h in halves]
        except Exception as exc:  # a method that cannot calibrate a half says why
            out["methods"][spec] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        (p1, p2), (u1, u2) = ([c.parameters() for c in cals], [c.fit.get("uncertainty") or {} for c in cals])
        groups: dict[str, list[float]] = {}
        for key, s1 in u1.items():
            s2 = u2.get(key)
            if key not in p1 or key not in p2 or s2 is None or not (np.isfinite(s1) and np.isfinite(s2)):
                continue
            if s1 <= 0 or s2 <= 0:
                continue
            groups.setdefault(key.rsplit(".", 1)[0], []).append(float((p1[key] - p2[key]) / np.hypot(s1, s2)))
        rows = {}
        for g, zs in sorted(groups.items()):
            z = np.asarray(zs)
            rows[g] = {"rms_z": _r(float(np.sqrt(np.mean(z**2)))), "max_abs_z": _r(float(np.max(np.abs(z)))),
                       "share_abs_z_over_2": _r(float(np.mean(np.abs(z) > 2))), "n": int(z.size),
                       "z": [_r(v, 2) for v in z]}
        out["methods"][spec] = {"models": [c.model for c in cals], "verdicts": [c.fit.get("verdict") for c in cals],
                                "poses": [len(c.fit["intervals"]) for c in cals], "groups": rows}
    return out


def _r(x: float, digits: int = 3):
    return None if x is None or not np.isfinite(x) else float(f"{x:.{digits}g}")


def table(results: list[dict], methods: list[str]) -> dict:
    """Per method and parameter group: RMS z, share |z| > 3, count, and whether the RMS is within :data:`GOAL`."""
    out: dict = {}
    for spec in methods:
        groups: dict[str, list[float]] = {}
        errors, models = {}, {}
        for res in results:
            r = res["methods"][spec]
            if "error" in r:
                errors[str(res["seed"])] = r["error"]
                continue
            models[r["model"]] = models.get(r["model"], 0) + 1
            for name, z in r["z"].items():
                groups.setdefault(name.rsplit(".", 1)[0], []).append(z)
        rows = {}
        for g, zs in sorted(groups.items()):
            zs = np.asarray(zs)
            rms = float(np.sqrt(np.mean(zs**2)))
            rows[g] = {"rms_z": _r(rms), "share_abs_z_over_3": _r(float(np.mean(np.abs(zs) > 3))),
                       "n": int(zs.size), "within_goal": bool(GOAL[0] <= rms <= GOAL[1])}
        out[spec] = {"models": models, "groups": rows, "errors": errors,
                     "outside_goal": [g for g, row in rows.items() if not row["within_goal"]]}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    # 60 seeds: an RMS over 30 seeds × 3 axes still scatters by about ±0.08 (1σ) about its value (six_position's
    # gyroscope bias reads 0.75 on seeds 0-29 and 0.99 on seeds 30-59), too much to judge a 0.8-1.25 band by
    parser.add_argument("--runs", type=int, default=60, help="number of seeds (from --first-seed)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--methods", default=DEFAULT_METHODS,
                        help="comma-separated, each 'procedure/name' or 'procedure/name:model'")
    parser.add_argument("--scenario-knobs", default="{}", help="JSON object of handheld scenario knobs")
    parser.add_argument("--real-methods", default=REAL_METHODS,
                        help="comma-separated methods ('name' or 'name:model') on the shared session's halves "
                             "('' for none)")
    parser.add_argument("--split-s", type=float, default=SPLIT_S,
                        help="where the shared session is cut [s from its start]")
    args = parser.parse_args()
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    for spec in methods:
        if spec.partition("/")[0] not in PROCEDURES or not spec.partition("/")[2]:
            parser.error(f"a method is 'procedure/name' (optionally ':model'), the procedure one of "
                         f"{', '.join(PROCEDURES)}; got {spec!r}")
    knobs = scenario_knobs(args.scenario_knobs, parser)
    seeds = list(range(args.first_seed, args.first_seed + args.runs))
    t0 = time.perf_counter()
    results = over_seeds(run_one, seeds, args.workers, methods=methods, knobs=knobs)
    real_methods = [m.strip() for m in args.real_methods.split(",") if m.strip()]
    real = real_halves(real_methods, args.split_s) if real_methods else None
    doc = {"benchmark": "error_bars", "scenario": "handheld (tosses: zhang2021)", "knobs": knobs, "runs": args.runs,
           "seeds": [seeds[0], seeds[-1]], "goal_rms_z": list(GOAL),
           "wall_s": round(time.perf_counter() - t0, 1), "methods": table(results, methods),
           "real_halves": real}
    print(json.dumps(doc))


if __name__ == "__main__":
    main()
