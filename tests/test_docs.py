"""The documentation's examples run, and its pages name everything they claim to cover.

Every ``.. code-block:: python`` and ``.. code-block:: console`` of a page in
``docs/`` runs here, in order, in a fresh folder holding the files of
``docs/examples`` (and the shared Xsens recording when the page uses it): the
Python blocks of a page share one namespace, as in a session; each console
block runs as one bash script (``set -e``), its ``$ `` lines being the
commands (a line ending in ``\\`` continues on the next), every other line
output shown to the reader. An ``imucalib`` on the PATH runs this checkout's
code.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
EXAMPLES = DOCS / "examples"
DATA = ROOT.parent / "shared" / "data" / "xsens_imu_tk"
XSENS = ("xsens_acc.mat", "xsens_gyro.mat")
#: packages of the optional extras an example may need (the test extra installs them all)
OPTIONAL = {"matplotlib", "pandas", "rosbags", "dask", "distributed", "fsspec", "tqdm"}

PAGES = sorted(p for p in DOCS.rglob("*.rst") if not {"_build", "_generated"} & set(p.relative_to(DOCS).parts))
_DIRECTIVE = re.compile(r"^(\s*)\.\. code-block:: *(\w+)\s*$")


def code_blocks(path: Path) -> list[tuple[str, int, str]]:
    """``(language, line, text)`` of every code block of an RST page, the text dedented."""
    lines = path.read_text(encoding="utf-8").splitlines()
    out = []
    i = 0
    while i < len(lines):
        m = _DIRECTIVE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, lang, start = len(m.group(1)), m.group(2), i + 1
        i += 1
        while i < len(lines) and lines[i].strip().startswith(":"):  # the directive's options
            i += 1
        body = []
        while i < len(lines) and (not lines[i].strip() or len(lines[i]) - len(lines[i].lstrip()) > indent):
            body.append(lines[i])
            i += 1
        while body and not body[-1].strip():
            body.pop()
        cut = min((len(b) - len(b.lstrip()) for b in body if b.strip()), default=0)
        out.append((lang, start, "\n".join(b[cut:] for b in body).strip("\n")))
    return out


def console_script(text: str) -> str:
    """The commands of a console block (``$ `` lines and their continuations) as a bash script."""
    commands, continued = [], False
    for line in text.splitlines():
        if continued:
            commands.append(line)
        elif line.startswith("$ "):
            commands.append(line[2:])
        else:
            continue
        continued = line.rstrip().endswith("\\")
    return "\n".join(commands)


def _environment(tmp: Path) -> dict:
    """PATH with an ``imucalib`` that runs this checkout, PYTHONPATH with its ``src``."""
    bindir = tmp / ".bin"
    bindir.mkdir()
    wrapper = bindir / "imucalib"
    wrapper.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m imucalib.cli "$@"\n')
    wrapper.chmod(0o755)
    env = dict(os.environ)
    env["PATH"] = f"{bindir}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), *filter(None, [env.get("PYTHONPATH")])])
    env["MPLBACKEND"] = "Agg"
    return env


def test_the_block_parser_reads_options_continuations_and_output(tmp_path):
    page = tmp_path / "p.rst"
    page.write_text("Text\n\n.. code-block:: console\n   :caption: x\n\n   $ imucalib plan \\\n"
                    "       --method six_position\n   output line\n\n   $ echo two\n\nAfter\n\n"
                    ".. code-block:: python\n\n   a = 1\n\n   b = a + 1\n")
    blocks = code_blocks(page)
    assert [(lang, line) for lang, line, _ in blocks] == [("console", 3), ("python", 14)]
    assert console_script(blocks[0][2]) == "imucalib plan \\\n    --method six_position\necho two"
    assert blocks[1][2] == "a = 1\n\nb = a + 1"


def test_there_are_pages_with_examples():
    names = {p.relative_to(DOCS).as_posix() for p in PAGES}
    assert {"index.rst", "architecture.rst", "api.rst", "guide/recording.rst", "guide/methods.rst",
            "guide/verdict.rst", "guide/formats.rst", "guide/exports.rst", "guide/thermal_magnetometer.rst",
            "guide/fleets.rst"} <= names
    assert sum(len(code_blocks(p)) for p in PAGES) >= 20


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if code_blocks(p)], ids=lambda p: p.relative_to(DOCS).as_posix())
def test_page_examples_run(page, tmp_path, monkeypatch):
    blocks = [b for b in code_blocks(page) if b[0] in ("python", "console")]
    if not blocks:
        pytest.skip("no runnable examples")
    if any(name in code for _, _, code in blocks for name in XSENS):
        if not DATA.is_dir():
            pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): the page's real-data examples "
                        "cannot run")
        for name in XSENS:
            (tmp_path / name).symlink_to(DATA / name)
    for f in EXAMPLES.iterdir():
        (shutil.copytree if f.is_dir() else shutil.copy)(f, tmp_path / f.name)
    env = _environment(tmp_path)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict = {"__name__": "__docs__"}
    where = page.relative_to(ROOT)
    for lang, line, code in blocks:
        if lang == "python":
            try:
                exec(compile(code, f"{where}:{line}", "exec"), namespace)  # noqa: S102
            except ModuleNotFoundError as exc:
                if exc.name not in OPTIONAL:
                    raise
                pytest.skip(f"{where}:{line} needs {exc.name}, from an optional extra that is not installed")
            continue
        script = console_script(code)
        assert script, f"{where}:{line}: a console block without a '$ ' command"
        run = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", script], cwd=tmp_path, env=env,
                             capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, (f"{where}:{line}: exit {run.returncode}\n{script}\n--- stdout\n"
                                     f"{run.stdout[-3000:]}\n--- stderr\n{run.stderr[-3000:]}")


# ------------------------------------------------------------- what the pages must name
def _page(name: str) -> str:
    return (DOCS / name).read_text(encoding="utf-8")


def test_the_verdict_page_names_every_threshold():
    from imucalib.verdict import THRESHOLDS

    text = _page("guide/verdict.rst")
    assert [k for k in THRESHOLDS if f"``{k}``" not in text] == []


def test_every_reader_method_and_export_format_has_its_section():
    from imucalib.export import FORMATS
    from imucalib.io import READERS
    from imucalib.methods import method_names

    formats, methods, exports = _page("guide/formats.rst"), _page("guide/methods.rst"), _page("guide/exports.rst")
    assert [r for r in (*READERS, "session") if f"(``{r}``" not in formats] == []
    assert [m for m in method_names() if f"* - ``{m}``" not in methods] == []
    assert [f for f in FORMATS if f"* - ``{f}``" not in exports] == []


def test_the_architecture_page_names_every_command_and_exit_code():
    from imucalib.cli import build_parser
    from imucalib.cli._common import EXIT_ERROR, EXIT_INTERRUPTED, EXIT_REJECTED

    text = _page("architecture.rst")
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert [c for c in sub.choices if f"``{c}``" not in text] == []
    for code in (0, EXIT_ERROR, EXIT_REJECTED, EXIT_INTERRUPTED):
        assert f"   * - {code}\n" in text


def _declared_fit_keys() -> set[str]:
    """Every key a calibration's ``fit`` may hold: the fields of the fit report's records (imucalib.fitreport)."""
    from imucalib.reportfields import FIELDS

    return {f.name for f in FIELDS}


def test_the_calibration_file_section_names_every_entry():
    import warnings

    from imucalib.methods import calibrate
    from imucalib.scenarios import session

    text = _page("architecture.rst")
    fit_text = text[text.index(".. _calibration-file:"):text.index("The command line\n")]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = session("handheld", rng=4, magnetometer=True, temperature=30.0, n_poses=16)
        doc = calibrate(sim.recording, method="tedaldi2014").to_dict()
    names = set(doc) | set(doc["accelerometer"]) | set(doc["gyroscope"]) | set(doc["magnetometer"])
    names |= set(doc["fit"]) | _declared_fit_keys()
    # "``magnetometer_direction_error_mean_deg`` and ``_max_deg``" names the pair
    missing = sorted(n for n in names if f"``{n}``" not in fit_text
                     and not (n.endswith("_max_deg") and f"``{n[:-len('max_deg')]}mean_deg`` and ``_max_deg``"
                              in " ".join(fit_text.split())))
    assert missing == []
    assert len(_declared_fit_keys()) > 80


def test_the_architecture_page_has_the_floors_of_check_layout():
    """Every floor of ``tools/check_layout.py``, top first, numbered as ``--floors`` prints them, with its modules."""
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        from check_layout import FLOORS
    finally:
        sys.path.remove(str(ROOT / "tools"))
    text = _page("architecture.rst")
    table = text[text.index(".. _floors:"):text.index("The data model\n")]
    rows = re.findall(r"^   \* - (\d+)\n     - (\w+)\n     - (.*?)\n     - ", table, flags=re.M | re.S)
    expected = [(str(i), name, [m or "(package)" for m in modules]) for i, (name, _, modules) in enumerate(FLOORS)]
    found = [(i, name, re.findall(r"``([\w.]+)``|(\(package\))", cells)) for i, name, cells in rows]
    found = [(i, name, [a or b for a, b in cells]) for i, name, cells in found]
    assert found == expected[::-1]
