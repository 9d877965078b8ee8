"""Evaluation: the papers' metrics, parameter errors against truth, and Monte Carlo.

* :func:`eq34` — Zhang 2021, eq. (34): ``Σ_j ‖a_j − f_C(ω_j, r) − f_E(ω̇_j, r)‖²`` over
  the weightless frames of an RD3 test sequence;
* :func:`eq35` — Zhang 2021, eq. (35): the cosine between the gravity measured on
  the base after a toss and the gravity before it carried through the toss by
  the calibrated gyroscope (RK4);
* :func:`reductions` — the §IV-B average reductions of a method against a
  baseline: ``mean(1 − L34_method / L34_baseline)`` (the baseline evaluated
  with the method's lever arm, as the paper does) and
  ``mean(1 − arccos L35_method / arccos L35_baseline)``;
* :func:`parameter_errors` — estimate − truth by parameter name;
* :func:`montecarlo` — N seeded runs of simulate → calibrate → compare;
* :func:`demo` — one Zhang 2021 session calibrated with the linear and the full
  model and with Tedaldi 2014, against the truth (``imucalib demo``).

The static ``fit`` figures of the calibration file are in :mod:`imucalib.metrics`.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable

import numpy as np

from .batch import execute
from .calibration import Calibration
from .kinematics import IntervalIntegrator, five_point_derivative, quat_to_matrix
from .methods.zhang2021 import lever_arm_matrix
from .verdict import LEVELS

__all__ = ["demo", "eq34", "eq35", "reductions", "parameter_errors", "montecarlo", "sequence_metrics"]


def eq34(calibration: Calibration, test, *, lever_arm: np.ndarray | None = None) -> float:
    """Weightless accelerometer error of one RD3 sequence (Zhang 2021, eq. 34) [(m/s²)²].

    ``lever_arm`` overrides the calibration's (the paper evaluates the baseline
    with the lever arm of its own 'all' calibration).
    """
    r = calibration.lever_arm if lever_arm is None else np.asarray(lever_arm, dtype=float)
    if r is None:
        raise ValueError("eq. (34) needs a lever arm: pass lever_arm= for a calibration without one")
    rec = test.recording
    out = calibration.apply(rec)
    dt = 1.0 / rec.rate
    total = 0.0
    for seg in test.segments:
        if seg.kind != "weightless":
            continue
        w = out.gyro[seg.slice]
        wd = five_point_derivative(w, dt)  # eq. (20)
        e = out.acc[seg.slice] - lever_arm_matrix(w, wd) @ r
        total += float(np.sum(e * e))
    return total


def eq35(calibration: Calibration, test) -> float:
    """Cosine between measured and gyro-propagated gravity across one toss (Zhang 2021, eq. 35)."""
    rec = test.recording
    static = [s for s in test.segments if s.kind == "static"]
    if len(static) < 2:
        raise ValueError("eq. (35) needs a static segment before and after the toss")
    first, last = static[0], static[-1]
    a0 = calibration.accelerometer_si(rec.acc[first.slice].mean(axis=0, keepdims=True))[0]
    a1 = calibration.accelerometer_si(rec.acc[last.slice].mean(axis=0, keepdims=True))[0]
    integ = IntervalIntegrator(rec.t, np.array([first.stop - 1]), np.array([last.start]))
    w = calibration.gyroscope_si(rec.gyro[integ.samples], rec.acc[integ.samples])
    rot = quat_to_matrix(integ.from_samples(w))[0]
    pred = rot.T @ a0
    return float(a1 @ pred / (np.linalg.norm(a1) * np.linalg.norm(pred)))


def sequence_metrics(calibration: Calibration, tests, *, lever_arm=None) -> dict:
    """eq. (34) and eq. (35) for every RD3 sequence."""
    return {
        "eq34": [eq34(calibration, t, lever_arm=lever_arm) for t in tests],
        "eq35": [eq35(calibration, t) for t in tests],
    }


def reductions(method: dict, baseline: dict) -> dict:
    """§IV-B average reductions of ``method`` against ``baseline`` (dicts from :func:`sequence_metrics`)."""
    m34, b34 = np.asarray(method["eq34"]), np.asarray(baseline["eq34"])
    m35 = np.arccos(np.clip(method["eq35"], -1, 1))
    b35 = np.arccos(np.clip(baseline["eq35"], -1, 1))
    return {
        "eq34_reduction": float(np.mean(1 - m34 / b34)),
        "eq35_reduction": float(np.mean(1 - m35 / b35)),
    }


def parameter_errors(estimate: Calibration, truth: Calibration) -> dict[str, float]:
    """``estimate − truth`` for every parameter the truth has (names as in :meth:`Calibration.parameters`)."""
    est = estimate.parameters()
    return {k: est.get(k, 0.0) - v for k, v in truth.parameters().items()}


# ------------------------------------------------------------ Monte Carlo
def _one_run(args) -> dict:
    scenario, method, model, seed, baseline, sim_options, method_options = args
    import warnings

    from .methods import calibrate
    from .scenarios import session

    try:
        sim = session(scenario, rng=seed, **sim_options)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cal = calibrate(sim, method=method, model=model, gravity=sim.truth.gravity,
                            **method_options)
            out = {"seed": seed, "parameters": cal.parameters(), "fit": cal.fit}
            if sim.tests:
                m = sequence_metrics(cal, sim.tests, lever_arm=cal.lever_arm if cal.lever_arm is not None
                                 else sim.truth.lever_arm)
                out["tests"] = m
                if baseline:
                    base = calibrate(sim, method=baseline, gravity=sim.truth.gravity)
                    r = cal.lever_arm if cal.lever_arm is not None else sim.truth.lever_arm
                    out["baseline_tests"] = sequence_metrics(base, sim.tests, lever_arm=r)
        return out
    except Exception as exc:  # a failing run is recorded, never aborts the batch
        return {"seed": seed, "error": f"{type(exc).__name__}: {exc}",
                "traceback": traceback.format_exc(limit=3)}


def montecarlo(
    scenario: str,
    method: str,
    *,
    model: str | None = None,
    runs: int = 20,
    workers: int | None = 1,
    scheduler: str | None = None,
    seed: int = 0,
    baseline: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    sim_options: dict | None = None,
    method_options: dict | None = None,
) -> dict:
    """Seeded runs of simulate → calibrate → compare with the truth.

    Run ``i`` uses seed ``seed + i``, so the summary does not depend on
    where the runs run: ``workers`` local processes (a pool that lives for
    the whole study), or with ``scheduler`` one Dask task per run on a
    ``"local"`` LocalCluster of ``workers`` processes (None: one per core) or
    the cluster at an address (:func:`imucalib.batch.execute`). Returns
    ``{"scenario", "method", "model", "runs",
    "parameters": [{"name", "truth", "mean", "std", "rms_error"}, …],
    "metrics": {…}, "verdicts": {"accepted": n, "suspect": n, "rejected": n},
    "failures": [{"seed", "message"}, …]}``; ``verdicts`` counts the runs that
    produced a calibration by its verdict (:mod:`imucalib.verdict`).
    """
    from .scenarios import session

    if runs < 1:
        raise ValueError(f"runs must be ≥ 1; got {runs}")
    if scheduler is None:
        workers = max(1, min(int(workers or 1), os.cpu_count() or 1, runs))
    sim_options = sim_options or {}
    method_options = method_options or {}
    jobs = [(scenario, method, model, seed + i, baseline, sim_options, method_options)
            for i in range(runs)]
    results = [r for _, r in execute(_one_run, jobs, workers=workers, scheduler=scheduler, progress=progress)]
    results.sort(key=lambda r: r["seed"])
    ok = [r for r in results if "error" not in r]
    failures = [{"seed": r["seed"], "message": r["error"]} for r in results if "error" in r]
    truth = session(scenario, rng=seed, **sim_options).truth.parameters()
    params = []
    for name, true in truth.items():
        vals = np.array([r["parameters"].get(name, 0.0) for r in ok]) if ok else np.array([])
        params.append({
            "name": name, "truth": true,
            "mean": float(vals.mean()) if vals.size else None,
            "std": float(vals.std()) if vals.size else None,
            "rms_error": float(np.sqrt(np.mean((vals - true) ** 2))) if vals.size else None,
        })
    metrics: dict = {}
    if ok:
        for key in ("accelerometer_residual_rms", "gyroscope_angle_error_mean_deg"):
            vals = [r["fit"][key] for r in ok if key in r["fit"]]
            if vals:
                metrics[key] = float(np.mean(vals))
        if all("tests" in r for r in ok):
            metrics["eq34_mean"] = float(np.mean([np.mean(r["tests"]["eq34"]) for r in ok]))
            metrics["eq35_mean"] = float(np.mean([np.mean(r["tests"]["eq35"]) for r in ok]))
        if baseline and all("baseline_tests" in r for r in ok):
            red = [reductions(r["tests"], r["baseline_tests"]) for r in ok]
            metrics["baseline"] = baseline
            metrics["eq34_reduction"] = float(np.mean([x["eq34_reduction"] for x in red]))
            metrics["eq35_reduction"] = float(np.mean([x["eq35_reduction"] for x in red]))
    verdicts = {level: sum(r["fit"].get("verdict") == level for r in ok) for level in LEVELS}
    return {"scenario": scenario, "method": method, "model": model, "runs": runs,
            "parameters": params, "metrics": metrics, "verdicts": verdicts, "failures": failures}


# ------------------------------------------------------------------- demo
def demo(seed: int = 0, *, progress: Callable[[str], None] | None = None) -> dict:
    """The main job on a built-in session: Zhang 2021's linear model against its full model.

    Simulates the ``zhang2021`` scenario (Table I truth, default noise),
    calibrates it with ``tedaldi2014``, ``zhang2021`` linear and ``zhang2021``
    all, and evaluates each on the session's test tosses (eqs. 34–35, the
    baselines with the full model's lever arm as the paper does).

    Parameters
    ----------
    seed : int
        Seed of the simulated session.
    progress : callable, optional
        Called with a short message before each stage.

    Returns
    -------
    dict
        ``{"scenario", "seed", "seconds", "parameters": [{"name", "truth",
        "linear", "all", "all_std"}, …], "metrics": {"eq34_mean": {…},
        "eq35_mean": {…}, "all_vs_tedaldi2014_eq34_reduction",
        "all_vs_tedaldi2014_eq35_reduction"}}``; ``linear`` is ``None`` for a
        parameter the linear model lacks, ``all_std`` is the full model's 1σ
        standard error (``None`` where it has none).
    """
    from .methods import calibrate
    from .scenarios import session

    say = progress or (lambda msg: None)
    t0 = time.perf_counter()
    say("simulating the zhang2021 session (Table I truth, default noise)")
    sim = session("zhang2021", rng=seed)
    g = sim.truth.gravity
    say("calibrating: tedaldi2014 (linear)")
    ted = calibrate(sim, method="tedaldi2014", gravity=g)
    say("calibrating: zhang2021 linear")
    lin = calibrate(sim, method="zhang2021", model="linear", gravity=g)
    say("calibrating: zhang2021 all")
    full = calibrate(sim, method="zhang2021", model="all", gravity=g)
    metrics = {"all": sequence_metrics(full, sim.tests),
               "linear": sequence_metrics(lin, sim.tests, lever_arm=full.lever_arm),
               "tedaldi2014": sequence_metrics(ted, sim.tests, lever_arm=full.lever_arm)}
    elapsed = time.perf_counter() - t0
    est = {"linear": lin.parameters(), "all": full.parameters()}
    unc = full.fit.get("uncertainty", {})
    rows = [{"name": k, "truth": v, "linear": est["linear"].get(k), "all": est["all"].get(k),
             "all_std": unc.get(k)} for k, v in sim.truth.parameters().items()]
    means = {eq: {name: float(np.mean(metrics[name][eq])) for name in ("tedaldi2014", "linear", "all")}
             for eq in ("eq34", "eq35")}
    verdicts = {name: {"verdict": c.fit.get("verdict"), "reasons": c.fit.get("verdict_reasons", [])}
                for name, c in (("tedaldi2014", ted), ("linear", lin), ("all", full))}
    return {
        "scenario": "zhang2021", "seed": seed, "seconds": round(elapsed, 3), "parameters": rows,
        "verdicts": verdicts,
        "metrics": {"eq34_mean": means["eq34"], "eq35_mean": means["eq35"],
                    **{f"all_vs_tedaldi2014_{k}": v
                       for k, v in reductions(metrics["all"], metrics["tedaldi2014"]).items()}},
    }
