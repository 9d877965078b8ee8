"""Time one Zhang 2021 'all' calibration of a default zhang2021 session; prints JSON.

The median wall time and the median CPU seconds (all threads of the process: a
second BLAS thread that waits shows here); ``OPENBLAS_NUM_THREADS=1`` in the
environment runs numpy's BLAS on one thread, as the ``imucalib`` command does.

Required ≤ 3 s on the 2-core reference machine, target ≤ 1 s, goal of the second
round of speed work ≤ 0.6 s. With ``--montecarlo`` also times
``montecarlo(zhang2021, zhang2021, all, runs=20, workers=2)`` (≤ 2 min).
``--baseline DIR`` also times the same call with another copy of the package
(``DIR``: e.g. the ``src`` of an older checkout) and with this one, in turns,
a fresh process each (``"in_turns"``: ``"after"``, ``"before"``, the medians of
``--runs`` calls in each of 3 processes a copy).
"""

from __future__ import annotations

import argparse
import json
import os
import time
import warnings

from _common import calls_in_turns, median_cpu_time, median_time

from imucalib.experiments.evaluate import montecarlo
from imucalib.methods import calibrate
from imucalib.scenarios import session


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--montecarlo", action="store_true")
    parser.add_argument("--baseline", metavar="DIR", help="another copy of the package to compare with")
    args = parser.parse_args()
    sim = session("zhang2021", rng=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        med, times = median_time(
            lambda: calibrate(sim, method="zhang2021", model="all", gravity=sim.truth.gravity),
            args.runs)
        cpu = median_cpu_time(
            lambda: calibrate(sim, method="zhang2021", model="all", gravity=sim.truth.gravity), args.runs)
    out = {"benchmark": "zhang2021_all_default_session", "runs": args.runs,
           "calibrate_median_s": round(med, 4), "calibrate_times_s": [round(t, 4) for t in times],
           "calibrate_cpu_median_s": round(cpu, 4), "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
           "required_s": 3.0, "target_s": 1.0, "goal_s": 0.6}
    if args.baseline:
        script = ("import warnings\nwarnings.simplefilter('ignore')\nfrom imucalib.methods import calibrate\n"
                  "from imucalib.scenarios import session\nsim = session('zhang2021', rng=0)\n"
                  "def call(): calibrate(sim, method='zhang2021', model='all', gravity=sim.truth.gravity)\n")
        out["in_turns"] = calls_in_turns(script, args.baseline, 3, args.runs)
    if args.montecarlo:
        t0 = time.perf_counter()
        montecarlo("zhang2021", "zhang2021", model="all", runs=20, workers=2)
        out["montecarlo_20_runs_2_workers_s"] = round(time.perf_counter() - t0, 2)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
