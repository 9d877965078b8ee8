"""The calibration file's checks: every entry of a document by kind, shape and text, and the parameters' sizes.

:func:`check_document` checks the parsed JSON of a calibration file entry by entry before
:meth:`imucalib.calibration.Calibration.from_dict` builds the calibration, and :func:`check_magnitudes` the
parameters it holds against what any MEMS sensor gives; :class:`CalibrationFileError` names the entry that is
wrong. :mod:`imucalib.calibration` re-exports them.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np

from .constants import STANDARD_GRAVITY, earth_gravity_text
from .fitreport import FitReport, VerdictReport
from .models import AXES, MISALIGNMENT_SHAPES, TriadModel
from .recording import ACC_UNITS, GYRO_UNITS, MAG_UNITS
from .thermalmodel import evaluate

__all__ = ["DEVICE_MAX_CHARS", "FORMAT", "FORMAT_VERSION", "FULL_SCALE", "GRAVITY_LIMITS", "READABLE_VERSIONS",
           "TEMPERATURE_LIMITS", "CalibrationFileError", "check_device", "check_document", "check_magnitudes"]

#: the longest device name a calibration holds [characters]
DEVICE_MAX_CHARS = 256

FORMAT = "imucalib.calibration"
FORMAT_VERSION = 2
#: the versions this one reads (version 1 is version 2 with the same ``fit`` object: files of both load)
READABLE_VERSIONS = (1, 2)


class CalibrationFileError(ValueError):
    """A calibration file (or dictionary) that cannot be used; the message names the entry.

    Examples
    --------
    Raised by :meth:`Calibration.load` and :meth:`Calibration.from_dict` for what is not a calibration:

    >>> from imucalib import Calibration
    >>> from imucalib.calibration import CalibrationFileError
    >>> try:
    ...     Calibration.from_dict({"format": "something else"})
    ... except CalibrationFileError as exc:
    ...     print(exc)
    not an imucalib calibration: 'format' is "something else", not "imucalib.calibration"
    """


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
    imucalib.calibfile.CalibrationFileError: not an imucalib calibration: 'format' is "something else", not ...
    """
    _check_format(d)
    units = _check_units(d)
    _check_entries(d)
    _check_unit_names(units)
    _check_magnetometer(d, units)
    _check_thermal(d)
    flat = d.get("fit")
    if flat is not None and not isinstance(flat, dict):
        raise CalibrationFileError(f"'fit': expected an object (the fit figures); got {_kind(flat)}")
    if isinstance(flat, dict):
        _check_verdict(FitReport.from_flat(flat).verdict)



def _check_format(d) -> None:
    """:func:`check_document`: a calibration of a version this one reads, with its sensors' sections."""
    if not isinstance(d, dict):
        raise CalibrationFileError(f"expected a JSON object (an imucalib calibration); got {_kind(d)}")
    if d.get("format") != FORMAT:
        raise CalibrationFileError(f"not an imucalib calibration: 'format' is {json.dumps(d.get('format'))}, "
                                   f"not \"{FORMAT}\"")
    version = d.get("format_version")
    if isinstance(version, bool) or version not in READABLE_VERSIONS:
        raise CalibrationFileError(f"calibration format_version {json.dumps(version)} is not supported "
                                   f"(this imucalib reads versions {', '.join(map(str, READABLE_VERSIONS))})")
    missing = [k for k in ("accelerometer", "gyroscope") if k not in d]
    if missing:
        raise CalibrationFileError(f"calibration lacks the {' and '.join(missing)} section(s)")
    _check_triad(d["accelerometer"], "accelerometer", "upper")
    if d["gyroscope"] is not None:  # null: an accelerometer-only calibration
        _check_triad(d["gyroscope"], "gyroscope", "full")


def _check_units(d) -> dict | None:
    """:func:`check_document`: the raw units of the sensors, one this version knows each; returns ``units``."""
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
    return units


def _check_entries(d) -> None:
    """:func:`check_document`: gravity, lever arm, method, model, device and creation time."""
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


def _check_unit_names(units) -> None:
    """:func:`check_document`: every unit a name (:data:`_UNIT`)."""
    for sensor, entry in (units or {}).items() if isinstance(units, dict) else ():
        if isinstance(entry, dict):
            for key, value in entry.items():
                if not isinstance(value, str):
                    raise CalibrationFileError(f"'units.{sensor}.{key}': expected a string; got {_kind(value)}")
                _identifier(value, f"'units.{sensor}.{key}'", _UNIT)


def _check_magnetometer(d, units) -> None:
    """:func:`check_document`: the magnetometer's section and its raw unit, when there is one."""
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


def _check_thermal(d) -> None:
    """:func:`check_document`: the thermal model's source and its temperatures, when there is one."""
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


def _check_verdict(verdict: VerdictReport) -> None:
    """Refuse a file's verdict that is not one of the three levels, or reasons and notes that are not texts."""
    if verdict.level is not None and verdict.level not in _VERDICTS:
        raise CalibrationFileError(f"'fit.verdict': expected one of {', '.join(_VERDICTS)}; got "
                                   f"{json.dumps(verdict.level)[:40]}")
    for key, texts in (("verdict_reasons", verdict.reasons), ("verdict_notes", verdict.notes)):
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


def check_magnitudes(calibration) -> None:
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
                                   f"{lo:g}-{hi:g} m/s^2; the Earth's is {earth_gravity_text()})")
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
