"""Allan deviation against the closed forms of white noise and random walk."""

import numpy as np
import pytest

from imucalib.noise import allan_deviation, noise_parameters


def test_white_noise_follows_minus_half_slope():
    rng = np.random.default_rng(0)
    rate, sigma = 100.0, 0.02
    x = rng.normal(0, sigma, size=(200_000, 2))
    taus, adev = allan_deviation(x, rate)
    expected = sigma / np.sqrt(taus * rate)  # σ(τ) = σ/√(τ f_s)
    ok = taus <= 10
    np.testing.assert_allclose(adev[ok, 0], expected[ok], rtol=0.1)
    p = noise_parameters(x, rate)
    np.testing.assert_allclose(p["white_noise_per_sample"], sigma, rtol=0.05)


def test_random_walk_follows_plus_half_slope():
    rng = np.random.default_rng(1)
    rate, k = 100.0, 1e-3  # rate random walk density [unit/√s]
    x = np.cumsum(rng.normal(0, k / np.sqrt(rate), size=400_000))
    taus, adev = allan_deviation(x, rate, taus=np.array([50.0, 100.0, 200.0]))
    np.testing.assert_allclose(adev, k * np.sqrt(taus / 3), rtol=0.35)  # few long clusters: loose


def test_errors():
    with pytest.raises(ValueError, match="at least 8 samples"):
        allan_deviation(np.ones(5), 100.0)
    with pytest.raises(ValueError, match="no cluster time fits"):
        allan_deviation(np.ones(100), 100.0, taus=[10.0])
