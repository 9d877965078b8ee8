"""imucalib: calibrate the accelerometer, gyroscope and magnetometer of low-cost MEMS IMUs without equipment.

The Python route is the command line's::

    import imucalib

    data = imucalib.read("session.csv")          # what ``imucalib calibrate`` reads, magnetometer included
    cal = imucalib.calibrate(data)               # the command line's default method
    cal.save("calib.json")                       # the file ``imucalib calibrate session.csv -o calib.json`` writes

with :func:`validate` and :func:`compare` beside them, and :class:`Calibration` (``Calibration.load``).
A table of averaged poses, one row per orientation, is read by ``imucalib.read("poses.csv", poses=True)``
(a :class:`PoseTable`) and its accelerometer calibrated by the same ``imucalib.calibrate(table)``.
The names below are imported on first use (PEP 562), so that ``import imucalib``
and the command line's start-up stay light: a command imports only what it runs; the same names are
imported under ``TYPE_CHECKING`` for type checkers and editors (go-to-definition from ``imucalib.calibrate``
reaches :func:`imucalib.methods.calibrate`, and from there each method's module).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # what _LAZY imports on first use, for type checkers and editors
    from .calibration import Calibration
    from .comparison import compare
    from .io.posetable import PoseTable
    from .methodinfo import DEFAULT_METHOD
    from .methods import calibrate
    from .models import TriadModel
    from .reading import read
    from .recording import STANDARD_GRAVITY, ImucalibWarning, Interval, Recording
    from .validation import validate

__all__ = [
    "Calibration",
    "DEFAULT_METHOD",
    "ImucalibWarning",
    "Interval",
    "PoseTable",
    "Recording",
    "STANDARD_GRAVITY",
    "TriadModel",
    "__version__",
    "calibrate",
    "compare",
    "read",
    "validate",
]

__version__ = "0.1.0"

#: the public names and the module each comes from (``(module, name there)`` where the name differs)
_LAZY: dict[str, str | tuple[str, str]] = {
    "Calibration": ".calibration",
    "DEFAULT_METHOD": ".methodinfo",
    "calibrate": ".methods",
    "compare": ".comparison",
    "read": ".reading",
    "validate": ".validation",
    "TriadModel": ".models",
    "ImucalibWarning": ".recording",
    "Interval": ".recording",
    "PoseTable": ".io.posetable",
    "Recording": ".recording",
    "STANDARD_GRAVITY": ".recording",
}


def __getattr__(name: str):
    where = _LAZY.get(name)
    if where is None:
        raise AttributeError(f"module 'imucalib' has no attribute {name!r}")
    module, attribute = where if isinstance(where, tuple) else (where, name)
    value = getattr(importlib.import_module(module, __name__), attribute)
    globals()[name] = value  # found directly from now on
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
