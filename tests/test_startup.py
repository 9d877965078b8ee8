"""Start-up: importing the package or the command line pulls in no heavy dependency; the help needs none."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = str(Path(__file__).resolve().parents[1] / "src")
HEAVY = ("scipy.optimize", "scipy.signal", "scipy.io", "matplotlib", "rosbags", "pandas")


def _modules_after(code: str) -> set[str]:
    """The modules loaded by a fresh interpreter after running ``code`` (this checkout's package)."""
    env = {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}
    out = subprocess.run([sys.executable, "-c", f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"],
                         capture_output=True, text=True, env=env, check=True)
    return set(json.loads(out.stdout.splitlines()[-1]))


@pytest.mark.parametrize("statement", ["import imucalib", "import imucalib.cli", "from imucalib.cli import main"])
def test_import_pulls_in_nothing_heavy(statement):
    loaded = _modules_after(statement)
    assert "imucalib" in loaded
    assert not {m for m in loaded if m.split(".")[0] in ("matplotlib", "rosbags", "pandas", "scipy")}, statement
    assert "numpy" not in loaded, f"{statement} imports numpy"


@pytest.mark.parametrize("argv", [["--version"], ["--help"], ["calibrate", "--help"], ["simulate", "--help"]])
def test_version_and_help_import_no_numpy(argv):
    loaded = _modules_after("import sys\nfrom imucalib.cli import main\n"
                            f"try:\n    main({argv!r})\nexcept SystemExit:\n    pass")
    assert not {m for m in loaded if m.split(".")[0] in ("numpy", "scipy", "matplotlib", "rosbags", "pandas")}


def test_a_command_imports_only_what_it_runs(tmp_path):
    """``export`` of a calibration file reads JSON: no estimator, no scipy.optimize, no simulator."""
    from imucalib.calibration import Calibration
    from imucalib.models import TriadModel

    path = tmp_path / "cal.json"
    Calibration(TriadModel(), TriadModel(), method="tedaldi2014", model="linear").save(path)
    loaded = _modules_after(f"from imucalib.cli import main\nmain(['export', {str(path)!r}, '--format', 'c'])")
    assert not loaded & set(HEAVY)
    assert not {m for m in loaded if m.split(".")[:2] in (["imucalib", "scenarios"], ["imucalib", "fit"],
                                                           ["imucalib", "methods"])}  # (fitreport is the record)


@pytest.mark.parametrize("argv", [["calibrate", "--help"], ["--version"]])
def test_a_command_imports_only_its_own_group(argv):
    from imucalib.cli import GROUPS

    loaded = _modules_after("from imucalib.cli import main\n"
                            f"try:\n    main({argv!r})\nexcept SystemExit:\n    pass")
    groups = {f"imucalib.cli.{g}" for g in GROUPS.values()}
    own = {f"imucalib.cli.{GROUPS[argv[0]]}", "imucalib.cli.apply"} if argv[0] in GROUPS else set()
    assert loaded & groups == own & groups


def test_lazy_names_resolve():
    import imucalib
    import imucalib.io
    from imucalib.recording import STANDARD_GRAVITY, Recording

    assert imucalib.Recording is Recording and imucalib.STANDARD_GRAVITY == STANDARD_GRAVITY
    assert set(imucalib.__all__) <= set(dir(imucalib))
    assert callable(imucalib.io.read) and callable(imucalib.io.write_csv)
    with pytest.raises(AttributeError):
        imucalib.no_such_name  # noqa: B018
    with pytest.raises(AttributeError):
        imucalib.io.no_such_name  # noqa: B018


def test_written_out_constants_agree():
    """The command line spells out two values so that its parser needs no numpy: they must stay the library's."""
    from imucalib.cli import _common, simulation
    from imucalib.recording import STANDARD_GRAVITY
    from imucalib.scenarios import SCENARIOS

    assert _common.STANDARD_GRAVITY == STANDARD_GRAVITY
    assert simulation.SCENARIOS == tuple(SCENARIOS)


@pytest.mark.parametrize("user", [{}, {"OMP_NUM_THREADS": "3"}, {"OPENBLAS_NUM_THREADS": "2"}])
def test_one_blas_thread_unless_the_user_chose(user):
    from imucalib.cli import BLAS_THREAD_VARIABLES

    env = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}
    env |= {"PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", ""), **user}
    code = ("import json, os\nfrom imucalib.cli import main\ntry:\n    main(['--version'])\nexcept SystemExit:\n"
            "    pass\nprint(json.dumps({v: os.environ.get(v) for v in " + repr(BLAS_THREAD_VARIABLES) + "}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    got = json.loads(out.stdout.splitlines()[-1])
    expected = {v: user.get(v) for v in BLAS_THREAD_VARIABLES} if user else dict.fromkeys(BLAS_THREAD_VARIABLES, "1")
    assert got == expected
