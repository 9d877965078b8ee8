"""Wang 2019: time of one calibration and of the §5.1 Monte Carlo; prints JSON.

``--tables`` runs 500 seeded simulations for each turntable error (3″, 3′, 3°)
with and without the initial-value estimation and prints the RMS errors in the
units of Tables 2–3 next to the paper's, and the divergent-run counts.
"""

from __future__ import annotations

import argparse
import json
import time

from _common import median_time

from imucalib.methods.wang2019 import calibrate, montecarlo
from imucalib.scenarios_wang2019 import session

PAPER_3ARCSEC_RMS = {  # Table 2 and Table 3, 3″ column, RMS (largest axis)
    "acc_bias_ug": 2.02, "acc_k1_ug_per_pulse": 3.35e-5, "acc_k2_fg_per_pulse2": 4.93e-2,
    "acc_k3_zg_per_pulse3": 0.62, "acc_misalignment_1e-4": 1.91e-2,
    "gyro_bias_1e-6_deg_s": 1.58e-2, "gyro_k1_1e-7_deg_s_pulse": 6.27e-8,
    "gyro_k2_1e-17_deg_s_pulse2": 9.40e-2, "gyro_misalignment_1e-4": 1.18e-4,
}


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
            out["tables"][tt] = {
                "rms_max_axis": {k: max(v) for k, v in est["rms"].items()},
                "divergent_with_initial_estimation": est["divergent_runs"],
                "divergent_without": nom["divergent_runs"],
                "seconds": round(time.perf_counter() - t0, 1),
            }
        out["paper_3arcsec_rms_max_axis"] = PAPER_3ARCSEC_RMS
    print(json.dumps(out))


if __name__ == "__main__":
    main()
