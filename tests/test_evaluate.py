"""Metrics on hand-computed cases and at the truth; Monte Carlo summaries."""

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.experiments.evaluate import montecarlo, parameter_errors
from imucalib.experiments.zhang2021 import eq34, eq35, reductions, sequence_metrics
from imucalib.metrics import fit_summary, gravity_residuals
from imucalib.models import TriadModel
from imucalib.recording import Interval, Recording
from imucalib.scenarios import TossSequence, session


def test_metrics_are_exact_at_the_truth():
    sim = session("zhang2021", rng=8, noise=0, n2=1, n3=4)
    m = sequence_metrics(sim.truth, sim.tests)
    np.testing.assert_allclose(m["eq35"], 1.0, atol=1e-12)
    # eq. (34) at the truth: only the five-point stencil's O(dt⁴) error remains
    assert max(m["eq34"]) < 1e-3
    fit = fit_summary(sim.truth, sim.recording, [s for s in sim.segments if s.kind == "static"])
    assert fit["accelerometer_residual_rms"] < 1e-10  # m/s², rounding of ‖a‖ ≈ 9.8
    assert fit["gyroscope_angle_error_max_deg"] < 1e-4


def test_hand_computed_cases():
    # identity calibration: raw = SI
    cal = Calibration(units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
                             "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}},
                      lever_arm=[0.1, 0.0, 0.0])
    n = 50
    t = np.arange(n) * 0.01
    w = np.tile([0.0, 0.0, 2.0], (n, 1))  # spin about z at 2 rad/s, r along x
    a = np.tile([0.4, 0.0, 0.0], (n, 1))  # centripetal ω² r = 4 · 0.1, no Euler term
    rec = Recording(t, a, w, acc_unit="m/s^2", gyro_unit="rad/s")
    test = TossSequence(rec, [Interval(0, n, "weightless")])
    assert eq34(cal, test) == pytest.approx(0.0, abs=1e-20)
    a2 = a + [0.0, 0.1, 0.0]  # 0.1 m/s² off on every frame
    assert eq34(cal, TossSequence(Recording(t, a2, w, acc_unit="m/s^2", gyro_unit="rad/s"),
                                  test.segments)) == pytest.approx(n * 0.01)
    # eq. (35): rest, a 90° turn about x in 1 s, rest
    n0, n1 = 20, 101
    w = np.zeros((n0 + n1 + n0, 3))
    w[n0 : n0 + n1, 0] = np.pi / 2 * (1 - np.cos(2 * np.pi * np.arange(n1) / (n1 - 1)))
    acc = np.tile([0.0, 0.0, 9.8], (len(w), 1))
    acc[n0 + n1 :] = [0.0, 9.8, 0.0]  # gravity after a +90° turn about x: Rᵀ ẑ = ŷ
    t = np.arange(len(w)) * 0.01
    seq = TossSequence(Recording(t, acc, w, acc_unit="m/s^2", gyro_unit="rad/s"),
                       [Interval(0, n0), Interval(n0, n0 + n1, "motion"), Interval(n0 + n1, len(w))])
    assert eq35(cal, seq) == pytest.approx(1.0, abs=1e-7)
    acc[n0 + n1 :] = [0.0, 0.0, 9.8]  # the sensor claims it never turned: cos 90° = 0
    assert eq35(cal, seq) == pytest.approx(0.0, abs=1e-6)
    red = reductions({"eq34": [1.0, 2.0], "eq35": [1.0, np.cos(0.1)]},
                     {"eq34": [4.0, 4.0], "eq35": [np.cos(0.2), np.cos(0.4)]})
    assert red["eq34_reduction"] == pytest.approx(0.625)
    assert red["eq35_reduction"] == pytest.approx(0.875)
    # gravity residual: a pose reading 9.9 with g = 9.8 → +0.1
    rec = Recording(np.arange(10) * 0.01, np.tile([0, 0, 9.9], (10, 1)), np.zeros((10, 3)),
                    acc_unit="m/s^2", gyro_unit="rad/s")
    np.testing.assert_allclose(gravity_residuals(cal, rec, [Interval(0, 10)], 9.8), [0.1])


def test_parameter_errors_by_name():
    truth = Calibration(accelerometer=TriadModel(scale=[2.0, 2.0, 2.0], shape="upper"))
    est = truth.with_(accelerometer=truth.accelerometer.with_(scale=np.array([2.5, 2.0, 2.0])))
    err = parameter_errors(est, truth)
    assert err["accelerometer.scale.x"] == pytest.approx(0.5)
    assert err["gyroscope.misalignment.xz"] == 0.0


@pytest.mark.slow
def test_montecarlo_summary_and_failures():
    opts = {"n2": 20, "n3": 2}
    one = montecarlo("zhang2021", "tedaldi2014", runs=2, workers=1, seed=3, sim_options=opts)
    two = montecarlo("zhang2021", "tedaldi2014", runs=2, workers=2, seed=3, sim_options=opts)
    assert one["parameters"] == two["parameters"]  # independent of the worker count
    assert set(one) == {"scenario", "method", "model", "runs", "parameters", "metrics", "verdicts", "failures"}
    assert one["verdicts"] == two["verdicts"] and sum(one["verdicts"].values()) == 2
    names = [p["name"] for p in one["parameters"]]
    assert "accelerometer.scale_quadratic.y" in names and "lever_arm.x" in names
    k1 = next(p for p in one["parameters"] if p["name"] == "accelerometer.scale.z")
    assert abs(k1["mean"] - k1["truth"]) > 1e-2  # the linear model's bias (Table I)
    bad = montecarlo("zhang2021", "nope", runs=2, sim_options=opts)
    assert [f["seed"] for f in bad["failures"]] == [0, 1]
    assert bad["verdicts"] == {"accepted": 0, "suspect": 0, "rejected": 0}  # no run produced a calibration
    assert "unknown method 'nope'" in bad["failures"][0]["message"]
