"""Every ```python block of the README runs as written, in a folder holding the shared Xsens files."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "xsens_imu_tk"
README = ROOT / "README.md"


def python_blocks(text: str) -> list[tuple[int, str]]:
    """``(line, code)`` of every fenced block opened by ```python, in order."""
    out = []
    for m in re.finditer(r"^```python[ \t]*\n(.*?)^```[ \t]*$", text, re.S | re.M):
        out.append((text.count("\n", 0, m.start()) + 1, m.group(1)))
    return out


BLOCKS = python_blocks(README.read_text(encoding="utf-8"))


def test_the_readme_has_python_blocks_and_the_extractor_finds_them():
    assert BLOCKS, "no ```python block found in README.md"
    sample = "text\n```python\nx = 1\n```\n```sh\nls\n```\n```python\ny = 2\n```\n"
    assert python_blocks(sample) == [(2, "x = 1\n"), (8, "y = 2\n")]


@pytest.mark.parametrize("line, code", BLOCKS, ids=[f"README.md:{line}" for line, _ in BLOCKS])
def test_readme_python_block_runs(line, code, tmp_path):
    if not (DATA / "xsens_acc.mat").is_file():
        pytest.skip(f"{DATA} not present (fresh clone): the README's blocks read the shared Xsens files")
    for source in sorted(DATA.iterdir()):
        (tmp_path / source.name).symlink_to(source)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, f"README.md:{line} failed:\n{proc.stderr[-3000:]}"
    # the shared files were read, never replaced: every write of the package is to a new file
    assert all((tmp_path / source.name).is_symlink() for source in DATA.iterdir())
