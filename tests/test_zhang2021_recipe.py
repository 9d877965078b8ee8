"""zhang2021 over the shared stages: no worse than tedaldi2014, model selection within the verdict's pose budget.

* the accelerometer comes from the static poses alone and the gyroscope from
  :func:`imucalib.fit.gyroscope.fit_gyroscope`, on the poses and rotations the
  shared detector keeps: the linear variant is tedaldi2014 to rounding;
* on the real Xsens session, zhang2021 with default options is within 1.2× of
  tedaldi2014 in-sample, on held-out poses and on the other half of the session;
* on hand-held sessions, the linear variant's gyroscope error is at most 1.2×
  what the true parameters leave, and accepted;
* model selection never picks a variant the verdict rejects for too few poses
  per parameter, by the verdict's own threshold;
* ``compare`` and ``calibrate`` name the same variant on the same recording.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib import verdict
from imucalib.crossval import leave_one_pose_out
from imucalib.methods import calibrate
from imucalib.metrics import fit_summary, gravity_direction_errors
from imucalib.recording import ImucalibWarning, Interval
from imucalib.scenarios import session

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"
G_XSENS = 9.81744


def _quiet(rec, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        return calibrate(rec, **kw)


def _intervals(cal) -> list[Interval]:
    return [Interval(int(a), int(b), "static") for a, b in cal.fit["intervals"]]


@pytest.fixture(scope="module")
def xsens():
    if not DATA.is_dir():
        pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): real-data test skipped")
    from imucalib.io import read

    return read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk")


def test_linear_variant_is_the_shared_stages():
    """Same poses, same rotations left out, same accelerometer and gyroscope as tedaldi2014."""
    sim = session("handheld", rng=7)
    g = sim.truth.gravity
    ted = calibrate(sim.recording, method="tedaldi2014", gravity=g)
    lin = calibrate(sim.recording, method="zhang2021", model="linear", gravity=g)
    assert lin.fit["intervals"] == ted.fit["intervals"]
    assert lin.fit.get("rotations_left_out") == ted.fit.get("rotations_left_out")
    p, q = lin.parameters(), ted.parameters()
    assert set(p) == set(q)
    np.testing.assert_allclose([p[k] for k in q], list(q.values()), rtol=1e-9, atol=1e-12)


def test_unreliable_rotations_are_left_out_as_the_shared_stage_finds_them(spiky_handheld):
    sim, spiky = spiky_handheld(4)  # four spikes, each in the middle of a different rotation
    cal = _quiet(spiky, method="zhang2021", gravity=sim.truth.gravity)
    assert sum("spike" in why for why in cal.fit["rotations_left_out"].values()) == 4
    np.testing.assert_allclose(cal.gyroscope.scale, sim.truth.gyroscope.scale, rtol=0.002)
    assert cal.fit["verdict"] == "accepted"


@pytest.mark.slow
def test_handheld_linear_gyroscope_at_the_noise_floor():
    """The linear variant (and the default) leave at most 1.2× the truth's gravity-direction error, accepted.

    ``benchmarks/bench_zhang_vs_tedaldi.py`` runs the same on 30 seeds.
    """
    for seed in range(4):
        sim = session("handheld", rng=seed)
        for model in ("linear", None):
            cal = _quiet(sim.recording, method="zhang2021", model=model, gravity=sim.truth.gravity)
            truth = np.degrees(np.mean(gravity_direction_errors(sim.truth, sim.recording, _intervals(cal))))
            assert cal.fit["gyroscope_angle_error_mean_deg"] <= 1.2 * truth, (seed, model)
            assert cal.fit["verdict"] == "accepted", (seed, model, cal.fit["verdict_reasons"])


@pytest.mark.slow
def test_xsens_no_worse_than_tedaldi_in_sample_and_held_out(xsens):
    """In-sample, leave-one-pose-out and half-session |a|−g and gyroscope error within 1.2× of tedaldi2014."""
    fits = {m: _quiet(xsens, method=m, gravity=G_XSENS) for m in ("tedaldi2014", "zhang2021")}
    for key in ("accelerometer_residual_rms", "gyroscope_angle_error_mean_deg"):
        assert fits["zhang2021"].fit[key] <= 1.2 * fits["tedaldi2014"].fit[key], key
    assert fits["zhang2021"].fit["verdict"] == "accepted"
    iv = _intervals(fits["tedaldi2014"])
    assert _intervals(fits["zhang2021"]) == iv
    folds = list(range(1, len(iv), 6))
    cv = {m: leave_one_pose_out(xsens, iv, lambda tr, m=m: _quiet(xsens, method=m, gravity=G_XSENS, intervals=tr),
                                gravity=G_XSENS, folds=folds) for m in fits}
    for key in ("cv_accelerometer_residual_rms", "cv_gyroscope_angle_error_mean_deg"):
        assert cv["zhang2021"][key] <= 1.2 * cv["tedaldi2014"][key], key
    half = len(iv) // 2
    for train, test in ((iv[:half], iv[half:]), (iv[half:], iv[:half])):
        held = {m: fit_summary(_quiet(xsens, method=m, gravity=G_XSENS, intervals=train), xsens, test, G_XSENS)
                for m in fits}
        for key in ("accelerometer_residual_rms", "gyroscope_angle_error_mean_deg"):
            assert held["zhang2021"][key] <= 1.2 * held["tedaldi2014"][key], key


@pytest.fixture(scope="module")
def twelve_poses():
    sim = session("handheld", rng=3, n_poses=11)
    assert len([s for s in sim.segments if s.kind == "static"]) == 12
    return sim


def test_selection_stays_within_the_verdicts_pose_budget(twelve_poses):
    """12 poses: the variants with 12 or 15 accelerometer parameters are rejected by the verdict, never selected."""
    sim = twelve_poses
    g = sim.truth.gravity
    cal = _quiet(sim.recording, method="zhang2021", model="all", gravity=g)
    sel = cal.fit["model_selection"]
    m = cal.fit["static_intervals"]
    assert m == 12
    assert sel["over_pose_budget"] == ["quadratic", "cubic", "all"]
    assert sel["selected"] == cal.model == "linear"
    assert not any("per parameter" in r for r in cal.fit["verdict_reasons"] if "rejected" in r)
    assert cal.fit["verdict"] != "rejected"
    # each variant forced (select=False): the verdict rejects for the pose budget exactly those left out
    iv = _intervals(cal)
    lim = verdict.THRESHOLDS["poses_per_parameter"]
    for name, p in (("linear", 9), ("quadratic", 12), ("cubic", 15)):
        rejected_for_budget = m / p <= lim[1]
        assert rejected_for_budget == (name in sel["over_pose_budget"])
        forced = _quiet(sim.recording, method="zhang2021", model=name, gravity=g, intervals=iv, select=False)
        assert (forced.fit["verdict"] == "rejected") == rejected_for_budget
        assert any("per parameter" in r for r in forced.fit["verdict_reasons"])  # 1.33 per parameter: suspect


def test_the_pose_budget_is_the_verdicts_own_threshold(twelve_poses, monkeypatch):
    """Lower the verdict's rejecting limit and the selection may take the larger variants: one value, one place."""
    sim = twelve_poses
    monkeypatch.setitem(verdict.THRESHOLDS, "poses_per_parameter", (1.5, 0.5))
    cal = _quiet(sim.recording, method="zhang2021", model="all", gravity=sim.truth.gravity)
    sel = cal.fit["model_selection"]
    assert sel["over_pose_budget"] == []
    assert set(sel["aic"]) == {"linear", "quadratic", "cubic", "all"}


def test_compare_and_calibrate_select_the_same_variant(tmp_path, capsys):
    """On the same file ``compare`` shows the variant ``calibrate`` selects: the selection runs once, in the method."""
    from imucalib.cli import main
    from imucalib.scenarios import write_session

    sim = session("handheld", rng=2, n_poses=16)
    write_session(sim, tmp_path / "s")
    g = str(sim.truth.gravity)
    assert main(["calibrate", str(tmp_path / "s"), "--method", "zhang2021", "--gravity", g,
                 "-o", str(tmp_path / "cal.json")]) == 0
    selected = json.loads((tmp_path / "cal.json").read_text())["model"]
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "s"), "--methods", "zhang2021", "--folds", "2", "--gravity", g,
                 "--json"]) == 0
    row = json.loads(capsys.readouterr().out)["methods"][0]
    assert row["model"] == "all" and row["model_selected"] == selected
    assert main(["compare", str(tmp_path / "s"), "--methods", "zhang2021", "--folds", "2", "--gravity", g]) == 0
    table = capsys.readouterr().out.splitlines()
    shown = table[2].split()[2]
    assert shown == ("all" if selected == "all" else f"all->{selected}")
