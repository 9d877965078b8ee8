"""The gyroscope at rest: one estimator over the static poses and the rotations, and the verdict's checks on it.

* the joint cost's Jacobian against finite differences;
* the calibrated gyroscope reads zero at rest (mean over the static poses) on the real Xsens session and on
  hand-held simulations with bias drift and tremor, while the rotations are no worse than before;
* the drift the poses show is found (and none where there is none);
* the verdict: a bias the rest contradicts, a shaken accelerometer, a gyroscope on too few rotations.
"""

import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib.cli import EXIT_REJECTED, main
from imucalib.fit.gyroscope import fit_gyroscope, joint_problem, static_gyro
from imucalib.io import read, write_csv
from imucalib.methods import calibrate
from imucalib.metrics import gravity_direction_errors
from imucalib.recording import Interval
from imucalib.scenarios import session
from imucalib.verdict import THRESHOLDS, predicted_direction_error, rest_rates, white_noise_variance

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"
needs_data = pytest.mark.skipif(not DATA.is_dir(), reason=f"real data not present: {DATA} (needs ../shared/data)")
G = 9.81744
#: the rest-rate criterion [deg/s]: the calibrated gyroscope's mean over the static poses, every axis
REST_LIMIT = 0.02


def _handheld(seed, **knobs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return session("handheld", rng=seed, **knobs)


def _calibrate(rec, method="tedaldi2014", gravity=G, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return calibrate(rec, method=method, gravity=gravity, **options)


def _intervals(cal):
    return [Interval(int(a), int(b), "static") for a, b in cal.fit["intervals"]]


def _rest_deg(cal, rec):
    """Mean calibrated rate [deg/s] over the static poses (each pose one weight) and over the initial rest."""
    w = np.degrees(rest_rates(cal, rec, _intervals(cal)))
    return w.mean(axis=0), w[0]


@pytest.fixture(scope="module")
def xsens():
    return read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk")


def test_joint_jacobian_matches_finite_differences():
    sim = _handheld(3, gyro_drift=0.05)
    cal = _calibrate(sim.recording, gravity=sim.truth.gravity)
    iv = _intervals(cal)
    static = static_gyro(sim.recording, iv, cal.accelerometer, drift=True)
    weights = np.ones(len(iv) - 1)
    weights[2] = 0.0
    fun, jac, _, size = joint_problem(sim.recording, iv, cal.accelerometer, static, weights, 1e-3)
    g = cal.gyroscope
    theta = np.concatenate([(g.misalignment * g.scale[None, :]).ravel(), g.bias, static.drift])
    assert size == theta.size == 15
    j = jac(theta)
    num = np.empty_like(j)
    for i in range(size):
        h = 1e-6 * max(abs(theta[i]), 1e-3)
        up, down = theta.copy(), theta.copy()
        up[i] += h
        down[i] -= h
        num[:, i] = (fun(up) - fun(down)) / (2 * h)
    scale = np.abs(num).max(axis=0)
    assert np.all(np.abs(j - num).max(axis=0) <= 1e-4 * scale + 1e-9), np.abs(j - num).max(axis=0) / scale


@needs_data
def test_xsens_reads_zero_at_rest_and_keeps_its_rotations(xsens):
    cal = _calibrate(xsens)
    assert cal.fit["gyroscope_bias_source"] == "joint"
    mean, rest = _rest_deg(cal, xsens)
    assert np.all(np.abs(mean) < REST_LIMIT), mean
    assert np.all(np.abs(rest) < REST_LIMIT), rest
    # the rotations no worse than with the bias held at the poses' means (0.123° mean, 0.275° max before)
    assert cal.fit["gyroscope_angle_error_mean_deg"] <= 0.1232
    assert cal.fit["gyroscope_angle_error_max_deg"] <= 0.2754
    assert cal.fit["verdict"] == "accepted", cal.fit["verdict_reasons"]
    # the rotations alone trade the bias against the scales: the poses disagree with that bias more
    alone = _calibrate(xsens, estimate_gyro_bias=True)
    assert np.max(np.abs(_rest_deg(alone, xsens)[0])) > 2 * np.max(np.abs(mean))


@pytest.mark.parametrize("seed", [0, 7])
def test_handheld_with_drift_and_tremor_reads_zero_at_rest(seed):
    """Five times the default drift (0.05 °/s per minute): the poses show it, the joint fit follows it."""
    sim = _handheld(seed, gyro_drift=0.05, tremor=0.3)
    rec, truth = sim.recording, sim.truth
    cal = _calibrate(rec, gravity=truth.gravity)
    mean, _ = _rest_deg(cal, rec)
    assert np.all(np.abs(mean) < REST_LIMIT), mean
    fit = cal.fit
    assert "gyroscope_bias_drift_per_s" in fit
    true_slope = np.asarray(sim.options["gyro_drift_counts_per_min"]) / 60  # counts per s
    est, se = np.asarray(fit["gyroscope_bias_drift_per_s"]), np.asarray(fit["gyroscope_bias_drift_se_per_s"])
    assert np.all(np.abs(est - true_slope) < 4 * se + 1e-3 * np.abs(true_slope)), (est, true_slope, se)
    # the rotations: near what the true parameters leave on the same poses
    iv = _intervals(cal)
    true_err = np.degrees(np.mean(gravity_direction_errors(truth, rec, iv)))
    assert fit["gyroscope_angle_error_mean_deg"] < 1.2 * true_err
    assert fit["verdict"] == "accepted", fit["verdict_reasons"]


def test_no_drift_is_found_where_there_is_none():
    sim = _handheld(2, gyro_drift=0.0, gyro_rw=0.0)
    cal = _calibrate(sim.recording, gravity=sim.truth.gravity)
    assert "gyroscope_bias_drift_per_s" not in cal.fit


def test_the_joint_bias_sits_between_the_poses_and_the_rotations():
    """Its 1σ from the joint Jacobian: smaller than the poses' alone, and the estimate within a few of them."""
    sim = _handheld(4)
    rec, truth = sim.recording, sim.truth
    cal = _calibrate(rec, gravity=truth.gravity)
    iv = _intervals(cal)
    fit = fit_gyroscope(rec, iv, cal.accelerometer)
    static = static_gyro(rec, iv, cal.accelerometer, drift="gyroscope_bias_drift_per_s" in cal.fit)
    se_poses = np.sqrt(np.diag(static.bias_cov))
    moved = np.abs(fit.model.bias - static.bias)
    assert np.all(moved < 4 * se_poses), (moved, se_poses)
    for ax in "xyz":
        assert np.isfinite(fit.errors[f"gyroscope.bias.{ax}"]) and fit.errors[f"gyroscope.bias.{ax}"] > 0
        assert fit.errors[f"gyroscope.scale.{ax}"] > 0


def test_a_bias_the_rest_contradicts_is_rejected():
    sim = _handheld(5)
    rec = sim.recording
    cal = _calibrate(rec, gravity=sim.truth.gravity)
    assert cal.fit["verdict"] == "accepted", cal.fit["verdict_reasons"]
    assert cal.fit["gyroscope_rest_rate_to_scatter"] < THRESHOLDS["rest_rate_to_scatter"][0]
    from imucalib.verdict import with_verdict

    g = cal.gyroscope
    for shift_deg, level in ((0.05, "suspect"), (0.17, "rejected")):  # 0.17 °/s: 10° of heading a minute
        shift = np.radians(shift_deg) / g.scale[0]  # raw counts on x
        bad = cal.with_(gyroscope=g.with_(bias=g.bias + [shift, 0, 0]))
        bad = with_verdict(bad.with_(fit={k: v for k, v in cal.fit.items() if not k.startswith("verdict")}), rec)
        assert bad.fit["verdict"] == level, bad.fit["verdict_reasons"]
        assert any("at rest the calibrated gyroscope reads" in r for r in bad.fit["verdict_reasons"])


def test_white_noise_is_blind_to_a_slow_shake():
    rng = np.random.default_rng(0)
    t = np.arange(20000) / 100.0
    noise = rng.normal(scale=0.03, size=(t.size, 3))
    shaken = noise + 2.5 * np.sin(2 * np.pi * 5 * t)[:, None]
    np.testing.assert_allclose(white_noise_variance(shaken), 0.03**2, rtol=0.1)
    np.testing.assert_allclose(white_noise_variance(noise), np.var(noise, axis=0), rtol=0.05)


def test_vibration_option_shakes_the_accelerometer_only():
    clean, shaken = _handheld(1), _handheld(1, vibration=(5.0, 2.5))
    np.testing.assert_array_equal(clean.recording.gyro, shaken.recording.gyro)
    np.testing.assert_array_equal(clean.recording.t, shaken.recording.t)
    d = shaken.recording.acc - clean.recording.acc
    amp = np.max(np.linalg.norm(d, axis=1)) * clean.truth.accelerometer.scale.mean()
    assert 2.3 < amp < 2.7
    np.testing.assert_array_equal(_handheld(1, vibration=(5.0, 0.0)).recording.acc, clean.recording.acc)
    assert shaken.options["vibration"] == [5.0, 2.5] and "vibration" not in clean.options


@pytest.mark.parametrize("seed", [1, 2])
def test_a_shaken_accelerometer_is_not_accepted(seed):
    """5 Hz, 2.5 m/s² on the accelerometer: the noise the gyroscope is judged against stays the sensor's."""
    clean = _handheld(seed)
    shaken = _handheld(seed, vibration=(5.0, 2.5))
    cal_clean = _calibrate(clean.recording, gravity=clean.truth.gravity)
    cal = _calibrate(shaken.recording, gravity=shaken.truth.gravity)
    assert cal_clean.fit["verdict"] == "accepted", cal_clean.fit["verdict_reasons"]
    assert cal.fit["verdict"] in ("suspect", "rejected")
    # the prediction: the same as the clean session's within 25 % (it was ~20× before)
    iv = _intervals(cal_clean)
    p_clean = np.mean(predicted_direction_error(cal_clean, clean.recording, iv))
    p_shaken = np.mean(predicted_direction_error(cal_clean, shaken.recording, iv))
    assert p_shaken < 1.25 * p_clean, (p_shaken, p_clean)
    scale_err = np.max(np.abs(cal.gyroscope.scale / shaken.truth.gyroscope.scale - 1))
    if scale_err > 0.01:
        assert any("gyroscope's gravity-direction error" in r for r in cal.fit["verdict_reasons"])


def test_a_gyroscope_on_too_few_rotations_is_rejected(capsys, tmp_path):
    """10 % of the samples dropped at random: most rotations have gaps and are left out."""
    sim = _handheld(0, drop=0.1)
    cal = _calibrate(sim.recording, gravity=sim.truth.gravity)
    kept = len(cal.fit["intervals"]) - 1 - len(cal.fit["rotations_left_out"])
    assert 2 * kept <= 9
    assert cal.fit["verdict"] == "rejected"
    assert any(f"the gyroscope rests on {kept} of the" in r for r in cal.fit["verdict_reasons"])
    write_csv(tmp_path / "rec.csv", sim.recording)
    code = main(["calibrate", str(tmp_path / "rec.csv"), "--gravity", str(sim.truth.gravity),
                 "-o", str(tmp_path / "c.json")])
    out = capsys.readouterr()
    assert code == EXIT_REJECTED, out.err
    assert "the gyroscope rests on" in out.out


def test_single_rotation_costs_match_rotation_matrices():
    """The scale search's closed form (Rodrigues) against scipy's rotation matrices, term by term."""
    from scipy.spatial.transform import Rotation

    from imucalib.fit.gyro_direction import _single_rotation_costs

    rng = np.random.default_rng(7)
    phi = rng.normal(size=(25, 3)) * 1.7
    phi[3] = 0.0  # a motion that does not turn
    dirs = rng.normal(size=(25, 2, 3))
    dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
    ks = np.geomspace(0.05, 5.0, 40)
    expected = np.array([
        sum(np.sum((d[1] - Rotation.from_rotvec(k * p).as_matrix().T @ d[0]) ** 2)
            for p, d in zip(phi, dirs, strict=True))
        for k in ks])
    np.testing.assert_allclose(_single_rotation_costs(phi, dirs, ks), expected, rtol=1e-12)


def test_static_gyro_pose_variances_are_numpys(monkeypatch):
    from imucalib.fit import gyro_static

    rec = _handheld(3).recording
    cal = _calibrate(rec)
    intervals = _intervals(cal)
    seen = []
    solve = gyro_static._weighted_regressions
    monkeypatch.setattr(gyro_static, "_weighted_regressions", lambda problems: seen.extend(problems) or solve(problems))
    static = static_gyro(rec, intervals, cal.accelerometer)
    want = np.array([np.var(rec.gyro[iv.slice], axis=0) / max(len(iv) - 1, 1) for iv in intervals])
    assert len(seen) % 3 == 0 and seen
    for k, (_, _, v) in enumerate(seen):  # each regression's pose variances, bit for bit
        assert np.array_equal(v, np.maximum(want[:, k % 3], 1e-300))
    assert np.array_equal(static.times, [np.mean(rec.t[iv.slice]) for iv in intervals])
