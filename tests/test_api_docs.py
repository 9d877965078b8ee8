"""The API page's functions are documented as numpydoc has it, and their Examples run.

Every ``autofunction``/``automethod`` of ``docs/api.rst`` (and every method's ``calibrate``, which the page's
``.. method-functions::`` lists from the registry, ``docs/methodlist.py``) has a Parameters section (unless it
takes none) and a Returns (or Yields) section; :data:`UNDOCUMENTED` (empty: every one has them) may only
shrink. Every Examples section on the page runs as a doctest.
"""

from __future__ import annotations

import doctest
import importlib
import inspect
import re
from pathlib import Path

import pytest

from imucalib.methods import METHODS

API = Path(__file__).resolve().parents[1] / "docs" / "api.rst"

#: functions on the API page still without a Parameters or a Returns section (none left)
UNDOCUMENTED: set[str] = set()


def api_functions() -> list[tuple[str, object]]:
    """``(name, function)`` of every autofunction and automethod of the API page, in order."""
    out, module = [], None
    for line in API.read_text(encoding="utf-8").splitlines():
        if line.strip() == ".. method-functions::":  # one autofunction per method of the registry
            out.extend((f"{module.__name__}.calibrate", module.calibrate) for module in METHODS.values())
            continue
        m = re.match(r"\.\. currentmodule:: (\S+)", line)
        if m:
            module = m.group(1)
            continue
        m = re.match(r"\.\. (?:autofunction|automethod)::\s+(\S+)", line)
        if not m:
            continue
        name = m.group(1) if m.group(1).startswith("imucalib.") else f"{module}.{m.group(1)}"
        owner, _, attr = name.rpartition(".")
        try:
            obj = getattr(importlib.import_module(owner), attr)
        except ModuleNotFoundError:  # a method: owner is module.Class
            parent, _, cls = owner.rpartition(".")
            obj = getattr(getattr(importlib.import_module(parent), cls), attr)
        out.append((name, obj))
    return out


FUNCTIONS = api_functions()


def _section(doc: str, title: str) -> bool:
    """Whether the numpydoc docstring ``doc`` has the section ``title`` with an entry under it."""
    return re.search(rf"^{title}\n{'-' * len(title)}\n+\S", doc, re.M) is not None


def _sections(obj) -> tuple[bool, bool]:
    doc = inspect.getdoc(obj) or ""
    params = [p for p in inspect.signature(obj).parameters if p not in ("self", "cls")]
    return _section(doc, "Parameters") or not params, _section(doc, "Returns") or _section(doc, "Yields")


def test_the_api_page_lists_functions():
    assert len(FUNCTIONS) >= 50
    names = [name for name, _ in FUNCTIONS]
    assert len(names) == len(set(names)), "an object listed twice on the API page"
    assert {f"imucalib.methods.{name}.calibrate" for name in METHODS} <= set(names)
    assert {name for name, _ in FUNCTIONS} >= UNDOCUMENTED  # a name gone from the page leaves the list too


def test_every_function_on_the_api_page_has_parameters_and_returns():
    missing = sorted(name for name, obj in FUNCTIONS if not all(_sections(obj)) and name not in UNDOCUMENTED)
    assert missing == [], f"no Parameters or Returns section: {missing}"
    done = sorted(name for name, obj in FUNCTIONS if all(_sections(obj)) and name in UNDOCUMENTED)
    assert done == [], f"documented now: take them out of UNDOCUMENTED: {done}"


@pytest.mark.parametrize("name, obj", [(n, o) for n, o in FUNCTIONS if ">>>" in (o.__doc__ or "")],
                         ids=lambda v: v if isinstance(v, str) else "")
def test_api_examples_run(name, obj):
    finder = doctest.DocTestFinder(recurse=False)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = finder.find(obj, name, globs={})
    assert tests and any(t.examples for t in tests)
    for test in tests:
        runner.run(test)
    assert runner.failures == 0, f"{name}: {runner.failures} example(s) failed (run with -s to see them)"
