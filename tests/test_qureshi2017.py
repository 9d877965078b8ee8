"""Qureshi 2017: Newton accelerometer fit, both gyroscope approaches, the 18-orientation protocol."""

import numpy as np
import pytest

from imucalib.conventions import to_qureshi
from imucalib.fit.accelerometer import qureshi_cost as _g_and_derivatives
from imucalib.methods import calibrate
from imucalib.scenarios import qureshi_orientations, qureshi_session, qureshi_truth, qureshi_validation


def test_protocol_structure():
    d = qureshi_orientations()
    assert d.shape == (18, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    rec, iv, truth = qureshi_session(0)
    assert rec.rate == pytest.approx(100.0)
    # the rest, 18 orientations and back to z up (19 turns), x and y turns (6), 90° about y, z turns (3)
    assert len(iv) == 1 + 19 + 6 + 1 + 3


@pytest.mark.parametrize("approach", ["static", "dynamic"])
def test_noise_free_recovery(approach):
    rec, iv, truth = qureshi_session(1, noise=0)
    cal = calibrate(rec, method="qureshi2017", gravity=truth.gravity, intervals=iv, gyroscope=approach)
    np.testing.assert_allclose(to_qureshi(cal.accelerometer), to_qureshi(truth.accelerometer), rtol=1e-6,
                               atol=1e-9)
    np.testing.assert_allclose(cal.gyroscope.scale, truth.gyroscope.scale, rtol=1e-6)
    np.testing.assert_allclose(cal.gyroscope.bias, truth.gyroscope.bias, rtol=1e-6, atol=1e-9)
    assert cal.fit["newton_iterations"] < 20


def test_hessian_matches_finite_differences():
    truth = qureshi_truth()
    d = qureshi_orientations()
    means = truth.accelerometer.inverse(truth.gravity * d) + 0.01
    x = to_qureshi(truth.accelerometer) * 1.01
    _, grad, hess = _g_and_derivatives(x, means, truth.gravity)
    h = 1e-6 * np.maximum(np.abs(x), 1e-3)
    fd_g = np.array([(_g_and_derivatives(x + e, means, truth.gravity)[0]
                      - _g_and_derivatives(x - e, means, truth.gravity)[0]) / (2 * e[i])
                     for i, e in enumerate(np.diag(h))])
    fd_h = np.column_stack([(_g_and_derivatives(x + e, means, truth.gravity)[1]
                             - _g_and_derivatives(x - e, means, truth.gravity)[1]) / (2 * e[i])
                            for i, e in enumerate(np.diag(h))])
    np.testing.assert_allclose(grad, fd_g, rtol=1e-5, atol=1e-6 * np.abs(fd_g).max())
    np.testing.assert_allclose(hess, fd_h, rtol=1e-5, atol=1e-6 * np.abs(fd_h).max())


def test_reproduces_the_papers_figures_on_simulation():
    rec, iv, truth = qureshi_session(7)  # BNO055-class noise
    for approach in ("static", "dynamic"):
        cal = calibrate(rec, method="qureshi2017", gravity=truth.gravity, gyroscope=approach)
        assert cal.fit["static_intervals"] == len(iv)
        # gyroscope scales within 0.41 % of truth (the paper's agreement with a rate table)
        assert np.max(np.abs(cal.gyroscope.scale / truth.gyroscope.scale - 1)) < 0.0041
    v = qureshi_validation(truth, 8)  # 92 fresh orientations, raw in g
    raw_rms = np.sqrt(np.mean((np.linalg.norm(v, axis=1) - 1.0) ** 2))
    cal_rms = np.sqrt(np.mean((np.linalg.norm(cal.accelerometer_si(v), axis=1) / truth.gravity - 1) ** 2))
    assert raw_rms / cal_rms >= 9  # the paper: 0.0129 g → 0.0014 g


def test_missing_rotations_are_named():
    from imucalib.scenarios import pose_session

    truth = qureshi_truth()
    x, y = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    turns = [(x, 90), (x, -180), (x, 90), (y, 90), (y, -180), (y, 90), (x, 180), (x, 45), (y, 45),
             (x, -45), (y, -45)]
    rec, iv = pose_session(truth, [(a, np.radians(t)) for a, t in turns], rng=3)
    with pytest.raises(ValueError, match="no usable rotation about the z axis"):
        calibrate(rec, method="qureshi2017", gravity=truth.gravity, intervals=iv, gyroscope="dynamic")
    rec, iv, truth = qureshi_session(2)
    with pytest.raises(ValueError, match="gyroscope must be 'static' or 'dynamic'"):
        calibrate(rec, method="qureshi2017", gravity=truth.gravity, intervals=iv, gyroscope="rate")


def test_montecarlo_command_reproduces_the_papers_figures(capsys):
    import json

    from imucalib.cli import main

    assert main(["montecarlo", "--scenario", "qureshi2017", "--method", "qureshi2017", "--runs", "4", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["runs"] == 4 and len(r["per_run"]) == 4
    assert r["reduction_fold_min"] >= 9  # the paper: 0.0129 g → 0.0014 g
    assert r["gyro_scale_rel_error_max"]["static"] < 0.0041 and r["gyro_scale_rel_error_max"]["dynamic"] < 0.0041
    assert main(["montecarlo", "--scenario", "qureshi2017", "--method", "tedaldi2014"]) == 2
