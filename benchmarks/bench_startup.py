"""Start-up of the ``imucalib`` command: whole-process times of cheap commands; prints JSON.

Each command runs as its own process (``python -m imucalib.cli …``) ``--runs``
times, in turns with the others, and the median is kept: ``--version``,
``--help``, ``calibrate --help``, and ``python -c "import imucalib"``; a bare
``python -c pass`` gives the interpreter's own start-up for reference. The
goal for ``--version`` is ≤ 0.15 s. ``--baseline DIR`` runs the same commands
with another copy of the package (``DIR`` on ``PYTHONPATH``, e.g. the ``src``
of an older checkout), in turns with this one; its figures are printed as
``"before"``. For each run, the CPU seconds other programs used meanwhile are
printed beside the times (the machine is shared).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from _common import time_processes

COMMANDS = {
    "version": ["-m", "imucalib.cli", "--version"],
    "help": ["-m", "imucalib.cli", "--help"],
    "calibrate_help": ["-m", "imucalib.cli", "calibrate", "--help"],
    "import_imucalib": ["-c", "import imucalib"],
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--baseline", metavar="DIR", help="another copy of the package to compare with")
    parser.add_argument("--save", metavar="FILE", help="store the figures (JSON) here")
    args = parser.parse_args()
    here = str(Path(__file__).resolve().parents[1] / "src")
    copies = {"after": {**os.environ, "PYTHONPATH": here}}
    if args.baseline:
        copies = {"before": {**os.environ, "PYTHONPATH": str(Path(args.baseline).resolve())}, **copies}
    commands = {"python_bare": ([sys.executable, "-c", "pass"], None)}
    for copy, env in copies.items():
        for name, argv in COMMANDS.items():
            commands[f"{copy}/{name}"] = ([sys.executable, *argv], env)
    timed = time_processes(commands, args.runs)
    result: dict = {"benchmark": "startup", "runs": args.runs, "goal_version_s": 0.15,
                    "python_bare": timed.pop("python_bare")}
    for key, value in timed.items():
        copy, name = key.split("/")
        result.setdefault(copy, {})[name] = value
    if args.save:
        Path(args.save).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
