"""The faster forms of the segmentation's statistics give numpy's numbers and the plain definitions' answers."""

from __future__ import annotations

import numpy as np
import pytest

from imucalib import segment
from imucalib.metrics import interval_means
from imucalib.recording import Interval
from imucalib.scenarios import session
from imucalib.segment import detect, poses, rest, windows
from imucalib.segment import still as still_module

SIZES = [1, 2, 7, 255, 256, 1000, 65_535, 65_536, 65_537, 140_001]


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("k", [1, 2, 3, 6])
def test_column_means_are_numpys_bit_for_bit(n: int, k: int) -> None:
    rng = np.random.default_rng(n * 10 + k)
    x = rng.normal(size=(n, k)) * 300 + 2e4
    for a in (x, np.round(x), np.asfortranarray(x)):
        assert windows.column_means(a).tobytes() == a.mean(axis=0).tobytes()


def test_interval_means_are_the_metrics_ones_bit_for_bit() -> None:
    rng = np.random.default_rng(5)
    for trial in range(40):
        n = int(rng.integers(50, 90_000))
        x = rng.normal(size=(n, 3)) * rng.uniform(0.01, 1e3) + rng.normal(size=3) * 1e4
        x = np.round(x) if trial % 2 else x
        ivs = [Interval(a, int(rng.integers(a + 1, min(n, a + 20_000) + 1)), "static")
               for a in rng.integers(0, n - 1, size=int(rng.integers(1, 12))).tolist()]
        want = interval_means(x, ivs).tobytes()
        assert windows.pose_means(x, ivs).tobytes() == want
        assert windows.pose_means(x, ivs, np.ascontiguousarray(x.T)).tobytes() == want


def test_static_runs_of_all_thresholds_are_detect_static_at_each() -> None:
    rng = np.random.default_rng(6)
    for trial in range(60):
        n = int(rng.integers(1, 20_000))
        stat = np.abs(np.cumsum(rng.normal(size=n))) + rng.uniform(0, 3, n)
        if trial % 3 == 0:
            stat[rng.random(n) < 0.3] = np.inf  # samples a gate takes out
        thresholds = (rng.choice([2, 3, 4, 6, 8, 10, 2.5], size=int(rng.integers(1, 9))) * rng.uniform(0.5, 3)).tolist()
        min_length = int(rng.integers(1, 50))
        assert detect.static_runs(stat, thresholds, min_length) == [
            segment.detect_static(None, t, window=3, min_length=min_length, statistic=stat) for t in thresholds]


def _still_inside_definition(gyro, half, bias, limit, intervals, offset_factor):
    """gyro_still's test of each interval's samples, interval by interval: its moving mean, median and distances."""
    out = {}
    for iv in intervals:
        m = windows.moving_mean_rows(gyro, half, iv.start, iv.stop) - bias
        dev = np.sqrt(np.einsum("ij,ij->i", m, m))
        local = np.linalg.norm(m - np.median(m, axis=0), axis=1)
        out[iv.start, iv.stop] = (local < limit) & (dev < offset_factor * limit)
    return out


@pytest.mark.parametrize("group_rows", [None, 3000])
def test_the_gates_poses_are_judged_as_one_by_one(group_rows, monkeypatch) -> None:
    if group_rows is not None:  # the poses' moving means held a few at a time
        monkeypatch.setattr(still_module, "STILL_ROWS", group_rows)
    rng = np.random.default_rng(7)
    mixed = 0
    for trial in range(40):
        n, half = int(rng.integers(200, 90_000)), int(rng.integers(0, 30))
        gyro = rng.normal(size=(n, 3)) * rng.uniform(1, 100) + rng.normal(size=3) * 100
        gyro = np.round(gyro) if trial % 2 else gyro
        starts = np.sort(rng.choice(n - 1, size=int(rng.integers(1, 25)), replace=False))
        intervals = [Interval(int(a), int(min(n, a + rng.choice([40, 1500, 80_000]))), "static") for a in starts]
        bias = gyro[:100].mean(axis=0)
        ms = [windows.moving_mean_rows(gyro, half, iv.start, iv.stop) - bias for iv in intervals]
        local = np.concatenate([np.linalg.norm(m - np.median(m, axis=0), axis=1) for m in ms])
        limit = float(np.quantile(local, rng.uniform(0.5, 1.0))) * rng.uniform(0.9, 1.3)  # near the distances
        offset = float(np.quantile(np.concatenate([np.linalg.norm(m, axis=1) for m in ms]), 0.7)) / limit
        still = np.zeros(n, dtype=bool)
        every = still_module.still_inside(gyro, (half, bias, limit), intervals, still, offset)
        want = np.zeros(n, dtype=bool)
        for iv in intervals:  # later intervals overwrite earlier ones, as gyro_still's loop did
            want[iv.slice] = _still_inside_definition(gyro, half, bias, limit, [iv], offset)[iv.start, iv.stop]
        assert np.array_equal(still, want)
        assert every == all(want[iv.slice].all() for iv in intervals)
        mixed += bool(want.any() and not want.all())
    assert mixed > 20  # the limits were near enough to the distances to split the samples


def test_unsteady_poses_screened_or_not_are_the_same(monkeypatch) -> None:
    cases = []
    for seed in (1, 2, 3):
        sim = session("handheld", rng=seed, n_poses=12, creep=3, tremor=0.15, rest=5.0)
        cases.append((sim.recording, [s for s in sim.segments if s.kind == "static"]))
    found = [[segment.unsteady_poses(rec, static, n_sigma=s, edge=e) for s in (4.0, 1.0) for e in (0.25, 0.1)]
             for rec, static in cases]
    monkeypatch.setattr(poses, "_floor_screen", lambda model, acc, means, poses, *a: np.ones(len(poses), bool))
    monkeypatch.setattr(poses, "_tilt_screen", lambda model, acc, poses, *a: np.ones(len(poses), bool))
    judged = [[segment.unsteady_poses(rec, static, n_sigma=s, edge=e) for s in (4.0, 1.0) for e in (0.25, 0.1)]
              for rec, static in cases]
    assert found == judged
    assert sum(len(d) for row in found for d in row) >= 3 * 4 * 3  # the creeping poses at least


def test_the_initial_rest_from_the_detectors_statistic_is_the_same() -> None:
    rec = session("handheld", rng=4).recording
    win = windows.odd_window(1.0, rec.rate)
    stat = segment.variance_norm(rec.acc, win)
    assert segment.find_initial_rest(rec, statistic=stat) == segment.find_initial_rest(rec)
    for n_level, factor in [(200, 30.0), (50, 3.0)]:
        assert rest.first_motion(rec, win, n_level, factor, acc_statistic=stat) == \
            rest.first_motion(rec, win, n_level, factor)
