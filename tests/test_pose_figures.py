"""The poses' figures computed once and shared (fit_summary, the verdict) are the same bits as each computed alone."""

import math
from pathlib import Path

import numpy as np
import pytest

from imucalib import verdict
from imucalib.io import read
from imucalib.methods import calibrate
from imucalib.metrics import fit_summary, gravity_noise_floor, gravity_residuals, interval_means
from imucalib.recording import Interval
from imucalib.scenarios import session
from imucalib.verdict import predicted_direction_error, rest_noise, rest_rates

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"


def _blocks(rng, count, columns, longest=3000):
    """Blocks of wide dynamic range (offsets, scales over 16 decades, spikes): sums whose order shows."""
    out = []
    for _ in range(count):
        n = int(rng.integers(1, longest))
        x = rng.normal(size=(n, columns)) * 10 ** rng.uniform(-8, 8, size=columns)
        x += rng.normal(size=columns) * 10 ** rng.uniform(-3, 6, size=columns)
        x[rng.integers(0, n, 3)] *= 1e6
        out.append(x)
    return out


@pytest.mark.parametrize("columns", [1, 3, 6])
def test_interval_means_are_each_columns_own_pairwise_mean(columns):
    rng = np.random.default_rng(10 + columns)
    x = np.concatenate(_blocks(rng, 6, columns, longest=20000))  # lengths past numpy's 8192-element buffer
    ends = np.sort(rng.integers(0, len(x), 60))
    intervals = [Interval(int(a), int(max(b, a + 1))) for a, b in zip(ends[:-1], ends[1:], strict=True)]
    intervals += [Interval(0, len(x)), Interval(5, 6)]
    got = interval_means(x, intervals)
    # each column alone: a contiguous 1-D copy of its differences from the interval's first sample, ndarray.mean
    want = np.array([[(x[i.slice, j] - x[i.start, j]).mean() + x[i.start, j] for j in range(columns)]
                     for i in intervals])
    assert np.array_equal(got, want)  # bit for bit
    # a sequential sum over the rows gives other numbers on these data: the check can fail
    seq = np.array([np.add.reduce(x[i.slice] - x[i.start], axis=0) / len(i) + x[i.start] for i in intervals])
    assert columns == 1 or not np.array_equal(got, seq)


def _rest_noise_alone(cal, rec, intervals):
    """rest_noise as the plain formulas give it, each pose calibrated and differenced on its own."""
    def variances(iv):
        acc = cal.accelerometer_si(rec.acc[iv.slice])
        gyro = cal.gyroscope_si(rec.gyro[iv.slice], rec.acc[iv.slice])
        wnv = [np.mean(np.diff(x, n=4, axis=0) ** 2, axis=0) / math.comb(8, 4) for x in (acc, gyro)]
        return float(np.mean(wnv[0])), float(np.mean(wnv[1]))

    s_a2, s_g2 = variances(intervals[0])
    poses = [variances(iv) for iv in intervals[1:] if len(iv) > 20]
    return (min(s_a2, float(np.median([p[0] for p in poses]))), min(s_g2, float(np.median([p[1] for p in poses]))))


def _noise_floor_alone(cal, rec, intervals):
    """gravity_noise_floor by np.var, ndarray.mean and np.linalg.norm (linear model)."""
    m = cal.accelerometer
    var = []
    for iv in intervals:
        raw = rec.acc[iv.slice]
        u = m.forward(raw.mean(axis=0)[None, :])[0]
        var.append(np.var(raw @ (m.scale * (m.misalignment.T @ (u / np.linalg.norm(u)))), ddof=1) / raw.shape[0])
    return float(np.sqrt(np.mean(var)))


def _sessions():
    yield "handheld2", session("handheld", rng=2).recording, {}  # rotations left out, a g-sensitivity
    if DATA.is_dir():
        yield "xsens", read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk"), {"gravity": 9.81744}


@pytest.mark.parametrize("pose_bytes", [None, 1 << 16])  # the poses in one group; in groups of ~900 samples
@pytest.mark.parametrize("name", ["handheld2", "xsens"])
def test_shared_pose_figures_are_the_figures_alone(name, pose_bytes, monkeypatch):
    if pose_bytes:
        monkeypatch.setattr(verdict.base, "POSE_BYTES", pose_bytes)  # the poses' figures live in verdict.base
    found = {n: (rec, kw) for n, rec, kw in _sessions()}
    if name not in found:
        pytest.skip(f"real data not present: {DATA} (needs ../shared/data)")
    rec, kw = found[name]
    cal = calibrate(rec, method="tedaldi2014", **kw)
    assert np.any(cal.gyroscope.g_sensitivity) and cal.accelerometer.is_linear
    iv = [Interval(int(a), int(b)) for a, b in cal.fit["intervals"]]
    assert rest_noise(cal, rec, iv) == _rest_noise_alone(cal, rec, iv)
    want = np.array([cal.gyroscope_si(rec.gyro[i.slice], rec.acc[i.slice]).mean(axis=0) for i in iv])
    assert np.array_equal(rest_rates(cal, rec, iv), want)
    assert gravity_noise_floor(cal, rec, iv) == _noise_floor_alone(cal, rec, iv)
    a = cal.accelerometer_si(interval_means(rec.acc, iv))
    assert np.array_equal(gravity_residuals(cal, rec, iv), np.linalg.norm(a, axis=1) - cal.gravity)
    s_a2, s_g2 = _rest_noise_alone(cal, rec, iv)
    t, n = rec.t, np.array([len(i) for i in iv], dtype=float)
    dur = t[[i.start for i in iv[1:]]] - t[[i.stop - 1 for i in iv[:-1]]]
    v = (s_g2 * dur * float(np.median(np.diff(t))) + s_g2 / len(iv[0]) * dur**2
         + s_a2 / cal.gravity**2 * (1 / n[:-1] + 1 / n[1:]))
    assert np.array_equal(predicted_direction_error(cal, rec, iv), np.sqrt(np.pi * v / 2))
    # the calibration's own figures, from fit_summary and the verdict, are the ones computed here
    fit = fit_summary(cal, rec, iv, cal.gravity)
    assert fit["accelerometer_noise_floor"] == cal.fit["accelerometer_noise_floor"] == _noise_floor_alone(cal, rec, iv)
    assert cal.fit["gyroscope_rest_rate_deg_s"] == [float(x) for x in np.degrees(want).mean(axis=0)]
