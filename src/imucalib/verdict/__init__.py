"""The verdict every calibration gets: ``accepted``, ``suspect`` or ``rejected``, with reasons.

A calibration's own cost says how well it fits the data it was fitted to; it
cannot say that the data or the model was wrong. The checks here use figures
the fit did not minimise, or that it cannot change:

* **time base** — the rate and the angular speed the *accelerometer* sees
  between poses (the angle between the gravity directions of consecutive poses
  over the time between them) must be a hand's: a 1000× time error cannot pass;
* **gravity** — the declared gravity must be one found on Earth's surface, and
  with physical accelerometer units the raw ``|a|`` at rest must agree with it;
* **plausibility** — scales near the declared unit's nominal factor (deg/s data
  declared rad/s is 57× off), cross-axis terms below 3°, a solver that converged;
* **redundancy** — poses per estimated accelerometer parameter; the gravity-norm
  residual against the white-noise floor, too high (model or poses wrong) and
  too low for the poses' degrees of freedom (an over-fit);
* **the gyroscope against the noise** — the gravity-direction error between
  poses against what the sensor noise alone predicts for these rotations
  (:func:`predicted_direction_error`, from the white noise of the sensor at
  rest: a shaken accelerometer or a trembling hand is not noise that excuses
  the error), over every rotation without saturated samples, spikes or gaps
  (the fit's outliers included), as ``validate`` judges it;
* **the raw readings** — with physical units, a calibration worse than the
  identity one (no bias, nominal scale, no misalignment) on ``|a| − g`` over
  the poses or on the gravity-direction error over every rotation is
  rejected (:mod:`imucalib.verdict.raw`);
* **the gyroscope at rest** — the calibrated rate's mean over the static poses
  against the standard error the poses' scatter allows (a bias the rest
  contradicts), and enough rotations kept for the gyroscope's nine scale and
  misalignment parameters;
* **known turns** — each turn by a known angle re-integrated with the calibration;
* **usefulness** — parameters whose 1σ is too large to be of use, or undetermined;
  an accelerometer parameter whose 1σ costs more than its nominal value would
  rejects the calibration;
* **directions the poses did not visit** — the 1σ of the calibrated ``|a|``
  the fit's covariance predicts where no pose pointed (an axis never up or
  down), against the noise floor ``validate`` judges by and its limits
  (:func:`unvisited_sigma`): a calibration ``validate`` would reject there
  is rejected now;
* **the magnetometer** — the calibrated field's norm and its dip to gravity must be
  the same in every pose, and its direction must turn as the gyroscope says;
* **finite numbers** — a NaN or infinite parameter or figure rejects: no limit trips on NaN.

Thresholds (:data:`THRESHOLDS`) come from Monte Carlo on the hand-held
scenario (``python -m imucalib.experiments.verdict_thresholds``, 30 sessions, tedaldi2014,
zhang2021 and ellipsoid): none of its good sessions is suspect or rejected.
The margins between the worst good session and the limit are 2.1× on the
gyroscope's error against its noise, 2.7× on its error in degrees, 3.3× on
its rest rate against the poses' scatter (5.3× on the rate itself), 7.3× on the
residual against the noise floor, 3.5× and 5.2× on the cross-axis terms,
over 40× on the 1σ, 1.5× on the over-fit check and 2.2× on poses per
parameter (zhang2021's selection keeps to the pose budget: it takes the
linear variant on every one of these sessions); the real Xsens session is
accepted by every method that models its sensor.

The directions check sets no limit of its own: its figure is the ratio
``validate`` would find on poses in the unvisited directions, judged by
``validate``'s ``residual_to_noise_high``; its cone is the one
:func:`imucalib.metrics.pose_coverage` advises by. Every good session above
visits each axis up and down (figure 0), and so do the Xsens session's two
halves. Its poses with ``|u_z| < 0.3`` predict 281× (``validate`` on the whole
session finds 45×: rejected); the 30 hand-held sessions calibrated on their
poses with ``|u_z| < 0.3`` are rejected (27) or suspect (3), their true ``|a|``
with z up or down off by 7-5500× the floor
(``python benchmarks/bench_coverage.py``).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..fit.accelerometer import REDUCED_MODELS
from ..fit.magnetometer import WEAK_DIP_DEG
from ..fitreport import FitReport, VerdictReport
from ..methodinfo import needing
from ..recording import Interval, Recording
from .base import (
    LEVELS,
    NOMINAL,
    THRESHOLDS,
    Check,
    Poses,
    grade,
    predicted_direction_error,
    rest_noise,
    rest_rates,
    white_noise_variance,
)
from .coverage import unvisited_checks, unvisited_sigma
from .gyroscope import (
    bias_drift_checks,
    gyroscope_noise_checks,
    known_turn_checks,
    rest_rate_checks,
    rotations_used_checks,
)
from .inputs import check_rate, gravity_checks, time_base_checks, time_unit_hint, turn_speed
from .raw import raw_checks

__all__ = ["LEVELS", "THRESHOLDS", "Check", "assess", "check_rate", "plausibility", "plausible",
           "predicted_direction_error", "rest_noise", "rest_rates", "time_unit_hint", "turn_speed",
           "unvisited_sigma", "white_noise_variance", "with_verdict", "worse_than_nominal"]


def plausible(calibration: Calibration) -> bool:
    """Whether nothing in :func:`plausibility` rejects ``calibration`` (converged, sane scales and axes).

    Parameters
    ----------
    calibration : Calibration
        The calibration to check.

    Returns
    -------
    bool
        True when no check of :func:`plausibility` rejects it.

    Examples
    --------
    Readings in m/s²: scale factors 1 % off the unit's are plausible, twice it on x is not:

    >>> from imucalib import Calibration
    >>> from imucalib.models import TriadModel
    >>> from imucalib.verdict import plausible
    >>> units = {"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
    ...          "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}}
    >>> plausible(Calibration(accelerometer=TriadModel(scale=[1.01, 0.99, 1.0]), units=units))
    True
    >>> plausible(Calibration(accelerometer=TriadModel(scale=[2.0, 1.0, 1.0]), units=units))
    False
    """
    return all(c.level < 2 for c in plausibility(calibration))


def _swapped_axes(sensor: str, model, deg: float) -> str:
    """For a gyroscope cross-axis term near 90°: the order of its raw axes the fitted matrix reads, as a hint."""
    if sensor != "gyroscope" or deg < 45.0:
        return ""
    m = model.misalignment @ np.diag(model.scale)
    cols = np.argmax(np.abs(m), axis=1)
    if len(set(cols.tolist())) != 3:
        return ""
    order = ", ".join(f"{'-' if m[i, c] < 0 else ''}{'xyz'[c]}" for i, c in enumerate(cols))
    return (f"; near 90°, the gyroscope's axes are swapped against the accelerometer's: the fit reads them as "
            f"({order}), so check the order and signs of the gyroscope's (or the accelerometer's) columns")


def plausibility(calibration: Calibration) -> list[Check]:
    """Convergence, scales against the declared units' nominal factors, cross-axis terms.

    Parameters
    ----------
    calibration : Calibration
        The calibration to check; no recording is needed.

    Returns
    -------
    list of Check
        One check per finding, each with its level (1 suspect, 2 rejected) and its sentence; empty when all is
        plausible.

    Examples
    --------
    Readings declared in g but fitted with 0.01 m/s² per unit (they were counts): the unit is wrong:

    >>> from imucalib import Calibration
    >>> from imucalib.models import TriadModel
    >>> from imucalib.verdict import plausibility
    >>> units = {"accelerometer": {"raw": "g", "calibrated": "m/s^2"},
    ...          "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}}
    >>> cal = Calibration(accelerometer=TriadModel(scale=[0.01, 0.01, 0.01]), units=units)
    >>> plausibility(cal)
    [Check(level=2, text="the accelerometer scale factor of axis x is 0.00102× the nominal ...")]
    >>> plausibility(Calibration())  # the identity, in counts: nothing to object
    []
    """
    out = []
    fit = calibration.fit
    if fit.method.converged is False:
        out.append(Check(2, "the solver did not converge: these parameters are not a minimum of the fit"))
    for sensor, model in (("accelerometer", calibration.accelerometer), ("gyroscope", calibration.gyroscope)):
        if model is None:  # an accelerometer-only calibration
            continue
        unit = calibration.units[sensor]["raw"]
        nominal = calibration.gravity if unit == "g" else NOMINAL.get(unit)
        if nominal is not None:
            rel = np.abs(model.scale / nominal - 1)
            worst = int(np.argmax(rel))
            level = grade(float(rel[worst]), THRESHOLDS["nominal_scale_rel"])
            if level:
                out.append(Check(level, f"the {sensor} scale factor of axis {'xyz'[worst]} is "
                                        f"{model.scale[worst] / nominal:.4g}× the nominal factor of the declared "
                                        f"unit {unit!r}: the unit (or the time base) is probably wrong"))
        off = np.abs(model.misalignment - np.diag(np.diag(model.misalignment)))
        deg = float(np.degrees(np.arctan(off.max())))
        limits = THRESHOLDS["cross_axis_deg" if sensor == "accelerometer" else "gyro_cross_axis_deg"]
        level = grade(deg, limits)
        if level:
            i, j = np.unravel_index(int(np.argmax(off)), off.shape)
            out.append(Check(level, f"the {sensor} cross-axis term {'xyz'[i]}{'xyz'[j]} is {deg:.1f}° (limit "
                                    f"{limits[0]:g}°): axes that far from orthogonal are implausible for a "
                                    f"MEMS sensor{_swapped_axes(sensor, model, deg)}"))
        if np.any(~np.isfinite(model.scale)) or np.any(model.scale == 0):
            out.append(Check(2, f"the {sensor} scale factors are not finite and non-zero"))
    return out


def _accelerometer_parameters(calibration: Calibration) -> int:
    reduced = {name: p for name, _, p, _ in REDUCED_MODELS if name != "linear"}
    name = calibration.fit.accelerometer.model
    if name in reduced:  # a model reduced to what the poses determine (fit.accelerometer.fit_determined)
        return reduced[name]
    acc = calibration.accelerometer
    n = 6 + {"upper": 3, "lower": 3, "full": 6, "diagonal": 0}.get(acc.shape, 3)
    n += 3 * int(np.any(acc.scale_quadratic)) + 3 * int(np.any(acc.scale_cubic))
    return n


def _redundancy(calibration: Calibration, fitted: bool = True) -> list[Check]:
    """Poses per parameter and the residual against the noise floor; ``fitted=False``: the residual-too-high only.

    On a recording the calibration was not fitted to (``fitted=False``) the poses are not the fit's, so neither
    their number nor an over-fit means anything; a residual far above the noise floor still does, whatever the
    method (an exact method's residual on new poses is a real one). A method that determines its parameters
    exactly (``six_position``, ``ferraris``: no redundancy to count, no over-fit to find) is judged on the
    residual over its poses as well, by the same limits: ``calibrate`` and ``validate`` on the same data agree.
    """
    fit = calibration.fit
    out = []
    m = fit.poses.static_intervals
    exact = "accelerometer" in str(fit.uncertainty.unavailable or "") or calibration.method in needing(
        "six faces")
    if not m:
        return out
    fitted = fitted and not exact  # the checks of the fit's redundancy: not for an exact method
    p = _accelerometer_parameters(calibration)
    per = m / p
    lim = THRESHOLDS["poses_per_parameter"]
    if fitted and (per <= lim[1] or per < lim[0]):
        out.append(Check(2 if per <= lim[1] else 1,
                         f"{m} static poses for {p} accelerometer parameters ({per:.2g} per parameter, at least "
                         f"{lim[0]:g} wanted): the fit can follow the noise; record more poses"))
    ratio = fit.accelerometer.residual_to_noise
    if ratio is not None and np.isfinite(ratio):
        level = grade(ratio, THRESHOLDS["residual_to_noise_high"])
        if level:
            out.append(Check(level, f"the gravity-norm residual is {ratio:.3g}× the white-noise floor (limit "
                                    f"{THRESHOLDS['residual_to_noise_high'][0]:g}×): the model leaves structure or "
                                    "some poses were not still"))
        if fitted and m > p:
            expected = np.sqrt((m - p) / m)
            if ratio / expected < THRESHOLDS["residual_to_noise_low"]:
                out.append(Check(1, f"the gravity-norm residual is {ratio:.3g}× the white-noise floor, "
                                    f"{ratio / expected:.2g}× what {m} poses leave after fitting {p} parameters: "
                                    "an over-fit (or the poses' noise is overestimated)"))
    return out


def _usefulness(calibration: Calibration) -> list[Check]:
    unc = calibration.fit.uncertainty.sigma or {}
    out = []
    params = calibration.parameters()
    for name, s in unc.items():
        value = params.get(name)
        if value is None:
            continue
        if s is None or not np.isfinite(s):
            out.append(Check(1, f"{name} is not determined by these poses and rotations (no finite 1σ)"))
        elif ".scale." in name and ("scale_quadratic" not in name and "scale_cubic" not in name) and value:
            if s / abs(value) > THRESHOLDS["scale_sigma_rel"]:
                out.append(Check(1, f"{name} has a 1σ of {100 * s / abs(value):.2g} % (limit "
                                    f"{100 * THRESHOLDS['scale_sigma_rel']:g} %): too uncertain to be of use"))
        elif ".misalignment." in name and np.degrees(s) > THRESHOLDS["misalignment_sigma_deg"]:
            out.append(Check(1, f"{name} has a 1σ of {np.degrees(s):.2g}° (limit "
                                f"{THRESHOLDS['misalignment_sigma_deg']:g}°): too uncertain to be of use"))
    return worse_than_nominal(calibration, unc, params) + out


def worse_than_nominal(calibration: Calibration, unc: dict, params: dict) -> list[Check]:
    """Accelerometer parameters whose 1σ costs more than holding them at their nominal value would: reject.

    Each parameter's effect on the calibrated output at 1 g on its axis
    (raw reading ``x = g/|k1|``): a scale ``k1`` times ``x``, ``k2`` times
    ``x²``, ``k3`` times ``x³``, a misalignment times ``g``, a bias times
    ``|k1|``. Its 1σ's effect is what estimating it risks; its estimate's
    departure from the nominal value (the declared unit's factor, or the mean
    of the other two axes' for counts; zero for the other terms) is what
    holding it there would cost. Where the first exceeds the second and
    :data:`THRESHOLDS` ``["parameter_effect_g"]`` of gravity (a parameter too
    uncertain to be of use), the calibration is worse than the nominal one:
    rejected, naming the parameter.
    """
    acc = calibration.accelerometer
    g = calibration.gravity
    unit = calibration.units["accelerometer"]["raw"]
    nominal = g if unit == "g" else NOMINAL.get(unit) if unit == "m/s^2" else None
    k1 = np.abs(acc.scale)
    x = g / k1
    floor = THRESHOLDS["parameter_effect_g"] * g
    out = []
    for name, s in unc.items():
        parts = name.split(".")
        if len(parts) != 3 or parts[0] != "accelerometer" or s is None or not np.isfinite(s) or name not in params:
            continue
        kind, axis, v = parts[1], parts[2], float(params[name])
        i = "xyz".index(axis[0])
        if kind == "scale":
            ref = nominal if nominal is not None else float(np.mean(np.delete(k1, i))) * np.sign(v)
            effect, cost = s * x[i], abs(v - ref) * x[i]
        elif kind in ("scale_quadratic", "scale_cubic"):
            power = 2 if kind == "scale_quadratic" else 3
            effect, cost = s * x[i] ** power, abs(v) * x[i] ** power
        elif kind == "misalignment":
            effect, cost = s * g, abs(v) * g
        elif kind == "bias":
            effect, cost = s * k1[i], abs(v) * k1[i]
        else:
            continue
        if effect > floor and effect > cost:
            out.append(Check(2, f"{name}: its 1σ moves the output by {effect:.3g} m/s² at 1 g, more than holding it "
                                f"at its nominal value would ({cost:.3g} m/s²): the poses do not determine it and the "
                                f"calibration is worse than the nominal one (record poses with {axis[0]} up and "
                                "down, or use a model without it)"))
    return out


def _magnetometer(calibration: Calibration) -> list[Check]:
    fit = calibration.fit
    if fit.magnetometer.error:
        return [Check(1, f"the magnetometer was not calibrated: {fit.magnetometer.error}")]
    mag = fit.magnetometer
    if calibration.magnetometer is None or mag.norm_spread is None:
        return []
    out = []
    figures = ((mag.norm_spread, "mag_norm_spread", "the calibrated field's norm varies by {:.2g} % "
                "over the poses (limit {:g} %): the field is not uniform (iron nearby) or the poses are wrong", 100),
               (mag.dip_spread_deg, "mag_dip_spread_deg", "the field's angle to gravity varies by {:.2g}° "
                "over the poses (limit {:g}°): the magnetometer's axes do not follow the accelerometer's", 1),
               (mag.direction_error_mean_deg, "mag_direction_error_deg", "the field direction turns "
                "{:.2g}° away from what the gyroscope says between poses (limit {:g}°)", 1))
    for value, limit, text, factor in figures:
        if value is None or not np.isfinite(value):
            continue
        level = grade(value, THRESHOLDS[limit])
        if level:
            out.append(Check(level, text.format(factor * value, factor * THRESHOLDS[limit][level - 1])))
    drift = fit.magnetometer.hard_iron_drift_over_session
    if drift is not None:
        level = int(drift > THRESHOLDS["mag_norm_spread"][0])
        out.append(Check(level, f"the magnetometer's hard iron drifted by {100 * drift:.2g} % of the field over the "
                                "poses (fitted: the calibration holds its value at the poses' mean time); used at "
                                "another time it will be off by as much (let the sensor warm up, keep currents away)"))
    dip = fit.magnetometer.dip_deg
    if dip is not None and abs(dip) < WEAK_DIP_DEG:
        out.append(Check(1, f"the field's dip is {dip:.1f}°, near the magnetic equator: whether the magnetometer's "
                            "axes are reflected cannot be told from these data (the sign follows --mag-hemisphere)"))
    return out


#: the figures made by applying the calibration to the data, and the data's temperature: NaN or infinite only
#: when the numbers overflow (other entries may be NaN where they do not apply: no detector scan, no rotation)
CALIBRATED_FIGURES = ("accelerometer_residual_rms", "accelerometer_residual_to_noise",
                      "gyroscope_angle_error_mean_deg", "gyroscope_angle_error_max_deg", "gyroscope_error_to_noise",
                      "gyroscope_rest_rate_deg_s", "temperature_c")


def _calibrated_figures(report: FitReport) -> dict:
    """The :data:`CALIBRATED_FIGURES` of ``report``, by name."""
    acc, gyro = report.accelerometer, report.gyroscope
    return {"accelerometer_residual_rms": acc.residual_rms, "accelerometer_residual_to_noise": acc.residual_to_noise,
            "gyroscope_angle_error_mean_deg": gyro.angle_error_mean_deg,
            "gyroscope_angle_error_max_deg": gyro.angle_error_max_deg, "gyroscope_error_to_noise": gyro.error_to_noise,
            "gyroscope_rest_rate_deg_s": gyro.rest_rate_deg_s, "temperature_c": report.thermal.temperature_c}


def _non_finite(calibration: Calibration, figures: FitReport) -> list[Check]:
    """A rejection when a parameter or a figure of the calibrated data is NaN or infinite.

    A comparison with NaN is false, so no other limit trips on one: a scale of
    1e308 makes every figure NaN and every check pass. The figures checked are
    :data:`CALIBRATED_FIGURES`, from ``fit`` and ``figures``; ``None`` (not
    available) passes.
    """
    bad = [name for name, v in calibration.parameters().items() if not np.isfinite(v)]
    for name, value in _calibrated_figures(calibration.fit.add(figures)).items():
        values = value if isinstance(value, list | tuple) else [value]
        numbers = [v for v in values if isinstance(v, float | int | np.number) and not isinstance(v, bool)]
        if numbers and not np.all(np.isfinite(np.asarray(numbers, dtype=float))):
            bad.append(name)
    if not bad:
        return []
    return [Check(2, f"{', '.join(bad[:6])}{' …' if len(bad) > 6 else ''} {'is' if len(bad) == 1 else 'are'} not a "
                     "finite number (NaN or infinite): the calibration's numbers overflowed or are undefined")]


def assess(calibration: Calibration, recording: Recording | None = None, intervals: list[Interval] | None = None, *,
           purpose: str = "calibrate", poses=None, own_figures: bool = False) -> FitReport:
    """Every check on ``calibration`` (with the recording it was made from, when there is one).

    ``purpose="validate"`` judges a calibration on a recording it was not
    fitted to (:func:`imucalib.validation.validate`, with ``fit`` holding the
    figures on that recording): the checks of the fit itself — poses per
    parameter, over-fit, the 1σ errors' usefulness — are left out; the
    residual against the noise floor, the gyroscope against its noise, the
    time base, gravity and plausibility remain. ``poses``: the poses' figures (``means``, ``up``, ``floor``,
    ``intervals``) of data that are no recording, a table of averaged poses (:mod:`imucalib.methods._pose_table`).

    Parameters
    ----------
    calibration : Calibration
        The calibration to judge, its fit figures in ``fit``.
    recording : Recording, optional
        The recording it was made from (or, for ``purpose="validate"``, the one it is checked on).
    intervals : list of Interval, optional
        The static poses of ``recording``; by default ``calibration.fit.poses.intervals``.
    purpose : {"calibrate", "validate"}
        What the verdict is for (above).
    poses : Poses, optional
        The poses' figures of data that are no recording (above).
    own_figures : bool
        Whether ``calibration.fit`` was made with these models on ``recording``, as a method's fit is before
        anything changes the calibration: the verdict then reads the figures it holds (the noise floor, the
        rotations the data do not allow, each rotation's error) instead of finding them again
        (:class:`~imucalib.verdict.base.Poses`).

    Returns
    -------
    FitReport
        Its :class:`~imucalib.fitreport.VerdictReport` (``level``, ``reasons``, ``notes``) and the figures the
        checks rest on: the verdict is the worst level among the checks (``accepted``, ``suspect`` or
        ``rejected``); reasons are the sentences of the suspect and rejecting ones, notes the rest.

    Examples
    --------
    A simulated session judged with its true calibration, and with an accelerometer 10 % off (with the
    figures the checks read, :func:`imucalib.metrics.fit_summary`):

    >>> from imucalib.metrics import fit_summary
    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> from imucalib.verdict import assess
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> assess(sim.truth, sim.recording, intervals).verdict.level
    'accepted'
    >>> acc = sim.truth.accelerometer
    >>> off = sim.truth.with_(accelerometer=acc.with_(scale=1.1 * acc.scale))
    >>> off = off.with_(fit=fit_summary(off, sim.recording, intervals))
    >>> found = assess(off, sim.recording, intervals).verdict
    >>> found.level, found.reasons[0]
    ('rejected', 'the gravity-norm residual is 520× the white-noise floor (limit 8×): ...')
    """
    if purpose not in ("calibrate", "validate"):
        raise ValueError(f"purpose must be 'calibrate' or 'validate'; got {purpose!r}")
    fitted = purpose == "calibrate"
    fit = calibration.fit
    if intervals is None and fit.poses.intervals:
        intervals = [Interval(int(a), int(b), "static") for a, b in fit.poses.intervals]
    intervals = intervals or []
    checks: list[Check] = []
    figures = FitReport()
    # the poses' figures several checks read (their means, noise, rates at rest), each computed once
    found = (poses if poses is not None else None if recording is None
             else Poses(calibration, recording, intervals, own_figures=own_figures))
    if recording is not None:  # the inputs first: a wrong time base or unit explains everything after it
        checks += time_base_checks(found)
    checks += gravity_checks(calibration, found)
    checks += plausibility(calibration)
    checks += _redundancy(calibration, fitted)
    if fitted:
        checks += _usefulness(calibration)
        if found is not None:
            coverage_checks, unvisited_figures = unvisited_checks(calibration, found)
            checks += coverage_checks
            figures = figures.add(unvisited_figures)
        if calibration.gyroscope is not None:
            checks += rotations_used_checks(calibration, intervals)
    if fit.accelerometer.model_reduced:
        checks.append(Check(1, f"{fit.accelerometer.model_reduced}: record more poses, in directions spread over "
                               "the sphere, for the full model"))
    if calibration.gyroscope is None:
        why = fit.gyroscope.not_calibrated or "no gyroscope (an accelerometer-only recording)"
        checks.append(Check(0, f"{why}; the calibration has no gyroscope, and the gyroscope checks are skipped"))
    elif recording is not None:
        gyro_checks, gyro_figures = gyroscope_noise_checks(calibration, found)
        checks += gyro_checks
        figures = figures.add(gyro_figures)
        if fitted:
            rest_checks, rest_figures = rest_rate_checks(found)
            checks += rest_checks
            figures = figures.add(rest_figures)
        checks += known_turn_checks(calibration, recording)
    if calibration.gyroscope is not None:
        checks += bias_drift_checks(calibration)
    raw, raw_figures = raw_checks(calibration, found, fitted)  # never worse than the raw readings (verdict.raw)
    checks += raw
    figures = figures.add(raw_figures)
    checks += _magnetometer(calibration)
    checks += _non_finite(calibration, figures)
    level = max((c.level for c in checks), default=0)
    return figures.add(VerdictReport(level=LEVELS[level],
                                     reasons=[c.text for c in sorted(checks, key=lambda c: -c.level) if c.level > 0],
                                     notes=[c.text for c in checks if c.level == 0]))


def with_verdict(calibration: Calibration, recording: Recording | None = None, intervals: list[Interval] | None = None,
                 *, own_figures: bool = False):
    """``calibration`` with ``fit`` holding its verdict, reasons, notes and the figures they rest on.

    Parameters
    ----------
    calibration : Calibration
        The calibration to judge.
    recording : Recording, optional
        The recording it was made from.
    intervals : list of Interval, optional
        Its static poses; by default ``calibration.fit.poses.intervals``.
    own_figures : bool
        Whether the fit's figures are this calibration's on ``recording`` (:func:`assess`).

    Returns
    -------
    Calibration
        A copy whose ``fit`` holds what :func:`assess` returns.

    Examples
    --------
    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> from imucalib.verdict import with_verdict
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> judged = with_verdict(sim.truth, sim.recording, intervals)
    >>> judged.fit.verdict.level, judged.fit.verdict.reasons
    ('accepted', [])
    """
    return calibration.with_(fit=calibration.fit.add(assess(calibration, recording, intervals,
                                                            own_figures=own_figures)))
