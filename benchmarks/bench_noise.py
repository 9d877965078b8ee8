"""Noise figures from the Allan deviation against the truth of simulated rests, and on the real Xsens rest; JSON.

* ``long``: 3000 s at 100 Hz of white noise plus a rate random walk on three
  axes of each sensor (accelerometer N = 2e-3, K = 3e-4; gyroscope N = 2e-4,
  K = 2e-5), over seeds: the recovered figure over the truth per axis
  (median, worst), how many axes have the figure (the +½ slope shown and
  read there within 20 % at 95 % confidence), how many are within 20 %, how
  many figures exceed their own upper bound and how many random walk bounds
  fall below the truth;
* ``short``: the same sensors over the 50 s of a calibration's initial rest:
  the random walk must be a bound (NaN figure) that holds the truth;
* ``bump``: the short rest with a 16 Hz vibration on one axis (the curve rises
  at τ ≈ 0.03 s): its random walk must stay a bound, under 0.01;
* ``xsens``: ``noise_summary`` of the shared Xsens session's initial rest
  (counts), what ``imucalib noise`` prints;
* ``allantools``: the largest relative difference of the deviations from
  allantools.oadev on the long rest's first axis (when allantools is installed).

Run ``python benchmarks/bench_noise.py [--seeds 30]``.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from _common import DATA

from imucalib.noise import allan_deviation, noise_parameters, noise_summary

SENSORS = {"accelerometer": (2e-3, 3e-4), "gyroscope": (2e-4, 2e-5)}  # (N [unit·√s], K [unit/√s])


def rest(rng, rate, n, white, walk):
    return (rng.normal(0, white * np.sqrt(rate), (n, 3))
            + np.cumsum(rng.normal(0, walk / np.sqrt(rate), (n, 3)), axis=0))


def stats(ratios):
    r = np.asarray(ratios)
    finite = r[np.isfinite(r)]
    return {"axes": int(r.size), "with_figure": int(finite.size),
            "within_20_percent": int(np.sum(np.abs(finite - 1) <= 0.2)),
            "median": float(np.median(finite)) if finite.size else None,
            "worst": float(finite[np.argmax(np.abs(finite - 1))]) if finite.size else None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--rate", type=float, default=100.0)
    args = parser.parse_args()
    rate = args.rate
    out: dict = {"rate_hz": rate}
    long = {name: {"white": [], "walk": [], "figure_above_bound": 0, "bound_below_truth": 0} for name in SENSORS}
    short = {name: {"walk_figures": 0, "bound_below_truth": 0, "white": []} for name in SENSORS}
    times = []
    first = None
    for seed in range(args.seeds):
        rng = np.random.default_rng(seed)
        for name, (white, walk) in SENSORS.items():
            x = rest(rng, rate, int(3000 * rate), white, walk)
            first = x[:, 0] if first is None else first
            t0 = time.perf_counter()
            p = noise_parameters(x, rate)
            times.append(time.perf_counter() - t0)
            long[name]["white"] += list(p["white_noise_density"] / white)
            long[name]["walk"] += list(p["random_walk"] / walk)
            for key in ("white_noise_density", "random_walk", "bias_instability"):
                long[name]["figure_above_bound"] += int(np.sum(p[key] > p[key + "_bound"]))
            long[name]["bound_below_truth"] += int(np.sum(p["random_walk_bound"] < walk))
            s = noise_parameters(x[: int(50 * rate)], rate)
            short[name]["walk_figures"] += int(np.sum(np.isfinite(s["random_walk"])))
            short[name]["bound_below_truth"] += int(np.sum(s["random_walk_bound"] < walk))
            short[name]["white"] += list(s["white_noise_density"] / white)
    out["long_3000s"] = {name: {"white_noise_over_truth": stats(v["white"]),
                                "random_walk_over_truth": stats(v["walk"]),
                                "figure_above_bound": v["figure_above_bound"],
                                "random_walk_bound_below_truth": v["bound_below_truth"]} for name, v in long.items()}
    out["short_50s"] = {name: {"white_noise_over_truth": stats(v["white"]), "random_walk_figures": v["walk_figures"],
                               "random_walk_bound_below_truth": v["bound_below_truth"]} for name, v in short.items()}
    out["seconds_per_sensor_3000s_median"] = float(np.median(times))
    rng = np.random.default_rng(100)
    n = int(50 * rate)
    t = np.arange(n) / rate
    x = rest(rng, rate, n, 3e-3, 1e-5)
    x[:, 0] += 0.05 * np.sin(2 * np.pi * 16.0 * t)
    p = noise_parameters(x, rate)
    out["bump_16hz"] = {"random_walk": p["random_walk"].tolist(), "random_walk_bound": p["random_walk_bound"].tolist()}
    data = DATA / "xsens_imu_tk"
    if data.is_dir():
        from imucalib.reading import read as read_data
        from imucalib.segment import find_initial_rest

        rec = read_data([str(data / "xsens_acc.mat"), str(data / "xsens_gyro.mat")], reader="imutk")
        doc = noise_summary(rec[find_initial_rest(rec)])
        keys = ("white_noise_density", "bias_instability", "random_walk", "random_walk_bound")
        out["xsens_rest_counts"] = {"seconds": doc["seconds"], **{
            name: {k: doc[name][k] for k in keys} for name in SENSORS}}
    else:
        out["xsens_rest_counts"] = f"skipped: {data} not present"
    try:
        import allantools
    except ImportError:
        out["allantools"] = "not installed"
    else:
        taus, ours = allan_deviation(first, rate)
        _, ref, _, _ = allantools.oadev(first, rate=rate, data_type="freq", taus=taus)
        out["allantools"] = {"max_rel_diff": float(np.max(np.abs(ours / ref - 1)))}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
