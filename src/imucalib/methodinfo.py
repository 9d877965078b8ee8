"""What each calibration method declares about itself, read without importing it.

Every module of :mod:`imucalib.methods` declares itself once, at module level::

    METHOD = MethodInfo(name=..., summary=..., needs=..., models=..., options=(Option(...), ...), paper=...)

:func:`declared` reads those declarations from the modules' source (the declaration holds literals only),
so that the modules below the methods (the verdict) and the command line's ``--method`` choices and help,
``compare``'s candidates, ``plan``, batch's manifest checks and the README's table of methods have them
without importing numpy. The registry (:data:`imucalib.methods.METHODS`) imports the modules themselves
and holds the declarations they define; a test checks that what is read here is what they hold.
"""

from __future__ import annotations

import ast
from collections import namedtuple
from functools import cache
from pathlib import Path

__all__ = ["DATA_KINDS", "DEFAULT_METHOD", "MethodInfo", "Option", "accelerometer_only", "declared", "method_names",
           "markdown_table", "needing", "read_declaration"]

#: the method ``imucalib calibrate`` and :func:`imucalib.calibrate` use when none is named
DEFAULT_METHOD = "tedaldi2014"

#: what a method may need: the kinds of data in :attr:`MethodInfo.needs`
DATA_KINDS = {
    "static poses": "rests in several orientations, found by the static detector",
    "rotations": "the motions between the poses, recorded (the gyroscope's fit integrates them)",
    "six faces": "the six faces of a cube among the poses (each axis up, then down), which alone give the "
                 "accelerometer in closed form",
    "known-angle turns": "a turn by a known angle about each axis while it is vertical",
    "tosses": "optional: spinning weightless tosses (the lever arm)",
    "turntable aggregates": "static position means and clockwise/counter-clockwise turn integrals",
    "gyroscope": "a gyroscope beside the accelerometer",
}


class Option(namedtuple("Option", "name default unit meaning")):
    """One keyword option of a method's ``calibrate``.

    Attributes
    ----------
    name : str
        The keyword.
    default : object
        Its default (``None``: found from the data, see ``meaning``).
    unit : str
        Its unit (``""`` for none).
    meaning : str
        What it sets, in a few words.

    A named tuple rather than a dataclass: :mod:`dataclasses` imports :mod:`inspect`, which the command
    line's start-up (building ``--method``'s help) should not pay for.
    """

    __slots__ = ()


class MethodInfo(namedtuple("MethodInfo", "name summary needs models options paper accelerometer_only",
                            defaults=(False,))):
    """A method's declaration: its name, summary, the data it needs, its models, options and paper.

    Attributes
    ----------
    name : str
        The name :func:`imucalib.calibrate` takes (the module's name).
    summary : str
        One line: what it estimates and how.
    needs : tuple of str
        The data it needs (keys of :data:`DATA_KINDS`).
    models : tuple of str
        Its model variants, the default first (``model=`` of :func:`imucalib.calibrate`).
    options : tuple of Option
        Its keyword options, with defaults and units.
    paper : str
        The paper it implements (file name under the papers' folder, and the section).
    accelerometer_only : bool
        True when it calibrates an accelerometer-only recording (no gyroscope section).
    """

    __slots__ = ()

    def __new__(cls, *args, **kwargs):
        info = super().__new__(cls, *args, **kwargs)
        unknown = [k for k in info.needs if k not in DATA_KINDS]
        if unknown:
            raise ValueError(f"{info.name}: unknown data kinds {unknown}; use those of DATA_KINDS")
        if not info.models:
            raise ValueError(f"{info.name}: a method has at least one model")
        return info

    @property
    def default_model(self) -> str:
        """The model used when none is named."""
        return self.models[0]


METHODS_DIR = Path(__file__).resolve().parent / "methods"
_CONSTRUCTORS = {"MethodInfo": MethodInfo, "Option": Option}


def _value(node: ast.expr):
    """The value of a declaration's expression: literals, and calls of :class:`MethodInfo` and :class:`Option`."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _CONSTRUCTORS:
        return _CONSTRUCTORS[node.func.id](*[_value(a) for a in node.args],
                                           **{k.arg: _value(k.value) for k in node.keywords})
    if isinstance(node, ast.Tuple):
        return tuple(_value(e) for e in node.elts)
    return ast.literal_eval(node)


def _statement(lines: list[str], start: int) -> ast.Module:
    """The statement that begins at ``lines[start]``, parsed (the first of the module parsed from that line on).

    The statement opens a bracket on its first line, so a run of lines that stops inside it leaves the bracket
    (or a string) open and does not parse: a line holding ``)`` inside a string does not end it. The runs
    tried first end on a line that begins with ``)`` (how a declaration laid out one keyword a line closes),
    then on any line holding one.
    """
    ends = [k for k in range(start, len(lines)) if lines[k].startswith(")")]
    for stop in [*ends, *(k for k in range(start, len(lines)) if ")" in lines[k])]:
        try:
            return ast.parse("\n".join(lines[start:stop + 1]))
        except SyntaxError:
            continue
    raise SyntaxError("the statement does not end")


def read_declaration(path: Path) -> MethodInfo | None:
    """The ``METHOD = MethodInfo(...)`` statement of the module at ``path``, or None when it has none."""
    lines = path.read_text(encoding="utf-8").splitlines()
    start = next((i for i, line in enumerate(lines) if line.startswith("METHOD = MethodInfo(")), None)
    if start is None:
        return None
    try:
        tree = _statement(lines, start)
    except SyntaxError:
        raise ValueError(f"{path}: the METHOD declaration does not parse") from None
    return _value(tree.body[0].value)


@cache
def declared() -> dict[str, MethodInfo]:
    """Every method's declaration, by name, in the order of :data:`DEFAULT_METHOD` first, then by name."""
    infos = {}
    for path in sorted(METHODS_DIR.glob("*.py")):
        if path.name.startswith("_"):
            continue
        info = read_declaration(path)
        if info is None:
            continue
        if info.name != path.stem:
            raise ValueError(f"{path}: declares the method {info.name!r}; a method is named as its module")
        infos[info.name] = info
    return dict(sorted(infos.items(), key=lambda kv: (kv[0] != DEFAULT_METHOD, kv[0])))


def method_names() -> list[str]:
    """The names of the declared methods, sorted."""
    return sorted(declared())


def markdown_table() -> str:
    """The README's table of methods, one row per declaration (``python -m imucalib.methodinfo`` prints it)."""
    rows = ["| method | data | models | estimates | paper |", "|---|---|---|---|---|"]
    for name, info in declared().items():
        default = " (default)" if name == DEFAULT_METHOD else ""
        models = ", ".join(f"`{m}`" for m in info.models)
        rows.append(f"| `{name}`{default} | {', '.join(info.needs)} | {models} | {info.summary} | {info.paper} |")
    return "\n".join(rows)


def needing(kind: str) -> tuple[str, ...]:
    """The declared methods that need ``kind`` of data (a key of :data:`DATA_KINDS`), sorted."""
    if kind not in DATA_KINDS:
        raise ValueError(f"unknown data kind {kind!r}; use one of {', '.join(DATA_KINDS)}")
    return tuple(sorted(name for name, info in declared().items() if kind in info.needs))


def accelerometer_only() -> tuple[str, ...]:
    """The declared methods that calibrate an accelerometer-only recording, sorted."""
    return tuple(sorted(name for name, info in declared().items() if info.accelerometer_only))


if __name__ == "__main__":
    print(markdown_table())
