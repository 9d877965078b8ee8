"""The guided recorder's cost per line on a long 1 kHz stream; prints JSON.

A simulated hand-held session at 1 kHz (``imucalib.scenarios.handheld``:
``--minutes`` of stream, a pose every ~5 s) is written as CSV and fed to
:class:`imucalib.record.Recorder` the way a live stream arrives: in batches of
``--batch`` lines (10 lines = 10 ms at 1 kHz), its session written to a file
as it goes (:class:`imucalib.record.SessionWriter`). Reported:

* ``cpu_fraction``: CPU seconds spent per second of stream, overall and per
  minute of stream (``per_minute``), against ``limit`` (0.15: 15 % of a core);
* ``us_per_line_by_stretch_position``: the mean cost of a line [µs] by where it
  lies within the 65,536-sample stretches of the detector's running sums
  (eighths of a stretch), to show that it does not grow within one;
* the trial calibrations (one per pose until the session is complete) are
  part of the cost; the final calibration at the end is not (it runs once,
  after the stream).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import SRC  # noqa: E402

sys.path.insert(0, str(SRC))

import numpy as np  # noqa: E402

from imucalib.io import write_csv  # noqa: E402
from imucalib.record import Recorder, SessionWriter  # noqa: E402
from imucalib.scenarios.handheld import generate  # noqa: E402

STRETCH = 65536


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--minutes", type=float, default=10.0, help="minutes of stream (default 10)")
    ap.add_argument("--batch", type=int, default=10, help="lines per batch (default 10)")
    ap.add_argument("--limit", type=float, default=0.15, help="the CPU fraction allowed (default 0.15)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rate = 1000.0
    n_poses = max(int((args.minutes * 60 - 30) / 5.5), 4)
    with tempfile.TemporaryDirectory() as tmp:
        s = generate(np.random.default_rng(args.seed), rate=rate, n_poses=n_poses, rest=30.0, jitter=0.0001)
        path = Path(tmp) / "stream.csv"
        write_csv(path, s["recording"])
        lines = path.read_bytes().splitlines(keepends=True)
        writer = SessionWriter(Path(tmp) / "session.csv")
        events: list[dict] = []
        recorder = Recorder(events.append, sink=writer.write_lines)
        n = len(lines)
        cost = np.zeros(n)  # CPU seconds per line, spread over its batch
        for i in range(0, n, args.batch):
            c0 = time.process_time()
            recorder.feed(lines[i:i + args.batch])
            k = min(args.batch, n - i)
            cost[i:i + k] = (time.process_time() - c0) / k
        c0 = time.process_time()
        recorder.end_stream()
        end_cost = time.process_time() - c0
        writer.finish()
    samples = n - 1
    seconds = samples / rate
    per_minute = [float(cost[1 + int(m * 60 * rate):1 + int((m + 1) * 60 * rate)].sum() / 60.0)
                  for m in range(int(seconds // 60))]
    position = (np.arange(samples) % STRETCH) * 8 // STRETCH
    by_position = [float(cost[1:][position == j].mean() * 1e6) for j in range(8)]
    print(json.dumps({
        "rate_hz": rate, "stream_s": round(seconds, 1), "lines": n, "batch_lines": args.batch,
        "poses_found": sum(e["event"] == "pose" for e in events), "poses_simulated": n_poses,
        "complete": any(e["event"] == "complete" for e in events),
        "cpu_fraction": round(float(cost.sum()) / seconds, 4),
        "cpu_fraction_max_minute": round(max(per_minute), 4) if per_minute else None,
        "per_minute": [round(v, 4) for v in per_minute],
        "us_per_line_by_stretch_position": [round(v, 1) for v in by_position],
        "end_of_stream_s": round(end_cost, 3),
        "limit": args.limit,
        "within_limit": bool(float(cost.sum()) / seconds <= args.limit and (not per_minute
                                                                            or max(per_minute) <= args.limit)),
    }, indent=1))


if __name__ == "__main__":
    main()
