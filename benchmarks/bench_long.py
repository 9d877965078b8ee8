"""Long recordings: time and peak memory of ``imucalib calibrate FILE.csv --method tedaldi2014``; prints JSON.

For each size (samples; default 0.36 M, 3.6 M and 10 M) a hand-held session at
1 kHz is simulated (:func:`imucalib.scenarios.handheld.generate`, poses held
long enough to reach the size: 3.6 M samples is one hour) and written as CSV
in a separate process; then the command runs in a child process, timed, and
its peak resident memory is read from the kernel's accounting of that child
alone (``os.wait4``). Times and peaks are medians of ``--runs`` runs. The goal
for 3.6 M samples is ≤ 20 s and ≤ 0.6 GB.

``--data-dir DIR`` keeps the CSV files there and reuses them (the 10 M file
takes a few minutes to simulate); ``--save FILE`` stores the figures and
``--before FILE`` prints figures stored earlier (from the code before a change)
next to today's. ``--sizes 360000,3600000`` picks the sizes.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RATE = 1000.0
SEED = 2024
N_POSES = 36
REST = 60.0


def dwell_for(samples: int) -> tuple[float, float]:
    """Pose holds [s] that make a session of about ``samples`` samples at :data:`RATE`."""
    # 0.5 % of the samples are dropped; rotations, re-grasps and pauses take about 2.75 s a pose
    per_pose = (samples / (0.995 * RATE) - REST) / N_POSES - 2.75
    return (0.95 * per_pose, 1.05 * per_pose)


def generate(samples: int, path: Path) -> None:
    """Simulate the session and write it as CSV (run in its own process)."""
    import numpy as np

    from imucalib.io import write_csv
    from imucalib.scenarios import handheld

    sim = handheld.generate(np.random.default_rng(SEED), rate=RATE, rest=REST, n_poses=N_POSES,
                            dwell=dwell_for(samples), jitter=2e-4, resolution=1e-6)
    write_csv(path, sim["recording"])


def run_child(cmd: list[str]) -> tuple[float, float, int]:
    """Wall time [s], peak RSS [GB] and exit code of one child process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    elapsed = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    if proc.returncode not in (0, 3):  # 3: a rejected calibration is still a finished run
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{err}")
    return elapsed, usage.ru_maxrss * 1024 / 1e9, proc.returncode  # ru_maxrss is in KiB on Linux


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", default="360000,3600000,10000000",
                        help="comma-separated numbers of samples (default 360000,3600000,10000000)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--data-dir", help="keep and reuse the simulated CSV files here")
    parser.add_argument("--save", metavar="FILE", help="store the figures (JSON) here")
    parser.add_argument("--before", metavar="FILE", help="figures stored earlier, printed next to today's")
    parser.add_argument("--generate", nargs=2, metavar=("SAMPLES", "PATH"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.generate:
        generate(int(args.generate[0]), Path(args.generate[1]))
        return
    sizes = [int(float(s)) for s in args.sizes.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        data_dir = Path(args.data_dir or tmp)
        data_dir.mkdir(parents=True, exist_ok=True)
        rows = []
        for size in sizes:
            path = data_dir / f"handheld_{size}_seed{SEED}.csv"
            if not path.exists():
                subprocess.run([sys.executable, __file__, "--generate", str(size), str(path)], check=True)
            with path.open("rb") as f:
                samples = sum(chunk.count(b"\n") for chunk in iter(lambda: f.read(1 << 24), b"")) - 1
            out = Path(tmp) / f"cal_{size}.json"
            cmd = [sys.executable, "-m", "imucalib.cli", "calibrate", str(path), "--method", "tedaldi2014",
                   "-o", str(out), "--json"]
            runs = [run_child(cmd) for _ in range(args.runs)]
            rows.append({"samples": samples, "file_mb": round(path.stat().st_size / 1e6, 1),
                         "median_s": round(statistics.median(r[0] for r in runs), 2),
                         "peak_rss_gb": round(statistics.median(r[1] for r in runs), 3),
                         "times_s": [round(r[0], 2) for r in runs],
                         "peak_rss_gb_runs": [round(r[1], 3) for r in runs],
                         "exit_code": runs[-1][2]})
    result: dict = {"benchmark": "long_recording_tedaldi2014", "rate_hz": RATE, "runs": args.runs,
                    "goal_3.6M": {"seconds": 20, "peak_rss_gb": 0.6}, "sizes": rows}
    if args.save:
        Path(args.save).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    if args.before:
        result = {"benchmark": result["benchmark"], "goal_3.6M": result["goal_3.6M"],
                  "before": json.loads(Path(args.before).read_text(encoding="utf-8"))["sizes"],
                  "after": rows}
    print(json.dumps(result))


if __name__ == "__main__":
    main()
