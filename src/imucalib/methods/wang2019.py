"""Wang, Cheng & Fu (Sensors 2019): multi-position calibration with nonlinear scale factors.

Model (eqs. 2, 6): ``f = C_a (K_a1 N + K_a2 N² + K_a3 N³ + ∇)``,
``ω = C_g (K_g1 N + K_g2 N² + ε)``, ``C`` unit lower-triangular; canonically
``TriadModel(shape="lower", output_bias=∇)`` (:mod:`imucalib.conventions`).

* Accelerometer, eq. (18): ``min Σ_i (‖C_a(K_a1 N_i + K_a2 N_i² + K_a3 N_i³ + ∇)‖² − g²)²``
  over the static positions (15 parameters, eq. 37).
* Gyroscope, eq. (30): ``min Σ_i (‖C_g K_g1 N_sum^i + C_g K_g2 N_sum^(2)i‖² − (2θ)²)²``
  over clockwise/counter-clockwise turn pairs, ``N_sum = ∫(N⁺ − N⁻) dt``
  (eqs. 27–29; 9 parameters, eq. 38), the Earth rate cancelling between the turns.
* Gyroscope bias, eq. (35): ``min Σ_i (‖C_g(K_g1 N_i + K_g2 N_i² + ε)‖² − ‖ω_ie‖²)²``
  over the static positions (3 parameters, eq. 39).
* Initial values (§4.3): the linear scales from eqs. (41) and (42), which are
  linear least squares in ``K1²``; everything else starts at zero. With
  ``initial="nominal"`` LM starts instead from a nominal ``K1`` of the
  distribution's centre (3 µg/pulse, 3·10⁻⁷ °/s/pulse), for the paper's
  Figs. 4–5 comparison.

All minimisations are Levenberg–Marquardt (:func:`imucalib.solve.levenberg_marquardt`)
with analytic Jacobians, on parameters scaled to order one. ``fit["uncertainty"]``
holds 1σ errors from each fit's Jacobian and residuals
(:func:`imucalib.solve.standard_errors`); the plan's 15 positions exactly
determine the accelerometer's 15 parameters, so its errors are not available
(null) unless more positions are recorded, and the gyroscope's rest on the
3 degrees of freedom left by 12 turn pairs (a rough estimate).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..models import TriadModel
from ..scenarios_wang2019 import DEG, EARTH_RATE, G0, MICRO_G
from ..solve import levenberg_marquardt, standard_errors

__all__ = ["PAPER_RMS", "calibrate", "parameter_errors_wang_units", "montecarlo", "plan_report"]


def _lower(e: np.ndarray) -> np.ndarray:
    return np.array([[1.0, 0, 0], [e[0], 1.0, 0], [e[1], e[2], 1.0]])


def _poly_norm_residuals(theta, scales, n_list, order, target2, with_bias, bias_fixed=None,
                         k_fixed=None, jac=False):
    """``‖C (Σ_k K_k N_k + ∇)‖² − target²`` and its Jacobian in scaled parameters.

    ``theta`` holds ``K_1..K_order`` (3 each), ``E`` (3) and ``∇`` (3, if
    ``with_bias``) divided by ``scales``; ``n_list[k]`` is the regressor of
    ``K_{k+1}`` (e.g. ``N``, ``N²``, ``N³``, or the turn integrals).
    """
    x = theta * scales
    if k_fixed is not None:  # bias-only problem: K and E fixed
        ks, e = k_fixed
        bias = x
    else:
        ks = x[: 3 * order].reshape(order, 3)
        e = x[3 * order : 3 * order + 3]
        bias = x[3 * order + 3 :] if with_bias else (bias_fixed if bias_fixed is not None else np.zeros(3))
    c = _lower(e)
    inner = sum(k * n for k, n in zip(ks, n_list, strict=True)) + bias  # (M, 3)
    out = inner @ c.T
    r = np.sum(out * out, axis=1) - target2
    if not jac:
        return r
    g = 2 * out @ c  # ∂r/∂inner (M, 3)
    cols = []
    if k_fixed is None:
        for n in n_list:
            cols.append(g * n)  # ∂r/∂K_kj
        # ∂r/∂E: E_yx → out_y += E_yx inner_x; E_zx → out_z += …; E_zy
        cols.append(np.column_stack([2 * out[:, 1] * inner[:, 0], 2 * out[:, 2] * inner[:, 0],
                                     2 * out[:, 2] * inner[:, 1]]))
        if with_bias:
            cols.append(g)
    else:
        cols.append(g)
    return r, np.concatenate(cols, axis=1) * scales[None, :]


def _solve(fun_jac, x0, scales):
    sol = levenberg_marquardt(lambda th: fun_jac(th, False), lambda th: fun_jac(th, True)[1],
                              x0 / scales, ftol=1e-15, xtol=1e-15, gtol=1e-14, max_iter=500)
    return sol.x * scales, sol


def calibrate(session, *, gravity: float | None = None, initial: str = "estimate") -> Calibration:
    """Calibrate from a :class:`~imucalib.scenarios_wang2019.WangSession`-like object.

    It needs ``positions_acc``, ``positions_gyro`` (static means, pulses/s),
    ``turn_sum``, ``turn_sum2`` and ``turn_angle`` (CW/CCW turn integrals) and
    ``latitude_deg`` (only through ``‖ω_ie‖``, which is latitude-free).
    """
    if initial not in ("estimate", "nominal"):
        raise ValueError(f"initial must be 'estimate' or 'nominal'; got {initial!r}")
    g = gravity or getattr(session, "gravity", G0)
    na = np.asarray(session.positions_acc, dtype=float)
    ng = np.asarray(session.positions_gyro, dtype=float)
    ns, ns2 = np.asarray(session.turn_sum, dtype=float), np.asarray(session.turn_sum2, dtype=float)
    two_theta = 2 * np.asarray(session.turn_angle, dtype=float)
    if na.shape[0] < 15:
        raise ValueError(f"the accelerometer model has 15 parameters; {na.shape[0]} positions "
                         "cannot determine them (record the 15 positions of the plan)")
    if ns.shape[0] < 9:
        raise ValueError(f"the gyroscope model has 9 parameters; {ns.shape[0]} turn pairs cannot "
                         "determine them (record the 12 pairs of the plan)")
    # ---- accelerometer (eq. 18), initial K1 from eq. (41)
    if initial == "estimate":
        q, *_ = np.linalg.lstsq(na**2, np.full(len(na), g**2), rcond=None)  # eq. (41): Σ K_j² N_j² = g²
        k1 = np.sqrt(np.abs(q))
    else:
        k1 = np.full(3, 3 * MICRO_G)
    n_max = np.max(np.abs(na), axis=0)
    scales_a = np.concatenate([k1, k1 / n_max, k1 / n_max**2, np.full(3, 1e-4), np.full(3, 1e-2 * g)])
    x0 = np.concatenate([k1, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)])
    xa, sol_a = _solve(lambda th, j: _poly_norm_residuals(th, scales_a, [na, na**2, na**3], 3, g**2,
                                                         True, jac=j), x0, scales_a)
    # ---- gyroscope scale and misalignment (eq. 30), initial K1 from eq. (42)
    if initial == "estimate":
        q, *_ = np.linalg.lstsq(ns**2, two_theta**2, rcond=None)  # eq. (42)
        kg1 = np.sqrt(np.abs(q))
    else:
        kg1 = np.full(3, 3e-7 * DEG)
    s_max = np.max(np.abs(ns), axis=0)
    s2_max = np.max(np.abs(ns2), axis=0) + 1e-300
    scales_g = np.concatenate([kg1, kg1 * s_max / s2_max, np.full(3, 1e-4)])
    x0 = np.concatenate([kg1, np.zeros(3), np.zeros(3)])
    xg, sol_g = _solve(lambda th, j: _poly_norm_residuals(th, scales_g, [ns, ns2], 2, two_theta**2,
                                                         False, jac=j), x0, scales_g)
    kg = xg[:6].reshape(2, 3)
    eg = xg[6:9]
    # ---- gyroscope bias (eq. 35)
    scales_b = np.full(3, EARTH_RATE * 0.01)
    xb, sol_b = _solve(lambda th, j: _poly_norm_residuals(th, scales_b, [ng, ng**2], 2,
                                                         EARTH_RATE**2, True, k_fixed=(kg, eg), jac=j),
                       np.zeros(3), scales_b)
    ka = xa[:9].reshape(3, 3)
    acc = TriadModel(misalignment=_lower(xa[9:12]), scale=ka[0], scale_quadratic=ka[1],
                     scale_cubic=ka[2], output_bias=xa[12:15], shape="lower")
    gyro = TriadModel(misalignment=_lower(eg), scale=kg[0], scale_quadratic=kg[1], output_bias=xb,
                      shape="lower")
    names_k = ("scale", "scale_quadratic", "scale_cubic")
    low = ("yx", "zx", "zy")
    unc = {}
    for prefix, sol, scales, keys in (
            ("accelerometer", sol_a, scales_a, [*names_k, "misalignment", "output_bias"]),
            ("gyroscope", sol_g, scales_g, [*names_k[:2], "misalignment"]),
            ("gyroscope", sol_b, scales_b, ["output_bias"])):
        names = [f"{prefix}.{k}.{c}" for k in keys for c in (low if k == "misalignment" else "xyz")]
        unc.update(zip(names, standard_errors(sol.jac, sol.fun) * scales, strict=True))
    fit = {"positions": int(na.shape[0]), "turn_pairs": int(ns.shape[0]),
           "accelerometer_cost": float(sol_a.cost), "gyroscope_cost": float(sol_g.cost),
           "bias_cost": float(sol_b.cost),
           "converged": bool(sol_a.success and sol_g.success and sol_b.success),
           "uncertainty": {k: float(v) for k, v in unc.items()}}
    if not np.isfinite(unc["accelerometer.scale.x"]):
        fit["uncertainty_unavailable"] = (f"accelerometer: {na.shape[0]} positions for 15 parameters leave no "
                                          "degrees of freedom to estimate the noise from the residuals")
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=g, method="wang2019",
                       model="wang2019", fit=fit)


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
    from ..scenarios_wang2019 import session

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
        from concurrent.futures import ProcessPoolExecutor

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
    from ..scenarios_wang2019 import plan, session

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
    _, ja = _poly_norm_residuals(xa, one, [na, na**2, na**3], 3, sim.gravity**2, True, jac=True)
    _, jg = _poly_norm_residuals(xg, np.ones(9), [ns, ns2], 2, (2 * sim.turn_angle) ** 2, False, jac=True)
    kg = xg[:6].reshape(2, 3)
    _, jb = _poly_norm_residuals(g.output_bias, np.ones(3), [ng, ng**2], 2, EARTH_RATE**2, True,
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
