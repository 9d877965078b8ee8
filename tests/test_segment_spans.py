"""Windowed statistics formed in pieces give the numbers of the whole-record pass, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from imucalib import presets, segment
from imucalib.recording import Recording
from imucalib.segment import rest, windows


def _first_motion_whole(recording: Recording, win: int, n_level: int, factor: float) -> int:
    """The definition: the statistic of the whole record, its median over ``n_level`` samples, the first exceedance."""
    first = len(recording)
    for signal in (recording.acc, recording.gyro):
        if signal is None:
            continue
        stat = segment.variance_norm(signal, win)
        level = float(np.median(stat[:n_level]))
        moving = np.nonzero(stat > factor * max(level, np.finfo(float).tiny))[0]
        if moving.size:
            first = min(first, int(moving[0]))
    return first


@pytest.mark.parametrize("n", [5, 700, 70_000, 140_001])
@pytest.mark.parametrize("window", [1, 3, 101, 2001])
def test_variance_norm_in_any_spans_is_the_whole_pass(n: int, window: int) -> None:
    rng = np.random.default_rng(n + window)
    x = rng.normal(size=(n, 3)) * 100 + 3e4
    whole = segment.variance_norm(x, window)
    cuts = sorted({0, n, *rng.integers(0, n, size=6).tolist()})
    parts = np.empty(n)
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        windows.variance_norm_rows(x, x.mean(axis=0), max(window // 2, 1), a, b, parts[a:b])
    assert np.array_equal(parts, whole)
    # the moving variance's windows inside the record come from slices, those at its ends are gathered: both
    # are E[x²] − E[x]² over the truncated window
    var = segment.moving_variance(x, window)
    half = max(window // 2, 1)
    for i in {0, n // 2, n - 1}:
        w = x[max(i - half, 0) : min(i + half + 1, n)]
        np.testing.assert_allclose(var[i], w.var(axis=0), rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("acc_moves, gyro_moves", [(150_000, 250_000), (250_000, 150_000), (None, 9000),
                                                   (3000, None), (None, None), (10, 20)])
def test_first_motion_reads_the_statistic_only_as_far_as_it_needs(acc_moves, gyro_moves) -> None:
    rng = np.random.default_rng(1)
    n = 300_000
    acc, gyro = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    if acc_moves is not None:
        acc[acc_moves:] *= 50
    if gyro_moves is not None:
        gyro[gyro_moves:] *= 50
    rec = Recording(np.arange(n) * 1e-3, acc, gyro)
    for win, n_level, factor in [(101, 1000, 3.0), (11, 7, 2.0), (2001, 5000, 10.0)]:
        assert rest.first_motion(rec, win, n_level, factor) == _first_motion_whole(rec, win, n_level, factor)
    alone = Recording(np.arange(n) * 1e-3, acc, None)
    assert rest.first_motion(alone, 101, 1000, 3.0) == _first_motion_whole(alone, 101, 1000, 3.0)


@pytest.mark.parametrize("n, half", [(5, 2), (700, 12), (140_001, 12), (70_000, 1500)])
def test_moving_mean_of_chosen_rows_is_the_whole_pass(n: int, half: int) -> None:
    rng = np.random.default_rng(n + half)
    x = rng.normal(size=(n, 3)) * 100 + 3e4
    whole = windows.moving_mean_rows(x, half, 0, n)
    keep = rng.random(n) < 0.3
    keep[:3] = keep[-3:] = True  # windows truncated at both ends
    assert np.array_equal(windows.moving_mean_rows(x, half, 0, n, keep=keep), whole[keep])
    # the definition, inside the record and at its ends
    for i in {0, 1, n // 2, n - 1}:
        np.testing.assert_allclose(whole[i], x[max(i - half, 0): i + half + 1].mean(axis=0), rtol=1e-12)


def test_gyro_still_outside_the_poses_is_the_plain_moving_mean_test() -> None:
    """The samples between the poses are judged by ``‖mean − bias‖ < limit`` over the whole-record moving mean."""
    from imucalib.scenarios import session

    sim = session("handheld", rng=2)
    rec = sim.recording
    intervals, _, rest, _ = segment.detect_intervals(rec, sim.truth.gravity, gyro_gate=False)
    scale = 1e-3
    still = segment.gyro_still(rec, rest, scale, intervals)
    n = max(int(round(presets.STILL_WINDOW * rec.rate)), 1)
    raw = rec.gyro[rest.slice]
    limit = max(presets.STILL_RATE / scale, presets.STILL_N_SIGMA * float(np.linalg.norm(raw.std(axis=0))) / np.sqrt(n))
    m = segment.moving_mean(rec.gyro, n) - raw.mean(axis=0)
    outside = np.ones(len(rec), dtype=bool)
    for iv in intervals:
        outside[iv.slice] = False
    plain = np.linalg.norm(m, axis=1) < limit
    assert outside.sum() > 1000 and 0 < plain[outside].sum() < outside.sum()
    assert np.count_nonzero(still[outside] != plain[outside]) <= 2  # rounding at the limit only


def test_spikes_are_the_definition_sample_by_sample() -> None:
    """Each sample against the docstring's conditions, one at a time (the big jumps are looked at first)."""
    rng = np.random.default_rng(3)
    n = 3000
    x = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    hits = rng.integers(2, n - 2, size=40)
    x[hits, hits % 3] += rng.choice([-1, 1], size=40) * rng.uniform(5, 200, size=40)
    x[1000:1003, 0] += 80  # a step held for three samples: no spike
    factor, isolation = 20.0, 4.0
    want = np.zeros(n, dtype=bool)
    for j in range(3):
        scale = np.median(np.abs(np.diff(x[:, j])))
        for i in range(2, n - 2):
            d0, d1, d2, d3 = (x[i - 1, j] - x[i - 2, j], x[i, j] - x[i - 1, j], x[i + 1, j] - x[i, j],
                              x[i + 2, j] - x[i + 1, j])
            jump = min(abs(d1), abs(d2))
            if (jump > factor * scale and np.sign(d1) != np.sign(d2) and jump > isolation * max(abs(d0), abs(d3))
                    and abs(x[i + 1, j] - x[i - 1, j]) < 0.25 * abs(d1)):
                want[i] = True
    got = segment.spikes(x, factor=factor, isolation=isolation)
    assert 20 <= want.sum() <= 40 and not got[1000:1003].any()
    assert np.array_equal(got, want)
