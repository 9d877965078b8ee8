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

from ..constants import GRAVITY_RANGE
from ..fit.accelerometer import REDUCED_MODELS, fit_sphere
from ..fit.magnetometer import WEAK_DIP_DEG
from ..fitreport import FitReport, GyroscopeReport, VerdictReport
from ..methodinfo import needing
from ..metrics import transition_bounds
from ..recording import Interval, Recording
from ..segment import unreliable_transitions
from .base import (
    GYRO_ROTATION_PARAMETERS,
    LEVELS,
    NOMINAL,
    THRESHOLDS,
    Check,
    Poses,
    grade,
    predicted_direction_error,
    predicted_error_of,
    rest_noise,
    rest_rates,
    rest_rates_of,
    white_noise_variance,
)
from .coverage import unvisited_checks, unvisited_sigma
from .raw import raw_checks

__all__ = ["LEVELS", "THRESHOLDS", "Check", "assess", "check_rate", "plausibility", "plausible",
           "predicted_direction_error", "rest_noise", "rest_rates", "time_unit_hint", "turn_speed",
           "unvisited_sigma", "white_noise_variance", "with_verdict", "worse_than_nominal"]


def check_rate(recording: Recording) -> None:
    """Raise ValueError at a sampling rate no IMU records at: the time base is wrong and nothing can be fitted.

    Parameters
    ----------
    recording : Recording
        The recording whose sampling rate is checked.

    Returns
    -------
    None

    Raises
    ------
    ValueError
        At a sampling rate no IMU records at (the time base is in the wrong unit, or broken).

    Examples
    --------
    Times in milliseconds read as seconds make a 1 kHz recording a 1 mHz one:

    >>> import numpy as np
    >>> from imucalib import Recording
    >>> from imucalib.verdict import check_rate
    >>> check_rate(Recording(np.arange(10) / 1000, np.zeros((10, 3)), None))  # 1 kHz: fine
    >>> check_rate(Recording(np.arange(10) * 1000.0, np.zeros((10, 3)), None))
    Traceback (most recent call last):
        ...
    ValueError: the sampling rate is 0.001 Hz, outside 5-50000 Hz where IMUs record: ...
    """
    rate = recording.rate
    lo, hi = THRESHOLDS["rate_hz"]
    if not lo <= rate <= hi:
        raise ValueError(f"the sampling rate is {rate:.4g} Hz, outside {lo:g}-{hi:g} Hz where IMUs record: "
                         f"{time_unit_hint(recording)}")


#: the time units a time column can be read in, and their length [s]
_TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
_TIME_NAMES = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}


def time_unit_hint(recording: Recording) -> str:
    """What a sampling rate outside an IMU's range most likely means: which time unit was read as which.

    The time column was read in ``metadata["time_unit"]``; the other unit that
    puts the rate at 10 Hz-2 kHz (where most IMUs record) is named, e.g.
    "the timestamps look like milliseconds read as microseconds (62.5 Hz then)".
    """
    read_as = recording.metadata.get("time_unit")
    if read_as not in _TIME_UNITS:
        return "the time base is probably wrong (a time column in another unit, or a wrong --rate)"
    for unit, length in _TIME_UNITS.items():
        rate = recording.rate * _TIME_UNITS[read_as] / length  # the stamps were in unit, not read_as
        if unit != read_as and 10 <= rate <= 2000:
            return (f"the timestamps look like {_TIME_NAMES[unit]} read as {_TIME_NAMES[read_as]} ({rate:.4g} Hz "
                    f"then): pass --time-unit {unit}")
    return f"the time column (read in {_TIME_NAMES[read_as]}) is probably in another unit: see --time-unit"


def turn_speed(calibration, recording: Recording, intervals: list[Interval]) -> float:
    """Median angular speed [deg/s] the accelerometer sees between poses (turns above 10°); NaN without any.

    The angle between the calibrated gravity directions of consecutive poses
    over the time between them: independent of the gyroscope and its unit.

    Parameters
    ----------
    calibration : Calibration
        Its accelerometer gives the gravity directions.
    recording : Recording
        The recording.
    intervals : list of Interval
        Its static poses, in time order.

    Returns
    -------
    float
        The median angular speed [deg/s], NaN without a turn above 10°.

    Examples
    --------
    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> from imucalib.verdict import turn_speed
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> round(turn_speed(sim.truth, sim.recording, intervals))  # deg/s, a hand's pace
    35
    """
    return _turn_speed(Poses(calibration, recording, intervals))


def _turn_speed(found: Poses) -> float:
    """:func:`turn_speed` from the poses' figures of one assessment."""
    recording, intervals = found.recording, found.intervals
    if len(intervals) < 2:
        return float("nan")
    acc = found.up
    u = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    ang = np.degrees(np.arccos(np.clip(np.sum(u[:-1] * u[1:], axis=1), -1, 1)))
    starts, stops = transition_bounds(intervals)
    dur = recording.t[stops] - recording.t[starts]
    ok = (ang > 10) & (dur > 0)
    return float(np.median(ang[ok] / dur[ok])) if np.any(ok) else float("nan")


def _time_base(found: Poses) -> list[Check]:
    speed = _turn_speed(found)
    lo, hi = THRESHOLDS["turn_speed_deg_s"]
    if not np.isfinite(speed) or lo <= speed <= hi:
        return []
    if not lo / 10 <= speed <= hi * 10:
        return [Check(2, f"between poses the accelerometer sees the sensor turn at {speed:.3g} deg/s (median), "
                         f"where a hand turns at {lo:g}-{hi:g} deg/s: the time base is wrong (check the time "
                         "column's unit)")]
    return [Check(1, f"between poses the accelerometer sees the sensor turn at {speed:.3g} deg/s (median), "
                     f"outside the {lo:g}-{hi:g} deg/s of a hand: check the time base")]


def _gravity(calibration, found: Poses | None) -> list[Check]:
    recording, intervals = (None, []) if found is None else (found.recording, found.intervals)
    g = calibration.gravity
    out = []
    lo, hi = GRAVITY_RANGE  # the command line warns outside the same range
    if not lo <= g <= hi:
        out.append(Check(2, f"the declared gravity {g:.5g} m/s² is outside {lo}-{hi} m/s², the range on Earth's "
                            "surface (a typo, or a value in g?); every accelerometer scale factor is off by the "
                            "same ratio"))
    unit = calibration.units["accelerometer"]["raw"]
    if recording is not None and len(intervals) >= 4 and unit in ("g", "m/s^2"):
        factor = g if unit == "g" else 1.0
        # the radius of the sphere through the static means: |a| at rest with the biases taken out
        means = found.means
        try:
            radius = g / float(fit_sphere(means, g).scale[0])
        except ValueError:
            radius = float(np.median(np.linalg.norm(means, axis=1)))
        norm = radius * factor
        rel = abs(norm / g - 1)
        level = grade(rel, THRESHOLDS["rest_norm_rel"])
        if level:
            out.append(Check(level, f"the raw |a| at rest is {norm:.4g} m/s² (read as {unit}, biases taken out), "
                                    f"{100 * rel:.1f} % "
                                    f"from the declared gravity {g:.5g} m/s²: check --gravity and --acc-unit"))
    return out


def plausible(calibration) -> bool:
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


def plausibility(calibration) -> list[Check]:
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


def _accelerometer_parameters(calibration) -> int:
    reduced = {name: p for name, _, p, _ in REDUCED_MODELS if name != "linear"}
    name = calibration.fit.accelerometer.model
    if name in reduced:  # a model reduced to what the poses determine (fit.accelerometer.fit_determined)
        return reduced[name]
    acc = calibration.accelerometer
    n = 6 + {"upper": 3, "lower": 3, "full": 6, "diagonal": 0}.get(acc.shape, 3)
    n += 3 * int(np.any(acc.scale_quadratic)) + 3 * int(np.any(acc.scale_cubic))
    return n


def _redundancy(calibration, fitted: bool = True) -> list[Check]:
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


def _gyroscope(calibration, found: Poses) -> tuple[list[Check], GyroscopeReport]:
    """The gyroscope's gravity-direction error between poses against what the sensor noise alone predicts.

    Judged on every rotation whose integration the data allow (:func:`imucalib.segment.unreliable_transitions`
    finds the rest: saturated samples, spikes, sampling gaps, unsteady poses — faults of the data, found from
    the recording alone), the ones the fit left out because their error was far from the others' included:
    ``calibrate`` and ``validate`` judge the same rotations of the same data by the same limits.
    """
    recording, intervals = found.recording, found.intervals
    fit = calibration.fit
    if fit.gyroscope.angle_error_mean_deg is None or len(intervals) < 2:
        return [], GyroscopeReport()
    pred = predicted_error_of(found, None)
    errors = found.direction_errors
    left_out = fit.gyroscope.rotations_left_out or {}
    left = set(left_out)
    faulty = unreliable_transitions(recording, intervals)
    judged = np.array([k not in faulty for k in range(len(pred))])
    figures = GyroscopeReport()
    out = []
    if left:
        kept = np.array([k not in left for k in range(len(pred))])
        if np.any(kept):
            figures = figures.with_(angle_error_kept_mean_deg=float(np.degrees(np.mean(errors[kept]))))
        if len(left) > len(pred) / 3:
            out.append(Check(1, f"{len(left)} of the {len(pred)} rotations between poses were left out of the "
                                "gyroscope fit (notes below say why): the rest may not cover every axis well"))
    if np.any(judged):
        mean_deg = float(np.degrees(np.mean(errors[judged])))
        pred_deg = float(np.degrees(np.mean(pred[judged])))
        ratio = mean_deg / pred_deg if pred_deg > 0 else float("inf")
        figures = figures.with_(angle_error_predicted_deg=pred_deg, error_to_noise=ratio)
        if faulty:
            figures = figures.with_(angle_error_reliable_mean_deg=mean_deg)
        floor = THRESHOLDS["gyro_error_floor_deg"]
        level = min(grade(ratio, THRESHOLDS["gyro_error_to_noise"]), grade(mean_deg, floor))
        over = (f" over the {int(np.sum(judged))} rotations without saturated samples, spikes or gaps"
                if faulty else "")
        if level:
            out.append(Check(level, f"the gyroscope's gravity-direction error between poses is {mean_deg:.3g}° "
                                    f"(mean{over}), {ratio:.3g}× the {pred_deg:.2g}° the sensor noise alone "
                                    f"predicts for these rotations (limit {THRESHOLDS['gyro_error_to_noise'][0]:g}×): "
                                    "the gyroscope calibration does not explain the rotations"))
    for k, why in sorted(left_out.items()):
        out.append(Check(0, f"the rotation from pose {k + 1} to {k + 2} was left out of the gyroscope "
                            f"fit: {why}"))
    return out, figures


def _rest_rate(found: Poses) -> tuple[list[Check], GyroscopeReport]:
    """The calibrated gyroscope at rest against what the poses' scatter allows.

    Per axis, the mean calibrated rate over the static poses ``r̄`` (each pose
    one weight) against its standard error ``s/√M`` from the scatter ``s`` of
    the poses' means (noise, tremor, drift: whatever makes them differ): a
    bias the poses support leaves ``|r̄| ≲ 3 s/√M``. A bias taken from the
    rotations alone, or from a rest that was not still, reads tens of times
    that. Below ``rest_rate_floor_deg_s`` the figure is not a reason.
    """
    if len(found.intervals) < 4:
        return [], GyroscopeReport()
    w = np.degrees(rest_rates_of(found))
    m = w.shape[0]
    mean = w.mean(axis=0)
    se = w.std(axis=0, ddof=1) / np.sqrt(m)
    z = np.divide(np.abs(mean), se, out=np.full(3, np.inf), where=se > 0)
    z[(mean == 0)] = 0.0
    figures = GyroscopeReport(rest_rate_deg_s=[float(x) for x in mean], rest_rate_to_scatter=float(z.max()))
    levels = [min(grade(float(z[j]), THRESHOLDS["rest_rate_to_scatter"]),
                  grade(float(abs(mean[j])), THRESHOLDS["rest_rate_floor_deg_s"])) for j in range(3)]
    j = int(np.argmax(levels))
    if not levels[j]:
        return [], figures
    return [Check(levels[j], f"at rest the calibrated gyroscope reads {mean[j]:.3g} °/s about {'xyz'[j]} (mean over "
                             f"the {m} static poses), {z[j]:.3g}× the {se[j]:.2g} °/s the poses' scatter allows "
                             f"(limit {THRESHOLDS['rest_rate_to_scatter'][0]:g}×): the gyroscope bias is not what "
                             "the sensor reads at rest")], figures


def _rotations_used(calibration, intervals: list[Interval]) -> list[Check]:
    """Enough rotations for the gyroscope's parameters: two direction components per rotation kept."""
    fit = calibration.fit
    if fit.gyroscope.bias_source is None or len(intervals) < 2:  # not a fit over the rotations between poses
        return []
    n = len(intervals) - 1
    kept = n - len(fit.gyroscope.rotations_left_out or {})
    per = 2 * kept / GYRO_ROTATION_PARAMETERS
    lim = THRESHOLDS["rotations_per_parameter"]
    level = 2 if per <= lim[1] else 1 if per < lim[0] else 0
    if not level:
        return []
    return [Check(level, f"the gyroscope rests on {kept} of the {n} rotations between poses ({2 * kept} direction "
                         f"components for its {GYRO_ROTATION_PARAMETERS} scale and misalignment parameters, "
                         f"{per:.2g} per parameter; at least {lim[0]:g} wanted): "
                         + ("they cannot determine it" if level == 2 else "too few to determine it well")
                         + "; record again without gaps, with more rotations")]


def _known_turns(calibration, recording: Recording) -> list[Check]:
    fit = calibration.fit
    turns = fit.gyroscope.turn_sections
    angle = fit.gyroscope.turn_angle_deg
    if not turns or not angle:
        return []
    out = []
    lim = THRESHOLDS["turn_angle_rel"]
    for sec in turns:
        s0, s1, axis = int(sec["start"]), int(sec["stop"]), int(sec["axis"])
        measured = sec.get("measured_deg")
        if measured is None:
            w = calibration.gyroscope_si(recording.gyro[s0:s1], recording.acc[s0:s1])
            measured = float(np.degrees(abs(np.trapezoid(w[:, axis], recording.t[s0:s1]))))
        rel = abs(measured / angle - 1)
        level = grade(rel, lim)
        if "measured_deg" in sec and level == 1:
            level = 0  # one rough scale for all three axes is itself good to a few per cent only
        if level:
            how = "by the poses' rough gyroscope scale" if "measured_deg" in sec else "with this calibration"
            out.append(Check(level, f"the turn about {'xyz'[axis]} (samples {s0}-{s1}) measures {measured:.4g}° "
                                    f"{how}, {100 * rel:.0f} % from the known angle {angle:g}° (limit "
                                    f"{100 * lim[0]:g} %): a wrong --turn-angle, or a motion that is not the turn"))
    return out


def _usefulness(calibration) -> list[Check]:
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


def worse_than_nominal(calibration, unc: dict, params: dict) -> list[Check]:
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


def _gyroscope_bias_drift(calibration) -> list[Check]:
    """A note on how far the gyroscope bias drifted over the session, when the fit found it drifting.

    From ``fit.gyroscope.bias_drift_over_session_deg_s``
    (:func:`imucalib.calibration.with_bias_session`): the calibrated rate at
    rest the drift adds to the stored (constant) bias's at the session's start
    and end. Never a reason: the fit models the drift, and ``apply`` corrects
    the calibrated session with it; the note tells that another recording's
    bias is off by as much unless taken from a rest of its own.
    """
    ends = calibration.fit.gyroscope.bias_drift_over_session_deg_s
    if ends is None:
        return []
    start, end = (np.asarray(row, dtype=float) for row in ends)
    j = int(np.argmax(np.maximum(np.abs(start), np.abs(end))))
    return [Check(0, f"the gyroscope bias drifted over the session: against the bias stored (at the poses' mean "
                     f"time) the rate at rest reads {start[j]:+.3g} °/s about {'xyz'[j]} at the start and "
                     f"{end[j]:+.3g} °/s at the end (x, y, z at the start: {', '.join(f'{v:+.2g}' for v in start)}; "
                     f"at the end: {', '.join(f'{v:+.2g}' for v in end)}); apply corrects this recording with the "
                     "drift, but another recording keeps the constant bias: take its bias from a rest of its own")]


def _magnetometer(calibration) -> list[Check]:
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


def _non_finite(calibration, figures: FitReport) -> list[Check]:
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


def assess(calibration, recording: Recording | None = None, intervals: list[Interval] | None = None, *,
           purpose: str = "calibrate", poses=None) -> FitReport:
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
    found = poses if poses is not None else None if recording is None else Poses(calibration, recording, intervals)
    if recording is not None:  # the inputs first: a wrong time base or unit explains everything after it
        checks += _time_base(found)
    checks += _gravity(calibration, found)
    checks += plausibility(calibration)
    checks += _redundancy(calibration, fitted)
    if fitted:
        checks += _usefulness(calibration)
        if found is not None:
            coverage_checks, unvisited_figures = unvisited_checks(calibration, found)
            checks += coverage_checks
            figures = figures.add(unvisited_figures)
        if calibration.gyroscope is not None:
            checks += _rotations_used(calibration, intervals)
    if fit.accelerometer.model_reduced:
        checks.append(Check(1, f"{fit.accelerometer.model_reduced}: record more poses, in directions spread over "
                               "the sphere, for the full model"))
    if calibration.gyroscope is None:
        why = fit.gyroscope.not_calibrated or "no gyroscope (an accelerometer-only recording)"
        checks.append(Check(0, f"{why}; the calibration has no gyroscope, and the gyroscope checks are skipped"))
    elif recording is not None:
        gyro_checks, gyro_figures = _gyroscope(calibration, found)
        checks += gyro_checks
        figures = figures.add(gyro_figures)
        if fitted:
            rest_checks, rest_figures = _rest_rate(found)
            checks += rest_checks
            figures = figures.add(rest_figures)
        checks += _known_turns(calibration, recording)
    if calibration.gyroscope is not None:
        checks += _gyroscope_bias_drift(calibration)
    raw, raw_figures = raw_checks(calibration, found, fitted)  # never worse than the raw readings (verdict.raw)
    checks += raw
    figures = figures.add(raw_figures)
    checks += _magnetometer(calibration)
    checks += _non_finite(calibration, figures)
    level = max((c.level for c in checks), default=0)
    return figures.add(VerdictReport(level=LEVELS[level],
                                     reasons=[c.text for c in sorted(checks, key=lambda c: -c.level) if c.level > 0],
                                     notes=[c.text for c in checks if c.level == 0]))


def with_verdict(calibration, recording: Recording | None = None, intervals: list[Interval] | None = None):
    """``calibration`` with ``fit`` holding its verdict, reasons, notes and the figures they rest on.

    Parameters
    ----------
    calibration : Calibration
        The calibration to judge.
    recording : Recording, optional
        The recording it was made from.
    intervals : list of Interval, optional
        Its static poses; by default ``calibration.fit.poses.intervals``.

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
    return calibration.with_(fit=calibration.fit.add(assess(calibration, recording, intervals)))
