"""The result of a calibration: both triad models, lever arm, fit quality; JSON I/O.

The file format is versioned JSON (``"format": "imucalib.calibration"``,
``"format_version": 1``); ``docs/architecture.rst`` describes every entry.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from .io.atomic import atomic_write
from .io.jsontext import SmallFileError, dumps, jsonable, read_json
from .models import AXES, MISALIGNMENT_SHAPES, MagnetometerModel, TriadModel
from .recording import ACC_UNITS, GYRO_UNITS, MAG_UNITS, STANDARD_GRAVITY, ImucalibWarning, Recording
from .reportfields import undeclared
from .thermal import ThermalModel, compensate, evaluate

__all__ = ["BIAS_DRIFT", "DEVICE_MAX_CHARS", "DRIFT_NOTICE_DEG_S", "FULL_SCALE", "Calibration", "CalibrationFileError",
           "FORMAT", "FORMAT_VERSION", "GRAVITY_LIMITS", "SESSION_CHECK_SAMPLES", "check_device", "check_document",
           "check_magnitudes", "with_bias_session"]

#: the longest device name a calibration holds [characters]
DEVICE_MAX_CHARS = 256

FORMAT = "imucalib.calibration"
FORMAT_VERSION = 1
_BLOCK = 1 << 16  # samples calibrated at a time by apply
#: what :meth:`Calibration.apply` takes for ``bias_drift``
BIAS_DRIFT = ("auto", "on", "off")
#: how many of the calibrated recording's samples recognise it (:meth:`Calibration.is_own_session`)
SESSION_CHECK_SAMPLES = 16
#: a drift not applied is said when it would move the calibrated rate at rest by more than this [°/s]
DRIFT_NOTICE_DEG_S = 0.02
#: the largest calibration file read (one is a few kilobytes; its fit figures a few hundred at most)
MAX_FILE_BYTES = 16 << 20


def _default_acc() -> TriadModel:
    return TriadModel(shape="upper")


def _default_gyro() -> TriadModel:
    return TriadModel(shape="full")


@dataclass(frozen=True)
class Calibration:
    """Calibrated models of an IMU's accelerometer and gyroscope.

    Apply it to raw data with :meth:`apply` (a :class:`Recording`) or
    :meth:`accelerometer_si` / :meth:`gyroscope_si` (arrays); save it with
    :meth:`save` and read it back with :meth:`load`.

    Attributes
    ----------
    accelerometer, gyroscope : TriadModel
        ``a = T_a f_a(u_a − b_a)``, ``ω = T_g f_g(u_g − b_g − G a)``. ``gyroscope`` is None for a
        calibration made from an accelerometer-only recording: it has no gyroscope section (the file
        writes ``"gyroscope": null`` and ``units`` has no gyroscope entry).
    lever_arm : (3,) ndarray or None
        Accelerometer origin → rotation centre [m] (Zhang 2021, eqs. 16–18).
    gravity : float
        Local gravity [m/s²] used for the calibration.
    method, model : str
        Which method and model variant produced it.
    units : dict
        Raw and calibrated units of each sensor.
    fit : dict
        Fit-quality figures, the verdict and its reasons (every entry in ``docs/architecture.rst``).
    magnetometer : MagnetometerModel or None
        Hard and soft iron and the map into the accelerometer's frame, when the IMU has a
        magnetometer and it was calibrated (``units["magnetometer"]`` then gives its units).
    """

    accelerometer: TriadModel = field(default_factory=_default_acc)
    gyroscope: TriadModel | None = field(default_factory=_default_gyro)
    lever_arm: np.ndarray | None = None
    gravity: float = STANDARD_GRAVITY
    method: str = "none"
    model: str = "linear"
    units: dict = field(
        default_factory=lambda: {
            "accelerometer": {"raw": "counts", "calibrated": "m/s^2"},
            "gyroscope": {"raw": "counts", "calibrated": "rad/s"},
        }
    )
    device: str | None = None
    created: str | None = None
    fit: dict = field(default_factory=dict)
    magnetometer: MagnetometerModel | None = None
    thermal: ThermalModel | None = None

    def __post_init__(self) -> None:
        if self.lever_arm is not None:
            r = np.array(self.lever_arm, dtype=np.float64).reshape(-1)
            if r.shape != (3,):
                raise ValueError(f"lever_arm must have 3 entries; got {np.shape(self.lever_arm)}")
            object.__setattr__(self, "lever_arm", r)
        if not (np.isfinite(self.gravity) and self.gravity > 0):
            raise ValueError(f"gravity must be a positive number of m/s²; got {self.gravity!r}")

    def with_(self, **changes) -> Calibration:
        """A copy with some fields replaced."""
        return replace(self, **changes)

    # ------------------------------------------------------------------ apply
    def accelerometer_si(self, raw_acc: np.ndarray) -> np.ndarray:
        """Calibrated specific force (N, 3) [m/s²] from raw accelerometer readings."""
        return self.accelerometer.forward(raw_acc)

    def gyroscope_si(self, raw_gyro: np.ndarray, raw_acc: np.ndarray | None = None) -> np.ndarray:
        """Calibrated angular rate (N, 3) [rad/s]; ``raw_acc`` is needed when G ≠ 0."""
        if self.gyroscope is None:
            raise ValueError("this calibration has no gyroscope (it was made from an accelerometer-only recording)")
        a = None
        if np.any(self.gyroscope.g_sensitivity):
            if raw_acc is None:
                raise ValueError("this calibration has a g-sensitivity: pass raw_acc as well")
            a = self.accelerometer_si(raw_acc)
        return self.gyroscope.forward(raw_gyro, a)

    def apply(self, recording, *, bias_drift: str = "auto", **read_options):
        """The recording with calibrated accelerometer [m/s²] and gyroscope [rad/s].

        The recording must be in the raw units this calibration was made for.
        A calibration without a gyroscope gives a recording without one.

        A pandas DataFrame is read as :func:`imucalib.io.read` reads it (its
        column names as a CSV header; ``read_options`` are that function's:
        ``columns``, ``acc_unit``, ``gyro_unit``, ``rate``, ``time_unit``) and
        a copy of it is returned with the calibrated columns added:
        ``acc_x_cal [m/s^2]`` … ``gyro_z_cal [rad/s]``, as ``imucalib apply``
        adds them to a CSV file.

        Parameters
        ----------
        recording : Recording or pandas.DataFrame
            Raw readings.
        bias_drift : {"auto", "on", "off"}
            Whether the gyroscope bias drifts as the calibration's fit found it,
            ``b(t) = b + d (t − t_ref)`` (Zhang 2021, eq. 11 with the linear drift
            of :func:`imucalib.fit.gyroscope.static_gyro`; ``d`` is
            ``fit["gyroscope_bias_drift_per_s"]``, ``t_ref``
            ``fit["gyroscope_bias_time_s"]``), or is the constant ``b``.
            ``"auto"`` (the default) applies the drift to the recording the
            calibration was made from, or a part of it (:meth:`is_own_session`),
            and keeps the constant bias on any other: a drift is not
            extrapolated to another recording, whose bias has moved by an
            amount the calibration does not know (a warning says so when the
            drift found would move the rest reading by more than
            :data:`DRIFT_NOTICE_DEG_S` over that recording). ``"on"`` applies it
            to any recording, in that recording's time base; ``"off"`` never.
            A calibration without a drift is the same under the three.
            ``metadata["gyroscope_bias_drift"]`` of the result says which was
            done: ``"applied"`` or ``"constant"``.
        """
        if not isinstance(recording, Recording):
            return self._apply_frame(recording, read_options, bias_drift)
        if read_options:
            raise TypeError(f"apply takes reading options ({', '.join(read_options)}) only with a DataFrame")
        drifting = self._drift_applies(recording, bias_drift)
        self.check_units(recording)
        if self.thermal is not None:  # compensated to the reference temperature, then as below (thermal.py, T2)
            base, compensated = compensate(self, recording)
            return base.apply(compensated, bias_drift="on" if drifting else "off")
        n = len(recording)
        has_gyro = recording.gyro is not None and self.gyroscope is not None
        offset = self.bias_offset(recording.t) if drifting and has_gyro else None
        acc, gyro = np.empty((n, 3)), (np.empty((n, 3)) if has_gyro else None)
        for a in range(0, n, _BLOCK):  # the models' temporaries stay the size of a block
            b = min(a + _BLOCK, n)
            acc[a:b] = self.accelerometer_si(recording.acc[a:b])
            if has_gyro:
                raw = recording.gyro[a:b] if offset is None else recording.gyro[a:b] - offset[a:b]
                gyro[a:b] = self.gyroscope.forward(raw, acc[a:b])
        mag, mag_unit = recording.mag, recording.mag_unit
        if mag is not None and self.magnetometer is not None:
            mag, mag_unit = self.magnetometer.forward(mag), self.magnetometer.unit
        return Recording(
            t=recording.t,
            acc=acc,
            gyro=gyro,
            acc_unit="m/s^2",
            gyro_unit="rad/s",
            temperature=recording.temperature,
            extra=dict(recording.extra),
            metadata={**recording.metadata, "calibration": self.method,
                      "gyroscope_bias_drift": "applied" if offset is not None else "constant"},
            mag=mag,
            mag_unit=mag_unit,
        )

    # ------------------------------------------------------------ bias drift
    @property
    def bias_drift(self) -> np.ndarray | None:
        """The gyroscope bias's linear drift ``d`` [raw units per s] the fit found, or None (constant bias)."""
        d = (self.fit or {}).get("gyroscope_bias_drift_per_s")
        if d is None or self.gyroscope is None:
            return None
        return np.asarray(d, dtype=np.float64).reshape(3)

    def bias_offset(self, t: np.ndarray) -> np.ndarray:
        """``d (t − t_ref)`` (N, 3) [raw]: what the drifting bias adds to the stored one at the times ``t`` [s].

        ``b(t) = b + d (t − t_ref)``: the static poses' gyroscope means with a
        bias that drifts linearly (Zhang 2021, eq. 11; the drift as
        :func:`imucalib.fit.gyroscope.static_gyro` fits it), ``t_ref`` the time
        at which the stored bias holds (``fit["gyroscope_bias_time_s"]``, the
        mean of the poses' times in the calibrated recording's time base).
        Zeros for a calibration without a drift.
        """
        t = np.asarray(t, dtype=np.float64).reshape(-1)
        d = self.bias_drift
        if d is None:
            return np.zeros((t.size, 3))
        t_ref = float(self.fit.get("gyroscope_bias_time_s", 0.0))
        return (t - t_ref)[:, None] * d[None, :]

    def drift_rate(self) -> np.ndarray | None:
        """The bias drift as the calibrated rate at rest moves with it, per axis [rad/s per s]; None without.

        A bias off by ``δ`` reads ``T diag(k1) δ`` at rest (the linear term of
        the model about the bias, ``ω = T f(u − b − G a)``).
        """
        d = self.bias_drift
        if d is None:
            return None
        g = self.gyroscope
        return (g.misalignment * g.scale[None, :]) @ d

    def is_own_session(self, recording: Recording) -> bool:
        """Whether ``recording`` is the recording this calibration was made from, or a part of it.

        Both must hold:

        * its first and last times lie within the calibrated recording's
          (``fit["gyroscope_bias_session_s"]``, in that recording's time base),
          give or take half a sample period;
        * of the calibrated recording's check samples
          (``fit["gyroscope_bias_session_check"]``: the time and raw gyroscope
          reading of :data:`SESSION_CHECK_SAMPLES` samples spread evenly over
          it), at least one falls within its time span, and every one that
          does is found in it at the same time with the same reading.

        Another recording with the same time base (a logger's clock that
        starts at zero each time) fails the second. A part shorter than the
        check samples' spacing (the calibrated span over
        ``SESSION_CHECK_SAMPLES − 1``) holds none of them and is not
        recognised: ``apply(…, bias_drift="on")`` applies the drift to it.
        False for a calibration without these fields (made before they
        existed, or without a drift) and for a recording without a gyroscope.
        """
        fit = self.fit or {}
        span, check = fit.get("gyroscope_bias_session_s"), fit.get("gyroscope_bias_session_check")
        if span is None or check is None or recording.gyro is None or len(recording) == 0:
            return False
        t = np.asarray(recording.t, dtype=np.float64)
        tol = 0.5 / recording.rate if len(recording) > 1 and recording.rate > 0 else 0.0
        if t[0] < span[0] - tol or t[-1] > span[1] + tol:
            return False
        check = np.asarray(check, dtype=np.float64).reshape(-1, 4)
        inside = check[(check[:, 0] >= t[0]) & (check[:, 0] <= t[-1])]
        if inside.size == 0:
            return False
        k = np.clip(np.searchsorted(t, inside[:, 0]), 0, len(t) - 1)
        k = np.where((k > 0) & (np.abs(t[k - 1] - inside[:, 0]) < np.abs(t[k] - inside[:, 0])), k - 1, k)
        same_time = np.isclose(t[k], inside[:, 0], rtol=1e-12, atol=1e-9)
        same_reading = np.all(np.isclose(recording.gyro[k], inside[:, 1:], rtol=1e-9, atol=0.0), axis=1)
        return bool(np.all(same_time & same_reading))

    def _drift_applies(self, recording: Recording, bias_drift) -> bool:
        """Whether :meth:`apply` corrects ``recording`` with the drifting bias (see its ``bias_drift``)."""
        if bias_drift not in BIAS_DRIFT:
            raise ValueError(f"bias_drift must be one of {', '.join(map(repr, BIAS_DRIFT))}; got {bias_drift!r}")
        rate = self.drift_rate()
        if bias_drift == "off" or rate is None or recording.gyro is None:
            return False
        if bias_drift == "on" or self.is_own_session(recording):
            return True
        span = float(recording.t[-1] - recording.t[0]) if len(recording) > 1 else 0.0
        moved = math.degrees(float(np.max(np.abs(rate)))) * span
        if moved > DRIFT_NOTICE_DEG_S:
            warnings.warn(f"this is not the recording the calibration was made from: its gyroscope bias is taken as "
                          f"the constant one stored, and the drift found in that session "
                          f"({60 * math.degrees(float(np.max(np.abs(rate)))):.3g} °/s per minute) is not "
                          f"extrapolated; a bias drifting as much would move the rest reading by {moved:.2g} °/s "
                          f"over this recording's {span:.0f} s. Take this recording's bias from a rest of its own, "
                          "or apply with bias_drift='on' (--bias-drift on) if it is part of the calibrated session",
                          ImucalibWarning, stacklevel=3)
        return False

    def _apply_frame(self, frame, read_options: dict, bias_drift: str = "auto"):
        from .io.readers import is_frame, read  # imucalib.io.readers costs 34 ms at start-up
        from .io.writers import calibrated_columns  # imucalib.io.writers costs 38 ms at start-up

        if not is_frame(frame):
            raise TypeError(f"apply takes a Recording or a pandas DataFrame; got {type(frame).__name__}")
        rec = read(frame, **read_options)
        out = self.apply(rec, bias_drift=bias_drift)
        mag = out.mag if self.magnetometer is not None and rec.mag is not None else None
        added = calibrated_columns(out.acc, out.gyro, mag, out.mag_unit)
        clash = [name for name in added if name in frame.columns]
        if clash:
            raise ValueError(f"the DataFrame already has the column(s) {', '.join(clash)}: apply a calibration to "
                             "raw data only once")
        return frame.assign(**added)

    def check_units(self, recording: Recording) -> None:
        """Raise ValueError unless the recording is in the raw units this calibration maps."""
        pairs = [("accelerometer", recording.acc_unit)]
        if recording.gyro is not None and self.gyroscope is not None:
            pairs.append(("gyroscope", recording.gyro_unit))
        if self.magnetometer is not None and recording.mag is not None and "magnetometer" in self.units:
            pairs.append(("magnetometer", recording.mag_unit))
        for sensor, unit in pairs:
            expected = self.units[sensor]["raw"]
            if unit != expected:
                raise ValueError(
                    f"this calibration maps {sensor} readings in {expected!r}, but the "
                    f"recording's {sensor} is in {unit!r}: read the data with the units "
                    "used for calibration"
                )

    # ------------------------------------------------------------- parameters
    def parameters(self) -> dict[str, float]:
        """Every named parameter (``accelerometer.scale.x`` …) → value."""
        out = self.accelerometer.parameters("accelerometer")
        out = {k: v for k, v in out.items() if ".g_sensitivity." not in k}
        if self.gyroscope is not None:
            out.update(self.gyroscope.parameters("gyroscope"))
        if self.lever_arm is not None:
            for i, axis in enumerate(AXES):
                out[f"lever_arm.{axis}"] = float(self.lever_arm[i])
        if self.magnetometer is not None:
            out.update(self.magnetometer.parameters("magnetometer"))
        return out

    def with_parameters(self, values: dict[str, float]) -> Calibration:
        """A copy with the named parameters set (names as in :meth:`parameters`)."""
        known = ("accelerometer.", "gyroscope.", "lever_arm.")
        if any(name.startswith("magnetometer.") for name in values):
            raise ValueError("the magnetometer's parameters are set through Calibration.with_(magnetometer=…)")
        for name in values:
            if not name.startswith(known):
                raise ValueError(f"unknown parameter {name!r}")
        lever = None if self.lever_arm is None else self.lever_arm.copy()
        for i, axis in enumerate(AXES):
            key = f"lever_arm.{axis}"
            if key in values:
                if lever is None:
                    lever = np.zeros(3)
                lever[i] = values[key]
        return replace(
            self,
            accelerometer=self.accelerometer.with_parameters("accelerometer", values),
            gyroscope=None if self.gyroscope is None else self.gyroscope.with_parameters("gyroscope", values),
            lever_arm=lever,
        )

    # ------------------------------------------------------------------- JSON
    def to_dict(self) -> dict[str, Any]:
        """The JSON-ready dictionary of the calibration file format."""
        out = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "method": self.method,
            "model": self.model,
            "created": self.created
            or datetime.now(UTC).replace(microsecond=0).isoformat().replace("+00:00", "Z"),
            "device": self.device,
            "units": self.units,
            "gravity": self.gravity,
            "accelerometer": self.accelerometer.to_dict(gyroscope=False),
            "gyroscope": None if self.gyroscope is None else self.gyroscope.to_dict(gyroscope=True),
            "lever_arm": None if self.lever_arm is None else self.lever_arm.tolist(),
            "fit": jsonable(self.fit),
        }
        if self.magnetometer is not None:  # only when there is one: files without it are as before
            out["magnetometer"] = self.magnetometer.to_dict()
        if self.thermal is not None:
            out["thermal"] = self.thermal.to_dict()
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Calibration:
        """Inverse of :meth:`to_dict`; checks the format, its version and every entry's type and shape.

        Raises :class:`CalibrationFileError` naming the entry that is wrong. A ``fit`` field that is not
        declared (:data:`imucalib.reportfields.FIELDS`: a file from another version) is kept as read, with an
        :class:`~imucalib.recording.ImucalibWarning` naming it.
        """
        check_document(d)
        unknown = undeclared(d.get("fit") or {})
        if unknown:
            warnings.warn(f"the calibration's fit holds field(s) this version does not know: {', '.join(unknown)}; "
                          "kept as read", ImucalibWarning, stacklevel=2)
        units = d.get("units")
        calibration = cls(
            accelerometer=TriadModel.from_dict(d["accelerometer"], default_shape="upper"),
            gyroscope=None if d["gyroscope"] is None else TriadModel.from_dict(d["gyroscope"], default_shape="full"),
            lever_arm=d.get("lever_arm"),
            gravity=float(d.get("gravity", STANDARD_GRAVITY)),
            method=d.get("method", "unknown"),
            model=d.get("model", "linear"),
            units={s: dict(units[s]) for s in ("accelerometer", "gyroscope", "magnetometer") if s in units}
            if units else cls().units,
            device=d.get("device"),
            created=d.get("created"),
            fit=d.get("fit") or {},
            magnetometer=None if d.get("magnetometer") is None else MagnetometerModel.from_dict(d["magnetometer"]),
            thermal=None if d.get("thermal") is None else ThermalModel.from_dict(d["thermal"]),
        )
        check_magnitudes(calibration)
        return calibration

    def to_json(self) -> str:
        """The calibration file's text: strict JSON (a number that is not available is ``null``)."""
        return dumps(self.to_dict(), indent=2)

    def save(self, path: str | Path) -> None:
        """Write the calibration file (JSON), through a temporary file moved into place."""
        with atomic_write(path, "w", encoding="utf-8") as fh:
            fh.write(self.to_json() + "\n")

    @classmethod
    def load(cls, path: str | Path) -> Calibration:
        """Read a calibration file written by :meth:`save`.

        Raises :class:`CalibrationFileError` (a ValueError) naming the file and
        the entry when it is missing, not JSON, or not a calibration.
        """
        path = Path(path)
        try:
            data = read_json(path, MAX_FILE_BYTES, "calibration file", "one is a few kilobytes of JSON, as "
                             "'imucalib calibrate -o FILE.json' writes it")
        except SmallFileError as exc:
            raise CalibrationFileError(f"{path}: {exc}") from None
        try:
            return cls.from_dict(data)
        except ValueError as exc:
            raise CalibrationFileError(f"{path}: {exc}") from None


class CalibrationFileError(ValueError):
    """A calibration file (or dictionary) that cannot be used; the message names the entry."""


def _kind(value) -> str:
    """A JSON value's kind in words."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    return {dict: "an object", list: "a list", str: "a string", int: "a number", float: "a number"}.get(
        type(value), type(value).__name__)


def _is_number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _finite(v) -> bool:
    try:
        return math.isfinite(float(v))
    except OverflowError:  # an integer beyond any float
        return False


def _numbers(value, shape: tuple[int, ...], where: str) -> None:
    """``value`` is a list (of lists) of finite numbers of ``shape``; else an error naming ``where``."""
    words = "3 numbers" if shape == (3,) else "3 rows of 3 numbers"
    rows = value if shape == (3,) else value if isinstance(value, list) else None
    ok = isinstance(value, list) and len(value) == shape[0]
    if ok and len(shape) == 2:
        ok = all(isinstance(r, list) and len(r) == shape[1] for r in rows)
        cells = [c for r in rows for c in r] if ok else []
    else:
        cells = value if ok else []
    if not ok or not all(_is_number(c) for c in cells):
        raise CalibrationFileError(f"{where}: expected {words}; got {json.dumps(value)[:80]}")
    if not all(_finite(c) for c in cells):
        raise CalibrationFileError(f"{where}: every entry must be a finite number; got {json.dumps(value)[:80]}")


def _check_triad(d, name: str, default_shape: str) -> None:
    if not isinstance(d, dict):
        raise CalibrationFileError(f"'{name}': expected an object of the model's entries; got {_kind(d)}")
    for key in ("misalignment", "scale", "bias"):
        if key not in d:
            raise CalibrationFileError(f"'{name}' lacks the entry '{key}'")
    shape = d.get("misalignment_shape", default_shape)
    if shape not in MISALIGNMENT_SHAPES:
        raise CalibrationFileError(f"'{name}.misalignment_shape': expected one of "
                                   f"{', '.join(MISALIGNMENT_SHAPES)}; got {json.dumps(shape)}")
    for key, value in d.items():
        if key in ("misalignment", "g_sensitivity"):
            _numbers(value, (3, 3), f"'{name}.{key}'")
        elif key in ("scale", "scale_quadratic", "scale_cubic", "bias", "output_bias"):
            _numbers(value, (3,), f"'{name}.{key}'")
    t = d["misalignment"]
    if any(t[i][i] != 1 for i in range(3)):
        raise CalibrationFileError(f"'{name}.misalignment': the diagonal must be 1, 1, 1; got "
                                   f"{', '.join(format(t[i][i], 'g') for i in range(3))}")
    free = set(MISALIGNMENT_SHAPES[shape])
    stray = [AXES[i] + AXES[j] for i in range(3) for j in range(3) if i != j and (i, j) not in free and t[i][j]]
    if stray:
        raise CalibrationFileError(f"'{name}.misalignment': misalignment_shape {shape!r} has no entry "
                                   f"{', '.join(stray)} (they must be 0)")
    if any(k == 0 for k in d["scale"]):
        raise CalibrationFileError(f"'{name}.scale': every scale factor must be non-zero")


#: what an identifier (method, model, created, thermal.source) may hold: it reaches C comments, YAML
#: comments and reports, so no blank, quote, ``*``, ``/``, ``#``, ``<``, ``&`` or line break
_IDENTIFIER = re.compile(r"[A-Za-z0-9_.:+\->]{1,64}")
#: what a unit name may hold (``m/s^2``, ``rad/s``, ``uT``)
_UNIT = re.compile(r"[A-Za-z0-9_.^/]{1,16}")
_VERDICTS = ("accepted", "suspect", "rejected")


def _identifier(value, where: str, pattern: re.Pattern = _IDENTIFIER) -> None:
    if not isinstance(value, str):
        raise CalibrationFileError(f"{where}: expected a string; got {_kind(value)}")
    if not pattern.fullmatch(value):
        allowed = "letters, digits and _ . ^ /" if pattern is _UNIT else "letters, digits and _ . : + - >"
        raise CalibrationFileError(f"{where}: {json.dumps(value)[:80]} is not a name imucalib writes (1 to "
                                   f"{pattern.pattern.rsplit(',', 1)[1][:-1]} of {allowed})")


def _printable(value: str, where: str, longest: int) -> None:
    if len(value) > longest or not value.isprintable():
        raise CalibrationFileError(f"{where}: {json.dumps(value)[:80]} is not one line of printable text of at "
                                   f"most {longest} characters")


def check_device(name: str) -> None:
    """Refuse (:class:`CalibrationFileError`) a device name a calibration cannot hold.

    One line of printable text (no control characters, tabs or line breaks)
    of at most :data:`DEVICE_MAX_CHARS` characters, as :func:`check_document`
    requires of a calibration file's ``device``.
    """
    _printable(name, "'device'", DEVICE_MAX_CHARS)


def check_document(d) -> None:
    """Check a calibration document (the parsed JSON of the file) entry by entry.

    Names (method, model, created, units, thermal.source) must be 1 to 64 letters, digits and
    ``_ . : + - >`` (16 of ``_ . ^ /`` for units), so that no comment, YAML scalar or HTML
    element can be left (the exports escape them again, :mod:`imucalib.export.text`);
    the device and the verdict's reasons and notes one line of printable text.

    Parameters
    ----------
    d : object
        The parsed JSON of a calibration file (:meth:`Calibration.to_dict` gives one).

    Returns
    -------
    None
        The document is one :meth:`Calibration.from_dict` can take.

    Raises
    ------
    CalibrationFileError
        Naming the first entry that is missing, of the wrong kind or shape, or not a finite number, or the
        first text outside what it may hold (a :class:`ValueError`).

    Examples
    --------
    >>> from imucalib.calibration import check_document
    >>> from imucalib.scenarios import session
    >>> check_document(session("handheld", rng=1).truth.to_dict())
    >>> check_document({"format": "something else"})
    Traceback (most recent call last):
        ...
    imucalib.calibration.CalibrationFileError: not an imucalib calibration: 'format' is "something else", not ...
    """
    if not isinstance(d, dict):
        raise CalibrationFileError(f"expected a JSON object (an imucalib calibration); got {_kind(d)}")
    if d.get("format") != FORMAT:
        raise CalibrationFileError(f"not an imucalib calibration: 'format' is {json.dumps(d.get('format'))}, "
                                   f"not \"{FORMAT}\"")
    version = d.get("format_version")
    if version != FORMAT_VERSION:
        raise CalibrationFileError(f"calibration format_version {json.dumps(version)} is not supported "
                                   f"(this imucalib reads version {FORMAT_VERSION})")
    missing = [k for k in ("accelerometer", "gyroscope") if k not in d]
    if missing:
        raise CalibrationFileError(f"calibration lacks the {' and '.join(missing)} section(s)")
    _check_triad(d["accelerometer"], "accelerometer", "upper")
    if d["gyroscope"] is not None:  # null: an accelerometer-only calibration
        _check_triad(d["gyroscope"], "gyroscope", "full")
    units = d.get("units")
    if units is not None:
        if not isinstance(units, dict):
            raise CalibrationFileError(f"'units': expected an object with 'accelerometer' and 'gyroscope'; "
                                       f"got {_kind(units)}")
        for sensor, allowed in (("accelerometer", ACC_UNITS), ("gyroscope", GYRO_UNITS)):
            entry = units.get(sensor)
            if sensor == "gyroscope" and d["gyroscope"] is None and entry is None:
                continue
            if not isinstance(entry, dict):
                raise CalibrationFileError(f"'units' has no '{sensor}' entry (an object with 'raw', one of "
                                           f"{', '.join(allowed)})" if entry is None else
                                           f"'units.{sensor}': expected an object with 'raw'; got {_kind(entry)}")
            if entry.get("raw") not in allowed:
                raise CalibrationFileError(f"'units.{sensor}.raw': expected one of {', '.join(allowed)}; got "
                                           f"{json.dumps(entry.get('raw'))}")
    gravity = d.get("gravity", STANDARD_GRAVITY)
    if not (_is_number(gravity) and _finite(gravity) and gravity > 0):
        raise CalibrationFileError(f"'gravity': expected a positive number of m/s^2; got {json.dumps(gravity)[:40]}")
    if d.get("lever_arm") is not None:
        _numbers(d["lever_arm"], (3,), "'lever_arm'")
    for key in ("method", "model"):
        if key in d and not isinstance(d[key], str):
            raise CalibrationFileError(f"'{key}': expected a string; got {_kind(d[key])}")
        if key in d:
            _identifier(d[key], f"'{key}'")
    for key in ("device", "created"):
        if d.get(key) is not None and not isinstance(d[key], str):
            raise CalibrationFileError(f"'{key}': expected a string or null; got {_kind(d[key])}")
    if d.get("created") is not None:
        _identifier(d["created"], "'created'")
    if d.get("device") is not None:
        check_device(d["device"])
    for sensor, entry in (units or {}).items() if isinstance(units, dict) else ():
        if isinstance(entry, dict):
            for key, value in entry.items():
                if not isinstance(value, str):
                    raise CalibrationFileError(f"'units.{sensor}.{key}': expected a string; got {_kind(value)}")
                _identifier(value, f"'units.{sensor}.{key}'", _UNIT)
    mag = d.get("magnetometer")
    if mag is not None:
        if not isinstance(mag, dict):
            raise CalibrationFileError(f"'magnetometer': expected an object (bias, soft_iron, alignment); got "
                                       f"{_kind(mag)}")
        for key, shape in (("bias", (3,)), ("soft_iron", (3, 3)), ("alignment", (3, 3))):
            _numbers(mag.get(key), shape, f"'magnetometer.{key}'")
        if mag.get("unit") is not None and mag["unit"] not in ("uT", "normalised"):
            raise CalibrationFileError(f"'magnetometer.unit': expected uT or normalised; got "
                                       f"{json.dumps(mag['unit'])[:40]}")
        raw = ((units or {}).get("magnetometer") or {}).get("raw")
        if raw not in MAG_UNITS:
            raise CalibrationFileError(f"'units.magnetometer.raw': expected one of {', '.join(MAG_UNITS)}; got "
                                       f"{json.dumps(raw)}")
    thermal = d.get("thermal")
    if thermal is not None and not isinstance(thermal, dict):
        raise CalibrationFileError(f"'thermal': expected an object (reference_c, range_c, parameters); got "
                                   f"{_kind(d['thermal'])}")
    if isinstance(thermal, dict):
        if thermal.get("source") is not None:
            _identifier(thermal["source"], "'thermal.source'")
        ref = thermal.get("reference_c", 25.0)
        span = thermal.get("range_c", [ref, ref])
        temps = [ref, *span] if isinstance(span, list) else [ref, span]
        if not all(_is_number(t) and _finite(t) and TEMPERATURE_LIMITS[0] <= t <= TEMPERATURE_LIMITS[1]
                   for t in temps):
            raise CalibrationFileError(f"'thermal': reference_c and range_c must be temperatures in "
                                       f"{TEMPERATURE_LIMITS[0]:g}..{TEMPERATURE_LIMITS[1]:g} degC; got "
                                       f"{json.dumps([ref, span])[:80]}")
    fit = d.get("fit")
    if fit is not None and not isinstance(fit, dict):
        raise CalibrationFileError(f"'fit': expected an object (the fit figures); got {_kind(fit)}")
    if isinstance(fit, dict):
        if fit.get("verdict") is not None and fit["verdict"] not in _VERDICTS:
            raise CalibrationFileError(f"'fit.verdict': expected one of {', '.join(_VERDICTS)}; got "
                                       f"{json.dumps(fit['verdict'])[:40]}")
        for key in ("verdict_reasons", "verdict_notes"):
            texts = fit.get(key)
            if texts is not None and not (isinstance(texts, list) and all(isinstance(r, str) for r in texts)):
                raise CalibrationFileError(f"'fit.{key}': expected a list of strings")
            for text in texts or []:
                _printable(text, f"'fit.{key}'", 2000)


#: the largest reading, in calibrated units, any MEMS sensor gives: 1000 g [m/s²] and 1000 rad/s (57 000 °/s)
FULL_SCALE = {"accelerometer": 1e4, "gyroscope": 1e3}
#: the widest common ranges, 16 g and 2000 °/s: where the nonlinear scale terms are evaluated
_COMMON_RANGE = {"accelerometer": 16 * STANDARD_GRAVITY, "gyroscope": math.radians(2000)}
#: gravity [m/s²] a calibration file may declare (the verdict judges whether it is the Earth's)
GRAVITY_LIMITS = (0.1, 100.0)
#: temperatures [°C] a thermal model may name
TEMPERATURE_LIMITS = (-273.15, 1000.0)
#: the finest raw count: full scale over 2⁴⁸ (no converter resolves more bits)
_FINEST_COUNT = 2.0**-48
#: the largest physical raw unit's scale factor against its nominal one, and the smallest
_NOMINAL_SPAN = (1e-2, 1e2)
#: the largest misalignment term (84°), g-sensitivity [rad/s per m/s²] and lever arm [m]
_MAX_MISALIGNMENT, _MAX_G_SENSITIVITY, _MAX_LEVER_ARM = 10.0, 1.0, 10.0
#: the largest magnetometer value in calibrated units (µT, or the normalised field)
_MAG_FULL_SCALE = 1e6


def _nominal(unit: str) -> float | None:
    return {"m/s^2": 1.0, "g": STANDARD_GRAVITY, "rad/s": 1.0, "deg/s": math.pi / 180}.get(unit)


def check_magnitudes(calibration: Calibration) -> None:
    """Refuse a calibration whose parameters are absurd for their units (a file's numbers, not a fit's).

    Each bound is orders of magnitude beyond any MEMS sensor, in the
    calibrated units (:data:`FULL_SCALE`, the model ``a = T (k1 x + k2 x² + k3 x³
    + d)``, ``x = u − b``, the architecture page of the documentation): one raw count between full scale/2⁴⁸
    and full scale (a physical unit's k1 within 10⁻² to 10² of its nominal
    factor); the bias ``k1 b`` and output bias ``d`` within full scale; at the
    raw reading ``k1`` maps to 16 g or 2000 °/s, ``k2 x²`` and ``k3 x³`` within
    full scale; misalignment terms within 10 (84°); the g-sensitivity ``k1 G`` within
    1 rad/s per m/s²; the lever arm within 10 m; gravity within
    :data:`GRAVITY_LIMITS`. A thermal model is checked at its range ± 100 °C.
    Within them no reading of a raw unit's range overflows; whether the values
    are *good* is the verdict's question.

    Raises
    ------
    CalibrationFileError
        Naming the first parameter out of bounds.
    """
    lo, hi = GRAVITY_LIMITS
    if not lo <= calibration.gravity <= hi:
        raise CalibrationFileError(f"'gravity': {calibration.gravity:g} m/s^2 is not a gravity (expected "
                                   f"{lo:g}-{hi:g} m/s^2; the Earth's is 9.78-9.83)")
    cals = [("", calibration)]
    if calibration.thermal is not None:
        t0, t1 = calibration.thermal.range_c
        with np.errstate(all="ignore"):
            cals += [(f" at {t:g} degC (its thermal model)", evaluate(calibration, t)) for t in (t0 - 100, t1 + 100)]
    for at, cal in cals:
        for sensor in ("accelerometer", "gyroscope"):
            if getattr(cal, sensor) is not None:  # no gyroscope: an accelerometer-only calibration
                _check_triad_magnitudes(getattr(cal, sensor), sensor, cal.units[sensor]["raw"], at)
    if calibration.lever_arm is not None and np.max(np.abs(calibration.lever_arm)) > _MAX_LEVER_ARM:
        raise CalibrationFileError(f"'lever_arm': beyond {_MAX_LEVER_ARM:g} m; got "
                                   f"{np.array2string(calibration.lever_arm, precision=3)}")
    mag = calibration.magnetometer
    if mag is not None:
        with np.errstate(all="ignore"):
            m = np.max(np.abs(mag.matrix))
            worst = m * max(float(np.max(np.abs(mag.bias))), 1.0)
        if not (np.isfinite(worst) and worst <= _MAG_FULL_SCALE):
            raise CalibrationFileError(f"'magnetometer': its matrix and bias reach {worst:.3g} {mag.unit} (beyond "
                                       f"{_MAG_FULL_SCALE:g}); not a magnetometer calibration")


def _check_triad_magnitudes(m: TriadModel, sensor: str, unit: str, at: str) -> None:
    full = FULL_SCALE[sensor]
    out = "m/s^2" if sensor == "accelerometer" else "rad/s"

    article = "an" if sensor == "accelerometer" else "a"

    def refuse(key: str, what: str) -> None:
        raise CalibrationFileError(f"'{sensor}.{key}'{at}: {what}; not a calibration of {article} {sensor} in {unit}")

    with np.errstate(all="ignore"):
        k1 = np.abs(m.scale)
        nominal = _nominal(unit)
        if nominal is None:
            if not np.all((k1 >= full * _FINEST_COUNT) & (k1 <= full)):
                refuse("scale", f"one count is {_worst(k1)} {out}, outside {full * _FINEST_COUNT:.3g}-{full:g}")
        elif not np.all((k1 >= nominal * _NOMINAL_SPAN[0]) & (k1 <= nominal * _NOMINAL_SPAN[1])):
            refuse("scale", f"{_worst(k1 / nominal)} times the unit's factor to {out} (expected "
                            f"{_NOMINAL_SPAN[0]:g}-{_NOMINAL_SPAN[1]:g})")
        x = _COMMON_RANGE[sensor] / k1  # the raw reading the linear term maps to the widest common range
        for key, values in (("bias", k1 * np.abs(m.bias)), ("output_bias", np.abs(m.output_bias)),
                            ("scale_quadratic", np.abs(m.scale_quadratic) * x**2),
                            ("scale_cubic", np.abs(m.scale_cubic) * x**3)):
            if not np.all(values <= full):
                refuse(key, f"worth {_worst(values)} {out}, beyond {full:g} {out}")
        off = np.abs(m.misalignment - np.eye(3))
        if not np.all(off <= _MAX_MISALIGNMENT):
            refuse("misalignment", f"a term of {_worst(off)}, beyond {_MAX_MISALIGNMENT:g} (84 deg)")
        g = np.abs(m.g_sensitivity) * k1[:, None]
        if not np.all(g <= _MAX_G_SENSITIVITY):
            refuse("g_sensitivity", f"{_worst(g)} rad/s per m/s^2, beyond {_MAX_G_SENSITIVITY:g}")


def _worst(values: np.ndarray) -> str:
    v = np.asarray(values, dtype=float).reshape(-1)
    bad = v[~np.isfinite(v)]
    return "not finite" if bad.size else f"{np.max(v):.3g}"


def with_bias_session(calibration: Calibration, recording: Recording) -> Calibration:
    """``calibration`` with the fit fields that tie its gyroscope bias drift to ``recording``, the one it came from.

    For a calibration whose fit found a drifting gyroscope bias
    (``fit["gyroscope_bias_drift_per_s"]``): ``gyroscope_bias_session_s``, the
    recording's first and last times, and ``gyroscope_bias_session_check``,
    :data:`SESSION_CHECK_SAMPLES` of its samples (time and raw gyroscope
    reading) spread evenly over it, which :meth:`Calibration.is_own_session`
    recognises it by; and ``gyroscope_bias_drift_over_session_deg_s``, the
    calibrated rate at rest the drift adds to the stored bias's at the
    recording's start and at its end (two rows of three axes, °/s): how far a
    constant bias is off at either end, and what a new recording's bias may
    differ by.

    Parameters
    ----------
    calibration : Calibration
        A calibration fitted on ``recording``.
    recording : Recording
        The recording it was fitted on, in raw units.

    Returns
    -------
    Calibration
        A copy with those three fit fields added; a calibration without a bias drift (or without a
        gyroscope) is returned as it is.
    """
    rate = calibration.drift_rate()
    if rate is None or recording.gyro is None or len(recording) == 0:
        return calibration
    t = np.asarray(recording.t, dtype=np.float64)
    k = np.unique(np.round(np.linspace(0, len(t) - 1, SESSION_CHECK_SAMPLES)).astype(int))
    t_ref = float(calibration.fit.get("gyroscope_bias_time_s", 0.0))
    ends = np.degrees(np.outer([t[0] - t_ref, t[-1] - t_ref], rate))
    fields = {"gyroscope_bias_session_s": [float(t[0]), float(t[-1])],
              "gyroscope_bias_session_check": [[float(t[i]), *(float(v) for v in recording.gyro[i])] for i in k],
              "gyroscope_bias_drift_over_session_deg_s": ends.tolist()}
    return calibration.with_(fit={**calibration.fit, **fields})


def units_of(recording: Recording) -> dict:
    """The ``units`` entry of a calibration made from ``recording`` (raw in, SI out); no gyroscope entry
    for an accelerometer-only recording."""
    out = {"accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"}}
    if recording.gyro is not None:
        out["gyroscope"] = {"raw": recording.gyro_unit, "calibrated": "rad/s"}
    return out
