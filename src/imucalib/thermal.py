r"""Calibrations that follow the sensor's temperature.

A MEMS sensor's biases move with temperature more than any other error
calibrated here (a consumer gyroscope's by ~0.02–0.05 °/s per °C, an
accelerometer's by ~0.3–1 mg per °C), its scale factors by ~0.01–0.03 %/°C
(Ru 2022, §2 lists thermal drift among the deterministic errors to calibrate).
A :class:`ThermalModel` makes chosen parameters polynomials in the temperature
``T`` around a reference ``T₀`` (these equations are this project's, derived
here; (T3) and (T4) are the gravity-norm and rest equations of Zhang 2021,
eqs. (10) and (11), with temperature-dependent biases and scales):

.. math::

    p(T) = c_0 + c_1 (T - T_0) + c_2 (T - T_0)^2 \qquad \text{(T1)}

with ``c₀`` the calibration's own value of ``p`` (the calibration *is* the
model at ``T₀``). Two ways to make one:

* :func:`combine` — calibrations made at several temperatures, each with its
  1σ, fitted by weighted least squares per parameter. The order is chosen by
  the data: the highest (2, then 1) whose top term exceeds 3σ of its own in
  that fit; the others stay constant (the weighted mean). With ``p_j ± σ_j``
  the calibrations' values at ``T_j`` and ``x_j = T_j − T₀``:

  .. math::

      \hat{\mathbf c} = \arg\min_{\mathbf c} \sum_j
      \Bigl(\frac{p_j - \sum_{l=0}^{m} c_l x_j^l}{\sigma_j}\Bigr)^2, \qquad
      m = \max\{m \le 2 : |\hat c_m| > 3\, \sigma(\hat c_m)\} \qquad \text{(T5)}

  So
  biases, scales and misalignments follow temperature where the calibrations'
  uncertainties say they move, and nowhere else.
* :func:`calibrate_ramp` — one session during a warm-up, calibrated directly
  with temperature-dependent biases (and scale factors where the data show
  them): the method runs, the slopes are fitted on its static poses (the
  accelerometer's with the gravity norm, eq. (T3); the gyroscope's biases from
  the poses' means, which read only the bias and the g-sensitivity at rest,
  eq. (T4), its scales with the gravity directions of Zhang 2021, eq. (14)),
  the recording is compensated (T2) and the method runs again, until the
  slopes stop changing. With ``ΔT_i = T_i − T₀`` the temperature of static
  pose ``i``, ``ū_i`` its raw mean, ``c`` the bias slopes and ``s`` the
  relative scale slopes (``⊙`` element by element):

  .. math::

      \bigl\lVert \mathbf T\, \mathrm{diag}\bigl(\mathbf k \odot (1 + \mathbf s\, \Delta T_i)\bigr)
      (\bar{\mathbf u}_i - \mathbf b - \mathbf c\, \Delta T_i) \bigr\rVert = g \qquad \text{(T3)}

      \bar{\mathbf u}_{g,i} - \mathbf G\, \mathbf a_i = \mathbf b_g + \mathbf c_g\, \Delta T_i \qquad \text{(T4)}

**Compensation** (T2). For a linear model ``a = T K (u − b)`` at each
sample's temperature, the readings

.. math::

    \mathbf u' = \mathbf b_0 + (\mathbf T_0 \mathbf K_0)^{-1}\, \mathbf T(T)\, \mathbf K(T)\,
    \bigl(\mathbf u - \mathbf b(T)\bigr) \qquad \text{(T2)}

give exactly the same calibrated values through the model at ``T₀``; for the
gyroscope ``G a`` is taken out and put back around the same map. So applying
a thermal calibration is compensating the recording and applying the
calibration at ``T₀``, and every figure of :mod:`imucalib.metrics` holds
unchanged. Nonlinear scale factors follow temperature only through the biases.
"""

from __future__ import annotations

import warnings

import numpy as np

from .calibration import Calibration
from .fitreport import FitReport, ThermalReport, UncertaintyReport, VerdictReport
from .recording import ImucalibWarning, Interval, Recording
from .residuals import AccelLayout, GyroLayout
from .thermalmodel import (
    POSSIBLE_C,
    REFERENCE_C,
    ThermalModel,
    at_temperature,
    compensate,
    decompensate,
    evaluate,
    fit_temperature,
    temperature_of,
    thermal_parameters,
)

__all__ = ["POSSIBLE_C", "REFERENCE_C", "SIGNIFICANCE", "ThermalModel", "at_temperature", "calibrate_ramp",
           "combine", "compensate", "decompensate", "evaluate", "thermal_parameters"]

#: a polynomial term is kept when it exceeds this many 1σ
SIGNIFICANCE = 3.0

def _polyfit(x: np.ndarray, y: np.ndarray, s: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Weighted LS of ``y`` on ``[1, x, x²][:order+1]``: coefficients, their covariance, χ²."""
    a = np.vander(x, order + 1, increasing=True)
    w = 1.0 / s
    coef, *_ = np.linalg.lstsq(a * w[:, None], y * w, rcond=None)  # eq. (T5)
    cov = np.linalg.pinv((a * w[:, None]).T @ (a * w[:, None]))
    chi2 = float(np.sum(((a @ coef - y) * w) ** 2))
    dof = len(x) - order - 1
    if dof > 0 and chi2 / dof > 1.0:  # the points scatter more than their 1σ: widen the model's own 1σ
        cov = cov * (chi2 / dof)
    return coef, cov, chi2


def _check_alike(calibrations: list) -> None:
    """Every calibration :func:`combine` takes of the same sensors, model, units and misalignment shape as the
    first."""
    first = calibrations[0]
    for i, cal in enumerate(calibrations[1:], start=2):
        if (cal.gyroscope is None) != (first.gyroscope is None):
            raise ValueError(f"calibration {i} {'has no' if cal.gyroscope is None else 'has a'} gyroscope and the "
                             f"first {'has one' if cal.gyroscope is None else 'has none'}: combine calibrations "
                             "of the same sensors (accelerometer-only ones together)")
        for what in ("model", "units"):
            if getattr(cal, what) != getattr(first, what):
                raise ValueError(f"calibration {i} has another {what} ({getattr(cal, what)!r}) than the first "
                                 f"({getattr(first, what)!r}): combine calibrations of one sensor made one way")
        if cal.accelerometer.shape != first.accelerometer.shape or (
                cal.gyroscope is not None and cal.gyroscope.shape != first.gyroscope.shape):
            raise ValueError(f"calibration {i} has another misalignment shape than the first")


def _significant_order(x: np.ndarray, y: np.ndarray, s: np.ndarray, order_max: int) -> tuple:
    """The polynomial fit (coefficients, covariance, order) of the highest order up to ``order_max`` whose own
    top term is beyond :data:`SIGNIFICANCE` σ (order 0 when none is)."""
    coef, cov, _ = _polyfit(x, y, s, 0)
    order = 0
    for m in range(order_max, 0, -1):  # the highest order whose own top term is significant
        c_m, cov_m, _ = _polyfit(x, y, s, m)
        z = abs(c_m[m]) / np.sqrt(cov_m[m, m]) if cov_m[m, m] > 0 else np.inf
        if z > SIGNIFICANCE:  # eq. (T5): the highest significant order
            coef, cov, order = c_m, cov_m, m
            break
    return coef, cov, order


def _decision(coef: np.ndarray, cov: np.ndarray, order: int) -> dict:
    """A parameter's order, ``|c₁|/σ`` and the decision in words (:func:`combine`'s summary)."""
    z1 = None
    if order >= 1:
        z1 = float(abs(coef[1]) / np.sqrt(cov[1, 1]))
    return {"order": order, "slope_over_sigma": z1,
            "reason": ("constant: no slope beyond 3σ" if order == 0 else
                       "linear in temperature" if order == 1 else "quadratic in temperature")}


def _padded(coef: np.ndarray, cov: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """``(c₁, c₂)`` and the (3, 3) covariance of ``(c₀, c₁, c₂)``, zero past ``order``."""
    c12 = np.zeros(2)
    c12[: order] = coef[1: order + 1]
    full = np.zeros((3, 3))
    full[: order + 1, : order + 1] = cov
    return c12, full


def combine(calibrations: list, *, reference_c: float = REFERENCE_C, max_order: int = 2) -> tuple:
    """One thermal calibration from calibrations made at several temperatures.

    Parameters
    ----------
    calibrations : list of Calibration
        Same method, model and units, each with ``fit.thermal.temperature_c`` (its recording's temperature) and
        ``fit.uncertainty.sigma`` (the 1σ weights).
    reference_c : float
        ``T₀`` [°C].
    max_order : int
        Highest polynomial order tried (2).

    Returns
    -------
    (Calibration, dict)
        The calibration at ``T₀`` with its :class:`ThermalModel`, and a summary: each parameter's order,
        ``|c₁|/σ``, ``|c₂|/σ`` and the decision in words.

    Raises
    ------
    ValueError
        For fewer than two calibrations, calibrations made within a fraction of a degree of each other,
        calibrations that differ in method, model, units or sensors, or one that already follows temperature.

    Examples
    --------
    One simulated sensor calibrated at 10, 25 and 40 °C:

    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> from imucalib.thermal import combine
    >>> cals = [calibrate(session("handheld", rng=1, rest=10, n_poses=14, temperature=c).recording)
    ...         for c in (10.0, 25.0, 40.0)]
    >>> cal, summary = combine(cals)
    >>> cal.thermal.source, summary["gyroscope.bias.x"]["order"]
    ('combined', 1)
    >>> combine(cals[:1])
    Traceback (most recent call last):
        ...
    ValueError: a thermal model needs calibrations at two or more temperatures; got 1
    """
    if len(calibrations) < 2:
        raise ValueError(f"a thermal model needs calibrations at two or more temperatures; got {len(calibrations)}")
    temps = []
    for i, cal in enumerate(calibrations):
        temps.append(fit_temperature(cal.fit.thermal.temperature_c, i + 1))
        if cal.thermal is not None:
            raise ValueError(f"calibration {i + 1} already follows temperature; combine calibrations made at one "
                             "temperature each")
    first = calibrations[0]
    _check_alike(calibrations)
    x = np.array(temps) - reference_c
    if np.ptp(x) < 1.0:
        raise ValueError(f"the calibrations were all made within {np.ptp(x):.2g} °C of each other: a thermal "
                         "model needs temperatures several °C apart")
    order_max = min(max_order, len(x) - 1)
    names = thermal_parameters(first)
    values = {n: np.array([c.parameters()[n] for c in calibrations]) for n in names}
    coefficients, covariance, decisions, base, base_sigma = {}, {}, {}, {}, {}
    for n in names:
        y = values[n]
        s = np.array([(c.fit.uncertainty.sigma or {}).get(n) or np.nan for c in calibrations], float)
        if not np.all(np.isfinite(s) & (s > 0)):
            base[n] = float(np.mean(y))  # no 1σ to judge a slope by: kept constant, said so
            decisions[n] = {"order": 0, "reason": "no 1σ in every calibration: kept constant (the mean)"}
            continue
        coef, cov, order = _significant_order(x, y, s, order_max)
        base[n] = float(coef[0])
        base_sigma[n] = float(np.sqrt(max(cov[0, 0], 0.0)))
        decisions[n] = _decision(coef, cov, order)
        if order >= 1:
            coefficients[n], covariance[n] = _padded(coef, cov, order)
    points = [{"temperature_c": t, "values": {n: float(values[n][i]) for n in names},
               "sigmas": {n: (c.fit.uncertainty.sigma or {}).get(n) for n in names}}
              for i, (t, c) in enumerate(zip(temps, calibrations, strict=True))]
    model = ThermalModel(reference_c=reference_c, coefficients=coefficients, covariance=covariance,
                         range_c=(min(temps), max(temps)), points=points, source="combined")
    levels = ("accepted", "suspect", "rejected")
    worst = max((c.fit.verdict.level or "accepted" for c in calibrations), key=levels.index)
    reasons = [f"the calibration at {t:.1f} °C: {r}" for t, c in zip(temps, calibrations, strict=True)
               for r in c.fit.verdict.reasons or []]
    fit = FitReport.of(VerdictReport(level=worst, reasons=reasons, notes=[]),
                       ThermalReport(decisions=decisions, temperature_c=[min(temps), reference_c, max(temps)],
                                     combined_from=len(calibrations)),
                       UncertaintyReport(sigma={**(first.fit.uncertainty.sigma or {}), **base_sigma}))
    out = first.with_(fit=fit, thermal=model).with_parameters(base)
    return out, decisions


# ------------------------------------------------------------------ one ramp session
def _accelerometer_slopes(calibration: Calibration, acc_means: np.ndarray, temps: np.ndarray) -> tuple:
    """(T3) on the static poses: bias slopes [raw/°C] and, for a linear model, relative scale slopes [1/°C].

    ``‖T diag(k (1 + s ΔT_i)) (u_i − b − c ΔT_i)‖ = g`` fitted with ``T``, ``k``, ``b`` (the gravity-norm
    model of Tedaldi 2014, Zhang 2021, eq. 10 unsquared) free beside the slopes, so the model cannot soak up a slope;
    returns ``(c, σ_c, s, σ_s)``. A nonlinear model gets bias slopes only.
    """
    from scipy.optimize import least_squares  # scipy.optimize costs 264 ms at start-up


    tri, g = calibration.accelerometer, calibration.gravity
    linear = tri.is_linear
    layout = AccelLayout(tri.shape, 1) if linear else None
    m = layout.size if linear else 3

    def model_of(th):
        return (layout.unpack(th[:m], tri) if linear else tri.with_(bias=th[:3]))

    def res(th):
        model = model_of(th)
        x = acc_means - np.outer(temps, th[m:m + 3])  # eq. (T3): ū_i − c ΔT_i
        if linear:
            x = (x - model.bias) * (1.0 + np.outer(temps, th[m + 3:m + 6])) + model.bias  # eq. (T3): k (1 + s ΔT_i)
        return np.linalg.norm(model.forward(x), axis=1) - g  # eq. (T3)

    start = layout.pack(tri) if linear else tri.bias
    n = m + (6 if linear else 3)
    if len(temps) <= n:
        raise ValueError(f"the accelerometer's temperature slopes need more than {n} static poses; got {len(temps)}")
    sol = least_squares(res, np.concatenate([start, np.zeros(n - m)]), method="lm", x_scale="jac")
    cov = np.linalg.pinv(sol.jac.T @ sol.jac) * (np.sum(sol.fun**2) / max(len(temps) - n, 1))
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    if linear:
        return sol.x[m:m + 3], sd[m:m + 3], sol.x[m + 3:m + 6], sd[m + 3:m + 6]
    return sol.x[m:m + 3], sd[m:m + 3], np.zeros(3), np.full(3, np.inf)


def _gyroscope_slopes(calibration: Calibration, recording: Recording, intervals: list[Interval], acc_means, temps,
                      reference_c: float) -> tuple:
    """(T4) bias slopes from the poses' means and (Zhang 2021, eq. 14) relative scale slopes, with 1σ."""
    from scipy.optimize import least_squares  # scipy.optimize costs 264 ms at start-up

    from .fit.gyroscope import gravity_direction_problem  # imucalib.fit.gyroscope costs 44 ms at start-up
    from .metrics import interval_means  # imucalib.metrics costs 25 ms at start-up

    gyro_means = interval_means(recording.gyro, intervals)
    gyro_g = calibration.gyroscope.g_sensitivity
    if np.any(gyro_g):
        gyro_means = gyro_means - calibration.accelerometer.forward(acc_means) @ gyro_g.T  # eq. (T4): ū_g − G a
    a = np.column_stack([np.ones_like(temps), temps])
    bias_slope, bias_sd = np.empty(3), np.empty(3)
    for k in range(3):
        coef, *_ = np.linalg.lstsq(a, gyro_means[:, k], rcond=None)  # eq. (T4)
        r = gyro_means[:, k] - a @ coef
        c = np.linalg.pinv(a.T @ a) * (r @ r / max(len(temps) - 2, 1))
        bias_slope[k], bias_sd[k] = coef[1], np.sqrt(max(c[1, 1], 0.0))
    tri = calibration.gyroscope
    if not tri.is_linear:
        return bias_slope, bias_sd, np.zeros(3), np.full(3, np.inf)
    base = calibration.with_(thermal=None)
    layout = GyroLayout(False)
    theta0 = layout.pack(tri)  # T_g K_g (Zhang 2021, eq. 14) free beside the slopes: no soaking up

    def res(th):
        rel = th[theta0.size:]
        model = ThermalModel(reference_c=reference_c, range_c=(-1e3, 1e3),
                             coefficients={f"gyroscope.scale.{ax}": [rel[i] * tri.scale[i], 0.0]
                                           for i, ax in enumerate("xyz")})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ImucalibWarning)
            rec = compensate(base.with_(thermal=model), recording)[1]
        fun = gravity_direction_problem(rec, intervals, calibration.accelerometer, tri.bias, False,
                                        g_sensitivity=tri.g_sensitivity)[0]
        return fun(th[:theta0.size])

    scale = np.concatenate([np.abs(theta0) + 1e-3 * np.abs(theta0).max(), np.full(3, 1e-4)])
    sol = least_squares(res, np.concatenate([theta0, np.zeros(3)]), method="lm", x_scale=scale)
    dof = max(2 * (len(intervals) - 1) - sol.x.size, 1)
    cov = np.linalg.pinv(sol.jac.T @ sol.jac) * (np.sum(sol.fun**2) / dof)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    return bias_slope, bias_sd, sol.x[theta0.size:], sd[theta0.size:]


def _slopes_model(slopes: dict, temp: np.ndarray, reference_c: float) -> ThermalModel:
    """The linear thermal model of the current ``slopes`` a ramp's recording is compensated with."""
    return ThermalModel(reference_c=reference_c, range_c=(float(temp.min()), float(temp.max())),
                        coefficients={n: [v, 0.0] for n, v in slopes.items() if v}, source="ramp")


def _without_gyroscope(slopes: dict, sds: dict, free: set) -> set:
    """The gyroscope's slopes taken out of ``slopes`` and ``sds`` (in place) and of ``free`` (returned)."""
    for n in [n for n in slopes if n.startswith("gyroscope.")]:
        del slopes[n], sds[n]
    return {n for n in free if not n.startswith("gyroscope.")}


def _slope_steps(cal: Calibration, compensated: Recording, intervals: list[Interval], reference_c: float,
                 sensors: tuple, sds: dict) -> dict:
    """Each slope's step from the poses of the compensated recording, its 1σ written into ``sds``
    (:func:`calibrate_ramp`)."""
    from .metrics import interval_means  # imucalib.metrics costs 25 ms at start-up

    temps = interval_means(compensated.temperature[:, None], intervals)[:, 0] - reference_c
    acc_means = interval_means(compensated.acc, intervals)
    steps = {}
    found = [("accelerometer", *_accelerometer_slopes(cal, acc_means, temps))]
    if "gyroscope" in sensors:
        found.append(("gyroscope", *_gyroscope_slopes(cal, compensated, intervals, acc_means, temps,
                                                      reference_c)))
    for sensor, b, b_sd, sc, sc_sd in found:
        k = getattr(cal, sensor).scale
        for i, a in enumerate("xyz"):
            steps[f"{sensor}.bias.{a}"], sds[f"{sensor}.bias.{a}"] = b[i], b_sd[i]
            steps[f"{sensor}.scale.{a}"], sds[f"{sensor}.scale.{a}"] = sc[i] * k[i], sc_sd[i] * abs(k[i])
    return steps


def _kept_model(kept: dict, sds: dict, temp: np.ndarray, reference_c: float) -> ThermalModel:
    """The ramp's thermal model: the slopes ``kept`` with their variances."""
    covariance = {}
    for n in kept:
        c = np.zeros((3, 3))
        c[1, 1] = sds[n] ** 2
        covariance[n] = c
    return ThermalModel(reference_c=reference_c, coefficients={n: [v, 0.0] for n, v in kept.items()},
                        covariance=covariance, range_c=(float(temp.min()), float(temp.max())), source="ramp")


def calibrate_ramp(run, recording: Recording, *, reference_c: float = REFERENCE_C, iterations: int = 6):
    """Calibrate one session recorded while the temperature changed, with parameters linear in temperature.

    ``run(recording) -> Calibration`` runs the method (with its options) on a recording. The method
    runs on the recording compensated (T2) with the current slopes; the biases' slopes (T3, T4) and,
    for linear models, the scale factors' relative slopes are fitted on its static poses and added;
    and so on until they change by less than a tenth of their 1σ. A bias slope is always kept (the
    bias is what moves most); a scale slope where it exceeds its own 1σ — for a prediction, leaving
    out a term costs its square, keeping it costs its variance — and the rest are fitted again
    without the others. On the hand-held scenario a warm-up of 60 poses gets within 1.1–1.2× of
    the true parameters' figures; 40 poses only to 1.2–1.4×.

    Parameters
    ----------
    run : callable
        ``run(recording) -> Calibration``: the method with its options.
    recording : Recording
        The session, with a temperature column.
    reference_c : float
        The reference temperature T₀ [°C] the parameters are given at.
    iterations : int
        The most rounds of compensate → calibrate → fit the slopes.

    Returns
    -------
    Calibration
        The calibration at ``reference_c`` with its thermal model (``calibration.thermal``: the slopes kept and
        their 1σ), made from the ramp (``thermal.source`` ``"ramp"``).

    Raises
    ------
    ValueError
        The recording has no temperature column.

    Examples
    --------
    A simulated warm-up from 20 to 40 °C, calibrated by ``tedaldi2014`` with biases linear in temperature;
    the gyroscope biases' slopes [counts/°C] against the simulation's:

    >>> import numpy as np
    >>> from imucalib.methods import tedaldi2014
    >>> from imucalib.scenarios import session
    >>> from imucalib.thermal import calibrate_ramp
    >>> sim = session("handheld", rng=1, rest=10, n_poses=20, ramp=(20.0, 40.0, 60.0))
    >>> def method(recording):
    ...     return tedaldi2014.calibrate(recording, gravity=9.81)
    >>> cal = calibrate_ramp(method, sim.recording, iterations=2)
    >>> np.round([cal.thermal.coefficients[f"gyroscope.bias.{a}"][0] for a in "xyz"], 1)
    array([ 2.4, -6.5,  0.5])
    >>> np.round([sim.truth.thermal.coefficients[f"gyroscope.bias.{a}"][0] for a in "xyz"], 1)
    array([ 2.6, -6.6,  0.4])
    """
    temp = temperature_of(recording)
    if np.ptp(temp) < 2.0:
        raise ValueError(f"the recording's temperature spans {np.ptp(temp):.2g} °C: a temperature model needs a "
                         "warm-up or a heater (several °C); calibrate without --temperature-model")
    sensors = ("accelerometer", "gyroscope")
    slopes = {f"{s}.{key}.{a}": 0.0 for s in sensors for key in ("bias", "scale") for a in "xyz"}
    sds = dict.fromkeys(slopes, np.inf)
    free = set(slopes)
    cal = None
    for rounds in range(2):  # all slopes; then again without the scale slopes the data do not support
        for _ in range(iterations):
            compensated = recording
            if cal is not None:
                compensated = compensate(cal.with_(thermal=_slopes_model(slopes, temp, reference_c)), recording)[1]
            cal = run(compensated)
            if cal.gyroscope is None and "gyroscope" in sensors:  # accelerometer-only: its slopes alone
                sensors = ("accelerometer",)
                free = _without_gyroscope(slopes, sds, free)
            intervals = [Interval(int(a), int(b)) for a, b in cal.fit.poses.intervals or []]
            if len(intervals) < 8:
                raise ValueError(f"the temperature slopes need at least 8 static poses over the warm-up; "
                                 f"got {len(intervals)}")
            steps = _slope_steps(cal, compensated, intervals, reference_c, sensors, sds)
            for n in free:
                slopes[n] += steps[n]
            if all(abs(steps[n]) <= 0.1 * sds[n] for n in free):
                break
        weak = {n for n in free if ".scale." in n and not abs(slopes[n]) > sds[n]}
        if not weak or rounds:
            break
        free -= weak  # a scale slope the data do not support is left out, and the rest fitted again
        for n in weak:
            slopes[n] = 0.0
    kept = {n: v for n, v in slopes.items() if v}
    model = _kept_model(kept, sds, temp, reference_c)
    unc = dict(cal.fit.uncertainty.sigma or {})
    unc.update({f"thermal.{n}.slope": float(sds[n]) for n in kept})
    return cal.with_(thermal=model, fit=cal.fit.add(
        UncertaintyReport(sigma=unc), ThermalReport(model="linear", slopes_left_out=sorted(set(slopes) - set(kept)))))
