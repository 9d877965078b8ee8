"""The gravity-norm fits' faster forms give the plain forms' numbers bit for bit: numpy's own linalg calls, the
residuals written out as before, and Levenberg–Marquardt on them."""

from __future__ import annotations

import numpy as np
import pytest

from imucalib import solve
from imucalib.fit import accelerometer
from imucalib.models import TriadModel
from imucalib.residuals import AccelLayout, GravityNorm, gravity_norm_residuals


def _plain_residuals(theta, layout, raw_means, gravity, squared=False, jacobian=False):
    """The residuals and Jacobian as first written: a loop per entry, the builtin sum, np.linalg.norm."""
    n_t = len(layout.entries)
    t = np.eye(3)
    for (i, j), v in zip(layout.entries, theta[:n_t], strict=True):
        t[i, j] = v
    k = theta[n_t : n_t + 3 * layout.order].reshape(layout.order, 3)
    x = raw_means - theta[-3:]
    powers = [x]
    for _ in range(1, layout.order):
        powers.append(powers[-1] * x)
    f = sum(kk * p for kk, p in zip(k, powers, strict=True))
    a = f @ t.T
    norm = np.linalg.norm(a, axis=1)
    r = norm**2 - gravity**2 if squared else norm - gravity
    if not jacobian:
        return r
    da = 2.0 * a if squared else a / norm[:, None]
    jac = np.empty((raw_means.shape[0], layout.size))
    for c, (i, j) in enumerate(layout.entries):
        jac[:, c] = da[:, i] * f[:, j]
    nt = da @ t
    col = n_t
    for p in powers:
        jac[:, col : col + 3] = nt * p
        col += 3
    dfdx = k[0] + sum((n + 1) * k[n] * powers[n - 1] for n in range(1, layout.order))
    jac[:, col : col + 3] = -nt * dfdx
    return r, jac


def _plain_solve_damped(a, g, lam):
    m = a + lam * np.eye(a.shape[0])
    try:
        c = np.linalg.cholesky(m)
        return np.linalg.solve(c.T, np.linalg.solve(c, -g))
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(m, -g, rcond=None)[0]


def _plain_lm(fun, jac, x0, ftol, xtol, gtol=1e-8, max_iter=200):
    """Levenberg–Marquardt as first written, every operation through numpy's public functions."""
    x = np.array(x0, dtype=np.float64)
    r = fun(x)
    cost, lam, nu, j = 0.5 * float(r @ r), None, 2.0, None
    tiny = np.finfo(float).tiny
    for _ in range(max_iter):
        if j is None:
            j = jac(x)
            a, g = j.T @ j, j.T @ r
            dinv = 1.0 / np.sqrt(np.maximum(np.diag(a).copy(), tiny))
            if np.max(np.abs(g) * dinv) <= gtol * max(np.sqrt(2 * cost), tiny):
                break
            if lam is None:
                lam = 1e-3
        a_s = a * dinv[:, None] * dinv[None, :]
        g_s = g * dinv
        step_s = _plain_solve_damped(a_s, g_s, lam)
        x_new = x + step_s * dinv
        r_new = fun(x_new)
        cost_new = 0.5 * float(r_new @ r_new) if np.all(np.isfinite(r_new)) else np.inf
        predicted = -(g_s @ step_s) - 0.5 * step_s @ (a_s @ step_s)
        rho = (cost - cost_new) / predicted if predicted > 0 else -1.0
        if rho > 0:
            reduction = cost - cost_new
            x, r, cost, j = x_new, r_new, cost_new, None
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            if reduction <= ftol * max(cost + reduction, tiny):
                break
            if np.linalg.norm(step_s) <= xtol * (np.linalg.norm(x / dinv) + xtol):
                break
        else:
            lam *= nu
            nu *= 2.0
            if lam > 1e16:
                break
    return x, r


def _poses(rng, n, noise=2e-3):
    d = rng.normal(size=(n, 3))
    truth = TriadModel(misalignment=np.array([[1, 0.01, -0.02], [0, 1, 0.015], [0, 0, 1]]),
                       scale=[1e-3, 1.02e-3, 0.98e-3], bias=[40.0, -25.0, 12.0], shape="upper")
    specific = 9.81 * d / np.linalg.norm(d, axis=1, keepdims=True) + rng.normal(0, noise, (n, 3))
    raw = np.linalg.solve(truth.misalignment * truth.scale, specific.T).T + truth.bias
    return np.round(raw, 2)


def test_the_damped_step_is_numpys_bit_for_bit() -> None:
    rng = np.random.default_rng(3)
    for trial in range(3000):
        n = int(rng.integers(1, 13))
        j = rng.normal(size=(n + int(rng.integers(0, 20)), n)) * 10.0 ** rng.integers(-6, 6, n)
        a = j.T @ j
        if trial % 5 == 0:
            a[0, 0] = -abs(a[0, 0]) - 1.0  # not positive definite: the least-squares fallback
        g = rng.normal(size=n)
        lam = 10.0 ** rng.uniform(-12, 3)
        assert solve._solve_damped(a, g, lam).tobytes() == _plain_solve_damped(a, g, lam).tobytes()


def test_the_linalg_helpers_are_numpys_bit_for_bit() -> None:
    rng = np.random.default_rng(4)
    for _ in range(500):
        m, n = int(rng.integers(4, 60)), int(rng.integers(1, 10))
        a = rng.normal(size=(m, n)) * 10.0 ** rng.integers(-3, 3, n)
        b = rng.normal(size=m)
        assert solve.lstsq(a, b).tobytes() == np.linalg.lstsq(a, b, rcond=None)[0].tobytes()
        assert solve.lstsq(a.T.copy().T, b).tobytes() == np.linalg.lstsq(a, b, rcond=None)[0].tobytes()
        s = a.T @ a + np.eye(n)
        assert solve.cholesky(s).tobytes() == np.linalg.cholesky(s).tobytes()
        v = rng.normal(size=n)
        assert solve.solve(s, v).tobytes() == np.linalg.solve(s, v).tobytes()
    with pytest.raises(np.linalg.LinAlgError):
        solve.cholesky(-np.eye(3))
    with pytest.raises(np.linalg.LinAlgError):
        solve.solve(np.zeros((3, 3)), np.ones(3))


@pytest.mark.parametrize("shape", ["upper", "lower", "full"])
@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("squared", [False, True])
def test_gravity_norm_residuals_are_the_plain_forms_bit_for_bit(shape, order, squared) -> None:
    rng = np.random.default_rng(order + 7 * squared)
    layout = AccelLayout(shape, order)
    raw = _poses(rng, 15)
    problem = GravityNorm(layout, raw, 9.81, squared=squared)
    for _ in range(20):
        theta = np.concatenate([rng.normal(0, 0.02, len(layout.entries)), rng.uniform(0.9e-3, 1.1e-3, 3),
                                rng.normal(0, 1e-9, 3 * (order - 1)), rng.normal(0, 50, 3)])
        r0, j0 = _plain_residuals(theta, layout, raw, 9.81, squared, jacobian=True)
        r1, j1 = gravity_norm_residuals(theta, layout, raw, 9.81, squared=squared, jacobian=True)
        assert r1.tobytes() == r0.tobytes() and j1.tobytes() == j0.tobytes()
        assert problem.residuals(theta).tobytes() == r0.tobytes()
        assert problem.jacobian(theta).tobytes() == j0.tobytes()  # from the terms just evaluated
        assert problem.jacobian(theta + 0.0).tobytes() == j0.tobytes()
        theta[-1] += 1.0  # a point not evaluated before: evaluated afresh
        fresh = _plain_residuals(theta, layout, raw, 9.81, squared, jacobian=True)[1]
        assert problem.jacobian(theta).tobytes() == fresh.tobytes()


def _plain_ellipsoid(raw, gravity):
    mu = raw.mean(axis=0)
    s = np.abs(raw - mu).max() or 1.0
    z = (raw - mu) / s
    x, y, w = z[:, 0], z[:, 1], z[:, 2]
    design = np.column_stack([x * x, y * y, w * w, 2 * x * y, 2 * x * w, 2 * y * w, 2 * x, 2 * y, 2 * w])
    p = np.linalg.lstsq(design, np.ones(len(z)), rcond=None)[0]
    a = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
    c = -np.linalg.solve(a, p[6:9])
    q = a * (gravity**2 / (1.0 + c @ a @ c)) / s**2
    tk = np.linalg.cholesky(q).T
    k = np.diag(tk).copy()
    return TriadModel(misalignment=np.triu(tk / k[None, :], 1) + np.eye(3), scale=k, bias=mu + s * c, shape="upper")


@pytest.mark.parametrize("seed", range(12))
def test_the_fits_are_the_plain_forms_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    raw = _poses(rng, int(rng.integers(12, 45)), noise=10.0 ** rng.uniform(-4, -1))
    layout = AccelLayout("upper", 1)
    start = _plain_ellipsoid(raw, 9.81)
    ellipsoid = accelerometer.fit_ellipsoid(raw, 9.81)
    for name in ("misalignment", "scale", "bias"):
        assert getattr(ellipsoid, name).tobytes() == getattr(start, name).tobytes()
    x, r = _plain_lm(lambda th: _plain_residuals(th, layout, raw, 9.81),
                     lambda th: _plain_residuals(th, layout, raw, 9.81, jacobian=True)[1],
                     layout.pack(start), ftol=1e-14, xtol=1e-14)
    model, res = accelerometer.fit_gravity_norm(raw, 9.81)
    assert res.tobytes() == r.tobytes()
    assert layout.pack(model).tobytes() == x.tobytes()
    fit = accelerometer.gravity_norm_fit(raw, 9.81)
    assert fit.residuals.tobytes() == r.tobytes()
    assert fit.jacobian.tobytes() == _plain_residuals(x, layout, raw, 9.81, jacobian=True)[1].tobytes()
