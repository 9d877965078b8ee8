"""Evaluation against the truth: parameter errors and the Monte Carlo of any scenario and method.

* :func:`parameter_errors` — estimate − truth by parameter name;
* :func:`montecarlo` — N seeded runs of simulate → calibrate → compare, with Zhang 2021's
  eqs. (34)–(35) on the sessions' test tosses where they have them
  (:mod:`imucalib.experiments.zhang2021`).

The static ``fit`` figures of the calibration file are in :mod:`imucalib.metrics`.
"""

from __future__ import annotations

import os
import traceback
import warnings
from collections.abc import Callable

import numpy as np

from ..batch import execute
from ..calibration import Calibration
from ..methods import calibrate
from ..scenarios import session
from ..verdict import LEVELS
from .zhang2021 import reductions, sequence_metrics

__all__ = ["montecarlo", "parameter_errors"]


def parameter_errors(estimate: Calibration, truth: Calibration) -> dict[str, float]:
    """``estimate − truth`` for every parameter the truth has (names as in :meth:`Calibration.parameters`).

    Parameters
    ----------
    estimate : Calibration
        The calibration to score.
    truth : Calibration
        The true parameters (a simulated session's ``truth``).

    Returns
    -------
    dict of str to float
        The error of each parameter, NaN where the estimate lacks it.

    Examples
    --------
    A calibration of a simulated session against its truth: the accelerometer's x bias is off by about
    one count, its scale factor by 0.009 %:

    >>> from imucalib.experiments.evaluate import parameter_errors
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> errors = parameter_errors(calibrate(sim.recording), sim.truth)
    >>> truth = sim.truth.parameters()
    >>> relative = errors["accelerometer.scale.x"] / truth["accelerometer.scale.x"]
    >>> round(errors["accelerometer.bias.x"], 2), round(100 * relative, 4)
    (0.98, 0.009)
    """
    est = estimate.parameters()
    return {k: est.get(k, 0.0) - v for k, v in truth.parameters().items()}


# ------------------------------------------------------------ Monte Carlo
def _one_run(args) -> dict:
    scenario, method, model, seed, baseline, sim_options, method_options = args


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


def _parameter_figures(truth: dict, ok: list[dict]) -> list[dict]:
    """Per parameter of the truth: its value and the runs' mean, standard deviation and RMS error (None
    without a run that calibrated)."""
    params = []
    for name, true in truth.items():
        vals = np.array([r["parameters"].get(name, 0.0) for r in ok]) if ok else np.array([])
        params.append({
            "name": name, "truth": true,
            "mean": float(vals.mean()) if vals.size else None,
            "std": float(vals.std()) if vals.size else None,
            "rms_error": float(np.sqrt(np.mean((vals - true) ** 2))) if vals.size else None,
        })
    return params


def _mean_metrics(ok: list[dict], baseline: str | None) -> dict:
    """The runs' mean figures, the Zhang 2021 tests' means and, with ``baseline``, the §IV-B reductions."""
    metrics: dict = {}
    for key, figure in (("accelerometer_residual_rms", lambda fit: fit.accelerometer.residual_rms),
                        ("gyroscope_angle_error_mean_deg", lambda fit: fit.gyroscope.angle_error_mean_deg)):
        vals = [figure(r["fit"]) for r in ok if figure(r["fit"]) is not None]
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
    return metrics


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
    the cluster at an address (:func:`imucalib.batch.execute`).

    Parameters
    ----------
    scenario : str
        A scenario of :data:`imucalib.scenarios.SCENARIOS`.
    method : str
        The method (:func:`imucalib.methods.method_names`).
    model : str, optional
        The method's model variant.
    runs : int
        Number of runs.
    workers : int, optional
        Local processes (or the LocalCluster's, with ``scheduler="local"``).
    scheduler : str, optional
        ``"local"`` or a Dask scheduler's address; by default local processes.
    seed : int
        Seed of the first run.
    baseline : str, optional
        Also run this method and report the Zhang 2021 §IV-B reductions against it.
    progress : callable, optional
        Called with ``(done, total)`` as runs finish.
    sim_options, method_options : dict, optional
        Options passed to :func:`imucalib.scenarios.session` and to the method.

    Returns
    -------
    dict
        ``{"scenario", "method", "model", "runs",
        "parameters": [{"name", "truth", "mean", "std", "rms_error"}, …],
        "metrics": {…}, "verdicts": {"accepted": n, "suspect": n, "rejected": n},
        "failures": [{"seed", "message"}, …]}``; ``verdicts`` counts the runs that
        produced a calibration by its verdict (:mod:`imucalib.verdict`).

    Examples
    --------
    Two short hand-held sessions (seeds 0 and 1) calibrated by ``tedaldi2014``:

    >>> from imucalib.experiments.evaluate import montecarlo
    >>> study = montecarlo("handheld", "tedaldi2014", runs=2,
    ...                    sim_options={"rest": 10, "n_poses": 14})
    >>> study["runs"], study["verdicts"]
    (2, {'accepted': 2, 'suspect': 0, 'rejected': 0})
    >>> study["parameters"][0]["name"], sorted(study["parameters"][0])
    ('accelerometer.misalignment.xy', ['mean', 'name', 'rms_error', 'std', 'truth'])
    """
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
    params = _parameter_figures(truth, ok)
    metrics = _mean_metrics(ok, baseline) if ok else {}
    verdicts = {level: sum(r["fit"].verdict.level == level for r in ok) for level in LEVELS}
    return {"scenario": scenario, "method": method, "model": model, "runs": runs,
            "parameters": params, "metrics": metrics, "verdicts": verdicts, "failures": failures}
