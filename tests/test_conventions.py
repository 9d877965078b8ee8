"""Each paper's convention maps exactly onto the canonical model and back."""

import numpy as np
import pytest

from imucalib import conventions as cv
from imucalib.scenarios import table1_truth


def test_zhang_table1_round_trip():
    truth = table1_truth()
    z = cv.to_zhang(truth.accelerometer)
    # Table I's set values as printed: T^a entries 0.03, −0.04, 0.035 and b^a = (0.04, 0.5, −0.35)
    np.testing.assert_allclose(z["b"], [0.04, 0.5, -0.35])
    back = cv.from_zhang_accelerometer(z["alpha"]["yz"], z["alpha"]["zy"], z["alpha"]["zx"], z["K"], z["b"])
    assert back.parameters("a") == truth.accelerometer.parameters("a")
    zg = cv.to_zhang(truth.gyroscope)
    np.testing.assert_allclose(zg["G"], 1e-4 * np.array([[1, 2, -1], [-1, 2, 1], [2, 3, 1]]))
    backg = cv.from_zhang_gyroscope(zg["gamma"], zg["K"], zg["b"], zg["G"])
    assert backg.parameters("g") == truth.gyroscope.parameters("g")


def test_qureshi_products_exact():
    th_yz, th_zx, th_zy = 0.012, -0.008, 0.019
    k = np.array([1.004, 0.995, 1.006])
    x = np.array([0.02, -0.03, 0.04, *k, th_yz * k[0], (th_yz * th_zx - th_zy) * k[0], th_zx * k[1]])
    m = cv.from_qureshi(x)
    # Qureshi's forward model K T_s^o (A − B) with T_s^o the inverse of eq. (3)
    t_inv = np.array([[1, -th_yz, th_zy], [0, 1, -th_zx], [0, 0, 1]])
    raw = np.random.default_rng(0).normal(size=(20, 3))
    ref = (raw - x[:3]) @ (np.diag(k) @ np.linalg.inv(t_inv)).T
    np.testing.assert_allclose(m.forward(raw), ref, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(cv.to_qureshi(m), x, rtol=1e-14)
    ang = cv.qureshi_angles(x)
    assert (ang["yz"], ang["zx"], ang["zy"]) == pytest.approx((th_yz, th_zx, th_zy), rel=1e-12)


def test_wang_output_bias_exact():
    rng = np.random.default_rng(1)
    e = {"yx": 2e-4, "zx": -3e-4, "zy": 1e-4}
    k1 = rng.uniform(1, 5, 3) * 1e-6  # g per pulse
    k2 = rng.uniform(-5, 5, 3) * 1e-15
    k3 = rng.uniform(-5, 5, 3) * 1e-21
    nabla = rng.uniform(-1e-2, 1e-2, 3)  # g
    m = cv.from_wang(e, k1, k2, k3, nabla)
    n = rng.uniform(-4e5, 4e5, size=(50, 3))  # pulses
    c = np.array([[1, 0, 0], [e["yx"], 1, 0], [e["zx"], e["zy"], 1]])
    ref = (k1 * n + k2 * n**2 + k3 * n**3 + nabla) @ c.T  # Wang 2019, eq. (2)
    np.testing.assert_allclose(m.forward(n), ref, rtol=1e-13)
    np.testing.assert_allclose(m.inverse(ref), n, rtol=1e-11)
    w = cv.to_wang(m)
    assert w["E"] == pytest.approx(e) and np.allclose(w["bias"], nabla)
    with pytest.raises(ValueError, match="upper-triangular"):
        cv.to_qureshi(m)
