"""Quaternion algebra and RK4 integration against scipy and closed forms."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from imucalib import kinematics as kin


@pytest.fixture
def rng():
    return np.random.default_rng(42)


def test_multiply_and_matrix_match_scipy(rng):
    p = Rotation.random(50, random_state=1)
    q = Rotation.random(50, random_state=2)
    ours = kin.quat_multiply(kin.from_scipy(p), kin.from_scipy(q))
    ref = kin.from_scipy(p * q)
    # same rotation up to the sign of the quaternion
    sign = np.sign(np.sum(ours * ref, axis=1, keepdims=True))
    np.testing.assert_allclose(ours * sign, ref, atol=1e-14)
    np.testing.assert_allclose(kin.quat_to_matrix(kin.from_scipy(p)), p.as_matrix(), atol=1e-14)


def test_matrix_to_quat_round_trip():
    r = Rotation.random(200, random_state=3)
    q = kin.matrix_to_quat(r.as_matrix())
    np.testing.assert_allclose(kin.quat_to_matrix(q), r.as_matrix(), atol=1e-13)
    assert np.all(q[:, 0] >= 0)


def test_rotvec_matches_scipy(rng):
    v = rng.normal(size=(100, 3)) * 2.0
    v[0] = [1e-12, 0, 0]
    q = kin.quat_from_rotvec(v)
    ref = kin.from_scipy(Rotation.from_rotvec(v))
    sign = np.sign(np.sum(q * ref, axis=1, keepdims=True))
    np.testing.assert_allclose(q * sign, ref, atol=1e-14)
    back = kin.quat_to_rotvec(q)
    np.testing.assert_allclose(back[1:], Rotation.from_quat(ref[1:, [1, 2, 3, 0]]).as_rotvec(), atol=1e-12)


def test_constant_rate_closed_form():
    # ω constant → q(t) = exp(½ ω t): exact for RK4 up to O(h⁵) per step
    w = np.array([0.3, -1.2, 2.0])
    t = np.arange(0, 3.0, 0.01)
    q = kin.integrate(t, np.tile(w, (t.size, 1)))
    ref = kin.quat_from_rotvec(t[:, None] * w)
    ang = np.linalg.norm(kin.quat_to_rotvec(kin.quat_multiply(kin.quat_conjugate(ref), q)), axis=1)
    # global RK4 error O(h⁴): 300 steps of |ω|h = 0.0235 rad give about 1e-9 rad
    assert ang.max() < 2e-9  # rad


def test_angle_between_small_and_large():
    u = np.array([[1.0, 0, 0], [1.0, 0, 0], [0, 0, 2.0]])
    v = np.array([[1.0, 1e-9, 0], [-1.0, 1e-9, 0], [0, 3.0, 0]])
    np.testing.assert_allclose(kin.angle_between(u, v), [1e-9, np.pi - 1e-9, np.pi / 2], rtol=1e-12)


def test_coning_closed_form():
    # Body rate of a coning motion: q(t) = exp(½ Ω t ẑ) ⊗ exp(½ β x̂) ⊗ exp(−½ Ω t ẑ)...
    # Use the attitude q(t) = exp(½ a t ẑ) ⊗ exp(½ b t x̂), whose body rate is
    # ω(t) = b x̂ + a R_x(−b t) ẑ = [b, a sin(bt), a cos(bt)].
    a, b = 1.7, 2.3
    t = np.arange(0, 4.0, 0.005)
    w = np.column_stack([np.full_like(t, b), a * np.sin(b * t), a * np.cos(b * t)])
    q = kin.integrate(t, w)
    ref = kin.quat_multiply(
        kin.quat_from_rotvec(np.outer(a * t, [0, 0, 1.0])),
        kin.quat_from_rotvec(np.outer(b * t, [1.0, 0, 0])),
    )
    ang = np.linalg.norm(kin.quat_to_rotvec(kin.quat_multiply(kin.quat_conjugate(ref), q)), axis=1)
    # RK4 with linearly interpolated rate: global error O(h²) from the interpolation
    assert ang.max() < 1e-4
    # scipy's own composition of the per-step rotations gives the same attitude trend
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-14)


def test_rk4_factor_matches_stagewise_rk4(rng):
    # the closed-form factor equals four explicit RK4 stages on q' = ½ q ⊗ ω(t)
    w0, w1 = rng.normal(size=(2, 3))
    h = 0.05
    q = kin.quat_normalize(rng.normal(size=4))

    def f(qq, w):
        return 0.5 * kin.quat_multiply(qq, np.concatenate([[0.0], w]))

    wm = 0.5 * (w0 + w1)
    k1 = f(q, w0)
    k2 = f(q + h / 2 * k1, wm)
    k3 = f(q + h / 2 * k2, wm)
    k4 = f(q + h * k3, w1)
    ref = q + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    ours = kin.quat_multiply(q, kin.rk4_step_factors(w0, w1, h))
    np.testing.assert_allclose(ours, ref, atol=1e-15)


def test_interval_integrator_matches_trajectory(rng):
    t = np.cumsum(rng.uniform(0.009, 0.011, 1000))
    w = rng.normal(size=(1000, 3))
    starts = np.array([0, 100, 400, 10])
    stops = np.array([50, 399, 999, 11])
    integ = kin.IntervalIntegrator(t, starts, stops)
    got = integ(w)
    for i, (a, b) in enumerate(zip(starts, stops, strict=True)):
        traj = kin.integrate(t[a : b + 1], w[a : b + 1])
        np.testing.assert_allclose(np.abs(np.sum(got[i] * traj[-1])), 1.0, atol=1e-12)
    # and the padded many-interval form agrees
    padded = np.zeros((2, 300, 3))
    padded[0, :51] = w[:51]
    padded[1, :300] = w[100:400]
    dt = np.zeros((2, 299))
    dt[0, :50] = np.diff(t[:51])
    dt[1] = np.diff(t[100:400])
    both = kin.integrate_intervals(padded, dt, lengths=np.array([51, 300]))
    np.testing.assert_allclose(np.abs(np.sum(both * got[:2], axis=1)), 1.0, atol=1e-12)


def test_sensitivity_matches_finite_differences(rng):
    t = np.arange(400) * 0.01
    w = np.column_stack([np.sin(3 * t), np.cos(2 * t), 0.5 + 0 * t])
    integ = kin.IntervalIntegrator(t, np.array([10, 50]), np.array([300, 399]))
    q, weights = integ.sensitivity(w[integ.samples])
    np.testing.assert_allclose(q, integ(w), atol=1e-15)
    dw = np.zeros_like(w)
    dw[120] = [1e-6, -2e-6, 0.5e-6]
    q2 = integ(w + dw)
    dphi = 2 * kin.quat_multiply(kin.quat_conjugate(q), q2)[:, 1:]
    r = kin.quat_to_matrix(q)
    dws = dw[integ.samples]
    pred = np.array([r[m].T @ np.einsum("pbc,pc->b", weights[m], dws[p0 : p0 + len(weights[m])])
                     for m, p0 in enumerate(integ.first_sample)])
    np.testing.assert_allclose(pred, dphi, rtol=1e-3, atol=1e-12)


def test_five_point_derivative_is_exact_for_quartics():
    dt = 0.01
    x = np.arange(50) * dt
    y = 3 * x**4 - x**3 + 2 * x
    d = kin.five_point_derivative(y, dt)
    exact = 12 * x**3 - 3 * x**2 + 2
    np.testing.assert_allclose(d[2:-2], exact[2:-2], atol=1e-9)
    with pytest.raises(ValueError, match="at least 5 samples"):
        kin.five_point_derivative(y[:4], dt)


def test_long_intervals_integrate_in_blocks_to_the_same_bits(monkeypatch):
    """Blocks of a long interval give the very numbers of integrating it whole, and agree with integrate()."""
    rng = np.random.default_rng(7)
    n = 6000
    t = np.cumsum(rng.uniform(0.009, 0.011, n))
    w = rng.normal(size=(n, 3))
    starts = np.array([0, 100, 400, 10, 1500, 3000, 3000, 4500])
    stops = np.array([50, 399, 999, 11, 2525, 5999, 3017, 4500 + 64])
    whole = kin.IntervalIntegrator(t, starts, stops)  # every interval at most BLOCK steps: no blocks
    assert whole._long.size == 0
    ws = w[whole.samples]
    q_whole = whole.from_samples(ws)
    q_sens, weights = whole.sensitivity(ws)
    values = rng.normal(size=(len(whole.samples), 3, 4))
    summed = whole.weighted_sum(weights, values)
    monkeypatch.setattr(kin.integrator, "BLOCK", 16)
    monkeypatch.setattr(kin.integrator, "CHUNK", 64)  # a few blocks at a time
    blocked = kin.IntervalIntegrator(t, starts, stops)
    assert blocked._long.size == 7 and np.array_equal(blocked.samples, whole.samples)
    assert np.array_equal(blocked.from_samples(ws), q_whole)
    q_b, weights_b = blocked.sensitivity(ws)
    assert np.array_equal(q_b, q_sens) and np.array_equal(q_b, q_whole)
    assert len(weights_b) == len(starts)
    for m in range(len(starts)):
        assert np.array_equal(weights_b[m], weights[m])
    assert np.array_equal(blocked.weighted_sum(weights_b, values), summed)
    q_f, weights_f = blocked.sensitivity(ws, blocked.step_factors(ws))  # the factors given: the same numbers
    assert np.array_equal(q_f, q_whole) and np.array_equal(blocked.from_samples(ws, blocked.step_factors(ws)), q_whole)
    assert np.array_equal(blocked.weighted_sum(weights_f, values), summed)
    for i, (a, b) in enumerate(zip(starts, stops, strict=True)):  # and each is the RK4 trajectory's end
        np.testing.assert_allclose(np.abs(np.sum(q_b[i] * kin.integrate(t[a : b + 1], w[a : b + 1])[-1])), 1.0,
                                   atol=1e-12)
    # a sum over more samples than SUM_BLOCK is formed block by block: the same to rounding
    monkeypatch.setattr(kin.integrator, "SUM_BLOCK", 100)
    np.testing.assert_allclose(blocked.weighted_sum(weights_b, values), summed, rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="stops"):
        kin.IntervalIntegrator(t, np.array([5]), np.array([5]))


def test_to_scipy_gives_the_same_rotation_and_from_scipy_undoes_it():
    rng = np.random.default_rng(5)
    q = kin.quat_normalize(rng.normal(size=(20, 4)))
    rot = kin.to_scipy(q)
    np.testing.assert_allclose(rot.as_matrix(), kin.quat_to_matrix(q), atol=1e-14)
    back = kin.from_scipy(rot)
    np.testing.assert_allclose(back * np.sign(back[:, :1] * q[:, :1]), q, atol=1e-15)


def test_rate_jacobian_by_blocks_gives_the_same_bits(monkeypatch):
    """weighted_sum of the rates' Jacobian formed a block at a time equals the whole per-sample array's."""
    from imucalib.residuals import gravity_direction_residuals_jac, linear_rate_jacobian

    rng = np.random.default_rng(3)
    n = 3000
    t = np.cumsum(rng.uniform(0.009, 0.011, n))
    integ = kin.IntervalIntegrator(t, np.array([0, 300, 1000, 2990]), np.array([200, 900, 2900, 2999]))
    s = len(integ.samples)
    v = rng.normal(size=(s, 3))
    tau = rng.uniform(-50, 50, s)
    m = np.eye(3) * 0.01 + rng.normal(scale=1e-4, size=(3, 3))
    whole = np.zeros((s, 3, 15))  # ∂(M v)/∂θ written out: M row by row, then b, then d
    for i in range(3):
        whole[:, i, 3 * i : 3 * i + 3] = v
    whole[:, :, 9:12] = -m
    whole[:, :, 12:15] = -m[None] * tau[:, None, None]
    dirs = rng.normal(size=(5, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    for sum_block in (kin.integrator.SUM_BLOCK, 500):  # one product per interval, then blocks of a long one
        monkeypatch.setattr(kin.integrator, "SUM_BLOCK", sum_block)
        r0, j0 = gravity_direction_residuals_jac(v @ m.T, whole, integ, dirs)
        r1, j1 = gravity_direction_residuals_jac(v @ m.T, linear_rate_jacobian(m, v, drift_time=tau), integ, dirs)
        assert np.array_equal(r0, r1) and np.array_equal(j0, j1)
        _, j2 = gravity_direction_residuals_jac(v @ m.T, linear_rate_jacobian(m, v, bias=False), integ, dirs)
        _, j3 = gravity_direction_residuals_jac(v @ m.T, np.ascontiguousarray(whole[:, :, :9]), integ, dirs)
        assert np.array_equal(j2, j3)
