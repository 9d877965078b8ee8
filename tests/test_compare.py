"""Cross-validation and the method comparison on the real Xsens data."""

import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib.comparison import compare, even_folds
from imucalib.crossval import leave_one_pose_out
from imucalib.io import read
from imucalib.methods import calibrate, tedaldi2014

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"
G = 9.81744


@pytest.fixture(scope="module")
def xsens():
    if not DATA.is_dir():
        pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): real-data test skipped")
    rec = read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk")
    return rec, tedaldi2014.detect_intervals(rec, G)[0]


def test_even_folds():
    assert even_folds(5, None) == [1, 2, 3, 4]
    assert even_folds(38, 4) == [1, 13, 25, 37]


@pytest.mark.slow
def test_compare_on_xsens(xsens):
    rec, iv = xsens
    out = compare(rec, gravity=G, methods=["tedaldi2014", "ellipsoid", "six_position", "wang2019"],
                  intervals=iv, folds=6)
    rows = {r["method"]: r for r in out["methods"]}
    # 38 poses: the holds long enough for Tedaldi's 1 s window keep its runs (segment.detector_runs); a 0.5 s
    # window alone would cut the pose at 165-172 s in two at a bump of 0.26 s
    assert out["static_intervals"] == 38 and out["folds"] == 6
    base = rows["tedaldi2014"]["cv_accelerometer_residual_rms"]
    assert 0 < base < 0.003  # m/s²
    assert rows["ellipsoid"]["ok"]
    assert rows["ellipsoid"]["cv_accelerometer_residual_rms"] <= 2 * base
    # the Xsens poses hold no face within 15° of +x: the six-position method says so
    assert not rows["six_position"]["ok"] and "+x" in rows["six_position"]["reason"]
    assert not rows["wang2019"]["ok"] and "turntable data" in rows["wang2019"]["reason"]


@pytest.mark.slow
def test_cubic_without_tosses_does_not_overfit(xsens):
    rec, iv = xsens
    folds = even_folds(len(iv), 4)

    def cv(model, **kw):
        def fit(training):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return calibrate(rec, method="zhang2021", model=model, gravity=G, intervals=training, **kw)
        return leave_one_pose_out(rec, iv, fit, gravity=G, folds=folds)["cv_accelerometer_residual_rms"]

    linear, cubic = cv("linear"), cv("cubic")
    assert cubic <= 1.05 * linear
    assert np.isfinite(linear) and linear < 0.003


def test_rank_orders_ran_then_verdict_then_score():
    from imucalib.comparison import rank

    def row(method, ok=True, verdict="accepted", acc=None, ang=None):
        return {"method": method, "ok": ok, "verdict": verdict, "cv_accelerometer_residual_rms": acc,
                "cv_gyroscope_angle_error_mean_deg": ang}

    rows = [row("cannot", ok=False, verdict=None),
            row("rejected_but_best_numbers", verdict="rejected", acc=0.001, ang=0.05),
            row("suspect", verdict="suspect", acc=0.002, ang=0.1),
            row("accepted_worse", acc=0.004, ang=0.1),   # score 0.004/0.001 + 0.1/0.05 = 6
            row("accepted_better", acc=0.002, ang=0.3)]  # score 2 + 6 = 8: worse overall
    ranked, best = rank(rows)
    assert [r["method"] for r in ranked] == ["accepted_worse", "accepted_better", "suspect",
                                             "rejected_but_best_numbers", "cannot"]
    assert [r["rank"] for r in ranked] == [1, 2, 3, 4, 5]
    assert ranked[0]["score"] == pytest.approx(0.004 / 0.001 + 0.1 / 0.05)
    assert ranked[1]["score"] == pytest.approx(0.002 / 0.001 + 0.3 / 0.05)
    assert ranked[-1]["score"] is None
    assert best == "accepted_worse"
    _, best = rank([row("r", verdict="rejected", acc=1, ang=1), row("x", ok=False)])
    assert best is None


def test_identical_scores_are_a_tie_not_an_arbitrary_best(tmp_path, capsys, monkeypatch):
    """Two methods with the same verdict and the same figures share the first rank; there is no best, and the
    table says it is a tie. A third, worse one keeps its own rank."""
    from imucalib import comparison as compare_module
    from imucalib.cli import main
    from imucalib.comparison import rank, tied_best
    from imucalib.io import write_csv
    from imucalib.recording import Recording

    def row(method, acc, ang, verdict="accepted"):
        return {"method": method, "ok": True, "verdict": verdict, "cv_accelerometer_residual_rms": acc,
                "cv_gyroscope_angle_error_mean_deg": ang, "model": None, "cv_folds_skipped": 0}

    rows = [row("ferraris", 0.002, 0.1), row("worse", 0.004, 0.1), row("six_position", 0.002, 0.1)]
    ranked, best = rank(rows)
    assert best is None
    assert [(r["method"], r["rank"]) for r in ranked] == [("ferraris", 1), ("six_position", 1), ("worse", 3)]
    assert tied_best(ranked) == ["ferraris", "six_position"]
    # a suspect method with the same figures is not tied with an accepted one
    ranked, best = rank([row("a", 0.002, 0.1), row("b", 0.002, 0.1, verdict="suspect")])
    assert best == "a" and tied_best(ranked) == []
    ranked, _ = rank(rows)
    result = {"static_intervals": 9, "folds": 4, "best": None, "tied": tied_best(ranked), "ranked_by": "score",
              "methods": ranked}
    monkeypatch.setattr(compare_module, "compare", lambda *a, **k: result)
    n = 200
    write_csv(tmp_path / "r.csv", Recording(np.arange(n) / 100, np.tile([0.0, 0.0, 9.81], (n, 1)), np.zeros((n, 3)),
                                            acc_unit="m/s^2", gyro_unit="rad/s"))
    assert main(["compare", str(tmp_path / "r.csv")]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[-1] == ("best: a tie between ferraris and six_position (the same verdict and score: "
                                    "nothing here prefers one)")


@pytest.mark.slow
def test_compare_ranks_a_cubic_sensor_known_to_need_the_cubic_model(tmp_path, capsys):
    """A simulated sensor with ten times Zhang 2021 Table I's nonlinearity: the cubic zhang2021 must rank
    before the linear tedaldi2014 (its held-out |a|-g is ~10x smaller), and wang2019, which needs turntable
    data, last."""
    from imucalib.cli import main
    from imucalib.scenarios import session, table1_truth, write_session

    truth = table1_truth()
    a = truth.accelerometer
    truth = truth.with_(accelerometer=a.with_(scale_quadratic=10 * a.scale_quadratic, scale_cubic=10 * a.scale_cubic))
    sim = session("zhang2021", rng=1, truth=truth)
    out = compare(sim.recording, gravity=truth.gravity, methods=["wang2019", "tedaldi2014", "zhang2021"], folds=4)
    order = [r["method"] for r in out["methods"]]
    assert order == ["zhang2021", "tedaldi2014", "wang2019"], [(r["method"], r.get("verdict"), r.get("score"))
                                                                for r in out["methods"]]
    rows = {r["method"]: r for r in out["methods"]}
    cv = {m: r["cv_accelerometer_residual_rms"] for m, r in rows.items()}
    assert cv["zhang2021"] < 0.3 * cv["tedaldi2014"]
    assert out["best"] == "zhang2021" and out["ranked_by"]
    write_session(sim, tmp_path / "s")
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "s"), "--methods", "wang2019,tedaldi2014,zhang2021", "--folds", "4",
                 "--gravity", str(truth.gravity)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[-1] == "best: zhang2021"
    table = [line.split()[:2] for line in lines[2:-1]]
    assert table == [["1", "zhang2021"], ["2", "tedaldi2014"], ["3", "wang2019"]]
