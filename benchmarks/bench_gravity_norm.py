"""Time the accelerometer's gravity-norm fits of a Tedaldi 2014 calibration of imu_tk's Xsens data; prints JSON.

The threshold scan fits ``‖a_k‖ = g`` (:func:`imucalib.fit.accelerometer.fit_gravity_norm`) once for each
distinct set of static intervals. Their inputs (the poses' raw means) are recorded from one calibration, then
the fits are timed alone: ``fits_cpu_median_s`` is the median CPU seconds of all of them (``--runs`` rounds),
and ``digest`` a SHA-256 of their results' bytes, which a faster form must leave unchanged.
"""

from __future__ import annotations

import argparse
import hashlib
import json

import numpy as np
from _common import median_cpu_time, require_data

from imucalib.io import read
from imucalib.methods import calibrate
from imucalib.segment import detect as segment  # the scan that calls fit_gravity_norm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=40)
    args = parser.parse_args()
    data = require_data("xsens_imu_tk")
    rec = read([data / "xsens_acc.mat", data / "xsens_gyro.mat"], reader="imutk")
    fit = segment.fit_gravity_norm
    inputs = []

    def recording(raw_means, gravity, **kw):
        inputs.append((np.array(raw_means), gravity, kw))
        return fit(raw_means, gravity, **kw)

    segment.fit_gravity_norm = recording
    try:
        calibrate(rec, method="tedaldi2014", gravity=9.81744)
    finally:
        segment.fit_gravity_norm = fit

    def fits():
        return [fit(m, g, **kw) for m, g, kw in inputs]

    digest = hashlib.sha256()
    for model, res in fits():
        for part in (model.misalignment, model.scale, model.bias, res):
            digest.update(part.tobytes())
    print(json.dumps({"fits": len(inputs), "poses": [len(m) for m, _, _ in inputs],
                      "fits_cpu_median_s": median_cpu_time(fits, args.runs), "digest": digest.hexdigest()}))


if __name__ == "__main__":
    main()
