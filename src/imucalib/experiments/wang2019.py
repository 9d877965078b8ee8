"""Wang 2019, §5.1: the Monte Carlo of Tables 2–3 and the plan's sensitivity and Fisher information.

The turntable sessions are :mod:`imucalib.scenarios.wang2019`'s (the plan, the truth's distributions and
the noise are described there); the method is :mod:`imucalib.methods.wang2019`. This module runs one on
the other: :func:`montecarlo` gives the RMS errors in the units of Tables 2–3 beside the paper's, and
:func:`plan_report` the sensitivity (eqs. 20–25, 31–34) and Cramér–Rao bound of every parameter.
"""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor

import numpy as np

from ..calibration import Calibration
from ..constants import DEG, EARTH_RATE, G0, MICRO_G
from ..methods.wang2019 import calibrate, poly_norm_residuals
from ..scenarios.wang2019 import plan, session

__all__ = ["DIVERGENCE", "PAPER_RMS", "montecarlo", "parameter_errors_wang_units", "plan_report"]


def parameter_errors_wang_units(estimate: Calibration, truth: Calibration) -> dict[str, np.ndarray]:
    """Errors in the units of Wang 2019, Tables 2–3 (µg, µg/pulse, fg/pulse², zg/pulse³, 1e-4…)."""
    a, ta = estimate.accelerometer, truth.accelerometer
    g, tg = estimate.gyroscope, truth.gyroscope
    low = [(1, 0), (2, 0), (2, 1)]
    return {
        "acc_bias_ug": (a.output_bias - ta.output_bias) / MICRO_G,
        "acc_k1_ug_per_pulse": (a.scale - ta.scale) / MICRO_G,
        "acc_k2_fg_per_pulse2": (a.scale_quadratic - ta.scale_quadratic) / (1e-15 * G0),
        "acc_k3_zg_per_pulse3": (a.scale_cubic - ta.scale_cubic) / (1e-21 * G0),
        "acc_misalignment_1e-4": np.array([a.misalignment[i] - ta.misalignment[i] for i in low]) / 1e-4,
        "gyro_bias_1e-6_deg_s": (g.output_bias - tg.output_bias) / (1e-6 * DEG),
        "gyro_k1_1e-7_deg_s_pulse": (g.scale - tg.scale) / (1e-7 * DEG),
        "gyro_k2_1e-17_deg_s_pulse2": (g.scale_quadratic - tg.scale_quadratic) / (1e-17 * DEG),
        "gyro_misalignment_1e-4": np.array([g.misalignment[i] - tg.misalignment[i] for i in low]) / 1e-4,
    }


#: Wang 2019, Tables 2-3: RMS of the 500-run Monte Carlo per axis (x, y, z; misalignments yx, zx, zy)
PAPER_RMS = {
    "3arcsec": {"acc_bias_ug": [1.90, 2.02, 1.96], "acc_k1_ug_per_pulse": [1.90e-5, 3.35e-5, 1.86e-5],
                "acc_k2_fg_per_pulse2": [4.93e-2, 4.64e-2, 4.72e-2], "acc_k3_zg_per_pulse3": [0.37, 0.62, 0.37],
                "acc_misalignment_1e-4": [1.91e-2, 1.90e-2, 1.87e-2],
                "gyro_bias_1e-6_deg_s": [1.58e-2, 1.94e-3, 2.04e-3],
                "gyro_k1_1e-7_deg_s_pulse": [3.14e-8, 6.27e-8, 3.88e-8],
                "gyro_k2_1e-17_deg_s_pulse2": [9.40e-2, 2.73e-2, 7.18e-2],
                "gyro_misalignment_1e-4": [1.18e-4, 1.18e-4, 8.02e-5]},
    "3arcmin": {"acc_bias_ug": [1.91, 2.01, 1.96], "acc_k1_ug_per_pulse": [1.90e-5, 3.35e-5, 1.86e-5],
                "acc_k2_fg_per_pulse2": [4.94e-2, 4.64e-2, 4.72e-2], "acc_k3_zg_per_pulse3": [0.38, 0.62, 0.37],
                "acc_misalignment_1e-4": [1.91e-2, 1.90e-2, 1.87e-2],
                "gyro_bias_1e-6_deg_s": [1.58e-2, 1.95e-3, 2.03e-3],
                "gyro_k1_1e-7_deg_s_pulse": [1.73e-8, 4.50e-8, 1.90e-8],
                "gyro_k2_1e-17_deg_s_pulse2": [0.15, 2.92e-2, 3.53e-2],
                "gyro_misalignment_1e-4": [1.90e-4, 1.90e-4, 4.17e-5]},
    "3deg": {"acc_bias_ug": [2.11, 1.95, 2.06], "acc_k1_ug_per_pulse": [2.04e-5, 3.41e-5, 1.81e-5],
             "acc_k2_fg_per_pulse2": [5.40e-2, 4.52e-2, 4.94e-2], "acc_k3_zg_per_pulse3": [0.40, 0.63, 0.35],
             "acc_misalignment_1e-4": [1.90e-2, 1.87e-2, 1.97e-2],
             "gyro_bias_1e-6_deg_s": [1.57e-2, 1.94e-3, 2.01e-3],
             "gyro_k1_1e-7_deg_s_pulse": [1.87e-8, 6.51e-8, 1.68e-8],
             "gyro_k2_1e-17_deg_s_pulse2": [0.10, 6.14e-2, 1.19e-2],
             "gyro_misalignment_1e-4": [1.41e-4, 1.31e-4, 1.81e-5]},
}


def _mc_run(args):
    seed, turntable_error, initial, noise, dwell_s = args
    sim = session(seed, turntable_error=turntable_error, noise=noise, dwell_s=dwell_s)
    try:
        cal = calibrate(sim, initial=initial)
    except (ValueError, np.linalg.LinAlgError) as exc:
        return {"seed": seed, "error": str(exc)}
    return {"seed": seed, "errors": parameter_errors_wang_units(cal, sim.truth)}


#: divergence: an error beyond the parameter's own spread (its §5.1 distribution's half-width)
DIVERGENCE = {"acc_bias_ug": 1e4, "acc_k1_ug_per_pulse": 2.0, "acc_k2_fg_per_pulse2": 5.0,
              "acc_k3_zg_per_pulse3": 5.0, "acc_misalignment_1e-4": 5.0,
              "gyro_bias_1e-6_deg_s": 5.0, "gyro_k1_1e-7_deg_s_pulse": 2.0,
              "gyro_k2_1e-17_deg_s_pulse2": 5.0, "gyro_misalignment_1e-4": 5.0}


def montecarlo(runs: int = 500, *, turntable_error: str = "3arcsec", seed: int = 0,
               initial: str = "estimate", workers: int = 1, noise: dict | None = None,
               dwell_s: float = 300.0) -> dict:
    """Wang 2019 §5.1 Monte Carlo: RMS errors per parameter (Tables 2–3 units), divergent runs.

    A run diverges when any error exceeds :data:`DIVERGENCE` (the half-width of
    that parameter's distribution: the estimate is no better than a guess).
    ``paper_rms`` holds the same column of Tables 2–3; ``within_paper`` says,
    per parameter group, whether the largest axis's RMS is at or below the
    table's largest. Groups are compared by their largest axis because which
    axis carries the larger error depends on the rotation plan, and the
    paper's plan (its Figs. 2–3) is not in its text.
    """
    if runs < 1:
        raise ValueError(f"runs must be at least 1; got {runs}")
    jobs = [(seed + i, turntable_error, initial, noise, dwell_s) for i in range(runs)]
    if workers > 1:
        with ProcessPoolExecutor(workers) as ex:
            results = list(ex.map(_mc_run, jobs, chunksize=8))
    else:
        results = [_mc_run(j) for j in jobs]
    ok = [r for r in results if "errors" in r]
    diverged = [r["seed"] for r in ok
                if any(np.any(np.abs(r["errors"][k]) > lim) for k, lim in DIVERGENCE.items())]
    good = [r for r in ok if r["seed"] not in set(diverged)]
    rms = {k: np.sqrt(np.mean([r["errors"][k] ** 2 for r in good], axis=0)).tolist() if good else None
           for k in DIVERGENCE}
    mean = {k: np.mean([r["errors"][k] for r in good], axis=0).tolist() if good else None
            for k in DIVERGENCE}
    paper = PAPER_RMS[turntable_error]
    within = {k: bool(rms[k] is not None and max(rms[k]) <= max(paper[k])) for k in DIVERGENCE}
    return {"scenario": "wang2019", "method": "wang2019", "runs": runs,
            "turntable_error": turntable_error, "initial": initial, "noise": noise or {}, "dwell_s": dwell_s,
            "rms": rms, "mean": mean, "paper_rms": paper, "within_paper": within,
            "divergent_runs": len(diverged), "divergent_seeds": diverged[:20],
            "failures": [{"seed": r["seed"], "message": r["error"]} for r in results if "error" in r]}


def plan_report(seed: int = 0) -> dict:
    """The position and rotation plan with each parameter's sensitivity and Fisher information.

    For a typical truth (drawn with ``seed``) and the noise of the scenario, the
    Jacobians of eqs. (18), (30) and (35) at the truth give, per parameter, the
    RMS sensitivity of the residuals (eqs. 20–25, 31–34) and the diagonal of
    the Fisher information ``JᵀJ/σ²`` with the Cramér–Rao standard deviation
    from its inverse; finite values for every parameter show that the plan
    observes them all.
    """
    sim = session(seed)
    t = sim.truth
    positions, axes = plan()
    a, g = t.accelerometer, t.gyroscope
    na, ng = sim.positions_acc, sim.positions_gyro
    ns, ns2 = sim.turn_sum, sim.turn_sum2
    low = [(1, 0), (2, 0), (2, 1)]
    xa = np.concatenate([a.scale, a.scale_quadratic, a.scale_cubic, [a.misalignment[i] for i in low],
                         a.output_bias])
    xg = np.concatenate([g.scale, g.scale_quadratic, [g.misalignment[i] for i in low]])
    one = np.ones(15)
    _, ja = poly_norm_residuals(xa, one, [na, na**2, na**3], 3, sim.gravity**2, True, jac=True)
    _, jg = poly_norm_residuals(xg, np.ones(9), [ns, ns2], 2, (2 * sim.turn_angle) ** 2, False, jac=True)
    kg = xg[:6].reshape(2, 3)
    _, jb = poly_norm_residuals(g.output_bias, np.ones(3), [ng, ng**2], 2, EARTH_RATE**2, True,
                                 k_fixed=(kg, xg[6:9]), jac=True)
    # residual noise: σ of ‖f‖² − g² from the position means (white noise averaged over the dwell);
    # of ‖2θ‖² from the turn integrals (white noise integrated over a clockwise and a counter-clockwise turn)
    o = sim.options
    per_mean = 1.0 / np.sqrt(o["dwell_s"] * o["sample_rate"])
    s_a = 2 * sim.gravity * o["noise"]["accelerometer"] * per_mean
    s_g = 2 * (4 * np.pi) * np.sqrt(2 * 360 / o["rate_deg_s"] / o["sample_rate"]) * o["noise"]["gyroscope"]
    s_b = 2 * EARTH_RATE * o["noise"]["gyroscope"] * per_mean
    names_a = [f"K_a1{c}" for c in "xyz"] + [f"K_a2{c}" for c in "xyz"] + [f"K_a3{c}" for c in "xyz"] \
        + ["E_ayx", "E_azx", "E_azy"] + [f"bias_a{c}" for c in "xyz"]
    names_g = [f"K_g1{c}" for c in "xyz"] + [f"K_g2{c}" for c in "xyz"] + ["E_gyx", "E_gzx", "E_gzy"]
    names_b = [f"bias_g{c}" for c in "xyz"]
    out = []
    for names, jac, sigma, x in ((names_a, ja, s_a, xa), (names_g, jg, s_g, xg),
                                 (names_b, jb, s_b, g.output_bias)):
        fisher = jac.T @ jac / sigma**2
        col = np.linalg.norm(jac, axis=0)
        js = jac / col  # scaled columns keep the inverse accurate across 40 orders of magnitude
        cov_s = np.linalg.pinv(js.T @ js) * sigma**2
        crlb = np.sqrt(np.clip(np.diag(cov_s), 0, None)) / col
        rank = int(np.linalg.matrix_rank(js))
        for k, name in enumerate(names):
            out.append({"parameter": name, "value": float(x[k]),
                        "sensitivity_rms": float(np.sqrt(np.mean(jac[:, k] ** 2))),
                        "fisher_information": float(fisher[k, k]), "crlb_std": float(crlb[k]),
                        "observable": bool(rank == len(names))})
    return {"positions_gravity_body": positions.tolist(), "rotation_axes_body": axes.tolist(),
            "turn_angle_deg": 360.0, "parameters": out}
