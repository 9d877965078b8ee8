"""Wang 2019: time of one calibration and of the §5.1 Monte Carlo; prints JSON.

``--tables`` runs 500 seeded simulations for each turntable error (3″, 3′, 3°)
with and without the initial-value estimation and prints the RMS errors per
axis in the units of Tables 2–3 next to the paper's, whether each group's
largest axis is at or below the table's, which axes are above the table's
same axis, and the divergent-run counts.
"""

from __future__ import annotations

import argparse
import json
import time

from _common import median_time

from imucalib.experiments.wang2019 import montecarlo
from imucalib.methods.wang2019 import calibrate
from imucalib.scenarios.wang2019 import session


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--tables", action="store_true")
    parser.add_argument("--mc-runs", type=int, default=500)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    sim = session(0)
    med, _ = median_time(lambda: calibrate(sim), args.runs)
    out = {"benchmark": "wang2019", "calibrate_median_s": round(med, 5)}
    if args.tables:
        out["tables"] = {}
        for tt in ("3arcsec", "3arcmin", "3deg"):
            t0 = time.perf_counter()
            est = montecarlo(args.mc_runs, turntable_error=tt, workers=args.workers)
            nom = montecarlo(args.mc_runs, turntable_error=tt, workers=args.workers, initial="nominal")
            paper = est["paper_rms"]
            out["tables"][tt] = {
                "rms": {k: [float(f"{x:.3g}") for x in v] for k, v in est["rms"].items()},
                "paper_rms": est["paper_rms"],
                "within_paper_max_axis": est["within_paper"],
                "axes_above_paper": {k: [i for i, (x, p) in enumerate(zip(v, paper[k], strict=True)) if x > p]
                                     for k, v in est["rms"].items()},
                "divergent_with_initial_estimation": est["divergent_runs"],
                "failures": len(est["failures"]) + len(nom["failures"]),
                "divergent_without": nom["divergent_runs"],
                "seconds": round(time.perf_counter() - t0, 1),
            }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
