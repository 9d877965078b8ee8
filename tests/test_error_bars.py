"""The reported 1σ errors are honest: RMS of (estimate − truth)/1σ per parameter group on simulated hand-held sessions.

A small Monte Carlo (``SEEDS``, apart from the benchmark's seeds 0–29) of
``benchmarks/bench_error_bars.py``. For ``n`` values of ``z = (estimate −
truth)/1σ`` from an honest 1σ, ``n · RMS²`` follows χ² with ``n`` degrees of
freedom (the sum of ``n`` squared standard normals). The benchmark's goal is
an RMS within 0.8–1.25 over 30 seeds; here, with fewer values, a group fails
when its RMS leaves that goal widened by the χ² sampling spread at ``n``:
below ``0.8 · √(χ²₀.₀₀₅(n)/n)`` or above ``1.25 · √(χ²₀.₉₉₅(n)/n)`` (a group
whose true RMS sits at an edge of the goal fails at most 0.5 % of the time on
that side; for n = 30 the band is 0.54–1.67, for n = 90 0.64–1.50). The
values of one session are not quite independent, which the 0.5 % leaves room for.

The truth of a drifting gyroscope bias is the session's bias at the time the
fit's bias holds (``fit["gyroscope_bias_time_s"]``, else the mean of the poses'
mean times): the scenario's truth (the bias at the start) plus the drift there,
from a twin session of the same seed without drift. The procedure ``tosses`` is
the ``zhang2021`` scenario with its weightless tosses (no drift), fewer seeds:
the band is derived from the count.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from imucalib.methods import calibrate
from imucalib.scenarios import session

SEEDS = range(100, 110)
#: the tosses' joint fit takes ten times as long: fewer seeds, a wider band
TOSS_SEEDS = range(100, 104)
GOAL = (0.8, 1.25)


def _band(n: int) -> tuple[float, float]:
    from scipy.stats import chi2  # here, not at the top: every test process imports this file to collect it

    return GOAL[0] * np.sqrt(chi2.ppf(0.005, n) / n), GOAL[1] * np.sqrt(chi2.ppf(0.995, n) / n)


def _z(method: str, procedure: str, seed: int) -> dict[str, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if procedure == "tosses":
            sim, twin = session("zhang2021", rng=seed), None
            cal = calibrate(sim.recording, method=method, gravity=sim.truth.gravity, weightless=sim.weightless)
        else:
            sim = session("handheld", rng=seed, procedure=procedure)
            twin = session("handheld", rng=seed, procedure=procedure, gyro_drift=0.0, gyro_rw=0.0)
            cal = calibrate(sim.recording, method=method, gravity=sim.truth.gravity)
    fit, rec = cal.fit, sim.recording
    drift = np.zeros(3)
    if twin is not None:
        t_ref = fit.get("gyroscope_bias_time_s")
        if t_ref is None:
            t_ref = np.mean([np.mean(rec.t[int(a):int(b)]) for a, b in fit["intervals"]])
        near = np.abs(rec.t - t_ref) <= 1.0
        drift = (rec.gyro[near] - twin.recording.gyro[near]).mean(axis=0)
    truth, est = sim.truth.parameters(), cal.parameters()
    out = {}
    for k, s in fit["uncertainty"].items():
        if k in truth and np.isfinite(s) and s > 0:
            ref = truth[k] + (drift["xyz".index(k[-1])] if k.startswith("gyroscope.bias.") else 0.0)
            out[k] = (est[k] - ref) / s
    return out


def _groups(method: str, procedure: str, seeds=SEEDS) -> dict[str, np.ndarray]:
    groups: dict[str, list[float]] = {}
    for seed in seeds:
        for k, z in _z(method, procedure, seed).items():
            groups.setdefault(k.rsplit(".", 1)[0], []).append(z)
    return {g: np.asarray(v) for g, v in groups.items()}


@pytest.mark.slow
@pytest.mark.parametrize(("method", "procedure", "expected"), [
    ("tedaldi2014", "poses", {"accelerometer.bias", "accelerometer.scale", "accelerometer.misalignment",
                              "gyroscope.bias", "gyroscope.scale", "gyroscope.misalignment",
                              "gyroscope.g_sensitivity"}),
    ("zhang2021", "poses", {"accelerometer.bias", "accelerometer.scale", "accelerometer.misalignment",
                            "gyroscope.bias", "gyroscope.scale", "gyroscope.misalignment"}),
    ("six_position", "ferraris", {"gyroscope.bias", "gyroscope.scale", "gyroscope.misalignment",
                                  "gyroscope.g_sensitivity", "accelerometer.misalignment"}),
    ("ferraris", "ferraris", {"accelerometer.bias", "accelerometer.scale", "accelerometer.misalignment",
                              "gyroscope.bias", "gyroscope.scale", "gyroscope.misalignment",
                              "gyroscope.g_sensitivity"}),
    ("zhang2021", "tosses", {"accelerometer.bias", "accelerometer.scale", "accelerometer.misalignment",
                             "gyroscope.bias", "gyroscope.scale", "gyroscope.misalignment", "lever_arm"}),
])
def test_rms_normalised_error_per_group(method, procedure, expected):
    groups = _groups(method, procedure, TOSS_SEEDS if procedure == "tosses" else SEEDS)
    assert expected <= set(groups), f"groups without a finite 1σ: {sorted(expected - set(groups))}"
    bad = {}
    for g, z in groups.items():
        rms = float(np.sqrt(np.mean(z**2)))
        lo, hi = _band(z.size)
        if not lo <= rms <= hi:
            bad[g] = f"RMS z {rms:.3g} over {z.size} values outside {lo:.2f}–{hi:.2f}"
    assert not bad, bad


def test_band_is_the_chi2_spread_of_the_goal():
    lo, hi = _band(30)
    assert lo == pytest.approx(0.54, abs=0.01) and hi == pytest.approx(1.67, abs=0.01)
    rng = np.random.default_rng(7)  # an honest 1σ leaves the band rarely, a 1σ a third of the error nearly always
    honest = np.sqrt(np.mean(rng.normal(size=(2000, 30)) ** 2, axis=1))
    third = np.sqrt(np.mean((3 * rng.normal(size=(2000, 30))) ** 2, axis=1))
    assert np.mean((honest < lo) | (honest > hi)) < 0.01
    assert np.mean((third < lo) | (third > hi)) > 0.95


def test_g_sensitivity_jacobian_matches_finite_differences():
    """The joint fit's ∂r/∂G, which carries the g-sensitivity's error into the bias's, against central differences."""
    from dataclasses import replace

    from imucalib.fit import gyro_joint
    from imucalib.fit import gyroscope as gy
    from imucalib.recording import Interval

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = session("handheld", rng=3)
        cal = calibrate(sim.recording, method="tedaldi2014", gravity=sim.truth.gravity)
    rec, fit = sim.recording, cal.fit
    ivs = [Interval(int(a), int(b), "static") for a, b in fit["intervals"]]
    drift = fit.get("gyroscope_bias_drift_per_s")
    static = gy.static_gyro(rec, ivs, cal.accelerometer, g_sensitivity=True, drift=drift is not None)
    weights, sigma = np.ones(len(ivs) - 1), fit["gyroscope_rotation_sigma_rad"]
    theta = np.concatenate([gy.GyroLayout(True).pack(cal.gyroscope), np.asarray(drift or [])])
    analytic = gyro_joint._g_sensitivity_jacobian(rec, ivs, cal.accelerometer, static, weights, sigma, theta)
    g0 = static.g_sensitivity
    h = 1e-3 * np.abs(g0).max()
    numeric = np.empty_like(analytic)
    for k in range(9):
        step = np.zeros(9)
        step[k] = h
        r = [gy.joint_problem(rec, ivs, cal.accelerometer, replace(static, g_sensitivity=g0 + sg * step.reshape(3, 3)),
                              weights, sigma)[0](theta) for sg in (1.0, -1.0)]
        numeric[:, k] = (r[0] - r[1]) / (2 * h)
    assert np.abs(analytic - numeric).max() < 1e-5 * np.abs(numeric).max()


@pytest.mark.slow
def test_six_position_measures_the_accelerometer_misalignment():
    """The rotations measure what the six faces cannot: the misalignment's error is a fraction of holding it at 0."""
    est, held = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed in SEEDS[:5]:
            sim = session("handheld", rng=seed, procedure="ferraris")
            cal = calibrate(sim.recording, method="six_position", gravity=sim.truth.gravity)
            assert cal.fit["accelerometer_misalignment"].startswith("estimated")
            t, t_hat = sim.truth.accelerometer.misalignment, cal.accelerometer.misalignment
            est += [t_hat[i, j] - t[i, j] for i, j in ((0, 1), (0, 2), (1, 2))]
            held += [t[i, j] for i, j in ((0, 1), (0, 2), (1, 2))]
    assert np.sqrt(np.mean(np.square(est))) < 0.4 * np.sqrt(np.mean(np.square(held)))
