"""imucalib: calibrate the accelerometer and gyroscope of low-cost MEMS IMUs without equipment.

The names below are imported on first use (PEP 562), so that ``import imucalib``
and the command line's start-up stay light: a command imports only what it runs.
"""

from __future__ import annotations

import importlib

__all__ = [
    "Calibration",
    "ImucalibWarning",
    "Interval",
    "Recording",
    "STANDARD_GRAVITY",
    "TriadModel",
    "__version__",
]

__version__ = "0.1.0"

#: the public names and the module each comes from
_LAZY = {
    "Calibration": ".calibration",
    "TriadModel": ".models",
    "ImucalibWarning": ".recording",
    "Interval": ".recording",
    "Recording": ".recording",
    "STANDARD_GRAVITY": ".recording",
}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'imucalib' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value  # found directly from now on
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
