"""The README's examples run as written: its shell and Python blocks, in order, in one fresh folder.

A reader starts in an empty folder with the package installed; so does this test. Every ```sh, ```bash
and ```python block runs, in the README's order, in one temporary folder (the blocks of the
usage section continue one session, as the README says), with an ``imucalib`` on the PATH that runs this
checkout. A block the tests cannot run as written (it installs the package, needs a device, or is a recipe
for the reader's own files) is preceded by a ``<!-- not run by tests/test_readme.py: REASON -->`` line, and
those are counted: a new block is run unless it says why not.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SHELLS = ("sh", "bash", "shell")
_FENCE = re.compile(r"^```(\w*)[ \t]*\n(.*?)^```[ \t]*$", re.S | re.M)
_NOT_RUN = re.compile(r"<!-- not run by tests/test_readme\.py: (.+?) -->\s*$")


def fenced_blocks(text: str) -> list[tuple[str, int, str, str | None]]:
    """``(language, line, code, reason)`` of every fenced block, in order; ``reason`` is why it is not run
    (the ``<!-- not run … -->`` comment on the line before the fence), or None."""
    out = []
    for m in _FENCE.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        why = _NOT_RUN.search(before)
        out.append((m.group(1), line, m.group(2), why.group(1) if why else None))
    return out


BLOCKS = fenced_blocks(README.read_text(encoding="utf-8"))
RUN = [(lang, line, code) for lang, line, code, why in BLOCKS if why is None and lang in ("python", *SHELLS)]


def test_the_extractor_finds_blocks_and_their_reasons():
    sample = ("text\n```python\nx = 1\n```\n<!-- not run by tests/test_readme.py: a device -->\n```sh\nls\n```\n"
              "```\ndiagram\n```\n")
    assert fenced_blocks(sample) == [("python", 2, "x = 1\n", None), ("sh", 6, "ls\n", "a device"),
                                     ("", 9, "diagram\n", None)]


def test_the_readme_runs_its_first_session_and_says_why_other_blocks_do_not_run():
    assert [lang for lang, _, _ in RUN].count("python") >= 1 and any(lang in SHELLS for lang, _, _ in RUN)
    assert "imucalib simulate" in next(code for lang, _, code in RUN if lang in SHELLS)
    not_run = [(line, why) for lang, line, _, why in BLOCKS if why is not None]
    assert all(len(why) > 10 for _, why in not_run)
    assert len(not_run) <= 4, not_run  # a new example is run, or says why it cannot be


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


#: the line of the README's "Every input, every command" section: the blocks before it are the first session
EVERY_INPUT = next(k + 1 for k, text in enumerate(README.read_text(encoding="utf-8").splitlines())
                   if text.startswith("### Every input"))


def _run_blocks(blocks, folder: Path, env: dict) -> None:
    for lang, line, code in blocks:
        command = [sys.executable, "-c", code] if lang == "python" else ["bash", "-e", "-o", "pipefail", "-c", code]
        proc = subprocess.run(command, cwd=folder, env=env, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, (f"README.md:{line} ({lang}) exit {proc.returncode}\n{code}\n--- stdout\n"
                                      f"{proc.stdout[-3000:]}\n--- stderr\n{proc.stderr[-3000:]}")


@pytest.mark.slow
def test_readme_first_session_runs_as_written_in_a_fresh_folder(tmp_path):
    """The first session's blocks, as a newcomer runs them first, on their own (the whole README: the test
    below): a documentation page's examples, run by ``.ci/run`` with the other slow tests."""
    folder = tmp_path / "reader"
    folder.mkdir()
    first = [b for b in RUN if b[1] < EVERY_INPUT]
    assert first and "imucalib simulate" in first[0][2]
    _run_blocks(first, folder, _environment(tmp_path))
    assert {"session", "calib.json", "calibration.html", "calibrated.csv"} <= {p.name for p in folder.iterdir()}


@pytest.mark.slow
def test_readme_blocks_run_as_written_in_a_fresh_folder(tmp_path):
    folder = tmp_path / "reader"
    folder.mkdir()
    _run_blocks(RUN, folder, _environment(tmp_path))
    made = {p.name for p in folder.iterdir()}
    assert {"session", "calib.json", "calibration.html", "calibrated.csv", "calib_py.json"} <= made, made
    # the section on every input and command continues the session: its exports, checks and simulations
    assert {"accel.json", "fit.png", "imu_calibration.h", "kalibr_imu_chain.yaml", "calib-imu.yaml",
            "accel_acc.calib", "check.png", "allan.png", "thermal.json", "thermal_combined.json",
            "fleet.sqlite", "imu-0042-hot.json"} <= made, made
