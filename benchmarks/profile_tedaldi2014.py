"""Where the Tedaldi 2014 calibration of imu_tk's Xsens session spends its time, per stage; prints JSON.

Runs the library call ``--runs`` times under :mod:`cProfile` and prints, for
each stage (a function of the package, matched by module and name), its
cumulative time per call [ms], the number of times it ran per call, and the
Levenberg–Marquardt fits' cost and Jacobian evaluations. The profiler slows
Python-level code more than numpy's, so the shares, not the absolute figures,
are what to compare; ``bench_tedaldi2014.py`` times the call itself.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats

from _common import require_data

from imucalib.io import read
from imucalib.methods import calibrate

#: (module path ending, function name) of the stages reported, in the order of the calibration
STAGES = [
    ("segment.py", "detect_intervals"),
    ("segment.py", "unreliable_transitions"),
    ("fit/gyroscope.py", "fit_gyroscope"),
    ("fit/gyro_static.py", "static_gyro"),
    ("fit/gyro_direction.py", "solve_direction"),
    ("fit/gyro_joint.py", "solve_joint"),
    ("fit/gyro_joint.py", "joint_errors"),
    ("metrics.py", "fit_summary"),
    ("verdict/__init__.py", "assess"),
    ("kinematics/integrator.py", "step_factors"),
    ("kinematics/integrator.py", "from_samples"),
    ("kinematics/integrator.py", "sensitivity"),
    ("kinematics/integrator.py", "weighted_sum"),
    ("solve.py", "levenberg_marquardt"),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=10)
    args = parser.parse_args()
    data = require_data("xsens_imu_tk")
    rec = read([str(data / "xsens_acc.mat"), str(data / "xsens_gyro.mat")], reader="imutk")
    calibrate(rec, method="tedaldi2014", gravity=9.81744)  # imports and first-call work out of the figures
    profile = cProfile.Profile()
    profile.enable()
    for _ in range(args.runs):
        calibrate(rec, method="tedaldi2014", gravity=9.81744)
    profile.disable()
    stats = pstats.Stats(profile).stats  # (file, line, name) → (calls, primitive calls, tottime, cumtime, callers)
    out = {}
    total = 0.0
    for (path, _, name), (_, calls, _, cumtime, _) in stats.items():
        path = path.replace("\\", "/")
        if name == "calibrate" and path.endswith("methods/__init__.py"):
            total = cumtime
        for suffix, stage in STAGES:
            if name == stage and path.endswith(suffix):
                key = f"{suffix.removesuffix('.py')}.{stage}"
                entry = out.setdefault(key, {"ms_per_call": 0.0, "runs_per_call": 0.0})
                entry["ms_per_call"] += round(1e3 * cumtime / args.runs, 2)
                entry["runs_per_call"] += calls / args.runs
    order = [f"{s.removesuffix('.py')}.{n}" for s, n in STAGES]
    print(json.dumps({"benchmark": "tedaldi2014_xsens_stages", "runs": args.runs, "profiled": True,
                      "calibrate_ms_per_call": round(1e3 * total / args.runs, 1),
                      "stages": {k: out[k] for k in order if k in out}}))


if __name__ == "__main__":
    main()
