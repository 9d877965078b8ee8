"""residuals.py: parameter layouts, residual values against independent computations, analytic Jacobians
against central finite differences."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from imucalib.kinematics import IntervalIntegrator
from imucalib.models import TriadModel
from imucalib.residuals import (
    AccelLayout,
    GyroLayout,
    gravity_direction_residuals,
    gravity_direction_residuals_jac,
    gravity_norm_residuals,
)

G = 9.80665


def _theta(layout: AccelLayout, rng) -> np.ndarray:
    """A plausible parameter vector: small cross-axis terms, scales near 1e-3 m/s² per count, biases in counts."""
    parts = [rng.normal(0, 0.02, len(layout.entries)), rng.uniform(0.9e-3, 1.1e-3, 3),
             rng.normal(0, 1e-9, 3), rng.normal(0, 1e-13, 3)][: 2 + layout.order - 1]
    return np.concatenate([*parts, rng.normal(0, 50, 3)])


def _raw_poses(rng, n=12) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    return 10_000 * d / np.linalg.norm(d, axis=1, keepdims=True) + rng.normal(0, 100, (n, 3))


def _fd(fun, theta, steps) -> np.ndarray:
    cols = []
    for p in range(theta.size):
        e = np.zeros_like(theta)
        e[p] = steps[p]
        cols.append((fun(theta + e) - fun(theta - e)) / (2 * steps[p]))
    return np.column_stack(cols)


@pytest.mark.parametrize("shape", ["upper", "lower", "full"])
@pytest.mark.parametrize("order", [1, 2, 3])
def test_accel_layout_packs_and_unpacks_every_parameter(shape, order):
    layout = AccelLayout(shape=shape, order=order)
    theta = np.arange(1.0, layout.size + 1)
    back = layout.pack(layout.unpack(theta))
    np.testing.assert_array_equal(back, theta)
    names = layout.names()
    assert len(names) == layout.size == len(set(names))
    assert names[-3:] == ["accelerometer.bias.x", "accelerometer.bias.y", "accelerometer.bias.z"]


def test_accel_layout_refuses_an_order_above_three():
    with pytest.raises(ValueError, match="order must be 1, 2 or 3"):
        AccelLayout(order=4)


@pytest.mark.parametrize("shape", ["upper", "lower", "full"])
@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("squared", [False, True])
def test_gravity_norm_residuals_equal_the_models_forward_norm(shape, order, squared):
    rng = np.random.default_rng(order + 10 * squared)
    layout = AccelLayout(shape=shape, order=order)
    theta = _theta(layout, rng)
    raw = _raw_poses(rng)
    # independent: the model's own forward map (Zhang 2021, eq. 9) and the norm, written out
    norm = np.linalg.norm(layout.unpack(theta).forward(raw), axis=1)
    expected = norm**2 - G**2 if squared else norm - G
    r = gravity_norm_residuals(theta, layout, raw, G, squared=squared)
    np.testing.assert_allclose(r, expected, rtol=1e-12, atol=1e-12)
    r2, _ = gravity_norm_residuals(theta, layout, raw, G, squared=squared, jacobian=True)
    np.testing.assert_array_equal(r2, r)


@pytest.mark.parametrize("shape", ["upper", "lower", "full"])
@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("squared", [False, True])
def test_gravity_norm_jacobian_matches_finite_differences(shape, order, squared):
    rng = np.random.default_rng(100 + order)
    layout = AccelLayout(shape=shape, order=order)
    theta = _theta(layout, rng)
    raw = _raw_poses(rng)
    _, jac = gravity_norm_residuals(theta, layout, raw, G, squared=squared, jacobian=True)
    steps = 1e-6 * np.maximum(np.abs(theta), 1e-9)
    fd = _fd(lambda th: gravity_norm_residuals(th, layout, raw, G, squared=squared), theta, steps)
    scale = np.abs(fd).max(axis=0) + 1e-300
    assert np.max(np.abs(jac - fd) / scale) < 1e-6


@pytest.mark.parametrize("estimate_bias", [False, True])
def test_gyro_layout_round_trip(estimate_bias):
    rng = np.random.default_rng(3)
    t = np.eye(3) + rng.normal(0, 0.01, (3, 3))
    np.fill_diagonal(t, 1.0)
    model = TriadModel(misalignment=t, scale=rng.uniform(1e-3, 2e-3, 3), bias=rng.normal(0, 5, 3), shape="full")
    layout = GyroLayout(estimate_bias=estimate_bias)
    theta = layout.pack(model)
    assert theta.size == layout.size == (12 if estimate_bias else 9)
    back = layout.unpack(theta, bias=model.bias)
    np.testing.assert_allclose(back.misalignment, model.misalignment, rtol=1e-14)
    np.testing.assert_allclose(back.scale, model.scale, rtol=1e-14)
    np.testing.assert_array_equal(back.bias, model.bias)


def _turns(rng, n_poses=5, rate=100.0, hold=20, turn=80):
    """Constant rates during each turn between poses: the true attitude changes are rotation vectors."""
    rates, starts, stops, turns = [np.zeros((hold, 3))], [], [], []
    for _ in range(n_poses - 1):
        w = rng.normal(0, 1.5, 3)
        starts.append(sum(len(r) for r in rates))  # the turn's first sample …
        rates.append(np.tile(w, (turn, 1)))
        stops.append(starts[-1] + turn - 1)  # … to its last: turn − 1 steps at the rate w
        rates.append(np.zeros((hold, 3)))
        turns.append(w * (turn - 1) / rate)
    w = np.concatenate(rates)
    return np.arange(len(w)) / rate, w, np.array(starts), np.array(stops), turns


def test_gravity_direction_residuals_against_rotation_vectors():
    """Zhang 2021, eq. (14): with constant rates, R_{k-1,k} = exp([ω T]×); gravity seen in the body turns by Rᵀ."""
    rng = np.random.default_rng(7)
    t, w, starts, stops, turns = _turns(rng)
    integ = IntervalIntegrator(t, starts, stops)
    g = [np.array([0.1, -0.2, 0.97]) / np.linalg.norm([0.1, -0.2, 0.97])]
    for phi in turns:
        g.append(Rotation.from_rotvec(phi).as_matrix().T @ g[-1])
    g = np.array(g)
    r = gravity_direction_residuals(w, integ, g)
    assert r.shape == (3 * (len(g) - 1),)
    assert np.max(np.abs(r)) < 1e-9  # RK4 on constant rates: exact to rounding over these steps
    shifted = g + np.array([0.0, 0.0, 1e-3])
    carried = [Rotation.from_rotvec(phi).as_matrix().T @ a for phi, a in zip(turns, shifted[:-1], strict=True)]
    expected = shifted[1:] - np.array(carried)
    np.testing.assert_allclose(gravity_direction_residuals(w, integ, shifted), expected.ravel(), atol=1e-9)


def test_gravity_direction_jacobian_matches_finite_differences():
    """rates = M u (M: the 9 entries of GyroLayout), so ∂ω_i/∂M_ij = u_j; the analytic Jacobian against central
    differences of the residuals in M."""
    rng = np.random.default_rng(11)
    t, w, starts, stops, _ = _turns(rng, n_poses=6)
    t = t + rng.uniform(-2e-4, 2e-4, t.size)  # uneven steps
    t.sort()
    m_true = np.eye(3) * 1e-3 + rng.normal(0, 2e-5, (3, 3))
    raw = np.linalg.solve(m_true, w.T).T + rng.normal(0, 5, w.shape)
    integ = IntervalIntegrator(t, starts, stops)
    g = rng.normal(size=(len(starts) + 1, 3))
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    theta = m_true.ravel()
    u = raw[integ.samples]
    rate_jac = np.zeros((u.shape[0], 3, 9))
    for i in range(3):
        rate_jac[:, i, 3 * i:3 * i + 3] = u
    res, jac = gravity_direction_residuals_jac(u @ m_true.T, rate_jac, integ, g)
    np.testing.assert_allclose(res, gravity_direction_residuals(raw @ m_true.T, integ, g), rtol=0, atol=1e-12)
    fd = _fd(lambda th: gravity_direction_residuals(raw @ th.reshape(3, 3).T, integ, g), theta,
             np.full(9, 1e-9))
    # the sensitivity weights are the trapezoid rule's (IntervalIntegrator.sensitivity): exact to O((ω dt)²)
    wdt = np.max(np.linalg.norm(w, axis=1)) * np.max(np.diff(t))
    assert np.max(np.abs(jac - fd)) < wdt**2 / 4 * np.max(np.abs(fd))
    assert np.max(np.abs(jac + fd)) > np.max(np.abs(fd))  # a sign error would not pass
