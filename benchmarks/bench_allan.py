"""Overlapping Allan deviation: imucalib.noise.allan_deviation against allantools.oadev; prints JSON.

Three axes of white noise plus a rate random walk (one hour at 100 Hz by
default), the same 40 cluster times for both; allantools takes one column per
call. The two are timed in alternation, so that a busy machine slows both
alike, and the largest relative difference of the deviations is reported.
Needs allantools (``pip install allantools``; the ``test`` extra has it).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from imucalib.noise import allan_deviation


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=360_000)
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    import allantools

    rng = np.random.default_rng(0)
    n, rate = args.samples, args.rate
    x = rng.normal(0, 0.02, (n, 3)) + np.cumsum(rng.normal(0, 1e-4, (n, 3)), axis=0)
    taus, ours = allan_deviation(x, rate)

    def theirs():
        return np.column_stack([allantools.oadev(x[:, j], rate=rate, data_type="freq", taus=taus)[1]
                                for j in range(3)])

    ref = theirs()
    times = {"imucalib": [], "allantools": []}
    for _ in range(args.runs):
        for name, fn in (("imucalib", lambda: allan_deviation(x, rate)), ("allantools", theirs)):
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(json.dumps({"benchmark": "allan_deviation", "samples": n, "axes": 3, "taus": int(taus.size),
                      "max_relative_difference": float(np.max(np.abs(ours / ref - 1))),
                      "imucalib_median_s": round(med["imucalib"], 4),
                      "allantools_median_s": round(med["allantools"], 4),
                      "imucalib_times_s": [round(t, 4) for t in times["imucalib"]],
                      "allantools_times_s": [round(t, 4) for t in times["allantools"]]}))


if __name__ == "__main__":
    main()
