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
with analytic Jacobians, on parameters scaled to order one. ``fit.uncertainty.sigma``
holds 1σ errors from each fit's Jacobian and residuals
(:func:`imucalib.solve.standard_errors`); the plan's 15 positions exactly
determine the accelerometer's 15 parameters, so its errors are not available
(null) unless more positions are recorded, and the gyroscope's rest on the
3 degrees of freedom left by 12 turn pairs (a rough estimate).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..constants import DEG, EARTH_RATE, G0, MICRO_G
from ..fitreport import FitReport, MethodReport, UncertaintyReport
from ..methodinfo import MethodInfo, Option
from ..models import TriadModel
from ..solve import levenberg_marquardt, standard_errors

METHOD = MethodInfo(
    name="wang2019",
    summary="navigation-grade model with nonlinear scale factors from turntable positions and "
            "clockwise/counter-clockwise turns (`imucalib plan --method wang2019` prints the plan)",
    needs=("turntable aggregates", "gyroscope"),
    models=("wang2019",),
    options=(
        Option("initial", "estimate", "", "starting point: estimate (closed form) or nominal"),
    ),
    paper="wang2019_multiposition_nonlinear.md (Wang, Cheng & Fu, Sensors 2019), eqs. 18, 30, 35",
)

__all__ = ["calibrate", "poly_norm_residuals"]


def _lower(e: np.ndarray) -> np.ndarray:
    return np.array([[1.0, 0, 0], [e[0], 1.0, 0], [e[1], e[2], 1.0]])


def poly_norm_residuals(theta, scales, n_list, order, target2, with_bias, bias_fixed=None,
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
    """Calibrate from a :class:`~imucalib.sessions.WangSession`-like object.

    It needs ``positions_acc``, ``positions_gyro`` (static means, pulses/s),
    ``turn_sum``, ``turn_sum2`` and ``turn_angle`` (CW/CCW turn integrals) and
    ``latitude_deg`` (only through ``‖ω_ie‖``, which is latitude-free).

    Parameters
    ----------
    session : WangSession
        The turntable session's aggregates (``imucalib simulate --scenario wang2019`` writes one).
    gravity : float, optional
        Local gravity [m/s²]; by default the session's.
    initial : {"estimate", "nominal"}
        Initial values from eqs. (41)–(42), or the nominal ones.

    Returns
    -------
    Calibration
        The ``wang2019`` model (nonlinear scale factors), with its fit figures and verdict in ``fit``.

    Raises
    ------
    ValueError
        For an unknown ``initial``, or fewer positions or turn pairs than the models' parameters.

    Examples
    --------
    A simulated turntable session (10 s per position instead of the paper's 300 s):

    >>> from imucalib.methods import wang2019
    >>> from imucalib.scenarios.wang2019 import session
    >>> turntable = session(rng=1, dwell_s=10)
    >>> cal = wang2019.calibrate(turntable)
    >>> (cal.accelerometer.scale / turntable.truth.accelerometer.scale).round(4)
    array([1., 1., 1.])
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
    xa, sol_a = _solve(lambda th, j: poly_norm_residuals(th, scales_a, [na, na**2, na**3], 3, g**2,
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
    xg, sol_g = _solve(lambda th, j: poly_norm_residuals(th, scales_g, [ns, ns2], 2, two_theta**2,
                                                         False, jac=j), x0, scales_g)
    kg = xg[:6].reshape(2, 3)
    eg = xg[6:9]
    # ---- gyroscope bias (eq. 35)
    scales_b = np.full(3, EARTH_RATE * 0.01)
    xb, sol_b = _solve(lambda th, j: poly_norm_residuals(th, scales_b, [ng, ng**2], 2,
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
    method = MethodReport(positions=int(na.shape[0]), turn_pairs=int(ns.shape[0]),
                          accelerometer_cost=float(sol_a.cost), gyroscope_cost=float(sol_g.cost),
                          bias_cost=float(sol_b.cost),
                          converged=bool(sol_a.success and sol_g.success and sol_b.success))
    sigma = UncertaintyReport(sigma={k: float(v) for k, v in unc.items()})
    if not np.isfinite(unc["accelerometer.scale.x"]):
        sigma = sigma.with_(unavailable=f"accelerometer: {na.shape[0]} positions for 15 parameters leave no "
                                        "degrees of freedom to estimate the noise from the residuals")
    fit = FitReport.of(method, sigma)
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=g, method="wang2019",
                       model="wang2019", fit=fit)
