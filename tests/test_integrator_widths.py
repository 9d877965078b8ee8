"""Intervals of many lengths integrated together give each interval's numbers alone, bit for bit."""

from __future__ import annotations

import numpy as np

from imucalib import kinematics as kin


def test_intervals_of_every_width_together_are_each_alone() -> None:
    rng = np.random.default_rng(11)
    n = 40_000
    t = np.cumsum(rng.uniform(0.004, 0.006, size=n))
    rates = rng.normal(size=(n, 3)) * 2.0
    lengths = [1, 2, 3, 7, 64, 65, 300, 513, 1024, 1025, 4096, 5000]  # widths 1 … 2¹³ (two blocks) at once
    starts = np.cumsum([0] + [m + 17 for m in lengths[:-1]])
    stops = starts + np.array(lengths)
    together = kin.IntervalIntegrator(t, starts, stops)
    q, weights = together.sensitivity(rates[together.samples])
    assert np.array_equal(together(rates), q)  # the tree products and the prefix products' last entries
    values = rng.normal(size=(together.samples.size, 3, 5))
    summed = together.weighted_sum(weights, values)
    for k, (a, b) in enumerate(zip(starts, stops, strict=True)):
        alone = kin.IntervalIntegrator(t, np.array([a]), np.array([b]))
        assert np.array_equal(alone(rates)[0], q[k])
        q1, w1 = alone.sensitivity(rates[alone.samples])
        assert np.array_equal(w1[0], weights[k])
        first = together.first_sample[k]
        v = values[first : first + b - a + 1]
        assert np.array_equal(alone.weighted_sum(w1, v)[0], summed[k])


def test_weighted_rotations_are_the_matrices_times_the_weights() -> None:
    rng = np.random.default_rng(12)
    q = rng.normal(size=(4, 3, 9))
    w = rng.uniform(0.1, 2.0, size=(3, 9))
    got = kin._weighted_rotations_soa(q, w)
    ref = kin.quat_to_matrix(np.moveaxis(q, 0, -1)) * w[..., None, None]
    assert got.shape == ref.shape == (3, 9, 3, 3)
    assert np.array_equal(got, ref)
    np.testing.assert_allclose(got[0, 0] @ got[0, 0].T, w[0, 0] ** 2 * np.eye(3), atol=1e-12)
