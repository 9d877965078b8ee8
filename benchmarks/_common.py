"""Shared helpers of the benchmark scripts: timing and the real data location."""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
#: this checkout's package source
SRC = Path(__file__).resolve().parents[1] / "src"


def median_cpu_time(fn: Callable[[], object], runs: int) -> float:
    """Median CPU seconds (all threads of this process) of ``runs`` calls, after one warm-up call."""
    fn()
    times = []
    for _ in range(runs):
        c0 = time.process_time()
        fn()
        times.append(time.process_time() - c0)
    return statistics.median(times)


def median_time(fn: Callable[[], object], runs: int, warm: bool = True) -> tuple[float, list[float]]:
    """Median wall time [s] of ``runs`` calls (after one warm-up call unless ``warm`` is False) and all times."""
    if warm:
        fn()
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


def require_data(sub: str) -> Path:
    path = DATA / sub
    if not path.is_dir():
        print(f'{{"skipped": "{path} not present (needs ../shared/data)"}}')
        sys.exit(0)
    return path


def machine_busy_s() -> float | None:
    """CPU seconds the whole machine has been busy (all cores; Linux /proc/stat), or None elsewhere."""
    import os

    try:
        fields = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    except (OSError, ValueError):
        return None
    user, nice, system, _idle, _iowait, irq, softirq, steal = fields[:8]
    return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")


def own_cpu_s() -> float:
    """CPU seconds of this process and its ended children."""
    import resource

    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def time_processes(commands: dict[str, tuple[list[str], dict | None]], runs: int) -> dict[str, dict]:
    """Whole-process wall times of each named ``(command, environment)``, run in turns ``runs`` times
    (so that every command sees the same load), after one untimed warm-up round.

    Returns, by name, the median [s], every time, the median CPU seconds of the process itself
    (``cpu_median_s``: less sensitive to other programs than the wall time), and for each run the CPU
    seconds other programs used on the machine meanwhile (``other_programs_cpu_s``: 0 on a quiet machine).
    """
    import subprocess

    for cmd, env in commands.values():
        subprocess.run(cmd, check=True, capture_output=True, env=env)
    times: dict[str, list[float]] = {name: [] for name in commands}
    others: dict[str, list[float | None]] = {name: [] for name in commands}
    cpu: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(runs):
        for name, (cmd, env) in commands.items():
            busy0, own0 = machine_busy_s(), own_cpu_s()
            t0 = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, env=env)
            elapsed = time.perf_counter() - t0
            busy1, own1 = machine_busy_s(), own_cpu_s()
            if proc.returncode not in (0, 3):
                raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr.decode()}")
            times[name].append(elapsed)
            cpu[name].append(own1 - own0)
            others[name].append(None if busy0 is None else round(max(0.0, (busy1 - busy0) - (own1 - own0)), 2))
    return {name: {"median_s": round(statistics.median(times[name]), 4),
                   "times_s": [round(t, 4) for t in times[name]],
                   "cpu_median_s": round(statistics.median(cpu[name]), 4),
                   "other_programs_cpu_s": others[name]} for name in commands}


def calls_in_turns(script: str, baseline: str, rounds: int, calls: int) -> dict[str, dict]:
    """The library call of ``script`` timed with this checkout's package (``"after"``) and with the one in
    ``baseline`` (``"before"``: e.g. the ``src`` of an older checkout), a fresh process each, in turns.

    ``script`` is Python source defining ``call()`` (e.g. one calibration of data it reads first). Each
    process warms up with one call, then prints the median wall time of ``calls`` calls; the two take turns
    ``rounds`` times so that both see the same machine. Returns, by name, the median of those medians and
    each of them [s].
    """
    import json
    import os
    import subprocess

    runner = ("import json, statistics, sys, time\n"
              "sys.path.insert(0, sys.argv[1])\n"
              f"{script}\n"
              "call()\n"
              "times = []\n"
              "for _ in range(int(sys.argv[2])):\n"
              "    t0 = time.perf_counter(); call(); times.append(time.perf_counter() - t0)\n"
              "print(json.dumps(statistics.median(times)))\n")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    copies = {"after": SRC, "before": Path(baseline).resolve()}
    medians: dict[str, list[float]] = {name: [] for name in copies}
    for _ in range(rounds):
        for name, src in copies.items():
            out = subprocess.run([sys.executable, "-c", runner, str(src), str(calls)], check=True,
                                 capture_output=True, text=True, env=env)
            medians[name].append(round(json.loads(out.stdout.strip().splitlines()[-1]), 4))
    return {name: {"median_s": statistics.median(m), "medians_s": m} for name, m in medians.items()}


def processes_in_pairs(after: tuple[list[str], dict | None], before: tuple[list[str], dict | None],
                       pairs: int) -> dict:
    """Whole-process wall times of two ``(command, environment)`` run in ``pairs`` pairs, the order swapped every
    pair, after one untimed run of each: the median of each pair's ratio ``after / before`` and its quartiles, and
    each command's median [s]. On a machine whose speed drifts (a shared virtual machine), the ratio of runs a
    second apart is steadier than a ratio of medians taken over minutes."""
    import subprocess

    for cmd, env in (after, before):
        subprocess.run(cmd, check=True, capture_output=True, env=env)
    times: dict[str, list[float]] = {"after": [], "before": []}
    ratios = []
    for i in range(pairs):
        got = {}
        for name in (("after", "before") if i % 2 == 0 else ("before", "after")):
            cmd, env = after if name == "after" else before
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True, env=env)
            got[name] = time.perf_counter() - t0
            times[name].append(got[name])
        ratios.append(got["after"] / got["before"])
    return {"pairs": pairs, "ratio_median": round(statistics.median(ratios), 4),
            "ratio_quartiles": [round(q, 4) for q in statistics.quantiles(ratios, n=4)] if pairs > 1 else None,
            "after_median_s": round(statistics.median(times["after"]), 4),
            "before_median_s": round(statistics.median(times["before"]), 4)}
