"""One declaration per method: read from the source without importing it, the same as the imported module's,
true to its ``calibrate``, and the source of the registry, the command line's help and the README's table."""

import importlib
import inspect
import re
from pathlib import Path

import pytest

from imucalib import methodinfo
from imucalib.methodinfo import DEFAULT_METHOD, MethodInfo, declared, markdown_table, needing

ROOT = Path(__file__).resolve().parents[1]
NAMES = list(declared())


def test_every_method_module_declares_itself():
    modules = sorted(p.stem for p in methodinfo.METHODS_DIR.glob("*.py") if not p.name.startswith("_"))
    assert sorted(NAMES) == modules
    assert DEFAULT_METHOD in NAMES


@pytest.mark.parametrize("name", NAMES)
def test_the_declaration_read_from_source_is_the_modules_own(name):
    module = importlib.import_module(f"imucalib.methods.{name}")
    assert isinstance(module.METHOD, MethodInfo)
    assert module.METHOD == declared()[name]


@pytest.mark.parametrize("name", NAMES)
def test_declared_options_are_the_keywords_of_calibrate_with_their_defaults(name):
    module = importlib.import_module(f"imucalib.methods.{name}")
    params = inspect.signature(module.calibrate).parameters
    keywords = {k: p.default for k, p in params.items() if p.kind is p.KEYWORD_ONLY}
    info = declared()[name]
    declared_options = {o.name: o.default for o in info.options}
    # every keyword but the shared ones (gravity, progress, the model) is declared, with its default
    assert set(keywords) - {"gravity", "progress", "model"} == set(declared_options)
    for key, default in declared_options.items():
        assert keywords[key] == default, (name, key)
    if "model" in keywords:
        assert keywords["model"] == info.default_model


def test_zhang2021_declares_its_models():
    from imucalib.methods import zhang2021

    assert set(declared()["zhang2021"].models) == set(zhang2021.MODELS)


def test_the_registry_is_built_from_the_declarations():
    from imucalib.methods import ACCELEROMETER_ONLY, METHODS, method_names

    assert list(METHODS) == NAMES and method_names() == sorted(NAMES)
    assert all(module.METHOD == declared()[name] and callable(module.calibrate) for name, module in METHODS.items())
    assert set(ACCELEROMETER_ONLY) == {n for n, i in declared().items() if i.accelerometer_only}
    assert needing("six faces") == ("ferraris", "six_position")
    assert needing("turntable aggregates") == ("wang2019",)


def test_the_readme_table_is_the_registrys():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index("| method | data | models |")
    table = text[start:text.index("\n\n", start)]
    assert table == markdown_table(), "README's table of methods differs: paste `python -m imucalib.methodinfo`"
    assert re.findall(r"^\| `(\w+)`", table, flags=re.M) == NAMES


def test_the_command_line_help_names_every_method(capsys):
    from imucalib.cli import main

    with pytest.raises(SystemExit):
        main(["calibrate", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert f"(default: {DEFAULT_METHOD};" in out
    for name in NAMES:
        assert name in out


def test_a_bad_declaration_is_refused(tmp_path):
    with pytest.raises(ValueError, match="unknown data kinds"):
        MethodInfo(name="x", summary="", needs=("telepathy",), models=("linear",), options=(), paper="")
    path = tmp_path / "m.py"
    path.write_text('import os\n\nMETHOD = MethodInfo(\n    name="m",\n    summary="s",\n    needs=(os.sep,),\n)\n')
    with pytest.raises(ValueError):
        methodinfo.read_declaration(path)


def test_a_declaration_is_read_to_its_closing_bracket_whatever_its_layout(tmp_path):
    path = tmp_path / "m.py"
    path.write_text('METHOD = MethodInfo(name="m", summary="""a summary\n)\n(""",\n    needs=("gyroscope",),'
                    ' models=("linear",), options=(Option("k", 2.0, "s", "a (bracket"),), paper="p")  # )\n'
                    "X = (\n)\n")
    info = methodinfo.read_declaration(path)
    assert info.summary == "a summary\n)\n(" and info.options[0].default == 2.0 and info.paper == "p"
