"""Strict JSON text: non-finite numbers become ``null``, numpy values plain Python ones.

JSON has no ``NaN`` or ``Infinity``; :func:`json.dumps` writes them all the
same unless told not to, and strict parsers (JavaScript's ``JSON.parse``,
``jq``, most other languages) reject the result. Everything the package
prints or writes as JSON goes through :func:`dumps`, where a number that is
not available (not finite) is ``null``.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

__all__ = ["dumps", "jsonable"]


def jsonable(x: Any) -> Any:
    """``x`` with numpy arrays and scalars made lists and Python numbers, and non-finite floats ``None``.

    Dictionaries, lists and tuples are converted item by item (tuples become
    lists); anything else is returned as it is.
    """
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def dumps(obj: Any, *, indent: int | None = None) -> str:
    """``obj`` as strict JSON text (:func:`jsonable` first; ``NaN``/``Infinity`` can never appear)."""
    return json.dumps(jsonable(obj), indent=indent, allow_nan=False)
