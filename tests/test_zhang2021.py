"""Zhang 2021: recovery of all 45 parameters, variants, weights, weightless and fall detection."""

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.fit import zhang_cost
from imucalib.methods import zhang2021
from imucalib.recording import ImucalibWarning, Interval, Recording
from synth import table1_truth, tedaldi_session, weightless_segments


@pytest.fixture(scope="module")
def truth():
    return table1_truth()


@pytest.fixture(scope="module")
def noise_free(truth):
    rec, _, iv = tedaldi_session(truth, seed=1, poses=40, rest=10, hold=3, move=2)
    wl = weightless_segments(truth, n=60, seed=2)
    return rec, iv, wl


def _rel_errors(cal, truth):
    tp, ep = truth.parameters(), cal.parameters()
    return {k: abs(ep[k] - v) / max(abs(v), 1e-300) for k, v in tp.items() if v != 0}


def test_layout_has_45_parameters_with_design_names():
    lay = zhang2021.ZhangLayout.of("all")
    assert lay.size == 45
    names = lay.names()
    assert len(set(names)) == 45
    assert "accelerometer.scale_quadratic.y" in names
    assert "gyroscope.g_sensitivity.yx" in names
    assert "lever_arm.z" in names
    assert zhang2021.ZhangLayout.of("linear").size == 21


def test_noise_free_all_45_parameters_recovered(truth, noise_free):
    rec, iv, wl = noise_free
    cal = zhang2021.calibrate(rec, weightless=wl, model="all", gravity=truth.gravity,
                              intervals=iv, noise_weights=False)
    errors = _rel_errors(cal, truth)
    assert len(errors) == 45
    worst = max(errors, key=errors.get)
    assert errors[worst] < 1e-6, (worst, errors[worst])
    assert cal.fit["weightless_residual_rms"] < 1e-4  # m/s²: the stencil's O(dt⁴) only


def test_jacobian_matches_finite_differences(truth, noise_free):
    rec, iv, wl = noise_free
    captured = {}
    original = zhang_cost.levenberg_marquardt  # the solver of eq. (21)

    def spy(fun, jac, x0, **kw):
        captured.update(fun=fun, jac=jac, x0=x0)
        return original(fun, jac, x0, **kw)

    zhang_cost.levenberg_marquardt = spy
    try:
        zhang2021.calibrate(rec, weightless=wl[:10], model="all", gravity=truth.gravity,
                            intervals=iv, noise_weights=False, max_iter=1)
    finally:
        zhang_cost.levenberg_marquardt = original
    fun, jac, x = captured["fun"], captured["jac"], captured["x0"]
    j = jac(x)
    h = 1e-6 * np.maximum(np.abs(x), 1e-4)
    fd = np.column_stack([(fun(x + e) - fun(x - e)) / (2 * e[i]) for i, e in enumerate(np.diag(h))])
    scale = np.abs(fd).max(axis=0) + 1e-12
    # the attitude sensitivity uses the trapezoidal rule: first-order exact to ~1e-4
    assert np.max(np.abs(j - fd).max(axis=0) / scale) < 2e-3


def test_linear_variant_is_biased_on_nonlinear_sensors(truth):
    rec, _, iv = tedaldi_session(truth, seed=3, poses=40, rest=10, hold=3, move=2,
                                 noise_acc=0.005, noise_gyro=0.0005)
    cal = zhang2021.calibrate(rec, model="linear", gravity=truth.gravity)
    assert cal.lever_arm is None
    assert not np.any(cal.accelerometer.scale_cubic) and not np.any(cal.gyroscope.scale_quadratic)
    # the shared gyroscope stage keeps G where the static poses support it (eq. 11): Table I's G, to its 1σ
    np.testing.assert_allclose(cal.gyroscope.g_sensitivity, truth.gyroscope.g_sensitivity, atol=2e-6)
    # a linear model absorbs k2, k3 into k1: some k1 is off by more than 1e-2 (Table I)
    err = np.abs(cal.accelerometer.scale - truth.accelerometer.scale)
    assert err.max() > 1e-2


def test_noisy_all_model_close_to_truth(truth):
    rec, _, _ = tedaldi_session(truth, seed=4, poses=40, rest=10, hold=3, move=2,
                                noise_acc=0.005, noise_gyro=0.0005)
    wl = weightless_segments(truth, n=100, seed=5, noise_acc=0.005, noise_gyro=0.0005)
    cal = zhang2021.calibrate(rec, weightless=wl, model="all", gravity=truth.gravity)
    tp, ep = truth.parameters(), cal.parameters()
    for name, tol in (("scale", 1e-3), ("scale_quadratic", 1e-3), ("scale_cubic", 1e-3),
                      ("bias", 1e-4 * 3)):
        for sensor in ("accelerometer", "gyroscope"):
            for a in "xyz":
                k = f"{sensor}.{name}.{a}"
                assert abs(ep[k] - tp[k]) < tol, (k, ep[k], tp[k])
    for a in "xyz":
        assert abs(ep[f"lever_arm.{a}"] - tp[f"lever_arm.{a}"]) < 1e-4  # 0.1 mm
    assert cal.fit["converged"]
    assert set(cal.fit["weights"]) == {"C1", "C2", "C3", "C4"}


def test_weights_follow_eqs_25_to_30():
    c = zhang2021.weights(
        acc_var=np.full(3, 1e-6), gyro_var=np.full(3, 4e-8), k1_acc=np.full(3, 9.8),
        k1_gyro=np.full(3, 3.0), gravity=9.8, dt=0.01, g_max=0.0, motion_steps=1,
        mean_rate=1.0, omega_max=30.0, r_hat=np.array([0.07, 0.0, 0.0]), n_mean=np.ones(2),
    )
    s_ao = 9.8**2 * 1e-6
    assert c["C1"][0] == pytest.approx(1 / (6 * s_ao**2 + 4 * 9.8**2 * s_ao), rel=1e-12)
    assert c["C2"][0] == pytest.approx(1 / 4e-8, rel=1e-12)
    s_wo = 9 * 4e-8
    sq = 0.25 * 0.01**2 * s_wo  # one step of eq. (28)
    assert c["C3"][0] == pytest.approx(1 / (2 * s_ao + 9.8**2 * (4 * sq + 8 * sq**2)), rel=1e-12)
    rx = 0.07
    var_x = 900 * s_wo * (8 * rx**2) + s_wo**2 * 4 * rx**2 + s_ao
    var_y = 900 * s_wo * (2 * rx**2) + s_wo**2 * rx**2 + 65 * s_wo * rx**2 / (72 * 1e-4) + s_ao
    assert c["C4"] == pytest.approx(1 / max(var_x, var_y), rel=1e-12)


def test_detect_weightless_and_fall(truth):
    rng = np.random.default_rng(9)
    rate = 100.0
    rest = np.tile([0.0, 0.0, truth.gravity], (500, 1))
    segs = weightless_segments(truth, n=4, seed=11)
    acc_parts, gyro_parts, truth_iv = [], [], []
    n = 0
    for s in segs:
        a_true = truth.accelerometer.forward(s.acc)
        w_true = truth.gyroscope.forward(s.gyro, a_true)
        for a_blk, w_blk, kind in ((rest[:100], np.zeros((100, 3)), "static"),
                                   (a_true, w_true, "weightless")):
            acc_parts.append(a_blk)
            gyro_parts.append(w_blk)
            if kind == "weightless":
                truth_iv.append((n, n + len(a_blk)))
            n += len(a_blk)
    acc = np.concatenate([rest] + acc_parts)
    gyro = np.concatenate([np.zeros((500, 3))] + gyro_parts)
    truth_iv = [(a + 500, b + 500) for a, b in truth_iv]
    acc_raw = truth.accelerometer.inverse(acc) + rng.normal(scale=5e-4, size=acc.shape)
    gyro_raw = truth.gyroscope.inverse(gyro, acc) + rng.normal(scale=2e-4, size=acc.shape)
    rec = Recording(np.arange(len(acc)) / rate, acc_raw, gyro_raw, acc_unit="g")
    found = zhang2021.detect_weightless(rec, rest=Interval(0, 500))
    assert len(found) == 4
    for iv, (a, b) in zip(found, truth_iv, strict=True):
        assert a <= iv.start < iv.stop <= b
        assert len(iv) >= 0.9 * (b - a)
    falls = zhang2021.detect_fall(truth, rec)
    assert len(falls) == 4
    loss = zhang2021.fall_loss(truth, rec)
    assert np.median(loss[:500]) == pytest.approx(truth.gravity, abs=0.05)  # at rest: g
    with pytest.raises(ValueError, match="no lever arm"):
        zhang2021.fall_loss(truth.with_(lever_arm=None), rec)


def test_clear_errors(truth, noise_free):
    rec, iv, _ = noise_free
    with pytest.raises(ValueError, match="model must be one of"):
        zhang2021.calibrate(rec, model="quartic", intervals=iv)
    with pytest.warns(ImucalibWarning, match="no weightless segments were found"):
        cal = zhang2021.calibrate(rec, weightless=[], model="cubic", intervals=iv,
                                  noise_weights=False)
    assert cal.lever_arm is None
    with pytest.raises(ValueError, match="at least 10 static intervals"):
        zhang2021.calibrate(rec, model="linear", intervals=iv[:5])
    assert isinstance(truth, Calibration)


def test_gyroscope_static_detector_eq22():
    from imucalib.scenarios import session
    from imucalib.segment import detect_static_gyro, find_initial_rest

    sim = session("zhang2021", rng=2, n2=20, n3=1)
    found = detect_static_gyro(sim.recording, find_initial_rest(sim.recording))
    truth = [s for s in sim.segments if s.kind == "static"]
    assert len(found) == len(truth) == 40
    for f, t in zip(found, truth, strict=True):
        assert t.start <= f.start < f.stop <= t.stop  # never reaches into a motion
        assert len(f) >= 0.3 * len(t)
    cal = zhang2021.calibrate(sim.recording, weightless=sim.weightless, detector="gyroscope",
                              gravity=sim.truth.gravity)
    assert cal.fit["static_intervals"] == 40
    np.testing.assert_allclose(cal.lever_arm, sim.truth.lever_arm, atol=1e-4)


def test_residual_against_the_noise_floor_tells_model_error():
    import warnings

    from imucalib.scenarios import session

    sim = session("zhang2021", rng=0)  # a sensor with cubic scale factors
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lin = zhang2021.calibrate(sim.recording, weightless=sim.weightless, model="linear", gravity=sim.truth.gravity)
        full = zhang2021.calibrate(sim.recording, weightless=sim.weightless, model="all", gravity=sim.truth.gravity)
    assert lin.fit["accelerometer_residual_to_noise"] > 10  # the linear model leaves structure …
    assert any("what the sensor noise explains" in f for f in lin.fit["quality_flags"])
    assert 0.5 < full.fit["accelerometer_residual_to_noise"] < 1.5  # … the full model only noise
    assert "quality_flags" not in full.fit
