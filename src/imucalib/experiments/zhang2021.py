"""Zhang 2021, §IV: the metrics of eqs. (34)–(35) on the test tosses, and the Table I session's demo.

* :func:`eq34` — eq. (34): ``Σ_j ‖a_j − f_C(ω_j, r) − f_E(ω̇_j, r)‖²`` over
  the weightless frames of an RD3 test sequence;
* :func:`eq35` — eq. (35): the cosine between the gravity measured on
  the base after a toss and the gravity before it carried through the toss by
  the calibrated gyroscope (RK4);
* :func:`reductions` — the §IV-B average reductions of a method against a
  baseline: ``mean(1 − L34_method / L34_baseline)`` (the baseline evaluated
  with the method's lever arm, as the paper does) and
  ``mean(1 − arccos L35_method / arccos L35_baseline)``;
* :func:`demo` — one session with Table I's truth calibrated with the linear and the full
  model and with Tedaldi 2014, against the truth (``imucalib demo``).

The Monte Carlo over many seeds is :func:`imucalib.experiments.evaluate.montecarlo`.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from ..calibration import Calibration
from ..kinematics import IntervalIntegrator, five_point_derivative, quat_to_matrix
from ..methods import calibrate
from ..methods.zhang2021 import lever_arm_matrix

__all__ = ["demo", "eq34", "eq35", "reductions", "sequence_metrics"]


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
    from ..scenarios import session  # imucalib.scenarios costs 21 ms at start-up

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
    unc = full.fit.uncertainty.sigma or {}
    rows = [{"name": k, "truth": v, "linear": est["linear"].get(k), "all": est["all"].get(k),
             "all_std": unc.get(k)} for k, v in sim.truth.parameters().items()]
    means = {eq: {name: float(np.mean(metrics[name][eq])) for name in ("tedaldi2014", "linear", "all")}
             for eq in ("eq34", "eq35")}
    verdicts = {name: {"verdict": c.fit.verdict.level, "reasons": c.fit.verdict.reasons or []}
                for name, c in (("tedaldi2014", ted), ("linear", lin), ("all", full))}
    return {
        "scenario": "zhang2021", "seed": seed, "seconds": round(elapsed, 3), "parameters": rows,
        "verdicts": verdicts,
        "metrics": {"eq34_mean": means["eq34"], "eq35_mean": means["eq35"],
                    **{f"all_vs_tedaldi2014_{k}": v
                       for k, v in reductions(metrics["all"], metrics["tedaldi2014"]).items()}},
    }
