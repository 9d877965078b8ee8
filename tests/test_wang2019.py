"""Wang 2019: the scenario's plan and truth, exact recovery, a small Monte Carlo against Tables 2-3."""

import numpy as np
import pytest

from imucalib.experiments.wang2019 import montecarlo, parameter_errors_wang_units, plan_report
from imucalib.methods import calibrate
from imucalib.scenarios.wang2019 import EARTH_RATE, G0, plan, session

QUIET = {"accelerometer": 0, "gyroscope": 0}


def test_plan_and_structure():
    positions, axes = plan()
    assert positions.shape == (15, 3) and axes.shape == (12, 3)
    np.testing.assert_allclose(np.linalg.norm(positions, axis=1), 1.0)
    # the six faces, and three 45°-type directions in each coordinate plane
    assert sum(np.isclose(np.abs(p).max(), 1.0) for p in positions) == 6
    sim = session(1)
    assert sim.positions_acc.shape == (15, 3) and sim.turn_sum.shape == (12, 3)
    t = sim.truth
    assert t.accelerometer.shape == "lower"
    k1_ug = t.accelerometer.scale / (1e-6 * G0)
    assert np.all((k1_ug >= 1) & (k1_ug <= 5))
    b = session(1)
    np.testing.assert_array_equal(sim.positions_acc, b.positions_acc)  # deterministic
    with pytest.raises(ValueError, match="turntable_error must be one of"):
        session(1, turntable_error="1deg")


def test_noise_free_outputs_are_consistent_and_recovered():
    sim = session(4, noise=QUIET, turntable_error="3deg")
    t = sim.truth
    np.testing.assert_allclose(np.linalg.norm(t.accelerometer.forward(sim.positions_acc), axis=1), G0,
                               rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(t.gyroscope.forward(sim.positions_gyro), axis=1),
                               EARTH_RATE, rtol=1e-10)
    cal = calibrate(sim, method="wang2019")
    err = parameter_errors_wang_units(cal, t)
    truth_scale = {"acc_k1_ug_per_pulse": t.accelerometer.scale / (1e-6 * G0),
                   "gyro_k1_1e-7_deg_s_pulse": t.gyroscope.scale / (1e-7 * np.pi / 180)}
    for key, true in truth_scale.items():
        assert np.max(np.abs(err[key] / true)) < 1e-6
    assert np.max(np.abs(err["acc_bias_ug"])) < 1e-4  # µg, of biases up to 1e4 µg
    assert np.max(np.abs(err["acc_misalignment_1e-4"])) < 1e-6
    assert np.max(np.abs(err["gyro_misalignment_1e-4"])) < 1e-6


@pytest.mark.slow
def test_small_montecarlo_within_the_papers_tables():
    r = montecarlo(16, turntable_error="3arcmin", workers=1)
    assert r["divergent_runs"] == 0 and not r["failures"]
    rms = r["rms"]
    # Table 2 (accelerometer), 3′ column, with 10 % slack for 16 runs
    assert max(rms["acc_k1_ug_per_pulse"]) <= 3.41e-5 * 1.1
    assert max(rms["acc_k2_fg_per_pulse2"]) <= 0.054 * 1.1
    assert max(rms["acc_k3_zg_per_pulse3"]) <= 0.63 * 1.1
    assert max(rms["acc_misalignment_1e-4"]) <= 0.0197 * 1.1
    assert max(rms["acc_bias_ug"]) <= 2.11 * 1.5
    # Table 3 (gyroscope), 3′ column, largest axis, 30 % slack for 16 runs
    paper = r["paper_rms"]
    for key in ("gyro_bias_1e-6_deg_s", "gyro_k1_1e-7_deg_s_pulse", "gyro_k2_1e-17_deg_s_pulse2",
                "gyro_misalignment_1e-4"):
        assert max(rms[key]) <= 1.3 * max(paper[key]), key
    assert paper["gyro_k1_1e-7_deg_s_pulse"] == [1.73e-8, 4.50e-8, 1.90e-8]


@pytest.mark.slow
def test_montecarlo_spread_equals_the_cramer_rao_bound():
    """The estimator is efficient: for one truth, the spread over noise draws is the CRLB of plan_report."""
    truth = session(0).truth
    report = {p["parameter"]: p["crlb_std"] for p in plan_report(0)["parameters"]}
    errs, reported = [], []
    for seed in range(100, 160):
        sim = session(seed, truth=truth)
        cal = calibrate(sim, method="wang2019")
        u = cal.fit["uncertainty"]
        reported.append([u[f"gyroscope.scale.{a}"] for a in "xyz"] + [u[f"gyroscope.output_bias.{a}"] for a in "xyz"])
        g, tg = cal.gyroscope, truth.gyroscope
        errs.append(np.concatenate([g.scale - tg.scale, [g.misalignment[1, 0] - tg.misalignment[1, 0]],
                                    g.output_bias - tg.output_bias,
                                    cal.accelerometer.output_bias - truth.accelerometer.output_bias]))
    rms = np.sqrt(np.mean(np.square(errs), axis=0))
    crlb = np.array([report[k] for k in ("K_g1x", "K_g1y", "K_g1z", "E_gyx", "bias_gx", "bias_gy", "bias_gz",
                                         "bias_ax", "bias_ay", "bias_az")])
    ratio = rms / crlb
    assert np.all((ratio > 0.65) & (ratio < 1.4)), ratio  # 60 runs: the RMS is known to ~9 %
    # the errors each fit reports (σ² from its residuals) agree with the spread on average
    mean_reported = np.sqrt(np.mean(np.square(reported), axis=0))
    spread = rms[[0, 1, 2, 4, 5, 6]]
    assert np.all((mean_reported / spread > 0.6) & (mean_reported / spread < 1.6)), mean_reported / spread


def test_noise_options_are_checked_and_reach_the_outputs():
    with pytest.raises(ValueError, match="unknown noise key"):
        session(1, noise={"gyroscope_sample": 1e-9})
    with pytest.raises(ValueError, match="non-negative"):
        session(1, noise={"gyroscope": -1.0})
    with pytest.raises(ValueError, match="must be positive"):
        session(1, dwell_s=0)
    truth = session(0).truth
    quiet = session(3, truth=truth, noise={"gyroscope": 0.0})
    loud = session(3, truth=truth, noise={"gyroscope": 1e-6})
    exact = session(3, truth=truth, noise=QUIET)
    # the gyroscope noise reaches the turn integrals and the position means, the accelerometer's does not
    np.testing.assert_array_equal(quiet.turn_sum, exact.turn_sum)
    assert np.abs(loud.turn_sum - exact.turn_sum).max() > 0
    assert np.abs(quiet.positions_acc - exact.positions_acc).max() > 0


def test_montecarlo_command_prints_the_tables_beside_the_papers(capsys):
    from imucalib.cli import main

    assert main(["montecarlo", "--scenario", "wang2019", "--method", "wang2019", "--runs", "3"]) == 0
    out = capsys.readouterr().out
    assert "paper max" in out and "gyro_k1_1e-7_deg_s_pulse" in out and "divergent runs: 0" in out
    assert main(["montecarlo", "--scenario", "zhang2021", "--method", "tedaldi2014", "--runs", "1",
                 "--noise-gyro", "1e-3"]) == 2
    assert "apply to the wang2019 scenario" in capsys.readouterr().err


def test_clear_errors(tmp_path):
    sim = session(2)
    sim.positions_acc = sim.positions_acc[:10]
    with pytest.raises(ValueError, match="15 parameters; 10 positions cannot determine them"):
        calibrate(sim, method="wang2019")
    from imucalib.recording import Recording

    rec = Recording(np.arange(5) * 0.01, np.ones((5, 3)), np.ones((5, 3)))
    with pytest.raises(ValueError, match="wang2019 needs turntable data"):
        calibrate(rec, method="wang2019")


def test_plan_shows_every_parameter_observable(capsys):
    from imucalib.cli import main
    rep = plan_report(0)
    assert len(rep["positions_gravity_body"]) == 15 and len(rep["rotation_axes_body"]) == 12
    assert len(rep["parameters"]) == 15 + 9 + 3
    assert all(p["observable"] and np.isfinite(p["crlb_std"]) for p in rep["parameters"])
    bias = next(p for p in rep["parameters"] if p["parameter"] == "bias_ax")
    assert 0.5 < bias["crlb_std"] / (1e-6 * G0) < 5  # µg: the order the Monte Carlo shows (~2 µg)
    assert main(["plan", "--method", "wang2019"]) == 0
    assert "observable" in capsys.readouterr().out


def test_simulate_then_calibrate_a_wang_directory(tmp_path, capsys):
    from imucalib.cli import main

    assert main(["simulate", "--scenario", "wang2019", "--seed", "5", "-o", str(tmp_path / "w")]) == 0
    assert main(["calibrate", str(tmp_path / "w"), "--method", "wang2019", "-o", str(tmp_path / "c.json")]) == 0
    from imucalib.calibration import Calibration

    cal, truth = Calibration.load(tmp_path / "c.json"), Calibration.load(tmp_path / "w" / "truth.json")
    np.testing.assert_allclose(cal.accelerometer.scale, truth.accelerometer.scale, rtol=1e-5)
    np.testing.assert_allclose(cal.accelerometer.output_bias, truth.accelerometer.output_bias, atol=1e-4)


def test_commands_that_need_samples_refuse_a_turntable_session(tmp_path, capsys):
    from imucalib.cli import main

    assert main(["simulate", "--scenario", "wang2019", "--seed", "2", "-o", str(tmp_path / "w")]) == 0
    assert main(["calibrate", str(tmp_path / "w"), "--method", "wang2019", "-o", str(tmp_path / "c.json")]) == 0
    capsys.readouterr()
    for argv in (["apply", str(tmp_path / "c.json"), str(tmp_path / "w"), "-o", str(tmp_path / "o.csv")],
                 ["validate", str(tmp_path / "c.json"), str(tmp_path / "w")],
                 ["noise", str(tmp_path / "w")], ["compare", str(tmp_path / "w")]):
        assert main(argv) == 2, argv
        assert "needs a recording of samples" in capsys.readouterr().err
