"""Strict JSON text: non-finite numbers become ``null``, numpy values plain Python ones.

JSON has no ``NaN`` or ``Infinity``; :func:`json.dumps` writes them all the
same unless told not to, and strict parsers (JavaScript's ``JSON.parse``,
``jq``, most other languages) reject the result. Everything the package
prints or writes as JSON goes through :func:`dumps`, where a number that is
not available (not finite) is ``null``.

The small files the package reads whole (a calibration, a sections file, a
noise file) are read by :func:`read_small_text` and :func:`read_json`: at most
a given size (``/dev/zero`` or a recording given by mistake is refused, not
read whole), as UTF-8 text, and for JSON strictly (:func:`loads`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["MAX_DEPTH", "JsonTextError", "SmallFileError", "dumps", "jsonable", "loads", "read_json",
           "read_small_text"]

#: nesting a document read with :func:`loads` may have (a calibration file has 5 levels)
MAX_DEPTH = 64


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


class JsonTextError(ValueError):
    """JSON text that :func:`loads` refuses: not strict JSON, a number out of range, or nested too deeply."""


def _no_constant(name: str):
    raise JsonTextError(f"{name} is not a JSON number (strict JSON has no NaN or Infinity)")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise JsonTextError(f"the number {text[:40]} is out of range (beyond ±1.8e308)")
    return value


def _depth(obj: Any, limit: int) -> int:
    """How deep ``obj`` nests, counted without recursion and up to ``limit + 1`` at most."""
    deepest, level = 0, [(obj, 1)]
    while level:
        value, d = level.pop()
        if isinstance(value, dict | list):
            deepest = max(deepest, d)
            if deepest > limit:
                return deepest
            items: Iterable = value.values() if isinstance(value, dict) else value
            level.extend((v, d + 1) for v in items if isinstance(v, dict | list))
    return deepest


def loads(text: str | bytes, *, max_depth: int = MAX_DEPTH) -> Any:
    """Strict JSON text parsed: ``NaN``, ``Infinity`` and numbers beyond a double refused, nesting bounded.

    Python's parser accepts ``NaN`` and ``Infinity``, reads ``1e999`` as infinity,
    and recurses once per level (a document nested 10 000 deep raises
    :class:`RecursionError`). Here each is a :class:`JsonTextError` (a
    :class:`ValueError`); :class:`json.JSONDecodeError` is raised as it is.
    """
    try:
        value = json.loads(text, parse_constant=_no_constant, parse_float=_finite_float)
    except RecursionError:
        raise JsonTextError(f"nested more than {max_depth} levels deep") from None
    except ValueError as exc:
        if isinstance(exc, json.JSONDecodeError | JsonTextError):
            raise
        raise JsonTextError(str(exc)) from None  # e.g. an integer of more than 4300 digits
    if _depth(value, max_depth) > max_depth:
        raise JsonTextError(f"nested more than {max_depth} levels deep")
    return value


class SmallFileError(ValueError):
    """A small input file that cannot be read whole: the message says why, without the file's name (the caller
    puts it, or the option that gave it, in front)."""


def _size(n: int) -> str:
    return f"{n >> 20} MB" if n >= 1 << 20 else f"{n >> 10} kB" if n >= 1 << 10 else f"{n} bytes"


def read_small_text(path: str | Path, max_bytes: int, name: str, about: str = "") -> str:
    """The text of a small file, read whole but never beyond ``max_bytes``.

    Parameters
    ----------
    path : str or Path
        The file.
    max_bytes : int
        The largest file taken; one byte more is read to tell a larger one.
    name : str
        What the file is, for the messages (``"calibration file"``).
    about : str, optional
        What such a file holds, said when the file is too large or not text.

    Returns
    -------
    str
        The text (UTF-8, a byte-order mark dropped).

    Raises
    ------
    SmallFileError
        A directory, a missing or unreadable file, one larger than
        ``max_bytes``, or one that is not UTF-8 text.
    """
    path = Path(path)
    why = f": {about}" if about else ""
    if path.is_dir():
        raise SmallFileError(f"is a directory, not a {name}")
    try:
        with path.open("rb") as fh:
            raw = fh.read(max_bytes + 1)  # bounded: /dev/zero or a huge file is refused, not read whole
    except FileNotFoundError:
        raise SmallFileError(f"{name} not found") from None
    except OSError as exc:
        raise SmallFileError(f"cannot be read ({exc.strerror or exc})") from None
    if len(raw) > max_bytes:
        raise SmallFileError(f"larger than {_size(max_bytes)}, not a {name}{why}")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise SmallFileError(f"not a text file{why}") from None


def read_json(path: str | Path, max_bytes: int, name: str, about: str = "") -> Any:
    """A small JSON file (:func:`read_small_text`) parsed strictly (:func:`loads`).

    Raises
    ------
    SmallFileError
        As :func:`read_small_text`, and for text that is not JSON (the line
        and column named) or not strict JSON (:class:`JsonTextError`'s reason).
    """
    text = read_small_text(path, max_bytes, name, about)
    try:
        return loads(text)
    except json.JSONDecodeError as exc:
        raise SmallFileError(f"not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})") from None
    except JsonTextError as exc:
        raise SmallFileError(f"not a {name}: {exc}") from None
