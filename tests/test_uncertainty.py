"""Reported 1σ errors: the formula against an independent computation, and against Monte Carlo spreads."""

import json
import warnings

import numpy as np
import pytest

from imucalib.methods import calibrate
from imucalib.solve import standard_errors
from synth import linear_truth, tedaldi_session


def test_standard_errors_of_a_linear_regression():
    rng = np.random.default_rng(0)
    x = np.column_stack([np.ones(50), rng.normal(size=50), 1e6 * rng.normal(size=50)])
    y = x @ [1.0, 2.0, 3e-6] + rng.normal(scale=0.1, size=50)
    beta = np.linalg.lstsq(x, y, rcond=None)[0]
    r = x @ beta - y
    s2 = r @ r / (50 - 3)
    expected = np.sqrt(np.diag(s2 * np.linalg.inv(x.T @ x)))  # the textbook formula
    np.testing.assert_allclose(standard_errors(x, r), expected, rtol=1e-8)
    # delta method: the sum of the first two parameters
    a = np.array([[1.0, 1.0, 0.0]])
    cov = s2 * np.linalg.inv(x.T @ x)
    np.testing.assert_allclose(standard_errors(x, r, transform=a), np.sqrt(a @ cov @ a.T)[0], rtol=1e-8)


def test_undetermined_parameters_are_nan_not_small():
    rng = np.random.default_rng(1)
    c = rng.normal(size=40)
    x = np.column_stack([np.ones(40), c, 2 * c, rng.normal(size=40)])  # columns 1 and 2 are collinear
    r = rng.normal(scale=0.1, size=40)
    se = standard_errors(x, r)
    assert np.isnan(se[1]) and np.isnan(se[2])
    assert np.all(np.isfinite(se[[0, 3]]))
    assert np.all(np.isnan(standard_errors(x[:4], r[:4])))  # no degrees of freedom left


@pytest.mark.slow
def test_tedaldi_errors_match_the_monte_carlo_spread():
    z = {"accelerometer": [], "gyroscope": []}
    for seed in range(20):
        rec, truth, iv = tedaldi_session(seed=seed, noise_acc=0.02, noise_gyro=0.003, poses=30)
        cal = calibrate(rec, method="tedaldi2014", gravity=truth.gravity, intervals=iv)
        est, tru = cal.parameters(), truth.parameters()
        unc = cal.fit["uncertainty"]
        assert len(unc) == 9 + 12 and all(np.isfinite(v) and v > 0 for v in unc.values())
        for k, s in unc.items():
            z[k.split(".")[0]].append((est[k] - tru[k]) / s)
        if seed == 0:  # the same errors, computed afterwards from the calibration and its recording
            from imucalib.methods.tedaldi2014 import uncertainty

            again = uncertainty(rec, iv, cal)
            np.testing.assert_allclose([again[k] for k in unc], list(unc.values()), rtol=1e-6)
    for sensor, values in z.items():
        rms = np.sqrt(np.mean(np.square(values)))
        assert 0.75 < rms < 1.3, (sensor, rms)  # 180 z-scores each: ~5 % sampling error


@pytest.mark.slow
def test_zhang_errors_match_the_monte_carlo_spread():
    from imucalib.scenarios import session

    zs = []
    for seed in range(5):
        sim = session("zhang2021", rng=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cal = calibrate(sim, method="zhang2021", model="all", gravity=sim.truth.gravity)
        unc = cal.fit["uncertainty"]
        assert len(unc) == 45 and all(np.isfinite(v) and v > 0 for v in unc.values())
        est, tru = cal.parameters(), sim.truth.parameters()
        zs += [(est[k] - tru[k]) / s for k, s in unc.items()]
    rms = np.sqrt(np.mean(np.square(zs)))
    assert 0.6 < rms < 1.5, rms


def test_wang_errors_and_their_absence_are_reported():
    from imucalib.scenarios.wang2019 import session

    sim = session(0)
    cal = calibrate(sim, method="wang2019")
    unc = cal.fit["uncertainty"]
    assert np.isnan(unc["accelerometer.scale.x"])  # 15 positions, 15 parameters
    assert "no degrees of freedom" in cal.fit["uncertainty_unavailable"]
    assert np.isfinite(unc["gyroscope.scale.x"]) and np.isfinite(unc["gyroscope.output_bias.z"])
    # strict JSON: the unavailable errors are null, not NaN
    doc = json.loads(cal.to_json(), parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert doc["fit"]["uncertainty"]["accelerometer.scale.x"] is None


def test_calibrate_prints_the_errors(capsys, tmp_path):
    from imucalib.cli import main
    from imucalib.io import write_csv

    rec, truth, _ = tedaldi_session(seed=3, noise_acc=0.02, noise_gyro=0.003, poses=30)
    write_csv(tmp_path / "s.csv", rec)
    assert main(["calibrate", str(tmp_path / "s.csv"), "--method", "tedaldi2014",
                 "--gravity", str(truth.gravity)]) == 0
    out = capsys.readouterr().out
    assert "1σ standard error" in out and out.count(" ± ") >= 18


def test_qureshi_and_ellipsoid_errors_match_the_spread():
    from imucalib.scenarios import qureshi_session

    z = []
    for seed in range(12):
        rec, iv, truth = qureshi_session(seed)
        for approach in ("static", "dynamic"):
            cal = calibrate(rec, method="qureshi2017", gravity=truth.gravity, intervals=iv, gyroscope=approach)
            unc = cal.fit["uncertainty"]
            keys = [k for k in unc if k.startswith("gyroscope.scale")]
            assert len(keys) == 3 and all(np.isfinite(unc[k]) for k in keys)
            est, tru = cal.parameters(), truth.parameters()
            if approach == "static":  # the accelerometer is the same fit for both approaches
                z += [(est[k] - tru[k]) / unc[k] for k in unc if k.startswith("accelerometer")]
            z += [(est[k] - tru[k]) / unc[k] for k in keys]
    rms = np.sqrt(np.mean(np.square(z)))
    assert 0.6 < rms < 1.6, rms
    rec, truth, iv = tedaldi_session(seed=5, noise_acc=0.02, noise_gyro=0.003, poses=30)
    cal = calibrate(rec, method="ellipsoid", gravity=truth.gravity, intervals=iv)
    assert len(cal.fit["uncertainty"]) == 9 + 12 and all(np.isfinite(list(cal.fit["uncertainty"].values())))


@pytest.mark.slow
def test_closed_form_methods_give_their_errors_or_say_why_not():
    """ferraris: a 1σ for every parameter (its equations' leftovers); six_position: its accelerometer's biases
    and scales are exactly determined (said so), the misalignment it estimates with the gyroscope has one."""
    from imucalib.scenarios import ferraris_session
    from synth import linear_truth

    truth = linear_truth()
    rec, iv, _ = ferraris_session(truth, 1)
    cal = calibrate(rec, method="ferraris", gravity=truth.gravity, intervals=iv)
    unc = cal.fit["uncertainty"]
    assert "uncertainty_unavailable" not in cal.fit
    linear = {k for k in cal.parameters() if k.split(".")[1] in ("misalignment", "scale", "bias")}
    assert linear <= set(unc) and all(np.isfinite(v) and v >= 0 for v in unc.values())
    g_sens = {f"gyroscope.g_sensitivity.{a}{b}" for a in "xyz" for b in "xyz"}
    assert {k for k in unc if ".g_sensitivity." in k} == g_sens
    cal = calibrate(rec, method="six_position", gravity=truth.gravity, intervals=iv)
    assert "six faces determine" in cal.fit["uncertainty_unavailable"]
    assert all(k.startswith(("gyroscope.", "accelerometer.misalignment.")) for k in cal.fit["uncertainty"])


def test_gyroscope_errors_carry_the_accelerometers_when_poses_are_confined_to_a_cone():
    """Poses within 20° of z leave the accelerometer's x/y poorly determined; the gyroscope's 1σ must say so."""
    truth = linear_truth()
    z = []
    for seed in range(6):
        rng = np.random.default_rng(seed)
        d = rng.normal(size=(30, 3))
        d[:, 2] = 0
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        tilt = np.radians(rng.uniform(0, 20, 30))
        dirs = np.column_stack([d[:, :2] * np.sin(tilt)[:, None], np.cos(tilt)])
        rec, _, iv = tedaldi_session(truth, seed=seed, noise_acc=0.02, noise_gyro=0.003, directions=dirs)
        cal = calibrate(rec, method="tedaldi2014", gravity=truth.gravity, intervals=iv)
        assert cal.fit["verdict"] != "accepted"
        unc, est, tru = cal.fit["uncertainty"], cal.parameters(), truth.parameters()
        z += [(est[k] - tru[k]) / unc[k] for k in unc if k.startswith("gyroscope.scale") and np.isfinite(unc[k])]
    # held exact, the accelerometer made these errors hundreds of σ (measured: RMS 364); carried, a few
    assert np.max(np.abs(z)) < 10 and np.sqrt(np.mean(np.square(z))) < 4, z
