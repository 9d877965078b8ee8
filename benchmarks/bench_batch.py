"""Batch throughput: device-calibrations per hour on 1 and 2 processes and a 2-worker Dask LocalCluster; prints JSON.

A manifest of ``--devices`` simulated hand-held sessions (the ``handheld`` scenario's defaults: a 30 s rest
and 30 poses, about 3.5 min at 100 Hz, each device with its own drawn truth) is calibrated with
tedaldi2014 into a new store, ``--runs`` times per configuration; the figure is the median wall time of
the whole ``run_batch`` call (pool or cluster start, reading, hashing, calibrating, storing), the
configurations taking turns run by run. The
LocalCluster's start-up is also timed on its own. Then the time of one calibration of a 10-minute 100 Hz
session (reading, hashing and calibrating one manifest row, :func:`imucalib.batch.run_row`).

Other work on the machine lowers the figures, and the 2-process speed-up most: the load average is
printed at the start and the end, and for each timed run the CPU seconds that other programs used on the
machine meanwhile (``other_programs_cpu_s``; 0 on a quiet machine).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
import warnings
from pathlib import Path

from _common import machine_busy_s, own_cpu_s

from imucalib.batch import Row, dask_client, run_batch, run_row
from imucalib.scenarios import session, write_session


def _fleet(directory: Path, devices: int) -> Path:
    lines = ["device,files,recorded_at"]
    for k in range(devices):
        d = write_session(session("handheld", rng=1000 + k), directory / f"dev{k:03d}")
        lines.append(f"BENCH-{k:03d},{d.name}/recording.csv,2024-01-01T00:{k % 60:02d}:00")
    manifest = directory / "manifest.csv"
    manifest.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return manifest


def _time_batch(manifest: Path, where: dict) -> tuple[float, float | None]:
    """Wall time [s] of one batch of ``manifest`` into a new store, and the CPU seconds other programs
    used on the machine meanwhile (what makes the figure noisy)."""
    with tempfile.TemporaryDirectory(dir=manifest.parent) as tmp:
        busy0, own0 = machine_busy_s(), own_cpu_s()
        t0 = time.perf_counter()
        result = run_batch(manifest, Path(tmp) / "store.sqlite", **where)
        elapsed = time.perf_counter() - t0
        busy1, own1 = machine_busy_s(), own_cpu_s()
    if result["calibrated"] + result["failed"] != result["rows"]:
        raise SystemExit(f"a run skipped rows: {result}")
    other = None if busy0 is None else max(0.0, (busy1 - busy0) - (own1 - own0))
    return elapsed, other


def _long_session(directory: Path, minutes: float) -> tuple[Path, float, int]:
    """A hand-held session of at least ``minutes`` at 100 Hz (more poses, same procedure)."""
    n_poses = 30
    while True:
        sim = session("handheld", rng=7, n_poses=n_poses)
        duration = float(sim.recording.t[-1] - sim.recording.t[0])
        if duration >= 60 * minutes:
            d = write_session(sim, directory / "long")
            return d / "recording.csv", duration, len(sim.recording)
        n_poses = int(n_poses * 60 * minutes / duration) + 2


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--devices", type=int, default=24)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--no-cluster", action="store_true", help="leave the Dask LocalCluster out")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    load_start = os.getloadavg()
    out: dict = {"benchmark": "batch", "devices": args.devices, "runs": args.runs, "cpu_count": os.cpu_count(),
                 "method": "tedaldi2014"}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        manifest = _fleet(tmp, args.devices)
        configs = {"workers_1": {"workers": 1}, "workers_2": {"workers": 2}}
        if not args.no_cluster:
            configs["localcluster_2"] = {"scheduler": "local", "workers": 2}
        times: dict[str, list[float]] = {name: [] for name in configs}
        others: dict[str, list[float | None]] = {name: [] for name in configs}
        for where in configs.values():  # warm the file cache and the imports
            _time_batch(manifest, where)
        for _ in range(args.runs):  # configurations interleaved: a change of the machine's load hits all of them
            for name, where in configs.items():
                elapsed, other = _time_batch(manifest, where)
                times[name].append(elapsed)
                others[name].append(other)
        for name in configs:
            med = statistics.median(times[name])
            out[name] = {"median_s": round(med, 3), "times_s": [round(t, 3) for t in times[name]],
                         "calibrations_per_hour": round(args.devices / med * 3600),
                         "other_programs_cpu_s": [None if o is None else round(o, 1) for o in others[name]]}
        out["speedup_2_workers"] = round(out["workers_1"]["median_s"] / out["workers_2"]["median_s"], 3)
        if not args.no_cluster:
            out["speedup_localcluster_2"] = round(out["workers_1"]["median_s"] / out["localcluster_2"]["median_s"],
                                                  3)
            starts = []
            for _ in range(args.runs):
                t0 = time.perf_counter()
                with dask_client("local", 2):
                    pass
                starts.append(time.perf_counter() - t0)
            out["localcluster_2"]["start_and_stop_median_s"] = round(statistics.median(starts), 3)
        path, duration, samples = _long_session(tmp, 10.0)
        row = Row(line=2, device="LONG", files=(str(path),))
        times = []
        for r in range(args.runs + 1):
            t0 = time.perf_counter()
            res = run_row({"row": row, "skip": []})
            if r:
                times.append(time.perf_counter() - t0)
        out["ten_minute_session"] = {"duration_s": round(duration, 1), "samples": samples,
                                     "file_mb": round(path.stat().st_size / 1e6, 2), "status": res["status"],
                                     "verdict": res["verdict"], "median_s": round(statistics.median(times), 3),
                                     "times_s": [round(t, 3) for t in times]}
    out["load_average_start"] = [round(x, 2) for x in load_start]
    out["load_average_end"] = [round(x, 2) for x in os.getloadavg()]
    print(json.dumps(out))


if __name__ == "__main__":
    main()
