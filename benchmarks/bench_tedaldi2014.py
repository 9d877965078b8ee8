"""Time the Tedaldi 2014 calibration on imu_tk's Xsens data; prints JSON.

* ``calibrate_median_s``: the library call (detection with the threshold scan,
  accelerometer and gyroscope fits), data already in memory;
* ``cli_median_s``: the whole ``imucalib calibrate … --json`` process;
* ``calibrate_cpu_median_s``, ``cli_cpu_median_s``: the CPU seconds of each
  (less sensitive than the wall time to other programs on a shared machine),
  and the CPU seconds other programs used during each process.

``--baseline DIR`` times the process of another copy of the package too (``DIR``
on ``PYTHONPATH``, e.g. the ``src`` of an older checkout), in turns with this
one (``"cli_before"``), and the library call of both in turns, a fresh process
each (``"calibrate_in_turns"``: ``"after"`` and ``"before"``, the medians of
``--runs`` calls in each of ``--rounds`` processes a copy, 3 by default); ``--pairs N`` times the two
processes in N pairs too, the order swapped every pair (``"cli_pairs"``: the median of the pairs' ratios,
steadier where the machine's speed drifts). ``--bytecode-cache`` also
times the processes with Python's compiled modules kept between runs
(``"cli_cached"``, ``"cli_before_cached"``: in a directory of its own,
whatever ``PYTHONDONTWRITEBYTECODE`` says), as an
installed package runs (pip compiles the modules when it installs them); without
it every process compiles the modules it imports from their source when the
environment forbids writing the compiled files. Goals: ≤ 0.1 s for the library
call, ≤ 0.35 s for the process.

imu_tk's Ceres-based call takes about 0.86 s on this kind of machine (whole
program about 2.4 s); the targets are ≤ 0.43 s and ≤ 1.5 s.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

from _common import calls_in_turns, median_cpu_time, median_time, processes_in_pairs, require_data, time_processes

from imucalib.io import read
from imucalib.methods import calibrate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--baseline", metavar="DIR", help="another copy of the package to compare with")
    parser.add_argument("--rounds", type=int, default=3,
                        help="processes per copy for the library call in turns (more: a steadier median; a "
                             "process's times shift by up to 10 %% with its memory layout)")
    parser.add_argument("--pairs", type=int, default=0,
                        help="with --baseline: also time the two processes in this many pairs, the order swapped "
                             "every pair (\"cli_pairs\": the median ratio after/before and its quartiles)")
    parser.add_argument("--bytecode-cache", action="store_true",
                        help="also time the processes with the compiled modules kept between runs")
    args = parser.parse_args()
    data = require_data("xsens_imu_tk")
    files = [str(data / "xsens_acc.mat"), str(data / "xsens_gyro.mat")]
    rec = read(files, reader="imutk")
    cal_med, cal_times = median_time(
        lambda: calibrate(rec, method="tedaldi2014", gravity=9.81744), args.runs)
    cmd = [sys.executable, "-m", "imucalib.cli", "calibrate", *files, "--reader", "imutk",
           "--method", "tedaldi2014", "--gravity", "9.81744", "--json"]
    cal_cpu = median_cpu_time(lambda: calibrate(rec, method="tedaldi2014", gravity=9.81744), args.runs)
    turns = {}
    commands = {"cli": (cmd, None)}
    if args.baseline:
        script = ("from imucalib.io import read\nfrom imucalib.methods import calibrate\n"
                  f"rec = read({files!r}, reader='imutk')\n"
                  "def call(): calibrate(rec, method='tedaldi2014', gravity=9.81744)\n")
        turns = {"calibrate_in_turns": calls_in_turns(script, args.baseline, args.rounds, args.runs)}
        commands["cli_before"] = (cmd, {**os.environ, "PYTHONPATH": str(Path(args.baseline).resolve())})
    with tempfile.TemporaryDirectory() as cache:
        if args.bytecode_cache:
            for name, (c, env) in list(commands.items()):
                env = {k: v for k, v in (env or os.environ).items() if k != "PYTHONDONTWRITEBYTECODE"}
                commands[f"{name}_cached"] = (c, {**env, "PYTHONPYCACHEPREFIX": str(Path(cache) / name)})
        timed = time_processes(commands, max(5, args.runs // 2))
        if args.baseline and args.pairs:
            names = ("cli_cached", "cli_before_cached") if args.bytecode_cache else ("cli", "cli_before")
            turns["cli_pairs"] = {"compiled_modules_cached": args.bytecode_cache,
                                  **processes_in_pairs(commands[names[0]], commands[names[1]], args.pairs)}
    cli = timed.pop("cli")
    print(json.dumps({
        "benchmark": "tedaldi2014_xsens",
        "runs": args.runs,
        "calibrate_median_s": round(cal_med, 4),
        "calibrate_times_s": [round(t, 4) for t in cal_times],
        "calibrate_cpu_median_s": round(cal_cpu, 4),
        "cli_median_s": cli["median_s"],
        "cli_times_s": cli["times_s"],
        "cli_cpu_median_s": cli["cpu_median_s"],
        "cli_other_programs_cpu_s": cli["other_programs_cpu_s"],
        **turns,
        **timed,
        "goals_s": {"calibrate": 0.1, "cli": 0.35},
        "imu_tk_reference_s": {"calibrate": 0.86, "program": 2.4},
    }))


if __name__ == "__main__":
    main()
