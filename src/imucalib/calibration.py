"""The result of a calibration: both triad models, lever arm, fit quality; JSON I/O.

The file format is versioned JSON (``"format": "imucalib.calibration"``,
``"format_version": 1``); ``docs/architecture.rst`` describes every entry.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from .io.atomic import atomic_write
from .io.jsontext import dumps, jsonable
from .models import AXES, MISALIGNMENT_SHAPES, MagnetometerModel, TriadModel
from .recording import ACC_UNITS, GYRO_UNITS, MAG_UNITS, STANDARD_GRAVITY, Recording
from .thermal import ThermalModel

__all__ = ["Calibration", "CalibrationFileError", "FORMAT", "FORMAT_VERSION", "check_document"]

FORMAT = "imucalib.calibration"
FORMAT_VERSION = 1
_BLOCK = 1 << 16  # samples calibrated at a time by apply


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
        ``a = T_a f_a(u_a − b_a)``, ``ω = T_g f_g(u_g − b_g − G a)``.
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
    gyroscope: TriadModel = field(default_factory=_default_gyro)
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
        a = None
        if np.any(self.gyroscope.g_sensitivity):
            if raw_acc is None:
                raise ValueError("this calibration has a g-sensitivity: pass raw_acc as well")
            a = self.accelerometer_si(raw_acc)
        return self.gyroscope.forward(raw_gyro, a)

    def apply(self, recording, **read_options):
        """The recording with calibrated accelerometer [m/s²] and gyroscope [rad/s].

        The recording must be in the raw units this calibration was made for.

        A pandas DataFrame is read as :func:`imucalib.io.read` reads it (its
        column names as a CSV header; ``read_options`` are that function's:
        ``columns``, ``acc_unit``, ``gyro_unit``, ``rate``, ``time_unit``) and
        a copy of it is returned with the calibrated columns added:
        ``acc_x_cal [m/s^2]`` … ``gyro_z_cal [rad/s]``, as ``imucalib apply``
        adds them to a CSV file.
        """
        if not isinstance(recording, Recording):
            return self._apply_frame(recording, read_options)
        if read_options:
            raise TypeError(f"apply takes reading options ({', '.join(read_options)}) only with a DataFrame")
        self.check_units(recording)
        if self.thermal is not None:  # compensated to the reference temperature, then as below (thermal.py, T2)
            from .thermal import compensate

            base, compensated = compensate(self, recording)
            return base.apply(compensated)
        n = len(recording)
        acc, gyro = np.empty((n, 3)), np.empty((n, 3))
        for a in range(0, n, _BLOCK):  # the models' temporaries stay the size of a block
            b = min(a + _BLOCK, n)
            acc[a:b] = self.accelerometer_si(recording.acc[a:b])
            gyro[a:b] = self.gyroscope.forward(recording.gyro[a:b], acc[a:b])
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
            metadata={**recording.metadata, "calibration": self.method},
            mag=mag,
            mag_unit=mag_unit,
        )

    def _apply_frame(self, frame, read_options: dict):
        from .io.readers import _is_frame, read
        from .io.writers import calibrated_columns

        if not _is_frame(frame):
            raise TypeError(f"apply takes a Recording or a pandas DataFrame; got {type(frame).__name__}")
        rec = read(frame, **read_options)
        out = self.apply(rec)
        mag = out.mag if self.magnetometer is not None and rec.mag is not None else None
        added = calibrated_columns(out.acc, out.gyro, mag, out.mag_unit)
        clash = [name for name in added if name in frame.columns]
        if clash:
            raise ValueError(f"the DataFrame already has the column(s) {', '.join(clash)}: apply a calibration to "
                             "raw data only once")
        return frame.assign(**added)

    def check_units(self, recording: Recording) -> None:
        """Raise ValueError unless the recording is in the raw units this calibration maps."""
        pairs = [("accelerometer", recording.acc_unit), ("gyroscope", recording.gyro_unit)]
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
            gyroscope=self.gyroscope.with_parameters("gyroscope", values),
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
            "gyroscope": self.gyroscope.to_dict(gyroscope=True),
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

        Raises :class:`CalibrationFileError` naming the entry that is wrong.
        """
        check_document(d)
        units = d.get("units")
        return cls(
            accelerometer=TriadModel.from_dict(d["accelerometer"], default_shape="upper"),
            gyroscope=TriadModel.from_dict(d["gyroscope"], default_shape="full"),
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
        if path.is_dir():
            raise CalibrationFileError(f"{path}: is a directory, not a calibration file (JSON)")
        try:
            data = json.loads(path.read_bytes().decode("utf-8-sig"))
        except FileNotFoundError:
            raise CalibrationFileError(f"{path}: calibration file not found") from None
        except UnicodeDecodeError:
            raise CalibrationFileError(f"{path}: not a text file; a calibration file is JSON, as "
                                       "'imucalib calibrate -o FILE.json' writes it") from None
        except json.JSONDecodeError as exc:
            raise CalibrationFileError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno}, column "
                                       f"{exc.colno})") from None
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


def check_document(d) -> None:
    """Check a calibration document (the parsed JSON of the file) entry by entry.

    Raises :class:`CalibrationFileError` naming the first entry that is
    missing, of the wrong kind or shape, or not a finite number.
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
    _check_triad(d["gyroscope"], "gyroscope", "full")
    units = d.get("units")
    if units is not None:
        if not isinstance(units, dict):
            raise CalibrationFileError(f"'units': expected an object with 'accelerometer' and 'gyroscope'; "
                                       f"got {_kind(units)}")
        for sensor, allowed in (("accelerometer", ACC_UNITS), ("gyroscope", GYRO_UNITS)):
            entry = units.get(sensor)
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
    for key in ("device", "created"):
        if d.get(key) is not None and not isinstance(d[key], str):
            raise CalibrationFileError(f"'{key}': expected a string or null; got {_kind(d[key])}")
    mag = d.get("magnetometer")
    if mag is not None:
        if not isinstance(mag, dict):
            raise CalibrationFileError(f"'magnetometer': expected an object (bias, soft_iron, alignment); got "
                                       f"{_kind(mag)}")
        for key, shape in (("bias", (3,)), ("soft_iron", (3, 3)), ("alignment", (3, 3))):
            _numbers(mag.get(key), shape, f"'magnetometer.{key}'")
        raw = ((units or {}).get("magnetometer") or {}).get("raw")
        if raw not in MAG_UNITS:
            raise CalibrationFileError(f"'units.magnetometer.raw': expected one of {', '.join(MAG_UNITS)}; got "
                                       f"{json.dumps(raw)}")
    if d.get("thermal") is not None and not isinstance(d["thermal"], dict):
        raise CalibrationFileError(f"'thermal': expected an object (reference_c, range_c, parameters); got "
                                   f"{_kind(d['thermal'])}")
    fit = d.get("fit")
    if fit is not None and not isinstance(fit, dict):
        raise CalibrationFileError(f"'fit': expected an object (the fit figures); got {_kind(fit)}")
    if isinstance(fit, dict):
        reasons = fit.get("verdict_reasons")
        if fit.get("verdict") is not None and not isinstance(fit["verdict"], str):
            raise CalibrationFileError(f"'fit.verdict': expected a string; got {_kind(fit['verdict'])}")
        if reasons is not None and not (isinstance(reasons, list) and all(isinstance(r, str) for r in reasons)):
            raise CalibrationFileError("'fit.verdict_reasons': expected a list of strings")


def units_of(recording: Recording) -> dict:
    """The ``units`` entry of a calibration made from ``recording`` (raw in, SI out)."""
    return {"accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"},
            "gyroscope": {"raw": recording.gyro_unit, "calibrated": "rad/s"}}
