"""The API page's objects are documented as numpydoc has it, with Examples that run.

Every ``autofunction``/``automethod`` of ``docs/api.rst`` (and every method's ``calibrate``, which the page's
``.. method-functions::`` lists from the registry, ``docs/methodlist.py``) has a Parameters section (unless it
takes none) and a Returns (or Yields) section; :data:`UNDOCUMENTED` (empty: every one has them) may only shrink. Every
``autofunction``, ``automethod``, ``autoclass`` and ``autoexception`` of the page (``autodata`` entries are
constants, exempt) has an Examples section, and every Examples section runs as a doctest: a failing example
fails its test. An exception an example shows being raised is listed in the Raises section of the function
that raises it.
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

_DIRECTIVE = re.compile(r"\.\. (autofunction|automethod|autoclass|autoexception)::\s+(\S+)")


def _resolve(name: str) -> object:
    owner, _, attr = name.rpartition(".")
    try:
        return getattr(importlib.import_module(owner), attr)
    except ModuleNotFoundError:  # a method: owner is module.Class
        parent, _, cls = owner.rpartition(".")
        return getattr(getattr(importlib.import_module(parent), cls), attr)


def api_objects(kinds: tuple[str, ...] = ("autofunction", "automethod", "autoclass", "autoexception")
                ) -> list[tuple[str, object]]:
    """``(name, object)`` of every directive of the API page among ``kinds``, in order."""
    out, module = [], None
    for line in API.read_text(encoding="utf-8").splitlines():
        if line.strip() == ".. method-functions::":  # one autofunction per method of the registry
            out.extend((f"{module.__name__}.calibrate", module.calibrate) for module in METHODS.values())
            continue
        m = re.match(r"\.\. currentmodule:: (\S+)", line)
        if m:
            module = m.group(1)
            continue
        m = _DIRECTIVE.match(line)
        if not m or m.group(1) not in kinds:
            continue
        name = m.group(2) if m.group(2).startswith("imucalib.") else f"{module}.{m.group(2)}"
        out.append((name, _resolve(name)))
    return out


def api_functions() -> list[tuple[str, object]]:
    """``(name, function)`` of every autofunction and automethod of the API page, in order."""
    return api_objects(("autofunction", "automethod"))


FUNCTIONS = api_functions()
OBJECTS = api_objects()


def _section(doc: str, title: str) -> bool:
    """Whether the numpydoc docstring ``doc`` has the section ``title`` with an entry under it."""
    return re.search(rf"^{title}\n{'-' * len(title)}\n+\S", doc, re.M) is not None


def _section_text(doc: str, title: str) -> str:
    """The text of section ``title`` of ``doc`` up to the next section ('' without one)."""
    m = re.search(rf"^{title}\n{'-' * len(title)}\n(.*?)(?=^\w[\w ]*\n-+\n|\Z)", doc, re.M | re.S)
    return m.group(1) if m else ""


def _sections(obj) -> tuple[bool, bool]:
    doc = inspect.getdoc(obj) or ""
    params = [p for p in inspect.signature(obj).parameters if p not in ("self", "cls")]
    return _section(doc, "Parameters") or not params, _section(doc, "Returns") or _section(doc, "Yields")


def test_the_api_page_lists_functions_and_classes():
    assert len(FUNCTIONS) >= 50
    assert len(OBJECTS) - len(FUNCTIONS) >= 25  # the classes and exceptions
    names = [name for name, _ in FUNCTIONS]
    assert len(names) == len(set(names)), "an object listed twice on the API page"
    assert {f"imucalib.methods.{name}.calibrate" for name in METHODS} <= set(names)
    assert {name for name, _ in FUNCTIONS} >= UNDOCUMENTED  # a name gone from the page leaves the list too


def test_every_function_on_the_api_page_has_parameters_and_returns():
    missing = sorted(name for name, obj in FUNCTIONS if not all(_sections(obj)) and name not in UNDOCUMENTED)
    assert missing == [], f"no Parameters or Returns section: {missing}"
    done = sorted(name for name, obj in FUNCTIONS if all(_sections(obj)) and name in UNDOCUMENTED)
    assert done == [], f"documented now: take them out of UNDOCUMENTED: {done}"


def test_every_object_on_the_api_page_has_examples():
    missing = [name for name, obj in OBJECTS if not _section(inspect.getdoc(obj) or "", "Examples")]
    assert missing == [], f"no Examples section: {missing}"


def test_an_exception_an_example_raises_is_in_the_raises_section():
    """A traceback shown in a function's Examples names an exception its Raises section lists."""
    unlisted = []
    for name, obj in FUNCTIONS:
        doc = inspect.getdoc(obj) or ""
        shown = re.findall(r"^Traceback \(most recent call last\):\n(?:\s+.*\n)*?([\w.]+?)(?::|$)",
                           _section_text(doc, "Examples"), re.M)
        raises = _section_text(doc, "Raises")
        unlisted += [f"{name}: {exc}" for exc in shown if exc.rpartition(".")[2] not in raises]
    assert unlisted == []


@pytest.mark.parametrize("name, obj", OBJECTS, ids=lambda v: v if isinstance(v, str) else "")
def test_api_examples_run(name, obj):
    finder = doctest.DocTestFinder(recurse=False)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = finder.find(obj, name, globs={})
    assert tests and any(t.examples for t in tests), f"{name}: no example to run (>>> lines)"
    for test in tests:
        runner.run(test)
    assert runner.failures == 0, f"{name}: {runner.failures} example(s) failed (run with -s to see them)"


def test_the_api_page_shows_the_type_hints():
    """The signatures carry their annotations (autodoc's "none" would hide them; "description" repeats them)."""
    conf = (API.parent / "conf.py").read_text(encoding="utf-8")
    setting = re.search(r'^autodoc_typehints\s*=\s*"(\w+)"', conf, re.M)
    assert setting is not None and setting.group(1) == "signature"
    assert inspect.signature(importlib.import_module("imucalib").calibrate).return_annotation not in (
        inspect.Signature.empty, None)
