"""Reading recordings (CSV, imu_tk text, MATLAB) and writing them as CSV.

The readers are imported on first use (PEP 562): a submodule such as
:mod:`.atomic` can be imported without them.
"""

from __future__ import annotations

import importlib

__all__ = ["READERS", "ReaderError", "guess_reader", "read", "write_csv"]

#: the public names and the module each comes from
_LAZY = {"READERS": ".readers", "ReaderError": ".readers", "guess_reader": ".readers", "read": ".readers",
         "write_csv": ".writers"}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'imucalib.io' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
