"""The joint gyroscope fit's Jacobians hold no per-sample Jacobian of every integrated sample at once."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from imucalib.fit import gyro_joint
from imucalib.fit import gyroscope as G
from imucalib.io import read
from imucalib.methods import calibrate
from imucalib.metrics import transition_bounds
from imucalib.recording import Interval, Recording

XSENS = Path(__file__).resolve().parents[2] / "shared" / "data" / "xsens_imu_tk"


def _peak(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.skipif(not XSENS.is_dir(), reason=f"{XSENS} not present (needs ../shared/data)")
def test_g_sensitivity_jacobian_memory_follows_the_parameters_jacobian() -> None:
    """∂r/∂G (the joint 1σ) in the memory of the fit's own Jacobian, not 216 more bytes per sample.

    The Xsens session resampled 8 times denser (long rotations): a per-sample
    (S, 3, 9) array of ∂ω/∂G would add 216 bytes per integrated sample to what
    the fit's Jacobian needs; the few (S, 3) arrays of readings it forms are
    under 100.
    """
    rec = read([str(XSENS / "xsens_acc.mat"), str(XSENS / "xsens_gyro.mat")], reader="imutk")
    cal = calibrate(rec, method="tedaldi2014", gravity=9.81744)
    k = 8
    t = np.linspace(rec.t[0], rec.t[-1], (len(rec) - 1) * k + 1)
    dense = Recording(t, np.column_stack([np.interp(t, rec.t, c) for c in rec.acc.T]),
                      np.column_stack([np.interp(t, rec.t, c) for c in rec.gyro.T]))
    intervals = [Interval(a * k, (b - 1) * k + 1, "static") for a, b in cal.fit["intervals"]]
    static = G.static_gyro(dense, intervals, cal.accelerometer, g_sensitivity=True, drift=True)
    assert static.g_sensitivity is not None
    weights = np.ones(len(intervals) - 1)
    theta = np.concatenate([G.GyroLayout(True).pack(cal.gyroscope),
                            static.drift if static.drift is not None else np.zeros(0)])
    _, jac, _, _ = G.joint_problem(dense, intervals, cal.accelerometer, static, weights, 1e-3)
    starts, stops = transition_bounds(intervals)
    samples = int(np.sum(stops - starts + 1))
    assert samples > 100_000
    base = _peak(lambda: jac(theta))
    peak = _peak(lambda: gyro_joint._g_sensitivity_jacobian(dense, intervals, cal.accelerometer, static, weights, 1e-3,
                                                   theta))
    assert peak < base + 150 * samples, f"{peak / 1e6:.1f} MB against {base / 1e6:.1f} MB for {samples} samples"
