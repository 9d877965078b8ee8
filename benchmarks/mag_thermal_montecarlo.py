"""Monte Carlo of the magnetometer calibration and of the thermal models on the hand-held scenario; prints JSON.

``--part magnetometer`` (default ``--runs 20``): hand-held sessions with the simulated magnetometer
(MPU-9250 axes, or ``--axes reflected`` for x ↔ y without z reversed), calibrated with ``--method``; per
run the normalised errors ``(estimate − truth)/σ`` of the 13 magnetometer parameters (hard iron 3, soft
iron 6, the alignment's small rotation 3 from scipy's ``Rotation``, the dip), and the field-norm and dip
spreads over the poses against what the true parameters give on the same poses. Prints the largest
|z|, the RMS z per parameter, the count beyond 3σ and the largest spread ratios.

``--part thermal``: per run a new sensor with datasheet-like thermal coefficients; calibrations at
10, 25 and 40 °C combined (:func:`imucalib.thermal.combine`) and a warm-up session (22 → 40 °C,
60 poses) calibrated with ``temperature_model="linear"``, each validated on a new session (32 °C,
and another warm-up): the accelerometer residual and gyroscope error over the true parameters' on
the same recording, and the same for the 25 °C calibration alone and the plain calibration of the
warm-up. The sessions have no turn-on bias offset, drift or random walk (``STEADY``): what changes
between them is the temperature.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from imucalib.fit.magnetometer import pose_figures, pose_references
from imucalib.methods import calibrate
from imucalib.metrics import interval_means
from imucalib.recording import ImucalibWarning, Interval
from imucalib.scenarios import handheld
from imucalib.thermal import combine
from imucalib.validation import validate

STEADY = {"turn_on": 0.0, "gyro_drift": 0.0, "gyro_rw": 0.0}
AXES = {"mpu9250": [[0, 1, 0], [1, 0, 0], [0, 0, -1]], "reflected": [[0, 1, 0], [1, 0, 0], [0, 0, 1]]}


def magnetometer_run(seed: int, method: str, axes: str) -> dict:
    d = handheld.generate(np.random.default_rng(1000 + seed), magnetometer={"axes": AXES[axes]})
    rec, truth = d["recording"], d["truth"]
    cal = calibrate(rec, method=method)
    m, t, u = cal.magnetometer, truth.magnetometer, cal.fit["uncertainty"]
    z = [(m.bias[i] - t.bias[i]) / u[f"magnetometer.bias.{a}"] for i, a in enumerate("xyz")]
    for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)):
        z.append((m.soft_iron[i, j] - t.soft_iron[i, j]) / u[f"magnetometer.soft_iron.{'xyz'[i]}{'xyz'[j]}"])
    same_hand = np.linalg.det(m.alignment) * np.linalg.det(t.alignment) > 0
    psi = Rotation.from_matrix(m.alignment @ t.alignment.T).as_rotvec() if same_hand else np.full(3, np.inf)
    z += [psi[i] / u[f"magnetometer.alignment_angle.{a}"] for i, a in enumerate("xyz")]
    z.append(np.radians(cal.fit["magnetometer_dip_deg"] - d["options"]["magnetometer"]["dip_deg"])
             / u["magnetometer.dip"])
    ivs = [Interval(a, b) for a, b in cal.fit["intervals"]]
    up, rot = pose_references(truth, rec, ivs)
    true_fig = pose_figures(t, interval_means(rec.mag, ivs), up, rot)
    return {"seed": seed, "verdict": cal.fit["verdict"], "z": [float(v) for v in z],
            "norm_spread_ratio": cal.fit["magnetometer_norm_spread"] / true_fig["norm_spread"],
            "dip_spread_ratio": cal.fit["magnetometer_dip_spread_deg"] / true_fig["dip_spread_deg"]}


def _figures(cal, rec) -> np.ndarray:
    v = validate(cal, rec)
    return np.array([v["accelerometer_residual_rms"], v["gyroscope_angle_error_mean_deg"]])


def thermal_run(seed: int, method: str) -> dict:
    rng = np.random.default_rng(seed)
    sensor = handheld.consumer_truth(rng)
    coeffs = handheld.datasheet_thermal(rng, sensor)
    cals = [calibrate(handheld.generate(np.random.default_rng(100 * seed + 10 + i), truth=sensor, thermal=coeffs,
                                        temperature=temp, **STEADY)["recording"], method=method)
            for i, temp in enumerate((10.0, 25.0, 40.0))]
    combined, _ = combine(cals)
    check = handheld.generate(np.random.default_rng(100 * seed + 99), truth=sensor, thermal=coeffs,
                              temperature=32.0, **STEADY)
    best = _figures(check["truth"], check["recording"])
    ramp = {"ramp": (22.0, 40.0, 150.0), "rest": 40.0, "n_poses": 60, **STEADY}
    warm = handheld.generate(np.random.default_rng(100 * seed + 50), truth=sensor, thermal=coeffs, **ramp)
    ramp_cal = calibrate(warm["recording"], method=method, temperature_model="linear")
    plain = calibrate(warm["recording"], method=method)
    check2 = handheld.generate(np.random.default_rng(100 * seed + 51), truth=sensor, thermal=coeffs, **ramp)
    best2 = _figures(check2["truth"], check2["recording"])
    return {"seed": seed,
            "combined_over_truth": (_figures(combined, check["recording"]) / best).tolist(),
            "at_25C_over_truth": (_figures(cals[1], check["recording"]) / best).tolist(),
            "ramp_over_truth": (_figures(ramp_cal, check2["recording"]) / best2).tolist(),
            "plain_over_truth": (_figures(plain, check2["recording"]) / best2).tolist()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("magnetometer", "thermal"), default="magnetometer")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--method", default="tedaldi2014")
    ap.add_argument("--axes", choices=tuple(AXES), default="mpu9250")
    args = ap.parse_args()
    warnings.simplefilter("ignore", ImucalibWarning)
    t0 = time.perf_counter()
    if args.part == "magnetometer":
        runs = [magnetometer_run(s, args.method, args.axes) for s in range(args.runs)]
        z = np.array([r["z"] for r in runs])
        out = {"part": "magnetometer", "method": args.method, "axes": args.axes, "runs": len(runs),
               "accepted": sum(r["verdict"] == "accepted" for r in runs),
               "max_abs_z": float(np.abs(z).max()), "beyond_3_sigma": int((np.abs(z) > 3).sum()),
               "parameters_compared": int(z.size),
               "rms_z_per_parameter": np.round(np.sqrt((z**2).mean(axis=0)), 3).tolist(),
               "max_norm_spread_ratio": max(r["norm_spread_ratio"] for r in runs),
               "max_dip_spread_ratio": max(r["dip_spread_ratio"] for r in runs)}
    else:
        runs = [thermal_run(s, args.method) for s in range(args.runs)]
        out = {"part": "thermal", "method": args.method, "runs": len(runs),
               **{f"max_{k}": np.max([r[k] for r in runs], axis=0).round(3).tolist()
                  for k in ("combined_over_truth", "ramp_over_truth")},
               **{f"min_{k}": np.min([r[k] for r in runs], axis=0).round(2).tolist()
                  for k in ("at_25C_over_truth", "plain_over_truth")},
               "per_run": runs}
    out["seconds"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
