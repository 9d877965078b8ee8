"""zhang2021 against tedaldi2014: |a|−g and the gyroscope's error, in-sample and held-out; prints JSON.

Both methods with default options (zhang2021: model ``all`` with its selection;
also ``linear`` on the hand-held sessions, where the truth is known).

* **Xsens** (imu_tk's session, ``../shared/data/xsens_imu_tk``, g = 9.81744):
  in-sample ``accelerometer_residual_rms`` [m/s²] and ``gyroscope_angle_error_mean_deg``;
  held-out by leave-one-pose-out (:func:`imucalib.crossval.leave_one_pose_out`,
  every pose) and by halves: fitted on the first half of the poses (the initial
  rest first), judged on the second half's poses and rotations, and the other way round.
* **Hand-held** (``handheld`` scenario, ``--seeds`` seeds): the same in-sample
  and halves figures, the gyroscope error against what the true parameters
  leave on the same poses (``gyro_to_truth``), and the verdicts.

Ratios are zhang2021 / tedaldi2014 (≤ 1.2 wanted) and fitted / truth (≤ 1.2 wanted).
"""

from __future__ import annotations

import argparse
import json
import warnings
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from _common import DATA

from imucalib.crossval import leave_one_pose_out
from imucalib.methods import calibrate
from imucalib.metrics import fit_summary, gravity_direction_errors
from imucalib.recording import Interval

XSENS_GRAVITY = 9.81744
#: (name, method, model): the calibrations compared
RUNS = (("tedaldi2014", "tedaldi2014", None), ("zhang2021", "zhang2021", None),
        ("zhang2021_linear", "zhang2021", "linear"))


def _fit(rec, method, model, gravity, intervals=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kw = {} if intervals is None else {"intervals": intervals}
        return calibrate(rec, method=method, model=model, gravity=gravity, **kw)


def _figures(cal) -> dict:
    return {"acc_rms": cal.fit["accelerometer_residual_rms"], "gyro_deg": cal.fit["gyroscope_angle_error_mean_deg"]}


def _halves(rec, method, model, gravity, intervals) -> dict:
    """Fit on one half of the poses, judge on the other's poses and rotations; the mean of both ways."""
    h = len(intervals) // 2
    first, second = intervals[:h], intervals[h:]
    acc, gyro = [], []
    for train, test in ((first, second), (second, first)):
        cal = _fit(rec, method, model, gravity, train)
        held = fit_summary(cal, rec, test, gravity)
        acc.append(held["accelerometer_residual_rms"])
        gyro.append(held["gyroscope_angle_error_mean_deg"])
    return {"acc_rms": float(np.mean(acc)), "gyro_deg": float(np.mean(gyro)),
            "acc_rms_each": acc, "gyro_deg_each": gyro}


def _intervals(cal) -> list[Interval]:
    return [Interval(int(a), int(b), "static") for a, b in cal.fit["intervals"]]


def xsens(folds: int | None) -> dict:
    path = DATA / "xsens_imu_tk"
    if not path.is_dir():
        return {"skipped": f"{path} not present"}
    from imucalib.io import read

    rec = read([path / "xsens_acc.mat", path / "xsens_gyro.mat"], reader="imutk")
    g = XSENS_GRAVITY
    out: dict = {}
    for name, method, model in RUNS[:2]:
        cal = _fit(rec, method, model, g)
        iv = _intervals(cal)
        sel = cal.fit.get("model_selection", {}).get("selected", cal.model)
        picks = list(range(1, len(iv)))
        if folds:
            picks = picks[:: max(1, len(picks) // folds)]
        cv = leave_one_pose_out(rec, iv, lambda tr, method=method, model=model: _fit(rec, method, model, g, tr),
                                gravity=g, folds=picks)
        out[name] = {"model": sel, "verdict": cal.fit["verdict"], "in_sample": _figures(cal),
                     "leave_one_pose_out": {"acc_rms": cv["cv_accelerometer_residual_rms"],
                                            "gyro_deg": cv["cv_gyroscope_angle_error_mean_deg"],
                                            "folds": cv["folds"]},
                     "halves": _halves(rec, method, model, g, iv)}
    z, t = out["zhang2021"], out["tedaldi2014"]
    out["ratio_zhang_to_tedaldi"] = {
        part: {k: z[part][k] / t[part][k] for k in ("acc_rms", "gyro_deg")}
        for part in ("in_sample", "leave_one_pose_out", "halves")}
    return out


def handheld_seed(seed: int) -> dict:
    from imucalib.scenarios import session

    sim = session("handheld", rng=seed)
    g = sim.truth.gravity
    row: dict = {"seed": seed}
    for name, method, model in RUNS:
        cal = _fit(sim.recording, method, model, g)
        iv = _intervals(cal)
        truth = float(np.degrees(np.mean(gravity_direction_errors(sim.truth, sim.recording, iv))))
        row[name] = {"model": cal.model, "verdict": cal.fit["verdict"], "in_sample": _figures(cal),
                     "gyro_to_truth": cal.fit["gyroscope_angle_error_mean_deg"] / truth,
                     "halves": _halves(sim.recording, method, model, g, iv)}
    return row


def _summary(rows: list[dict]) -> dict:
    out: dict = {}
    for name, _, _ in RUNS:
        gt = np.array([r[name]["gyro_to_truth"] for r in rows])
        verdicts = [r[name]["verdict"] for r in rows]
        out[name] = {"gyro_to_truth_median": float(np.median(gt)), "gyro_to_truth_max": float(gt.max()),
                     "accepted": verdicts.count("accepted"), "sessions": len(rows),
                     "models": sorted({r[name]["model"] for r in rows})}
        if name != "tedaldi2014":
            ratios = {}
            for part in ("in_sample", "halves"):
                for k in ("acc_rms", "gyro_deg"):
                    v = np.array([r[name][part][k] / r["tedaldi2014"][part][k] for r in rows])
                    ratios[f"{part}_{k}"] = {"median": float(np.median(v)), "max": float(v.max())}
            out[name]["ratio_to_tedaldi"] = ratios
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--folds", type=int, default=0, help="Xsens held-out poses (0: every pose)")
    parser.add_argument("--per-seed", action="store_true", help="also print every hand-held session's figures")
    args = parser.parse_args()
    result = {"benchmark": "zhang_vs_tedaldi", "xsens": xsens(args.folds or None)}
    with ProcessPoolExecutor(args.workers) as ex:
        rows = list(ex.map(handheld_seed, range(args.seeds)))
    result["handheld"] = {"seeds": args.seeds, "summary": _summary(rows)}
    if args.per_seed:
        result["handheld"]["sessions"] = rows
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
