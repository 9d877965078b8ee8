"""What phone apps write: recognising phyphox and Sensor Logger files from their headers.

Both apps write one CSV per sensor, each with its own time stamps:

* phyphox ("Acceleration with g" and "Gyroscope" experiments, or a combined
  export) writes ``"Time (s)","Acceleration x (m/s^2)","Acceleration y (m/s^2)",
  "Acceleration z (m/s^2)","Absolute acceleration (m/s^2)"`` and ``"Time (s)",
  "Gyroscope x (rad/s)","Gyroscope y (rad/s)","Gyroscope z (rad/s)","Absolute (rad/s)"``,
  separated by commas, tabs, or semicolons (then with decimal commas). Its
  "Linear Acceleration" experiment leaves gravity out.
* Sensor Logger writes ``time,seconds_elapsed,z,y,x`` in every motion file:
  ``time`` in nanoseconds since the epoch, the axes in the order z, y, x,
  accelerations in m/s² and rates in rad/s. Its ``Accelerometer.csv`` is the
  acceleration *without* gravity; ``TotalAcceleration.csv`` (Android) holds the
  total specific force a calibration needs, as does the optional
  ``AccelerometerUncalibrated.csv`` (in g on iOS, in m/s² on Android).

This module knows the layouts only; :mod:`.readers` parses the text and builds
the recording. It imports nothing from :mod:`.readers`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..recording import STANDARD_GRAVITY
from .errors import ReaderError

__all__ = ["PhoneFile", "check_specific_force", "identify", "sensor_logger_header"]

_SENSOR_LOGGER_HEAD = ("time", "seconds_elapsed")
_PHYPHOX_AXIS = re.compile(
    r"^(linear acceleration|acceleration|gyroscope)\s+([xyz])\s*\(([^)]*)\)$", re.I)
_PHYPHOX_TIME = re.compile(r"^time\s*\(s\)$", re.I)


@dataclass(frozen=True)
class PhoneFile:
    """One sensor file of a phone app, as recognised from its header.

    Attributes
    ----------
    app : {"phyphox", "Sensor Logger"}
    sensor : {"acc", "gyro"}
    time : int
        Index of the time column.
    time_unit : {"s", "ns"}
    axes : tuple of int
        Indices of the x, y and z columns (whatever order the file has them in).
    unit : str or None
        Unit of the samples, or None when it is to be judged from their size
        (Sensor Logger's uncalibrated accelerometer: g on iOS, m/s² on Android).
    gravity_free : bool
        The file holds acceleration with gravity taken out (not usable for calibration).
    """

    app: str
    sensor: str
    time: int
    time_unit: str
    axes: tuple[int, int, int]
    unit: str | None
    gravity_free: bool = False


def _clean(name: str) -> str:
    return name.strip().strip('"').strip("'").strip()


def identify(path: Path, names: list[str]) -> PhoneFile | None:
    """The phone-app layout of a file with header ``names``, or None when it is not one.

    Parameters
    ----------
    path : Path
        The file; Sensor Logger's files are told apart by their names
        (``TotalAcceleration.csv``, ``Gyroscope.csv`` …) since their headers are
        identical.
    names : list of str
        The header's cells.
    """
    names = [_clean(n) for n in names]
    lower = [n.lower() for n in names]
    if len(lower) >= 5 and tuple(lower[:2]) == _SENSOR_LOGGER_HEAD and set(lower[2:5]) == {"x", "y", "z"}:
        stem = path.stem.lower().replace(" ", "").replace("_", "")
        if "gyro" in stem:
            sensor, unit, free = "gyro", "rad/s", False
        elif "gravity" in stem and "total" not in stem:
            raise ReaderError(
                f"{path}: Sensor Logger's Gravity file holds the phone's estimate of gravity only; "
                "calibration needs the total specific force: pass TotalAcceleration.csv (Android) or "
                "AccelerometerUncalibrated.csv instead")
        elif "uncalibrated" in stem and "acc" in stem:
            sensor, unit, free = "acc", None, False
        elif "total" in stem:
            sensor, unit, free = "acc", "m/s^2", False
        elif "acc" in stem:
            sensor, unit, free = "acc", "m/s^2", True
        else:
            return None  # a Sensor Logger header but a name that says neither: the caller decides by order
        return PhoneFile("Sensor Logger", sensor, 0, "ns",
                         (lower.index("x"), lower.index("y"), lower.index("z")), unit, free)
    if not lower or not _PHYPHOX_TIME.match(lower[0]):
        return None
    found: dict[str, int] = {}
    kinds, units = set(), set()
    for j, name in enumerate(names[1:], start=1):
        m = _PHYPHOX_AXIS.match(name)
        if m:
            kinds.add(m.group(1).lower())
            units.add(m.group(3).strip().replace("²", "^2"))
            found.setdefault(m.group(2).lower(), j)
    if len(kinds) != 1 or set(found) != {"x", "y", "z"}:
        return None
    kind = kinds.pop()
    unit = units.pop() if len(units) == 1 else None
    sensor = "gyro" if kind == "gyroscope" else "acc"
    return PhoneFile("phyphox", sensor, 0, "s", (found["x"], found["y"], found["z"]), unit,
                     gravity_free=kind == "linear acceleration")


def sensor_logger_header(names: list[str]) -> bool:
    """Whether ``names`` is Sensor Logger's motion header (``time,seconds_elapsed,z,y,x``)."""
    lower = [_clean(n).lower() for n in names]
    return len(lower) >= 5 and tuple(lower[:2]) == _SENSOR_LOGGER_HEAD and set(lower[2:5]) == {"x", "y", "z"}


def check_specific_force(path: Path, spec: PhoneFile, acc: np.ndarray) -> str:
    """The accelerometer unit of ``acc`` after checking that it holds gravity; an error when it does not.

    Calibration needs the total specific force (gravity included): a file with
    gravity taken out is refused with a message naming the file to use instead.
    A median magnitude below a third of gravity is taken as gravity-free, whatever
    the file's name says (the samples decide, not the name).
    """
    norm = float(np.median(np.linalg.norm(acc, axis=1)))
    if spec.app == "phyphox":
        if spec.gravity_free:
            raise ReaderError(
                f"{path}: phyphox's 'Linear Acceleration' leaves gravity out; calibration needs the total "
                "specific force: record with the 'Acceleration with g' experiment and pass its file")
        if spec.unit not in ("m/s^2", "g"):
            raise ReaderError(f"{path}: unknown accelerometer unit {spec.unit!r} in the header")
        return spec.unit
    if spec.unit is None:  # uncalibrated: g on iOS, m/s² on Android
        unit = "g" if 0.3 < norm < 3.0 else "m/s^2"
    else:
        unit = spec.unit
    in_si = norm * (STANDARD_GRAVITY if unit == "g" else 1.0)
    if in_si < STANDARD_GRAVITY / 3:
        raise ReaderError(
            f"{path}: the accelerometer samples leave gravity out (their median magnitude is {in_si:.2g} "
            "m/s^2): Sensor Logger's Accelerometer.csv is the acceleration without gravity, and calibration "
            "needs the total specific force: pass TotalAcceleration.csv (Android) or "
            "AccelerometerUncalibrated.csv (turn on uncalibrated logging in the app's settings) instead")
    return unit
