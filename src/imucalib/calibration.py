"""The result of a calibration: both triad models, lever arm, fit quality; JSON I/O.

The file format is the versioned JSON of ``DESIGN.md`` (``"format":
"imucalib.calibration"``, ``"format_version": 1``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from .io.atomic import atomic_write
from .io.jsontext import dumps, jsonable
from .models import AXES, TriadModel
from .recording import STANDARD_GRAVITY, Recording

__all__ = ["Calibration", "FORMAT", "FORMAT_VERSION"]

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
        Fit-quality figures (see ``DESIGN.md``).
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
        n = len(recording)
        acc, gyro = np.empty((n, 3)), np.empty((n, 3))
        for a in range(0, n, _BLOCK):  # the models' temporaries stay the size of a block
            b = min(a + _BLOCK, n)
            acc[a:b] = self.accelerometer_si(recording.acc[a:b])
            gyro[a:b] = self.gyroscope.forward(recording.gyro[a:b], acc[a:b])
        return Recording(
            t=recording.t,
            acc=acc,
            gyro=gyro,
            acc_unit="m/s^2",
            gyro_unit="rad/s",
            temperature=recording.temperature,
            extra=dict(recording.extra),
            metadata={**recording.metadata, "calibration": self.method},
        )

    def _apply_frame(self, frame, read_options: dict):
        from .io.readers import _is_frame, read
        from .io.writers import calibrated_columns

        if not _is_frame(frame):
            raise TypeError(f"apply takes a Recording or a pandas DataFrame; got {type(frame).__name__}")
        rec = read(frame, **read_options)
        out = self.apply(rec)
        added = calibrated_columns(out.acc, out.gyro)
        clash = [name for name in added if name in frame.columns]
        if clash:
            raise ValueError(f"the DataFrame already has the column(s) {', '.join(clash)}: apply a calibration to "
                             "raw data only once")
        return frame.assign(**added)

    def check_units(self, recording: Recording) -> None:
        """Raise ValueError unless the recording is in the raw units this calibration maps."""
        for sensor, unit in (("accelerometer", recording.acc_unit),
                             ("gyroscope", recording.gyro_unit)):
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
        return out

    def with_parameters(self, values: dict[str, float]) -> Calibration:
        """A copy with the named parameters set (names as in :meth:`parameters`)."""
        known = ("accelerometer.", "gyroscope.", "lever_arm.")
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
        return {
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

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Calibration:
        """Inverse of :meth:`to_dict`; checks the format and its version."""
        if d.get("format") != FORMAT:
            raise ValueError(f"not an imucalib calibration: 'format' is {d.get('format')!r}")
        version = d.get("format_version")
        if version != FORMAT_VERSION:
            raise ValueError(
                f"calibration format_version {version!r} is not supported "
                f"(this imucalib reads version {FORMAT_VERSION})"
            )
        missing = [k for k in ("accelerometer", "gyroscope") if not isinstance(d.get(k), dict)]
        if missing:
            raise ValueError(f"calibration lacks the {' and '.join(missing)} section(s)")
        return cls(
            accelerometer=TriadModel.from_dict(d["accelerometer"], default_shape="upper"),
            gyroscope=TriadModel.from_dict(d["gyroscope"], default_shape="full"),
            lever_arm=d.get("lever_arm"),
            gravity=float(d.get("gravity", STANDARD_GRAVITY)),
            method=d.get("method", "unknown"),
            model=d.get("model", "linear"),
            units=d.get("units") or cls().units,
            device=d.get("device"),
            created=d.get("created"),
            fit=d.get("fit", {}),
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
        """Read a calibration file written by :meth:`save`."""
        path = Path(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ValueError(f"{path}: calibration file not found") from None
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}: not valid JSON ({exc})") from None
        try:
            return cls.from_dict(data)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None


def units_of(recording: Recording) -> dict:
    """The ``units`` entry of a calibration made from ``recording`` (raw in, SI out)."""
    return {"accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"},
            "gyroscope": {"raw": recording.gyro_unit, "calibrated": "rad/s"}}
