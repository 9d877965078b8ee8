"""The command line as a package over library functions: imports one way, choices from the library."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from imucalib.calibration import Calibration
from imucalib.cli import build_parser, main
from imucalib.io import read, write_csv
from synth import tedaldi_session

PACKAGE = Path(__file__).resolve().parent.parent / "src" / "imucalib"


def _imports(path: Path, package: str) -> set[str]:
    """Absolute names of the modules ``path`` (a module of ``package``) imports."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[: len(base) - node.level + 1]
                name = ".".join([*base, node.module] if node.module else base)
            else:
                name = node.module or ""
            out.add(name)
            out.update(f"{name}.{a.name}" for a in node.names)
    return out


def _package_of(path: Path) -> str:
    """The package a module file belongs to (a package's ``__init__`` belongs to the package itself)."""
    return ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts[:-1])


def test_library_never_imports_the_command_line():
    for path in PACKAGE.rglob("*.py"):
        if "cli" in path.relative_to(PACKAGE).parts:
            continue
        bad = {n for n in _imports(path, _package_of(path)) if n == "imucalib.cli" or n.startswith("imucalib.cli.")}
        assert not bad, f"{path.relative_to(PACKAGE)} imports {sorted(bad)}"


def test_common_imports_no_command_module():
    names = _imports(PACKAGE / "cli" / "_common.py", "imucalib.cli")
    assert not {n for n in names if n.startswith("imucalib.cli")}


def test_scenario_choices_follow_the_library(monkeypatch):
    import imucalib.scenarios as scenarios

    monkeypatch.setitem(scenarios.SCENARIOS, "bench_test", scenarios.SCENARIOS["zhang2021"])

    def choices(command: str) -> list[str]:
        sub = next(a for a in build_parser()._actions if a.dest == "command").choices[command]
        return list(next(a for a in sub._actions if a.dest == "scenario").choices)

    assert choices("simulate") == [*scenarios.SCENARIOS, "wang2019"]
    assert choices("montecarlo") == [*scenarios.SCENARIOS, "wang2019", "qureshi2017"]


def test_validate_is_the_library_function(capsys, tmp_path):
    from imucalib.methods import calibrate
    from imucalib.validation import validate

    rec, truth, _ = tedaldi_session(seed=12, noise_acc=0.003, noise_gyro=0.002)
    calibrate(rec, method="tedaldi2014", gravity=truth.gravity).save(tmp_path / "c.json")
    cal = Calibration.load(tmp_path / "c.json")
    write_csv(tmp_path / "second.csv", tedaldi_session(truth, seed=13, noise_acc=0.003, noise_gyro=0.002)[0])
    result = validate(cal, read(tmp_path / "second.csv"))  # the recording the command reads
    assert result["gravity"] == cal.gravity and result["static_intervals"] == len(result["intervals"]) >= 20
    assert result["at_calibration"]["static_intervals"] == cal.fit["static_intervals"]
    assert result["temperature_c"] is None
    assert main(["validate", str(tmp_path / "c.json"), str(tmp_path / "second.csv"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    result.pop("intervals")
    assert doc == {"calibration": str(tmp_path / "c.json"), **json.loads(json.dumps(result))}


def test_wang2019_session_written_and_read_back(tmp_path):
    from imucalib.scenarios import read_session, write_session
    from imucalib.scenarios.wang2019 import session

    sim = session(5, dwell_s=10.0)
    assert sim.seed == 5
    write_session(sim, tmp_path / "w")
    meta = json.loads((tmp_path / "w" / "session.json").read_text(encoding="utf-8"))
    assert meta["scenario"] == "wang2019" and meta["seed"] == 5 and meta["turntable_error"] == "3arcsec"
    back = read_session(tmp_path / "w")
    for name in ("positions_acc", "positions_gyro", "turn_sum", "turn_sum2", "turn_angle"):
        np.testing.assert_array_equal(getattr(back, name), getattr(sim, name))
    assert back.seed == 5 and back.options == json.loads(json.dumps(sim.options))
    assert isinstance(back.truth, Calibration)


def test_python_dash_m_runs_the_command():
    done = subprocess.run([sys.executable, "-m", "imucalib.cli", "--version"], capture_output=True, text=True,
                          check=False)
    assert done.returncode == 0 and done.stdout.startswith("imucalib ")


def test_each_command_parses_alike_with_its_group_alone():
    """A command's parser built with only its group is the one built with every group: same help, same choices."""
    from imucalib.cli import GROUPS

    def commands(parser) -> dict:
        return next(a for a in parser._actions if a.dest == "command").choices

    full = commands(build_parser())
    assert list(full) == list(GROUPS)  # every command has its group, in the order of the help
    for command, group in GROUPS.items():
        alone = commands(build_parser(command))
        assert set(alone) == {c for c, g in GROUPS.items() if g == group}, command
        assert alone[command].format_help() == full[command].format_help(), command
    assert commands(build_parser("")) == {}
