"""Time the Tedaldi 2014 calibration on imu_tk's Xsens data; prints JSON.

* ``calibrate_median_s``: the library call (detection with the threshold scan,
  accelerometer and gyroscope fits), data already in memory;
* ``cli_median_s``: the whole ``imucalib calibrate … --json`` process.

imu_tk's Ceres-based call takes about 0.86 s on this kind of machine (whole
program about 2.4 s); the targets are ≤ 0.43 s and ≤ 1.5 s.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

from _common import median_time, require_data

from imucalib.io import read
from imucalib.methods import calibrate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    data = require_data("xsens_imu_tk")
    files = [str(data / "xsens_acc.mat"), str(data / "xsens_gyro.mat")]
    rec = read(files, reader="imutk")
    cal_med, cal_times = median_time(
        lambda: calibrate(rec, method="tedaldi2014", gravity=9.81744), args.runs)
    cmd = [sys.executable, "-m", "imucalib.cli", "calibrate", *files, "--reader", "imutk",
           "--method", "tedaldi2014", "--gravity", "9.81744", "--json"]
    cli_med, cli_times = median_time(
        lambda: subprocess.run(cmd, check=True, capture_output=True), max(3, args.runs // 2))
    print(json.dumps({
        "benchmark": "tedaldi2014_xsens",
        "runs": args.runs,
        "calibrate_median_s": round(cal_med, 4),
        "calibrate_times_s": [round(t, 4) for t in cal_times],
        "cli_median_s": round(cli_med, 4),
        "cli_times_s": [round(t, 4) for t in cli_times],
        "targets_s": {"calibrate": 0.43, "cli": 1.5},
        "imu_tk_reference_s": {"calibrate": 0.86, "program": 2.4},
    }))


if __name__ == "__main__":
    main()
