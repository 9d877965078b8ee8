"""The simulator: structure, determinism, exact geometry, eqs. (17)-(18), files."""

import numpy as np
import pytest

from imucalib import kinematics as kin
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import random_truth, read_session, session, table1_truth, write_session


@pytest.fixture(scope="module")
def clean():
    return session("zhang2021", rng=5, noise=0)


def test_structure(clean):
    rec = clean.recording
    assert rec.rate == pytest.approx(100.0)
    static = [s for s in clean.segments if s.kind == "static"]
    motion = [s for s in clean.segments if s.kind == "motion"]
    assert len(static) == 40 and len(motion) == 39  # n1 = 40 directions
    assert len(static[0]) == 1000  # 10 s initial rest
    assert all(len(s) == 300 for s in static[1:])  # t1 = 3 s
    assert all(len(s) == 200 for s in motion)  # t2 = 2 s
    assert len(rec) == 1000 + 39 * 500
    assert len(clean.weightless) == 100
    assert all(len(w) == 100 and w.rate == pytest.approx(100.0) for w in clean.weightless)
    assert len(clean.tests) == 10
    kinds = [s.kind for s in clean.tests[0].segments]
    assert kinds == ["static", "motion", "weightless", "motion", "static"]


def test_deterministic_per_seed():
    a = session("zhang2021", rng=11, n2=3, n3=1)
    b = session("zhang2021", rng=11, n2=3, n3=1)
    c = session("zhang2021", rng=12, n2=3, n3=1)
    np.testing.assert_array_equal(a.recording.acc, b.recording.acc)
    np.testing.assert_array_equal(a.weightless[2].gyro, b.weightless[2].gyro)
    assert not np.allclose(a.recording.acc, c.recording.acc)


def test_static_norm_and_transitions_exact(clean):
    truth = clean.truth
    out = truth.apply(clean.recording)
    static = [s for s in clean.segments if s.kind == "static"]
    norms = np.linalg.norm(out.acc[np.concatenate([np.arange(s.start, s.stop) for s in static])], axis=1)
    np.testing.assert_allclose(norms, truth.gravity, rtol=1e-12)
    # RK4 through each transition carries gravity from one pose to the next (< 1e-6 rad)
    errs = []
    for a, b in zip(static[:-1], static[1:], strict=True):
        integ = kin.IntervalIntegrator(out.t, np.array([a.stop - 1]), np.array([b.start]))
        r = kin.quat_to_matrix(integ(out.gyro))[0]
        errs.append(kin.angle_between(out.acc[b.start], r.T @ out.acc[a.stop - 1]))
    assert max(errs) < 1e-6


def test_weightless_accelerometer_is_eqs_17_18(clean):
    truth = clean.truth
    r = truth.lever_arm
    w_rec = truth.apply(clean.weightless[7])
    w = w_rec.gyro
    # independent evaluation: ω̇ by a high-order finite difference of the true rate
    wd = np.gradient(w, 0.01, axis=0, edge_order=2)
    expected = -np.cross(w, np.cross(w, r)) - np.cross(wd, r)  # = f_C + f_E
    # central differences of a smooth spin: O(dt²) ≈ 1e-3 relative to ω̇
    inner = slice(2, -2)
    np.testing.assert_allclose(w_rec.acc[inner], expected[inner], atol=0.05)
    np.testing.assert_allclose(np.linalg.norm(w, axis=1), np.linalg.norm(w[0]), rtol=1e-12)


def test_truth_round_trip_and_table1(tmp_path):
    sim = session("zhang2021", rng=2, n2=2, n3=1)
    write_session(sim, tmp_path / "s")
    back = read_session(tmp_path / "s")
    np.testing.assert_allclose(back.recording.acc, sim.recording.acc, rtol=1e-15)
    np.testing.assert_allclose(back.weightless[1].gyro, sim.weightless[1].gyro, rtol=1e-15)
    assert [s.to_dict() for s in back.segments] == [s.to_dict() for s in sim.segments]
    assert back.truth.parameters() == pytest.approx(sim.truth.parameters(), rel=1e-15)
    t1 = table1_truth()
    assert t1.gyroscope.bias[0] == pytest.approx(-0.40)  # the fitted columns' 0.40, negated
    with pytest.raises(ValueError, match="not a simulated session directory"):
        read_session(tmp_path)


def test_noise_levels_and_options():
    sim = session("zhang2021", rng=3, n2=1, n3=1)
    rest = sim.recording[sim.segments[0]]
    sa = np.std(rest.acc, axis=0) * sim.truth.accelerometer.scale
    np.testing.assert_allclose(sa, 0.005, rtol=0.1)  # default σ_a in m/s²
    with pytest.warns(ImucalibWarning, match="were clipped"):
        sat = session("zhang2021", rng=3, n2=1, n3=1, full_scale={"gyroscope": 5.0})
    assert np.max(np.abs(sat.weightless[0].gyro)) <= 5.0
    q = session("zhang2021", rng=3, n2=1, n3=1, lsb={"accelerometer": 1 / 2048})
    np.testing.assert_allclose(q.recording.acc * 2048, np.round(q.recording.acc * 2048), atol=1e-9)
    with pytest.raises(ValueError, match="unknown scenario"):
        session("nope", rng=1)
    with pytest.raises(ValueError, match="noise keys"):
        session("zhang2021", rng=1, noise={"acc": 1.0})


def test_random_truth_is_monotonic_and_varied():
    t = random_truth(4)
    assert np.all(np.abs(t.accelerometer.misalignment - np.eye(3)) <= 0.05)
    assert np.all(t.accelerometer.scale_cubic > 0)
    # invertible over ±16 g and ±2000 °/s
    x = np.linspace(-16, 16, 50)[:, None] * np.ones(3) * 9.81
    np.testing.assert_allclose(t.accelerometer.forward(t.accelerometer.inverse(x)), x, rtol=1e-12)
