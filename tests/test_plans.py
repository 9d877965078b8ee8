"""Accelerometer pose plans: bounds against closed forms and against a Monte Carlo of the fit."""

import numpy as np
import pytest

from imucalib.fit.accelerometer import fit_gravity_norm as calibrate_accelerometer
from imucalib.plans import accelerometer_plan, plan_directions

G = 9.80665


def _bounds(rep):
    return {p["parameter"]: p["crlb_std"] for p in rep["parameters"]}


def test_six_faces_match_the_closed_form_and_miss_the_misalignments():
    sigma = 0.002
    b = _bounds(accelerometer_plan("six", noise=sigma, gravity=G))
    # eqs. 8-9 of Ru 2022: k = (up − down)/(2g), b = (up + down)/2 → σ_k = σ√2/(2g), σ_b = σ/√2
    for a in "xyz":
        assert b[f"accelerometer.scale.{a}"] == pytest.approx(sigma * np.sqrt(2) / (2 * G), rel=1e-9)
        assert b[f"accelerometer.bias.{a}"] == pytest.approx(sigma / np.sqrt(2), rel=1e-9)
    assert all(np.isnan(b[f"accelerometer.misalignment.{e}"]) for e in ("xy", "xz", "yz"))


def test_nine_attitudes_bound_the_spread_of_the_fit():
    sigma = 0.002
    rep = accelerometer_plan("nine", noise=sigma, gravity=G)
    assert all(p["observable"] for p in rep["parameters"])
    d = plan_directions("nine")
    rng = np.random.default_rng(0)
    est = []
    for _ in range(300):
        means = G * d + rng.normal(0, sigma, d.shape)  # a nominal sensor in m/s²
        model, _ = calibrate_accelerometer(means, G)
        est.append(np.concatenate([[model.misalignment[0, 1], model.misalignment[0, 2], model.misalignment[1, 2]],
                                   model.scale - 1, model.bias]))
    spread = np.std(est, axis=0)
    bound = np.array([p["crlb_std"] for p in rep["parameters"]])
    np.testing.assert_allclose(spread, bound, rtol=0.15)  # 300 runs: the std is known to ~4 %


def test_more_poses_tighter_bounds_and_errors():
    nine = _bounds(accelerometer_plan("nine"))
    many = _bounds(accelerometer_plan(36))
    assert all(many[k] < nine[k] for k in nine)
    assert len(plan_directions(36)) == 36
    np.testing.assert_allclose(np.linalg.norm(plan_directions(36), axis=1), 1.0)
    with pytest.raises(ValueError, match="plan must be 'six', 'nine' or a number"):
        plan_directions("twelve")
    with pytest.raises(ValueError, match="noise must be a positive"):
        accelerometer_plan("nine", noise=0)


def test_plan_command(capsys):
    from imucalib.cli import main

    assert main(["plan", "--method", "six_position"]) == 0
    out = capsys.readouterr().out
    assert out.count("NOT determined by these poses") == 3
    assert main(["plan", "--method", "tedaldi2014", "--poses", "nine", "--noise-acc", "0.001"]) == 0
    out = capsys.readouterr().out
    assert "NOT determined" not in out and "0.001 m/s^2" in out


def test_plan_says_when_observable_poses_are_too_few_for_an_accepted_verdict(capsys):
    import json
    import math

    from imucalib.cli import main
    from imucalib.verdict import THRESHOLDS

    need = math.ceil(THRESHOLDS["poses_per_parameter"][0] * 9)  # 9 parameters of the linear accelerometer model
    assert main(["plan", "--method", "tedaldi2014", "--poses", "nine"]) == 0
    out = capsys.readouterr().out
    assert "NOT determined" not in out and f"hold {need} or more poses (--poses {need}" in out
    assert main(["plan", "--method", "tedaldi2014", "--poses", str(need), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["poses"] == need == rep["poses_for_accepted"]
    assert main(["plan", "--method", "tedaldi2014", "--poses", str(need)]) == 0
    assert "not enough" not in capsys.readouterr().out
    assert main(["plan", "--method", "six_position"]) == 0  # six faces: an exact method, no redundancy wanted
    assert "not enough" not in capsys.readouterr().out
