"""Time the simulation of one default zhang2021 session; prints JSON (target ≤ 0.5 s)."""

from __future__ import annotations

import argparse
import json

from _common import median_time

from imucalib.scenarios import session


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    seeds = iter(range(10_000))
    med, times = median_time(lambda: session("zhang2021", rng=next(seeds)), args.runs)
    print(json.dumps({"benchmark": "simulate_zhang2021_default", "runs": args.runs,
                      "median_s": round(med, 4), "times_s": [round(t, 4) for t in times],
                      "target_s": 0.5}))


if __name__ == "__main__":
    main()
