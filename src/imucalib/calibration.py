"""The result of a calibration: both triad models, lever arm, fit quality; JSON I/O.

The file format is versioned JSON (``"format": "imucalib.calibration"``,
``"format_version": 2``; version 1 files, whose content is the same, load too); ``docs/architecture.rst``
describes every entry.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from .calibfile import (
    DEVICE_MAX_CHARS,
    FORMAT,
    FORMAT_VERSION,
    FULL_SCALE,
    GRAVITY_LIMITS,
    READABLE_VERSIONS,
    CalibrationFileError,
    check_device,
    check_document,
    check_magnitudes,
)
from .constants import STANDARD_GRAVITY
from .fitreport import FitReport, GyroscopeReport
from .io.atomic import atomic_write
from .io.jsontext import SmallFileError, dumps, jsonable, read_json
from .models import AXES, MagnetometerModel, TriadModel
from .recording import ImucalibWarning, Recording
from .thermalmodel import ThermalModel, compensate

__all__ = ["BIAS_DRIFT", "DEVICE_MAX_CHARS", "DRIFT_NOTICE_DEG_S", "FULL_SCALE", "Calibration", "CalibrationFileError",
           "FORMAT", "FORMAT_VERSION", "GRAVITY_LIMITS", "READABLE_VERSIONS", "SESSION_CHECK_SAMPLES", "check_device",
           "check_document", "check_magnitudes", "with_bias_session"]

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
    fit : FitReport
        Fit-quality figures, the verdict and its reasons, stage by stage (:mod:`imucalib.fitreport`; every
        entry in ``docs/architecture.rst``). A mapping of the file's flat ``fit`` keys is turned into one.
    magnetometer : MagnetometerModel or None
        Hard and soft iron and the map into the accelerometer's frame, when the IMU has a
        magnetometer and it was calibrated (``units["magnetometer"]`` then gives its units).

    Raises
    ------
    ValueError
        For a ``lever_arm`` without three entries or a ``gravity`` that is not a positive number.

    Examples
    --------
    A simulated session's true calibration (:func:`imucalib.calibrate` makes one from a recording),
    applied, saved and read back:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib import Calibration
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> cal = sim.truth
    >>> calibrated = cal.apply(sim.recording)
    >>> calibrated.acc_unit, calibrated.gyro_unit
    ('m/s^2', 'rad/s')
    >>> path = Path(tempfile.mkdtemp()) / "calib.json"
    >>> cal.save(path)
    >>> Calibration.load(path).parameters() == cal.parameters()
    True
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
    fit: FitReport = field(default_factory=FitReport)
    magnetometer: MagnetometerModel | None = None
    thermal: ThermalModel | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.fit, FitReport):
            object.__setattr__(self, "fit", FitReport.from_flat(self.fit or {}))
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
        ``columns``, ``acc_unit``, ``gyro_unit``, ``rate``, ``time_unit``, and
        ``mag_unit`` as for :func:`imucalib.read`) and
        a copy of it is returned with the calibrated columns added:
        ``acc_x_cal [m/s^2]`` … ``gyro_z_cal [rad/s]`` (and ``mag_x_cal`` …
        when both have a magnetometer), as ``imucalib apply`` adds them to a CSV file.

        Parameters
        ----------
        recording : Recording or pandas.DataFrame
            Raw readings.
        bias_drift : {"auto", "on", "off"}
            Whether the gyroscope bias drifts as the calibration's fit found it,
            ``b(t) = b + d (t − t_ref)`` (Zhang 2021, eq. 11 with the linear drift
            of :func:`imucalib.fit.gyroscope.static_gyro`; ``d`` is
            ``fit.gyroscope.bias_drift_per_s``, ``t_ref``
            ``fit.gyroscope.bias_time_s``), or is the constant ``b``.
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
        d = self.fit.gyroscope.bias_drift_per_s
        if d is None or self.gyroscope is None:
            return None
        return np.asarray(d, dtype=np.float64).reshape(3)

    def bias_offset(self, t: np.ndarray) -> np.ndarray:
        """``d (t − t_ref)`` (N, 3) [raw]: what the drifting bias adds to the stored one at the times ``t`` [s].

        ``b(t) = b + d (t − t_ref)``: the static poses' gyroscope means with a
        bias that drifts linearly (Zhang 2021, eq. 11; the drift as
        :func:`imucalib.fit.gyroscope.static_gyro` fits it), ``t_ref`` the time
        at which the stored bias holds (``fit.gyroscope.bias_time_s``, the
        mean of the poses' times in the calibrated recording's time base).
        Zeros for a calibration without a drift.
        """
        t = np.asarray(t, dtype=np.float64).reshape(-1)
        d = self.bias_drift
        if d is None:
            return np.zeros((t.size, 3))
        t_ref = float(self.fit.gyroscope.bias_time_s or 0.0)
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
          (``fit.gyroscope.bias_session_s``, in that recording's time base),
          give or take half a sample period;
        * of the calibrated recording's check samples
          (``fit.gyroscope.bias_session_check``: the time and raw gyroscope
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
        fit = self.fit
        span, check = fit.gyroscope.bias_session_s, fit.gyroscope.bias_session_check
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
        from .io.magnetometer import attach_magnetometer  # with the readers below: loaded when a file is applied
        from .io.readers import is_frame, read  # imucalib.io.readers costs 34 ms at start-up
        from .io.writers import calibrated_columns  # imucalib.io.writers costs 38 ms at start-up

        if not is_frame(frame):
            raise TypeError(f"apply takes a Recording or a pandas DataFrame; got {type(frame).__name__}")
        options = {k: v for k, v in read_options.items() if k != "mag_unit"}  # its magnetometer, as imucalib.read
        rec = attach_magnetometer(read(frame, **options), read_options.get("mag_unit"))
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
            "fit": jsonable(self.fit.to_flat()),
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
        declared (:mod:`imucalib.fitreport`: a file from another version) is kept as read, with an
        :class:`~imucalib.recording.ImucalibWarning` naming it.
        """
        check_document(d)
        unknown = FitReport.undeclared(d.get("fit") or {})
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
            fit=FitReport.from_flat(d.get("fit") or {}),
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


def with_bias_session(calibration: Calibration, recording: Recording) -> Calibration:
    """``calibration`` with the fit fields that tie its gyroscope bias drift to ``recording``, the one it came from.

    For a calibration whose fit found a drifting gyroscope bias
    (``fit.gyroscope.bias_drift_per_s``): ``gyroscope_bias_session_s``, the
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

    Examples
    --------
    A calibration stripped of those fields no longer recognises its own recording; they are added back:

    >>> from imucalib.calibration import with_bias_session
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> cal = calibrate(sim.recording)
    >>> bare = cal.with_(fit={k: v for k, v in cal.fit.items() if "over_session" not in k
    ...                       and not k.startswith("gyroscope_bias_session")})
    >>> bare.is_own_session(sim.recording)
    False
    >>> restored = with_bias_session(bare, sim.recording)
    >>> restored.is_own_session(sim.recording), restored.fit.gyroscope.bias_session_s
    (True, [0.0, 90.56])
    """
    rate = calibration.drift_rate()
    if rate is None or recording.gyro is None or len(recording) == 0:
        return calibration
    t = np.asarray(recording.t, dtype=np.float64)
    k = np.unique(np.round(np.linspace(0, len(t) - 1, SESSION_CHECK_SAMPLES)).astype(int))
    t_ref = float(calibration.fit.gyroscope.bias_time_s or 0.0)
    ends = np.degrees(np.outer([t[0] - t_ref, t[-1] - t_ref], rate))
    session = GyroscopeReport(bias_session_s=[float(t[0]), float(t[-1])],
                              bias_session_check=[[float(t[i]), *(float(v) for v in recording.gyro[i])] for i in k],
                              bias_drift_over_session_deg_s=ends.tolist())
    return calibration.with_(fit=calibration.fit.add(session))


def units_of(recording: Recording) -> dict:
    """The ``units`` entry of a calibration made from ``recording`` (raw in, SI out); no gyroscope entry
    for an accelerometer-only recording."""
    out = {"accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"}}
    if recording.gyro is not None:
        out["gyroscope"] = {"raw": recording.gyro_unit, "calibrated": "rad/s"}
    return out
