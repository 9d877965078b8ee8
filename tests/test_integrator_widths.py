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
    got = kin.products.weighted_rotations_soa(q, w)
    ref = kin.quat_to_matrix(np.moveaxis(q, 0, -1)) * w[..., None, None]
    assert got.shape == ref.shape == (3, 9, 3, 3)
    assert np.array_equal(got, ref)
    np.testing.assert_allclose(got[0, 0] @ got[0, 0].T, w[0, 0] ** 2 * np.eye(3), atol=1e-12)


def test_bit_reversed_products_are_the_interleaved_ones() -> None:
    """The tree and prefix products on bit-reversed storage (contiguous halves) form the very products of the
    interleaved recursions, for groups of several widths reduced together; and they are the ordered products."""
    rng = np.random.default_rng(13)
    widths, rows = [16, 16, 4, 1], [3, 2, 5, 2]
    natural = [rng.normal(size=(4, m, w)) for m, w in zip(rows, widths, strict=True)]
    stored = [np.ascontiguousarray(f[:, :, kin.products.bit_reversal(w)].transpose(0, 2, 1))
              for f, w in zip(natural, widths, strict=True)]
    trees = kin.products.tree_products_halves(stored)
    assert np.array_equal(trees, np.concatenate([kin.products.tree_product_soa(f) for f in natural], axis=1))
    prefixes = kin.products.prefix_products_halves(stored)
    for f, w, got in zip(natural, widths, prefixes, strict=True):
        back = got[:, kin.products.bit_reversal(w)].transpose(0, 2, 1)  # the involution undoes the storage order
        assert np.array_equal(back, kin.products.prefix_product_soa(f))
        sequential = f[:, :, 0]
        for i in range(1, w):  # left to right, one factor at a time: equal to rounding
            sequential = kin.products._qmul_soa(sequential, f[:, :, i])
            np.testing.assert_allclose(back[:, :, i], sequential, rtol=1e-12, atol=1e-12)
    assert list(kin.products.bit_reversal(8)) == [0, 4, 2, 6, 1, 5, 3, 7]


def test_sensitivity_after_the_cost_of_the_same_factors_is_the_same() -> None:
    """The tree levels :meth:`from_samples` keeps for the same factors give :meth:`sensitivity` the very numbers
    it forms alone; other factors (or none kept) are integrated afresh."""
    rng = np.random.default_rng(14)
    n = 6000
    t = np.cumsum(rng.uniform(0.004, 0.006, size=n))
    starts = np.array([10, 400, 1500, 2200, 5000])
    stops = np.array([300, 1450, 1600, 4900, 5990])  # widths 512, 1024, 128, 4096 (a long one), 1024
    together = kin.IntervalIntegrator(t, starts, stops)
    rates = rng.normal(size=(together.samples.size, 3))
    other = rates + 0.1
    steps, other_steps = together.step_factors(rates), together.step_factors(other)
    alone_q, alone_w = kin.IntervalIntegrator(t, starts, stops).sensitivity(rates, steps)
    together.from_samples(rates, steps)
    assert together._tree_levels is not None  # kept: the path under test is the one taken
    q, w = together.sensitivity(rates, steps)
    assert np.array_equal(q, alone_q)
    assert all(np.array_equal(a, b) for a, b in zip(w, alone_w, strict=True))
    together.from_samples(other, other_steps)  # the levels kept are now another rate's: not used for these
    q2, w2 = together.sensitivity(rates, steps)
    assert np.array_equal(q2, alone_q)
    assert all(np.array_equal(a, b) for a, b in zip(w2, alone_w, strict=True))


def test_weights_kept_by_a_caller_are_not_overwritten_by_the_next_sensitivity() -> None:
    """The rotations array is reused only when nothing refers to it: weights (or a view of them) a caller keeps
    stay as they were, and a reused array gives the numbers a fresh one does."""
    rng = np.random.default_rng(15)
    t = np.cumsum(rng.uniform(0.009, 0.011, size=5000))
    integ = kin.IntervalIntegrator(t, np.array([10, 1000, 2000]), np.array([600, 1900, 2500]))
    rates = rng.normal(size=(integ.samples.size, 3))
    _, weights = integ.sensitivity(rates)
    kept, view = [w.copy() for w in weights], weights[1]
    _, other = integ.sensitivity(2 * rates)
    assert all(np.array_equal(a, b) for a, b in zip(weights, kept, strict=True))
    del weights, other
    assert np.array_equal(view, kept[1])
    del view
    first = [w.copy() for w in integ.sensitivity(3 * rates)[1]]  # into the array nothing refers to any more
    again = [w.copy() for w in kin.IntervalIntegrator(t, integ.starts, integ.stops).sensitivity(3 * rates)[1]]
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))


def test_many_short_intervals_in_parts_are_the_same_as_in_one(monkeypatch) -> None:
    """Short intervals integrated a part at a time (a recording of hours of short turns) give the numbers of one
    part, bit for bit: attitudes, every ``A_j`` and the weighted sums, also beside long intervals."""
    rng = np.random.default_rng(16)
    n = 60_000
    t = np.cumsum(rng.uniform(0.004, 0.006, size=n))
    lengths = rng.integers(1, 700, size=60)
    lengths[[5, 40]] = [5000, 4097]  # two long intervals among them
    starts = np.cumsum(np.concatenate([[3], lengths[:-1] + rng.integers(1, 40, size=59)]))
    stops = starts + lengths
    rates = rng.normal(size=(n, 3)) * 2.0
    one = kin.IntervalIntegrator(t, starts, stops)
    monkeypatch.setattr(kin.integrator, "PART_STEPS", 2048)
    parts = kin.IntervalIntegrator(t, starts, stops)
    assert len(one._parts) == 1 and len(parts._parts) > 5  # the paths under test are the ones taken
    assert np.array_equal(one.samples, parts.samples)
    r = rates[one.samples]
    values = rng.normal(size=(one.samples.size, 3, 4))
    for steps in (None, one.step_factors(r)):
        assert np.array_equal(parts.from_samples(r, steps), one.from_samples(r, steps))
        q1, w1 = one.sensitivity(r, steps)
        q2, w2 = parts.sensitivity(r, steps)
        assert np.array_equal(q1, q2)
        assert np.array_equal(one.weighted_sum(w1, values), parts.weighted_sum(w2, values))
        assert np.array_equal(one.weighted_sum(w1, lambda a, b: values[a:b]),
                              parts.weighted_sum(w2, lambda a, b: values[a:b]))
        assert all(np.array_equal(a, b) for a, b in zip(w1, w2, strict=True))
        assert np.array_equal(q2, parts(rates))


def test_memory_of_the_sensitivity_does_not_follow_the_number_of_short_intervals() -> None:
    """Eight times as many short intervals: the peak of sensitivity() and weighted_sum() beyond their inputs
    grows by a few bytes a sample (all of one part's per-sample temporaries at once: 166 bytes a sample)."""
    import tracemalloc

    rng = np.random.default_rng(17)

    def excess(count: int) -> tuple[int, int]:
        lengths = rng.integers(200, 500, size=count)
        starts = np.cumsum(np.concatenate([[0], lengths[:-1] + 50]))
        stops = starts + lengths
        t = np.arange(stops[-1] + 10) * 0.005
        integ = kin.IntervalIntegrator(t, starts, stops)
        r = rng.normal(size=(integ.samples.size, 3))
        steps = integ.step_factors(r)

        def values(a, b):
            return np.ones((b - a, 3, 12))

        tracemalloc.start()
        try:
            base = tracemalloc.get_traced_memory()[0]
            _, weights = integ.sensitivity(r, steps)
            integ.weighted_sum(weights, values)
            return tracemalloc.get_traced_memory()[1] - base, integ.samples.size
        finally:
            tracemalloc.stop()

    small, n_small = excess(1_000)  # about 350 k samples: more than one part
    big, n_big = excess(8_000)
    assert n_big > 7 * n_small
    per_sample = (big - small) / (n_big - n_small)
    assert per_sample < 40, f"{per_sample:.0f} bytes a sample more ({small / 1e6:.0f} → {big / 1e6:.0f} MB)"
