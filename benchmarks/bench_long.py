"""Long recordings: time and peak memory of ``imucalib calibrate FILE.csv --method tedaldi2014``; prints JSON.

For each size (samples; default 0.36 M, 3.6 M and 10 M) a hand-held session at
1 kHz is simulated (:func:`imucalib.scenarios.handheld.generate`, poses held
long enough to reach the size: 3.6 M samples is one hour) and written as CSV
in a separate process; then the command runs in a child process, timed, and
its peak resident memory is read from the kernel's accounting of that child
alone (``os.wait4``). Times and peaks are medians of ``--runs`` runs. The goal
for 3.6 M samples is ≤ 20 s and ≤ 0.6 GB. ``imucalib apply`` of the
calibration to the same file is measured too (``--no-apply`` to skip it).

``--baseline DIR`` runs the same commands with another copy of the package
(``DIR`` is put on ``PYTHONPATH``: e.g. the ``src`` of an older checkout),
alternating with this one run by run so that both see the same load on the
machine; its figures are printed as ``"before"``. ``--engine`` picks the CSV
parser of this copy (:data:`imucalib.io.csvparse.ENGINE`). ``--data-dir DIR``
keeps the CSV files there and reuses them (the 10 M file takes a few minutes
to simulate); ``--save FILE`` stores the figures. ``--sizes 360000,3600000``
picks the sizes.
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


def run_child(cmd: list[str], env: dict | None = None) -> tuple[float, float]:
    """Wall time [s] and peak RSS [GB] of one child process (exit 0, or 3 for a rejected calibration)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    err = proc.stderr.read().decode(errors="replace")  # drained while it runs
    _, status, usage = os.wait4(proc.pid, 0)
    elapsed = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    proc.stderr.close()
    if proc.returncode not in (0, 3):
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{err}")
    return elapsed, usage.ru_maxrss * 1024 / 1e9  # ru_maxrss is in KiB on Linux


def _cli(engine: str | None) -> list[str]:
    if engine is None:
        return [sys.executable, "-m", "imucalib.cli"]
    return [sys.executable, "-c", "import sys; import imucalib.io.csvparse as c; c.ENGINE = sys.argv[1]; "
            "from imucalib.cli import main; sys.exit(main(sys.argv[2:]))", engine]


def _summary(runs: list[tuple[float, float]]) -> dict:
    return {"median_s": round(statistics.median(r[0] for r in runs), 2),
            "peak_rss_gb": round(statistics.median(r[1] for r in runs), 3),
            "times_s": [round(r[0], 2) for r in runs], "peak_rss_gb_runs": [round(r[1], 3) for r in runs]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", default="360000,3600000,10000000",
                        help="comma-separated numbers of samples (default 360000,3600000,10000000)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--engine", choices=("auto", "numpy", "pandas", "python"),
                        help="the CSV parser of this copy (default: its own choice)")
    parser.add_argument("--baseline", metavar="DIR", help="another copy of the package to compare with")
    parser.add_argument("--no-apply", action="store_true", help="time calibrate only")
    parser.add_argument("--data-dir", help="keep and reuse the simulated CSV files here")
    parser.add_argument("--save", metavar="FILE", help="store the figures (JSON) here")
    parser.add_argument("--generate", nargs=2, metavar=("SAMPLES", "PATH"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.generate:
        generate(int(args.generate[0]), Path(args.generate[1]))
        return
    sizes = [int(float(s)) for s in args.sizes.split(",")]
    here = {**os.environ}
    copies = {"after": (_cli(args.engine), here)}
    if args.baseline:
        copies = {"before": (_cli(None), {**os.environ, "PYTHONPATH": str(Path(args.baseline).resolve())}),
                  **copies}
    result: dict = {"benchmark": "long_recording_tedaldi2014", "rate_hz": RATE, "runs": args.runs,
                    "engine": args.engine or "default", "goal_3.6M": {"seconds": 20, "peak_rss_gb": 0.6},
                    **{name: [] for name in copies}}
    with tempfile.TemporaryDirectory() as tmp:
        data_dir = Path(args.data_dir or tmp)
        data_dir.mkdir(parents=True, exist_ok=True)
        for size in sizes:
            path = data_dir / f"handheld_{size}_seed{SEED}.csv"
            if not path.exists():
                subprocess.run([sys.executable, __file__, "--generate", str(size), str(path)], check=True)
            with path.open("rb") as f:
                samples = sum(chunk.count(b"\n") for chunk in iter(lambda f=f: f.read(1 << 24), b"")) - 1
            runs: dict = {name: {"calibrate": [], "apply": []} for name in copies}
            for _ in range(args.runs):
                for name, (cli, env) in copies.items():
                    cal = Path(tmp) / f"cal_{name}_{size}.json"
                    runs[name]["calibrate"].append(run_child(
                        [*cli, "calibrate", str(path), "--method", "tedaldi2014", "-o", str(cal), "--json"], env))
                    if not args.no_apply:
                        out = Path(tmp) / f"applied_{name}.csv"
                        runs[name]["apply"].append(run_child(
                            [*cli, "apply", str(cal), str(path), "-o", str(out), "--force"], env))
                        out.unlink()
            for name in copies:
                row = {"samples": samples, "file_mb": round(path.stat().st_size / 1e6, 1),
                       "calibrate": _summary(runs[name]["calibrate"])}
                if not args.no_apply:
                    row["apply"] = _summary(runs[name]["apply"])
                result[name].append(row)
    if args.save:
        Path(args.save).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
