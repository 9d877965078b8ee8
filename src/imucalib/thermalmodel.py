"""The temperature model a calibration holds, and its evaluation: the record's part of the thermal model.

A :class:`ThermalModel` makes some of a calibration's parameters polynomials in temperature (T1); this
module evaluates them at a temperature (T2), and compensates a recording's readings to the reference
temperature and back (T3)–(T4). Fitting the model — combining calibrations made at several temperatures,
or one warm-up session — is :mod:`imucalib.thermal`'s, which holds the equations (T1)–(T5).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from .recording import ImucalibWarning, Recording

__all__ = ["POSSIBLE_C", "REFERENCE_C", "ThermalModel", "at_temperature", "compensate", "decompensate", "evaluate",
           "fit_temperature", "temperature_of", "thermal_parameters"]

#: reference temperature ``T₀`` [°C] of a thermal model (datasheets quote their figures at 25 °C)
REFERENCE_C = 25.0
#: the parameters a thermal model may make temperature-dependent
_THERMAL_KEYS = ("bias", "scale", "misalignment")


@dataclass(frozen=True)
class ThermalModel:
    """Polynomials (T1) in temperature for some of a calibration's parameters.

    Attributes
    ----------
    reference_c : float
        ``T₀`` [°C].
    coefficients : dict
        Parameter name (``gyroscope.bias.x`` …) → ``[c₁, c₂]`` (per °C, per °C²).
    covariance : dict
        Parameter name → (3, 3) covariance of ``[c₀, c₁, c₂]``, for the model's own 1σ at any T.
    range_c : (float, float)
        Temperatures the model was made from [°C]; outside them it extrapolates.
    points : list of dict
        The calibration points ``{"temperature_c", "values", "sigmas"}`` it was fitted to (for plots).
    source : str
        ``"combined"`` (:func:`combine`) or ``"ramp"`` (:func:`calibrate_ramp`).

    Examples
    --------
    Calibrations of one simulated sensor at 10, 25 and 40 °C, combined (:func:`combine`) into one with a
    thermal model:

    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> from imucalib.thermal import combine
    >>> cals = [calibrate(session("handheld", rng=1, rest=10, n_poses=14, temperature=c).recording)
    ...         for c in (10.0, 25.0, 40.0)]
    >>> cal, summary = combine(cals)
    >>> model = cal.thermal
    >>> model.source, model.reference_c, [round(c) for c in model.range_c]
    ('combined', 25.0, [10, 40])
    >>> "gyroscope.bias.x" in model.coefficients
    True
    """

    reference_c: float = REFERENCE_C
    coefficients: dict = field(default_factory=dict)
    covariance: dict = field(default_factory=dict)
    range_c: tuple = (REFERENCE_C, REFERENCE_C)
    points: list = field(default_factory=list)
    source: str = "combined"

    def __post_init__(self) -> None:
        coeffs = {}
        for name, c in self.coefficients.items():
            c = np.asarray(c, dtype=float).reshape(-1)
            if c.shape != (2,) or not np.all(np.isfinite(c)):
                raise ValueError(f"thermal coefficients of {name} must be two finite numbers [c1, c2]; got {c!r}")
            parts = name.split(".")
            if len(parts) != 3 or parts[0] not in ("accelerometer", "gyroscope") or parts[1] not in _THERMAL_KEYS:
                raise ValueError(f"{name} cannot follow temperature here (only biases, scales and misalignments)")
            coeffs[name] = c
        object.__setattr__(self, "coefficients", coeffs)
        lo, hi = (float(v) for v in self.range_c)
        if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
            raise ValueError(f"a thermal model's range must be two temperatures, low first; got {self.range_c!r}")
        object.__setattr__(self, "range_c", (lo, hi))

    def deltas(self, temperature) -> dict[str, np.ndarray]:
        """Each parameter's change from its value at ``T₀`` at ``temperature`` (scalar or (N,))."""
        dt = np.asarray(temperature, dtype=float) - self.reference_c
        return {name: c[0] * dt + c[1] * dt * dt for name, c in self.coefficients.items()}  # eq. (T1) less c₀

    def sigma(self, name: str, temperature: float) -> float:
        """The model's own 1σ of ``name`` at ``temperature``."""
        cov = np.asarray(self.covariance.get(name, np.zeros((3, 3))), dtype=float)
        dt = float(temperature) - self.reference_c
        v = np.array([1.0, dt, dt * dt])  # eq. (T1)
        return float(np.sqrt(max(v @ cov @ v, 0.0)))

    def to_dict(self) -> dict:
        return {"reference_c": self.reference_c, "range_c": list(self.range_c), "source": self.source,
                "parameters": {name: {"coefficients": c.tolist(),
                                      "order": 2 if c[1] else 1,
                                      "covariance": np.asarray(self.covariance.get(name, np.zeros((3, 3)))).tolist()}
                               for name, c in self.coefficients.items()},
                "points": self.points}

    @classmethod
    def from_dict(cls, d: dict) -> ThermalModel:
        if not isinstance(d, dict) or not isinstance(d.get("parameters", {}), dict):
            raise ValueError("the thermal section must be an object with reference_c, range_c and parameters")
        try:
            params = d.get("parameters", {})
            return cls(reference_c=float(d.get("reference_c", REFERENCE_C)),
                       coefficients={k: v["coefficients"] for k, v in params.items()},
                       covariance={k: np.asarray(v.get("covariance", np.zeros((3, 3))), float)
                                   for k, v in params.items()},
                       range_c=tuple(d.get("range_c", (REFERENCE_C, REFERENCE_C))),
                       points=list(d.get("points", [])), source=str(d.get("source", "combined")))
        except (KeyError, TypeError) as exc:
            raise ValueError(f"the thermal section is malformed: {exc}") from None


def fit_temperature(t, number: int) -> float:
    """The temperature [°C] of a calibration's ``fit.thermal.temperature_c``: a number, or its recording's
    ``[lowest, mean, highest]``; a ValueError naming calibration ``number`` for anything else."""
    if t is None or t == []:
        raise ValueError(f"calibration {number} has no temperature: it was made from a recording without a "
                         "temperature column")
    if isinstance(t, list | tuple) and len(t) == 3:
        t = t[1]
    if isinstance(t, bool) or not isinstance(t, int | float) or not math.isfinite(t):
        raise ValueError(f"calibration {number}: fit.temperature_c must be a temperature [°C] or [lowest, mean, "
                         f"highest]; got {str(t)[:40]}")
    return float(t)


def thermal_parameters(calibration) -> list[str]:
    """Names of ``calibration``'s parameters a thermal model may vary (biases, scales, misalignments)."""
    return [n for n in calibration.parameters() if n.split(".")[0] in ("accelerometer", "gyroscope")
            and n.split(".")[1] in _THERMAL_KEYS]


def evaluate(calibration, temperature: float):
    """The calibration at one ``temperature`` [°C]: its parameters evaluated by (T1), no thermal model left."""
    model = calibration.thermal
    if model is None:
        return calibration
    values = calibration.parameters()
    deltas = model.deltas(float(temperature))
    missing = sorted(set(deltas) - set(values))
    if missing:
        raise ValueError(f"the thermal model varies {', '.join(missing)}, which the calibration does not have "
                         f"(its {calibration.model} model, {'no gyroscope, ' if calibration.gyroscope is None else ''}"
                         "its misalignment shape): the file is damaged or was edited; combine the calibrations "
                         "again (imucalib thermal)")
    # eq. (T1)
    return calibration.with_(thermal=None).with_parameters({k: values[k] + float(v) for k, v in deltas.items()})


#: the temperatures a working IMU can be at [°C]: above absolute zero, and below the 260 °C peak of lead-free
#: reflow soldering (IPC/JEDEC J-STD-020), past which no board-mounted sensor survives
POSSIBLE_C = (-273.15, 260.0)


def at_temperature(calibration, temperature: float):
    """``(calibration at temperature, notes)``: :func:`evaluate` for a temperature a user gave.

    A temperature no sensor can be at (not a number, below absolute zero, above :data:`POSSIBLE_C`) is a
    ValueError; one outside the temperatures the model was made from (by more than 1 °C, as :func:`compensate`
    allows) gets a note that it extrapolates there.
    """
    t = float(temperature)
    lo_c, hi_c = POSSIBLE_C
    if not (math.isfinite(t) and lo_c <= t <= hi_c):
        raise ValueError(f"{temperature!r} °C is no temperature a working sensor is at (expected {lo_c:g} to "
                         f"{hi_c:g} °C: above absolute zero and below soldering heat)")
    notes = []
    model = calibration.thermal
    if model is not None:
        lo, hi = model.range_c
        if not lo - 1.0 <= t <= hi + 1.0:
            notes.append(f"{t:g} °C is outside the {lo:.1f}–{hi:.1f} °C the thermal calibration was made from: it "
                         "extrapolates there")
    return evaluate(calibration, t), notes


# ------------------------------------------------------------------ compensation (T2)
def _per_sample(base, model: ThermalModel, prefix: str, temperature: np.ndarray):
    """Per-sample bias (N, 3), ``T K`` (N, 3, 3) or None when constant, for one triad."""
    deltas = {k: v for k, v in model.deltas(temperature).items() if k.startswith(prefix + ".")}
    n = temperature.shape[0]
    bias = np.broadcast_to(base.bias, (n, 3)).copy()
    scale = np.broadcast_to(base.scale, (n, 3)).copy()
    t = np.broadcast_to(base.misalignment, (n, 3, 3)).copy()
    axes = "xyz"
    varies = False
    for name, d in deltas.items():
        _, key, comp = name.split(".")
        if key == "bias":
            bias[:, axes.index(comp)] += d
        elif key == "scale":
            scale[:, axes.index(comp)] += d
            varies = True
        else:
            t[:, axes.index(comp[0]), axes.index(comp[1])] += d
            varies = True
    if varies and not base.is_linear:
        raise ValueError("a nonlinear scale-factor model follows temperature through its biases only")
    tk = t * scale[:, None, :] if varies else None  # eq. (T2): T(T) K(T)
    return bias, tk


def compensate(calibration, recording: Recording) -> tuple:
    """``(calibration at T₀, recording compensated by (T2))``: the same calibrated values as the thermal model.

    Parameters
    ----------
    calibration : Calibration
        A calibration, with or without a thermal model (without one, both are returned as they are).
    recording : Recording
        The recording to compensate; it needs a temperature column when the calibration follows temperature.

    Returns
    -------
    calibration : Calibration
        The calibration at its reference temperature T₀, without the thermal model.
    recording : Recording
        The recording's readings moved to T₀ by (T2).

    Raises
    ------
    ValueError
        The recording has no temperature column.

    Examples
    --------
    A thermal calibration of a simulated warm-up gives the same calibrated values as its calibration at
    25 °C applied to the compensated recording:

    >>> import numpy as np
    >>> from imucalib.methods import tedaldi2014
    >>> from imucalib.scenarios import session
    >>> from imucalib.thermal import calibrate_ramp, compensate
    >>> sim = session("handheld", rng=1, rest=10, n_poses=20, ramp=(20.0, 40.0, 60.0))
    >>> def method(recording):
    ...     return tedaldi2014.calibrate(recording, gravity=9.81)
    >>> cal = calibrate_ramp(method, sim.recording, iterations=2)
    >>> at_25, compensated = compensate(cal, sim.recording)
    >>> at_25.thermal is None
    True
    >>> np.allclose(at_25.apply(compensated).acc, cal.apply(sim.recording).acc)
    True
    """
    model = calibration.thermal
    if model is None:
        return calibration, recording
    temp = temperature_of(recording)
    lo, hi = model.range_c
    outside = (temp < lo - 1.0) | (temp > hi + 1.0)
    if np.any(outside):
        warnings.warn(f"{int(outside.sum())} samples were recorded at {float(temp[outside].min()):.1f}–"
                      f"{float(temp[outside].max()):.1f} °C, outside the {lo:.1f}–{hi:.1f} °C the thermal "
                      "calibration was made from: it extrapolates there", ImucalibWarning, stacklevel=3)
    base = calibration.with_(thermal=None)
    acc = _map(recording.acc, base.accelerometer, *_per_sample(base.accelerometer, model, "accelerometer", temp))
    gyro = recording.gyro  # an accelerometer-only calibration (or recording): the rates are not calibrated
    if base.gyroscope is not None and gyro is not None:
        a_si = base.accelerometer.forward(acc)
        g = base.gyroscope.g_sensitivity
        ga = a_si @ g.T if np.any(g) else 0.0
        # eq. (T2), G a out and back
        gyro = _map(gyro - ga, base.gyroscope, *_per_sample(base.gyroscope, model, "gyroscope", temp)) + ga
    out = Recording(t=recording.t, acc=acc, gyro=gyro, acc_unit=recording.acc_unit, gyro_unit=recording.gyro_unit,
                    temperature=recording.temperature, extra=dict(recording.extra),
                    metadata={**recording.metadata, "thermal_compensation": model.reference_c},
                    mag=recording.mag, mag_unit=recording.mag_unit)
    return base, out


def _map(u: np.ndarray, base, bias: np.ndarray, tk: np.ndarray | None) -> np.ndarray:
    """``b₀ + (T₀K₀)⁻¹ T K (u − b)`` per sample (``tk`` None: ``u − b + b₀``)."""
    x = u - bias
    if tk is not None:
        tk0 = base.misalignment * base.scale[None, :]
        x = np.linalg.solve(tk0, np.einsum("nij,nj->ni", tk, x).T).T  # eq. (T2)
    return x + base.bias


def decompensate(calibration, raw_reference: tuple[np.ndarray, np.ndarray], temperature: np.ndarray,
                 specific_force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Raw readings at ``temperature`` from readings made by the model at ``T₀``: (T2) inverted.

    ``raw_reference`` are ``(acc, gyro)`` that the calibration at ``T₀`` maps to ``specific_force``
    and the true rates; used to simulate a sensor whose parameters follow the thermal model.
    """
    model, base = calibration.thermal, calibration.with_(thermal=None)
    temp = np.asarray(temperature, dtype=float)
    out = []
    for u0, tri, prefix in ((raw_reference[0], base.accelerometer, "accelerometer"),
                            (raw_reference[1], base.gyroscope, "gyroscope")):
        if tri is None or u0 is None:  # no gyroscope calibrated: its readings as they are
            out.append(u0)
            continue
        bias, tk = _per_sample(tri, model, prefix, temp)
        ga = specific_force @ tri.g_sensitivity.T if prefix == "gyroscope" and np.any(tri.g_sensitivity) else 0.0
        x = u0 - ga - tri.bias
        if tk is not None:
            tk0 = tri.misalignment * tri.scale[None, :]
            x = np.linalg.solve(tk, (x @ tk0.T)[..., None])[..., 0]  # eq. (T2) inverted
        out.append(x + bias + ga)
    return out[0], out[1]


def temperature_of(recording: Recording) -> np.ndarray:
    temp = recording.temperature
    if temp is None:
        raise ValueError("this calibration follows temperature, but the recording has no temperature column: "
                         "record the sensor's temperature, or use the calibration at one temperature "
                         "(imucalib thermal … --at C)")
    if not np.all(np.isfinite(temp)):
        raise ValueError(f"the recording's temperature column has {int(np.count_nonzero(~np.isfinite(temp)))} "
                         "missing values; a thermal calibration needs the temperature of every sample")
    return temp


# ------------------------------------------------------------------ combine calibrations
