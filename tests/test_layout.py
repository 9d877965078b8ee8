"""The package's layout rules (``tools/check_layout.py``) hold, and the checker catches each kind of violation."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "src" / "imucalib"


def _load_checker() -> ModuleType:
    spec = importlib.util.spec_from_file_location("check_layout", ROOT / "tools" / "check_layout.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look the module up while the class is built
    spec.loader.exec_module(module)
    return module


layout = _load_checker()


def make_package(base: Path, files: dict[str, str], name: str = "pkg") -> Path:
    """Write a package ``base/name`` holding ``files`` (relative path → source); every folder gets an ``__init__``."""
    root = base / name
    root.mkdir()
    (root / "__init__.py").write_text("")
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        for folder in path.relative_to(root).parents:
            init = root / folder / "__init__.py"
            if not init.exists():
                init.write_text("")
        path.write_text(text)
    return root


#: a small package that follows every rule
CLEAN = {
    "segment.py": "import numpy as np\n\n\ndef poses():\n    return np.zeros(3)\n",
    "models.py": "from dataclasses import dataclass\n",
    "fit/accelerometer.py": "from ..models import dataclass\nfrom ..segment import poses\n",
    "methods/__init__.py": "def run(name):\n    from . import alpha\n    from . import beta\n    return alpha, beta\n",
    "methods/alpha.py": "from ..fit.accelerometer import poses\nfrom ..segment import poses as p\nimport pkg.models\n",
    "methods/beta.py": "from .. import segment\nfrom ..fit import accelerometer\n",
    "scenarios/__init__.py": "from . import paper\nfrom .paper import session\n",
    "scenarios/paper.py": "from ..methods.alpha import poses\n\n\ndef session():\n    pass\n",
    "cli/__init__.py": "from .run import main\n",
    "cli/run.py": "from ..methods import run\n\n\ndef main():\n    run('alpha')\n",
}


def test_real_package_follows_the_layout_rules(scanned):
    violations = layout.violations(scanned)
    assert violations == [], "layout violations in src/imucalib:\n" + "\n".join(violations)


def test_clean_synthetic_package_passes(tmp_path, capsys):
    root = make_package(tmp_path, CLEAN)
    assert layout.check(root) == []
    assert layout.main([str(root)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("layout ok: 12 modules, ")


# ------------------------------------------------------------------------------------------------- methods


@pytest.mark.parametrize("source", [
    "from .beta import x\n",
    "from . import beta\n",
    "from pkg.methods.beta import x\n",
    "import pkg.methods.beta\n",
    "from ..methods import beta\n",
])
def test_method_importing_another_method_is_caught(tmp_path, source):
    root = make_package(tmp_path, {**CLEAN, "methods/alpha.py": "import numpy\n" + source})
    violations = layout.check(root)
    assert len(violations) == 1, violations
    assert violations[0].startswith("method imports another method: pkg.methods.alpha → pkg.methods.beta")
    assert violations[0].endswith(f"{root / 'methods' / 'alpha.py'}:2)")


def test_function_local_method_import_is_caught(tmp_path):
    source = "def calibrate(x):\n    if x:\n        from .beta import helper\n        return helper(x)\n"
    root = make_package(tmp_path, {**CLEAN, "methods/alpha.py": source})
    violations = layout.check(root)
    assert [v.split(" (")[0] for v in violations] == [
        "method imports another method: pkg.methods.alpha → pkg.methods.beta"]
    assert violations[0].endswith("alpha.py:3)")


@pytest.mark.parametrize("source", ["from .. import methods\n", "import pkg.methods\n", "from ..methods import run\n"])
def test_method_importing_the_methods_package_is_caught(tmp_path, source):
    root = make_package(tmp_path, {**CLEAN, "methods/alpha.py": source})
    # the registry imports alpha, so this is a cycle as well
    assert [v.split(" (")[0] for v in layout.check(root)] == [
        "method imports the methods package: pkg.methods.alpha → pkg.methods",
        "import cycle: pkg.methods → pkg.methods.alpha → pkg.methods"]


def test_modules_inside_one_method_package_may_import_each_other(tmp_path):
    files = {**CLEAN, "methods/gamma/__init__.py": "from .solver import solve\n",
             "methods/gamma/solver.py": "from ..gamma import helpers\n", "methods/gamma/helpers.py": ""}
    root = make_package(tmp_path, files)
    assert layout.check(root) == []
    files["methods/gamma/helpers.py"] = "from ..alpha import poses\n"
    (tmp_path / "again").mkdir()
    root = make_package(tmp_path / "again", files)
    assert [v.split(" (")[0] for v in layout.check(root)] == [
        "method imports another method: pkg.methods.gamma.helpers → pkg.methods.alpha"]


@pytest.mark.parametrize(("source", "target"), [
    ("from ..scenarios.paper import session\n", "pkg.scenarios.paper"),
    ("from ..scenarios import paper\n", "pkg.scenarios.paper"),
    ("from ..scenarios import session\n", "pkg.scenarios"),
    ("import pkg.scenarios\n", "pkg.scenarios"),
    ("def f():\n    from ..simulate import session\n", "pkg.simulate"),
])
def test_method_importing_a_scenario_or_simulator_is_caught(tmp_path, source, target):
    root = make_package(tmp_path, {**CLEAN, "simulate.py": "", "methods/beta.py": source})
    violations = layout.check(root)
    assert [v.split(" (")[0] for v in violations] == [f"method imports scenario: pkg.methods.beta → {target}"]


def test_registry_may_import_methods_but_not_scenarios(tmp_path):
    registry = CLEAN["methods/__init__.py"] + "\n\ndef cases():\n    from ..scenarios import paper\n"
    root = make_package(tmp_path, {**CLEAN, "methods/__init__.py": registry})
    assert [v.split(" (")[0] for v in layout.check(root)] == [
        "registry imports scenario: pkg.methods → pkg.scenarios.paper"]


def test_other_modules_may_import_methods_and_scenarios(tmp_path):
    files = {**CLEAN, "evaluate.py": "from .methods import alpha, beta\nfrom .scenarios.paper import session\n"}
    assert layout.check(make_package(tmp_path, files)) == []


# -------------------------------------------------------------------------------------------------- cycles


def test_two_module_cycle_is_caught(tmp_path):
    files = {**CLEAN, "a.py": "import os\nfrom .b import y\n", "b.py": "def g():\n    from .a import x\n"}
    root = make_package(tmp_path, files)
    violations = layout.check(root)
    assert len(violations) == 1, violations
    message = violations[0]
    assert message.startswith("import cycle: pkg.a → pkg.b → pkg.a (")
    assert f"{root / 'a.py'}:2" in message and f"{root / 'b.py'}:2" in message


def test_three_module_cycle_across_subpackages_is_caught(tmp_path):
    files = {**CLEAN,
             "io/readers.py": "from ..plans import plan\n",
             "plans.py": "from .report import show\n",
             "report.py": "from .io import readers\n"}
    violations = layout.check(make_package(tmp_path, files))
    assert [v.split(" (")[0] for v in violations] == [
        "import cycle: pkg.io.readers → pkg.plans → pkg.report → pkg.io.readers"]


def test_cycle_through_a_package_init_is_caught(tmp_path):
    files = {**CLEAN, "segment.py": "from .fit import SENSORS\n",
             "fit/__init__.py": "from ..segment import poses\n\nSENSORS = ()\n"}
    violations = layout.check(make_package(tmp_path, files))
    assert [v.split(" (")[0] for v in violations] == ["import cycle: pkg.fit → pkg.segment → pkg.fit"]


def test_each_cycle_of_a_larger_component_is_reported():
    graph = {"a": {"b"}, "b": {"a", "c"}, "c": {"d"}, "d": {"b"}, "e": {"a"}, "f": set()}
    assert layout.strongly_connected(graph)[0] == ["a", "b", "c", "d"]
    assert layout.find_cycles(graph) == [["a", "b", "a"], ["b", "c", "d", "b"]]


def test_a_module_importing_its_own_package_names_is_no_cycle(tmp_path):
    files = {**CLEAN, "io/__init__.py": "VERSION = 1\nfrom . import VERSION as V\n"}
    assert layout.check(make_package(tmp_path, files)) == []


# ----------------------------------------------------------------------------------------------------- CLI


@pytest.mark.parametrize("rel", ["cli/run.py", "cli/__init__.py"])
def test_cli_package_file_of_401_lines_is_caught_and_400_passes(tmp_path, rel):
    body = CLEAN[rel]
    filler = lambda n: body + "#\n" * (n - body.count("\n"))  # noqa: E731
    root = make_package(tmp_path, {**CLEAN, rel: filler(400)})
    assert layout.check(root) == []
    (root / rel).write_text(filler(401))
    assert layout.check(root) == [f"cli file too long: {root / rel} has 401 lines (max 400)"]


def test_single_cli_module_of_401_lines_is_caught(tmp_path):
    files = {k: v for k, v in CLEAN.items() if not k.startswith("cli/")}
    root = make_package(tmp_path, {**files, "cli.py": "x = 1\n" * 400})
    assert layout.check(root) == []
    (root / "cli.py").write_text("x = 1\n" * 401)
    assert layout.check(root) == [f"cli file too long: {root / 'cli.py'} has 401 lines (max 400)"]


def test_only_cli_files_are_limited(tmp_path):
    root = make_package(tmp_path, {**CLEAN, "report.py": "x = 1\n" * 1000})
    assert layout.check(root) == []


# ----------------------------------------------------------------------------------------- import resolution


def test_from_dot_import_resolves_to_the_submodule_else_the_package(tmp_path):
    files = {**CLEAN, "methods/alpha.py": "from . import beta\nfrom . import run\nfrom .. import segment, models\n"}
    scanned = layout.scan(make_package(tmp_path, files))
    assert scanned.graph()["pkg.methods.alpha"] == {"pkg.methods.beta", "pkg.methods", "pkg.segment", "pkg.models"}
    assert scanned.graph()["pkg.scenarios"] == {"pkg.scenarios.paper"}


def test_no_implicit_edges_to_parent_packages_and_outside_imports_ignored(tmp_path):
    files = {**CLEAN,
             "report.py": "import os.path\nfrom scipy import linalg\nimport pkg.fit.accelerometer\n"}
    scanned = layout.scan(make_package(tmp_path, files))
    assert scanned.graph()["pkg.report"] == {"pkg.fit.accelerometer"}
    assert scanned.graph()["pkg.fit.accelerometer"] == {"pkg.models", "pkg.segment"}


def test_missing_module_and_unreadable_file_are_reported(tmp_path):
    files = {**CLEAN, "report.py": "from .nowhere import x\n", "broken.py": "def (:\n"}
    violations = layout.check(make_package(tmp_path, files))
    assert len(violations) == 2, violations
    assert violations[0].startswith("unreadable: ") and "broken.py" in violations[0]
    assert violations[1].startswith("missing module: pkg.report imports pkg.nowhere (")


def test_main_prints_each_violation_and_exits_1(tmp_path, capsys):
    files = {**CLEAN, "methods/alpha.py": "from .beta import x\n",
             "a.py": "from .b import y\n", "b.py": "from .a import x\n"}
    root = make_package(tmp_path, files)
    assert layout.main([str(root)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(":")[0] for line in lines] == ["method imports another method", "import cycle"]


# -------------------------------------------------------------------------------------------------- floors
#: floors of the synthetic package: models below segment, segment below methods, methods below cli
PKG_FLOORS = (
    ("base", "", ("models",)),
    ("stages", "", ("segment", "fit")),
    ("simulators", "", ("scenarios",)),
    ("methods", "", ("methods",)),
    ("top", "", ("", "cli")),
)
#: CLEAN without its scenario's import of a method (which these floors forbid)
FLOORED = {**CLEAN, "scenarios/paper.py": "from ..segment import poses\n\n\ndef session():\n    pass\n"}


def test_clean_synthetic_package_on_floors_passes(tmp_path):
    assert layout.check(make_package(tmp_path, FLOORED), floors=PKG_FLOORS) == []


@pytest.mark.parametrize("rel, source, target", [
    ("scenarios/paper.py", "from ..methods.alpha import poses\n", "pkg.methods.alpha"),
    ("models.py", "def f():\n    from .segment import poses\n", "pkg.segment"),
    ("fit/accelerometer.py", "import pkg.scenarios.paper\n", "pkg.scenarios.paper"),
    ("fit/accelerometer.py", "from .. import scenarios\n", "pkg.scenarios"),
])
def test_an_import_that_runs_up_is_caught(tmp_path, rel, source, target):
    root = make_package(tmp_path, {**FLOORED, rel: source})
    found = layout.check(root, floors=PKG_FLOORS)
    assert len(found) == 1 and found[0].startswith("import runs up: ") and f"→ {target} " in found[0], found


def test_a_module_on_no_floor_is_caught_and_the_longest_prefix_decides(tmp_path):
    root = make_package(tmp_path, {**FLOORED, "extra.py": "", "fit/low.py": ""})
    floors = (("base", "", ("models", "fit.low")), *PKG_FLOORS[1:])
    found = layout.check(root, floors=floors)
    assert found == [f"module on no floor: pkg.extra ({layout._display(root / 'extra.py')}); add it to FLOORS"]
    scanned = layout.scan(root)
    assert layout.floor_of(scanned, "pkg.fit.low", floors) == 0
    assert layout.floor_of(scanned, "pkg.fit.accelerometer", floors) == 1
    assert layout.floor_of(scanned, "pkg", floors) == 4


def test_floors_apply_to_the_real_package_by_default_and_to_no_other(tmp_path):
    root = make_package(tmp_path, CLEAN)  # its scenario imports a method: fine without floors
    assert layout.check(root) == []
    assert layout.check(root, floors=PKG_FLOORS)[0].startswith("import runs up: pkg.scenarios.paper")
    assert layout.FLOORS_PACKAGE == PACKAGE.name


@pytest.fixture(scope="module")
def scanned() -> layout.Layout:
    """The real package scanned once for the tests that read its modules and imports (~1.3 s a scan)."""
    return layout.scan(PACKAGE)


def test_the_real_floors_keep_simulators_below_methods_and_experiments_above(scanned):
    names = [name for name, _, _ in layout.FLOORS]
    assert names.index("readers") < names.index("sessions") < names.index("simulators") \
        < names.index("methods") < names.index("experiments")
    where = {m: layout.floor_of(scanned, m) for m in scanned.modules}
    assert None not in where.values()
    assert names[where["imucalib.reading"]] == "sessions" and names[where["imucalib.io.sessionfiles"]] == "readers"
    assert {names[f] for m, f in where.items() if m == "imucalib.io" or m.startswith("imucalib.io.")} == {"readers"}
    assert not [m for _, _, modules in layout.FLOORS for m in modules if m.startswith("io.")]  # io is one floor
    table = layout.floor_table()
    assert table.splitlines()[1].split()[1] == "interface" and table.splitlines()[-1].split()[1] == "foundations"


def test_the_calibration_record_sits_below_the_estimators_and_no_fit_imports_the_segmentation(scanned):
    """The record below every stage that takes a calibration; the fits below the segmentation that runs them."""
    names = [name for name, _, _ in layout.FLOORS]
    floor = {m: names[layout.floor_of(scanned, m)] for m in scanned.modules}
    below = names.index("records")
    for user in ("imucalib.verdict", "imucalib.thermal", "imucalib.metrics", "imucalib.fit.magnetometer",
                 "imucalib.segment"):
        assert names.index(floor[user]) > below, user
    assert floor["imucalib.calibration"] == "records" and floor["imucalib.models"] == "foundations"
    assert names.index("fits") < names.index("segmentation")
    fits = [i for i in scanned.imports
            if i.source.startswith("imucalib.fit") and i.target.startswith("imucalib.segment")]
    assert fits == []


def test_a_fit_importing_the_segmentation_is_caught(tmp_path):
    floors = (("base", "", ("models",)), ("fits", "", ("fit",)), ("segmentation", "", ("segment",)),
              ("top", "", ("", "methods", "scenarios", "cli")))
    root = make_package(tmp_path, {"models.py": "", "fit/accelerometer.py": "from ..segment import poses\n",
                                   "segment.py": "def poses():\n    pass\n"})
    found = layout.check(root, floors=floors)
    assert len(found) == 1 and found[0].startswith("import runs up: pkg.fit.accelerometer"), found


# -------------------------------------------------------------------------------------------- private names
@pytest.mark.parametrize("rel, source, message", [
    ("cli/run.py", "from ..segment import _helper\n", "private name imported from another module: pkg.cli.run → "
                                                       "pkg.segment._helper"),
    ("cli/run.py", "def f():\n    from pkg.models import _x, y\n", "private name imported from another module"),
    ("segment.py", "from .cli._common import x\n", "private module imported from outside its package: pkg.segment"),
    ("segment.py", "from .cli import _common\n", "private module imported from outside its package: pkg.segment"),
])
def test_a_private_import_across_modules_is_caught(tmp_path, rel, source, message):
    root = make_package(tmp_path, {**CLEAN, "cli/_common.py": "x = 1\n", rel: source})
    found = layout.check(root)
    assert len(found) == 1 and found[0].startswith(message), found


def test_private_modules_inside_their_package_and_dunders_pass(tmp_path):
    files = {**CLEAN, "cli/_common.py": "x = 1\n", "cli/__init__.py": "from ._common import x\nfrom .run import main\n",
             "cli/run.py": "from . import _common\nfrom ._common import x\nfrom .. import __name__ as n\n"}
    assert layout.check(make_package(tmp_path, files)) == []


def test_main_prints_the_floors_table(capsys):
    assert layout.main(["--floors", str(PACKAGE)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:3] == ["#", "floor", "modules"] and out[-1].startswith("layout ok: ")
