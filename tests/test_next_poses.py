"""What to record next: the poses that most shrink the worst 1σ, and how they are said in words."""

import numpy as np
import pytest

from imucalib.methods import calibrate
from imucalib.plans import _unit_jacobian, describe_direction, describe_poses, next_poses, plan_directions
from synth import tedaldi_session


def _worst_sigma(directions, prior=1e-9):
    j = _unit_jacobian(np.asarray(directions, dtype=float))
    return float(np.sqrt(np.max(np.diag(np.linalg.inv(j.T @ j + prior * np.eye(9))))))


def _no_z_faces(n=40):
    d = plan_directions(n)
    return d[np.abs(d[:, 2]) < 0.45]  # no pose within 63° of z up or z down


def test_a_session_without_the_z_faces_is_told_to_record_z():
    d = _no_z_faces()
    nxt = next_poses(d)
    assert nxt.shape == (3, 3)
    np.testing.assert_allclose(np.linalg.norm(nxt, axis=1), 1.0, rtol=1e-12)
    assert abs(nxt[0, 2]) > 0.99  # the first pose suggested is a z face
    assert describe_direction(nxt[0]) in ("z up", "z down")
    assert any(abs(u[2]) > 0.5 and np.sign(u[2]) != np.sign(nxt[0, 2]) for u in nxt[1:])  # then the other side


def test_the_choice_is_the_best_candidate_by_direct_inversion():
    # an independent computation: the worst σ with each candidate added, by inverting the information directly
    d = _no_z_faces()
    first = next_poses(d, count=1, simple=0.0)[0]
    cand = np.vstack([np.eye(3), -np.eye(3), plan_directions(200)])
    worst = [_worst_sigma(np.vstack([d, c])) for c in cand]
    assert _worst_sigma(np.vstack([d, first])) <= min(worst) * (1 + 1e-6)
    # and each suggestion shrinks the worst σ of the recorded poses
    before = _worst_sigma(d)
    after = _worst_sigma(np.vstack([d, next_poses(d)]))
    assert after < 0.5 * before  # 3.9 → 1.2 (relative σ for unit pose noise): z's bias and scale were weak


def test_six_faces_are_told_to_tilt():
    nxt = next_poses(plan_directions("six"))
    # the faces leave the misalignments undetermined: every suggestion is off the faces (Ru 2022, Table 3)
    assert np.all(np.max(np.abs(nxt), axis=1) < 0.9)
    assert _worst_sigma(np.vstack([plan_directions("six"), nxt])) < 100  # every parameter now determined


def test_calibration_carries_next_poses_pointing_at_z():
    d = _no_z_faces(30)
    rec, truth, intervals = tedaldi_session(seed=11, directions=np.vstack([d[:1], d]), noise_acc=0.002,
                                            noise_gyro=0.001)
    cal = calibrate(rec, method="tedaldi2014", gravity=truth.gravity, intervals=intervals)
    nxt = np.asarray(cal.fit["next_poses"])
    assert nxt.shape == (3, 3)
    assert abs(nxt[0, 2]) > 0.9  # within 25° of a z face (here 19° off z up: it also helps a misalignment)
    assert describe_poses(nxt).startswith(("z up", "z down"))


@pytest.mark.parametrize(("u", "words"), [
    ([0, 0, 1], "z up"), ([0, 0, -1], "z down"), ([1, 0, 0], "x up"), ([0, -1, 0], "y down"),
    ([0.05, 0, 1], "z up"),  # 3° off the face
    ([0, 1, 1], "y up tilted 45° about x towards z up"),
    ([0, 1, -1], "y up tilted 45° about x towards z down"),
    ([np.sin(np.radians(30)), 0, np.cos(np.radians(30))], "z up tilted 30° about y towards x up"),
    ([1, 1, 1], "corner with x, y and z up"),
    ([1, -1, 1], "corner with x and z up, y down"),
    ([0.3, 0.2, 1], "z up tilted 20° towards x and y up"),
])
def test_words(u, words):
    assert describe_direction(u) == words


def test_words_of_a_sequence_and_bad_input():
    assert describe_poses([[0, 0, 1], [0, 0, -1]]) == "z up, then z down"
    with pytest.raises(ValueError, match="non-zero"):
        describe_direction([0, 0, 0])


def test_report_draws_the_next_poses_on_the_coverage_figure(tmp_path):
    import re

    from imucalib.report import coverage_svg, html_report

    d = _no_z_faces(30)
    rec, truth, intervals = tedaldi_session(seed=11, directions=np.vstack([d[:1], d]), noise_acc=0.002,
                                            noise_gyro=0.001)
    cal = calibrate(rec, method="tedaldi2014", gravity=truth.gravity, intervals=intervals)
    page = html_report(cal, tmp_path / "r.html", recording=rec, intervals=intervals).read_text(encoding="utf-8")
    assert "coverage-sphere" in page
    for u in cal.fit["next_poses"]:
        assert describe_direction(u) in page
    # positions: z up at the centre of the left disc, x up on the right edge of both discs
    svg = coverage_svg(None, [[0, 0, 1], [1, 0, 0]], size=200)
    red = [(float(x), float(y)) for x, y in re.findall(r"cx='([\d.]+)' cy='([\d.]+)' r='8'", svg)]
    r = 200 * 0.42
    assert red[0] == pytest.approx((100.0, 110.0))
    assert red[1] == pytest.approx((100.0 + r, 110.0), abs=0.1)  # the equator, on the upper disc
    assert red[2] == pytest.approx((300.0 + r, 110.0), abs=0.1)  # and on the lower one
    blue = re.findall(r"r='4'", coverage_svg(np.vstack([d, [0, 0, 1]]), []))
    assert len(blue) >= len(d) + 1


def test_terminal_says_what_to_record_next_after_the_reasons(capsys, tmp_path):
    from imucalib.cli import EXIT_REJECTED, main
    from imucalib.io import write_csv
    from imucalib.scenarios import ferraris_session
    from synth import linear_truth

    rec, _, _ = ferraris_session(linear_truth(), 5)
    write_csv(tmp_path / "f.csv", rec)
    code = main(["calibrate", str(tmp_path / "f.csv"), "--method", "ferraris", "--turn-angle", "180"])
    out = capsys.readouterr().out
    assert code == EXIT_REJECTED
    lines = out.splitlines()
    advice = [k for k, line in enumerate(lines) if line.startswith("  record next: ")]
    assert len(advice) == 1
    reasons = [k for k, line in enumerate(lines) if line.startswith("  - ")]
    assert reasons and advice[0] == max(reasons) + 1  # right after the reasons
    cal_words = lines[advice[0]].removeprefix("  record next: ").split(", then ")
    assert 1 <= len(cal_words) <= 3 and all(w for w in cal_words)
    # an accepted calibration prints no advice
    assert main(["calibrate", str(tmp_path / "f.csv"), "--method", "ferraris"]) == 0
    assert "record next" not in capsys.readouterr().out
