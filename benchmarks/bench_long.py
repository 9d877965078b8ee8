"""Long recordings: time and peak memory of ``imucalib calibrate FILE.csv --method tedaldi2014``; prints JSON.

For each size (samples; default 0.36 M, 3.6 M and 10 M) a hand-held session at
1 kHz is simulated (:func:`imucalib.scenarios.handheld.generate`, poses held
long enough to reach the size: 3.6 M samples is one hour) and written as CSV
in a separate process; then the command runs in a child process, timed, and
its peak resident memory is read from the kernel's accounting of that child
alone (``os.wait4``). Times and peaks are medians of ``--runs`` runs. The goal
for 3.6 M samples is ≤ 20 s and ≤ 0.6 GB. ``imucalib apply`` of the
calibration to the same file is measured too (``--no-apply`` to skip it).

Long rotations (``--cases xsens_imutk,xsens_csv``): imu_tk's Xsens session
(``../shared/data/xsens_imu_tk``, 51 175 samples at 100 Hz, about 35 % of them
in motion) resampled to ``--xsens-samples`` (3.6 M: about 7 kHz, each rotation
some 35 000 samples) by linear interpolation, with white noise of the initial
rest's own spread added per axis (seeded), written as an imu_tk pair and as one
CSV, and calibrated as ``imucalib calibrate … --method tedaldi2014 --gravity
9.81744``. The hand-held sessions' rotations are a few hundred samples; these
are a hundred times longer, so a memory peak that follows the longest rotation
shows here. The goal is the same: ≤ 20 s and ≤ 0.6 GB at 3.6 M samples.
``--cases xsens_tiled`` is its control: the same session at its own 100 Hz,
laid end to end forwards and backwards in time (a backward copy reversed, its
gyroscope mirrored about the initial rest's mean: the same turns undone, so
each copy starts where the last one ended) to the same number of samples, with
the same noise, as an imu_tk pair: the same share of motion in rotations of a
few hundred samples. Its peak beside ``xsens_imutk``'s shows whether memory
follows the length of a single rotation.

``--baseline DIR`` runs the same commands with another copy of the package
(``DIR`` is put on ``PYTHONPATH``: e.g. the ``src`` of an older checkout),
alternating with this one run by run so that both see the same load on the
machine; its figures are printed as ``"before"``. ``--engine`` picks the CSV
parser of this copy (:data:`imucalib.io.csvparse.ENGINE`). ``--data-dir DIR``
keeps the CSV files there and reuses them (the 10 M file takes a few minutes
to simulate); ``--save FILE`` stores the figures. ``--sizes 360000,3600000``
picks the sizes of the hand-held sessions, ``--cases`` the cases
(``handheld,xsens_imutk,xsens_csv,xsens_tiled``, the default).
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

from _common import machine_busy_s

RATE = 1000.0
SEED = 2024
N_POSES = 36
REST = 60.0
XSENS_GRAVITY = 9.81744
CASES = ("handheld", "xsens_imutk", "xsens_csv", "xsens_tiled")


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


def _xsens():
    """imu_tk's Xsens session and its initial rest."""
    import warnings

    from imucalib.io import read
    from imucalib.segment import find_initial_rest

    source = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = read([str(source / "xsens_acc.mat"), str(source / "xsens_gyro.mat")], reader="imutk")
    return rec, rec[find_initial_rest(rec)]


def _write_imutk(path_stem: Path, t, cols: dict) -> None:
    """``cols`` as imu_tk's text pair: time and three values per line."""
    import numpy as np

    for name in ("acc", "gyro"):
        with path_stem.with_name(f"{path_stem.name}_{name}.mat").open("w", encoding="ascii") as f:
            for a in range(0, len(t), 1 << 18):
                b = min(len(t), a + (1 << 18))
                np.savetxt(f, np.column_stack([t[a:b], cols[name][a:b]]), fmt="%15.7e")


def generate_xsens(samples: int, directory: Path) -> None:
    """The Xsens session resampled to ``samples`` samples with noise, as an imu_tk pair and a CSV (own process)."""
    import numpy as np

    from imucalib.io import write_csv
    from imucalib.recording import Recording

    rec, rest = _xsens()
    rng = np.random.default_rng(SEED)
    t = np.linspace(rec.t[0], rec.t[-1], samples)
    cols = {}
    for name in ("acc", "gyro"):
        raw, sd = getattr(rec, name), getattr(rest, name).std(axis=0)
        cols[name] = np.stack([np.interp(t, rec.t, raw[:, i]) + sd[i] * rng.standard_normal(samples)
                               for i in range(3)], axis=1)
    _write_imutk(directory / f"xsens_{samples}", t, cols)
    write_csv(directory / f"xsens_{samples}.csv", Recording(t, cols["acc"], cols["gyro"], "counts", "counts"))


def generate_xsens_tiled(samples: int, directory: Path) -> None:
    """The Xsens session at its own rate laid end to end, forwards and backwards, to ``samples`` samples with
    the same noise as :func:`generate_xsens`, as an imu_tk pair (own process)."""
    import numpy as np

    rec, rest = _xsens()
    rng = np.random.default_rng(SEED)
    n, step = len(rec), float(np.median(np.diff(rec.t)))
    copy = np.arange(samples) // n
    k = np.arange(samples) % n
    backward = copy % 2 == 1
    k[backward] = n - 1 - k[backward]  # a backward copy retraces the one before it, sample by sample
    local = rec.t - rec.t[0]
    span = local[-1] + step
    t = copy * span + np.where(backward, local[-1] - local[k], local[k])
    cols = {}
    for name in ("acc", "gyro"):
        raw, sd = getattr(rec, name), getattr(rest, name).std(axis=0)
        values = raw[k]
        if name == "gyro":  # turns undone: the rate mirrored about the rest's reading (bias kept)
            values[backward] = 2 * rest.gyro.mean(axis=0) - values[backward]
        cols[name] = values + sd * rng.standard_normal((samples, 3))
    _write_imutk(directory / f"xsens_tiled_{samples}", t, cols)


def run_child(cmd: list[str], env: dict | None = None) -> tuple[float, float, float | None, float]:
    """Wall time [s] and peak RSS [GB] of one child process (exit 0, or 3 for a rejected calibration), the
    CPU seconds other programs used on the machine meanwhile (what makes the time noisy), and its own."""
    busy0 = machine_busy_s()
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    err = proc.stderr.read().decode(errors="replace")  # drained while it runs
    _, status, usage = os.wait4(proc.pid, 0)
    elapsed = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    proc.stderr.close()
    if proc.returncode not in (0, 3):
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{err}")
    busy1 = machine_busy_s()
    other = None if busy0 is None else round(max(0.0, busy1 - busy0 - usage.ru_utime - usage.ru_stime), 1)
    return elapsed, usage.ru_maxrss * 1024 / 1e9, other, usage.ru_utime + usage.ru_stime  # maxrss: KiB


def _cli(engine: str | None) -> list[str]:
    if engine is None:
        return [sys.executable, "-m", "imucalib.cli"]
    return [sys.executable, "-c", "import sys; import imucalib.io.csvparse as c; c.ENGINE = sys.argv[1]; "
            "from imucalib.cli import main; sys.exit(main(sys.argv[2:]))", engine]


def _summary(runs: list[tuple[float, float, float | None, float]]) -> dict:
    return {"median_s": round(statistics.median(r[0] for r in runs), 2),
            "cpu_median_s": round(statistics.median(r[3] for r in runs), 2),
            "peak_rss_gb": round(statistics.median(r[1] for r in runs), 3),
            "times_s": [round(r[0], 2) for r in runs], "peak_rss_gb_runs": [round(r[1], 3) for r in runs],
            "other_programs_cpu_s": [r[2] for r in runs]}


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
    parser.add_argument("--cases", default=",".join(CASES), help=f"comma-separated, of {', '.join(CASES)}")
    parser.add_argument("--xsens-samples", type=float, default=3.6e6,
                        help="samples of the resampled Xsens session (default 3.6e6)")
    parser.add_argument("--generate", nargs=2, metavar=("SAMPLES", "PATH"), help=argparse.SUPPRESS)
    parser.add_argument("--generate-xsens", nargs=2, metavar=("SAMPLES", "DIR"), help=argparse.SUPPRESS)
    parser.add_argument("--generate-xsens-tiled", nargs=2, metavar=("SAMPLES", "DIR"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.generate:
        generate(int(args.generate[0]), Path(args.generate[1]))
        return
    if args.generate_xsens:
        generate_xsens(int(args.generate_xsens[0]), Path(args.generate_xsens[1]))
        return
    if args.generate_xsens_tiled:
        generate_xsens_tiled(int(args.generate_xsens_tiled[0]), Path(args.generate_xsens_tiled[1]))
        return
    cases = args.cases.split(",")
    if set(cases) - set(CASES):
        parser.error(f"unknown case(s) {', '.join(sorted(set(cases) - set(CASES)))}; choose among {', '.join(CASES)}")
    sizes = [int(float(s)) for s in args.sizes.split(",")] if "handheld" in cases else []
    xsens = int(args.xsens_samples)
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
        jobs = []  # (case, input files, reader and gravity options)
        imutk = ["--reader", "imutk", "--gravity", str(XSENS_GRAVITY)]  # an imu_tk pair of the Xsens session
        for size in sizes:
            path = data_dir / f"handheld_{size}_seed{SEED}.csv"
            if not path.exists():
                subprocess.run([sys.executable, __file__, "--generate", str(size), str(path)], check=True)
            jobs.append(("handheld", [path], []))
        if {"xsens_imutk", "xsens_csv"} & set(cases):
            pair = [data_dir / f"xsens_{xsens}_acc.mat", data_dir / f"xsens_{xsens}_gyro.mat"]
            csv = data_dir / f"xsens_{xsens}.csv"
            if not all(p.exists() for p in (*pair, csv)):
                subprocess.run([sys.executable, __file__, "--generate-xsens", str(xsens), str(data_dir)], check=True)
            if "xsens_imutk" in cases:
                jobs.append(("xsens_imutk", pair, imutk))
            if "xsens_csv" in cases:
                jobs.append(("xsens_csv", [csv], imutk[2:]))
        if "xsens_tiled" in cases:
            pair = [data_dir / f"xsens_tiled_{xsens}_acc.mat", data_dir / f"xsens_tiled_{xsens}_gyro.mat"]
            if not all(p.exists() for p in pair):
                subprocess.run([sys.executable, __file__, "--generate-xsens-tiled", str(xsens), str(data_dir)],
                               check=True)
            jobs.append(("xsens_tiled", pair, imutk))
        for case, paths, options in jobs:
            path = paths[-1]
            with path.open("rb") as f:
                samples = sum(chunk.count(b"\n") for chunk in iter(lambda f=f: f.read(1 << 24), b""))
            samples -= len(paths) == 1  # a CSV's header line
            data = [str(p) for p in paths]
            runs: dict = {name: {"calibrate": [], "apply": []} for name in copies}
            for _ in range(args.runs):
                for name, (cli, env) in copies.items():
                    cal = Path(tmp) / f"cal_{name}_{case}_{samples}.json"
                    runs[name]["calibrate"].append(run_child(
                        [*cli, "calibrate", *data, "--method", "tedaldi2014", *options, "-o", str(cal), "--json"],
                        env))
                    if not args.no_apply:
                        out = Path(tmp) / f"applied_{name}.csv"
                        runs[name]["apply"].append(run_child(
                            [*cli, "apply", str(cal), *data, *options[:2 if len(paths) == 2 else 0],
                             "-o", str(out), "--force"], env))
                        out.unlink()
            for name in copies:
                size_mb = round(sum(p.stat().st_size for p in paths) / 1e6, 1)
                row = {"case": case, "samples": samples, "file_mb": size_mb,
                       "calibrate": _summary(runs[name]["calibrate"])}
                if not args.no_apply:
                    row["apply"] = _summary(runs[name]["apply"])
                result[name].append(row)
    if args.save:
        Path(args.save).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
