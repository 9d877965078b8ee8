"""Directions the poses did not visit: the verdict predicts the calibrated |a|'s 1σ there and rejects what validate
would reject; sessions that visit every axis up and down are left as they were."""

import warnings

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.fit.accelerometer import fit_gravity_norm
from imucalib.methods import calibrate
from imucalib.metrics import interval_means
from imucalib.recording import Interval, Recording
from imucalib.scenarios import session
from imucalib.verdict import THRESHOLDS, unvisited_sigma

G = 9.80665
REJECT = THRESHOLDS["residual_to_noise_high"][1]


def _poses(directions, truth, rng, *, n=200, noise=0.02):
    """A recording of static poses only (``n`` samples each, white noise ``noise`` m/s² per sample, raw counts)."""
    raw = truth.accelerometer.inverse(G * np.asarray(directions))
    acc = np.repeat(raw, n, axis=0) + rng.normal(scale=noise, size=(len(raw) * n, 3)) / truth.accelerometer.scale
    intervals = [Interval(k * n, (k + 1) * n, "static") for k in range(len(raw))]
    return Recording(np.arange(len(acc)) / 100.0, acc, None), intervals


def _directions_without_z(rng, m, limit=0.3):
    """``m`` gravity directions spread round the sphere with ``|u_z| < limit``."""
    az = np.linspace(0, 2 * np.pi, m, endpoint=False) + rng.uniform(0, 0.3, m)
    z = rng.uniform(-limit, limit, m)
    r = np.sqrt(1 - z * z)
    return np.column_stack([r * np.cos(az), r * np.sin(az), z])


def test_the_predicted_sigma_is_the_spread_of_refits_where_no_pose_looked():
    """Noise-only poses with |u_z| < 0.3: over 300 refits, the RMS of ‖a‖ − g with z up (where the prediction is
    largest) is within 0.75-1.33 of the 1σ unvisited_sigma predicts from one fit's covariance (median over
    the refits), and that is above validate's suspect limit × the noise floor."""
    from synth import linear_truth

    truth = linear_truth()
    rng = np.random.default_rng(3)
    dirs = _directions_without_z(rng, 14)
    errors, predicted, direction = [], [], None
    for _ in range(300):
        rec, iv = _poses(dirs, truth, rng)
        model, _ = fit_gravity_norm(interval_means(rec.acc, iv), G, initial=truth.accelerometer)
        cal = Calibration(accelerometer=model, gyroscope=None, gravity=G,
                          units={"accelerometer": {"raw": "counts", "calibrated": "m/s^2"}})
        found = unvisited_sigma(cal, rec, iv)
        if direction is None:
            direction = np.asarray(found["direction"])
            assert abs(direction[2]) > 0.9 and found["unvisited"] > 0.05
        predicted.append(found["sigma"])
        raw = truth.accelerometer.inverse(G * direction[None, :])
        errors.append(float(np.linalg.norm(model.forward(raw)) - G))
    ratio = np.sqrt(np.mean(np.square(errors))) / np.median(predicted)
    assert 0.75 < ratio < 1.33, ratio
    assert np.median(predicted) / found["floor"] > THRESHOLDS["residual_to_noise_high"][0]


def test_every_direction_visited_leaves_nothing_to_predict():
    from synth import linear_truth

    truth = linear_truth()
    rng = np.random.default_rng(4)
    dirs = rng.normal(size=(24, 3))
    dirs = np.vstack([np.eye(3), -np.eye(3), dirs / np.linalg.norm(dirs, axis=1, keepdims=True)])
    rec, iv = _poses(dirs, truth, rng)
    model, _ = fit_gravity_norm(interval_means(rec.acc, iv), G, initial=truth.accelerometer)
    cal = Calibration(accelerometer=model, gyroscope=None, gravity=G,
                      units={"accelerometer": {"raw": "counts", "calibrated": "m/s^2"}})
    found = unvisited_sigma(cal, rec, iv)
    assert found["ratio"] == 0.0 and found["unvisited"] == 0.0 and found["direction"] is None


def _intervals(cal):
    return [Interval(int(a), int(b), "static") for a, b in cal.fit["intervals"]]


def _away_from_z(cal, rec, limit):
    iv = _intervals(cal)
    up = cal.accelerometer_si(interval_means(rec.acc, iv))
    uz = up[:, 2] / np.linalg.norm(up, axis=1)
    return [v for v, z in zip(iv, uz, strict=True) if abs(z) < limit]


def _true_error_with_z_up_or_down(cal, truth, floor):
    """The largest ``| ‖a‖ − g |`` [× floor] of ``cal`` on the true raw readings with z within 10° of up or down."""
    u = np.array([[np.sin(a) * np.cos(b), np.sin(a) * np.sin(b), s * np.cos(a)]
                  for a in np.radians([0, 5, 10]) for b in np.linspace(0, 2 * np.pi, 8) for s in (1, -1)])
    raw = truth.accelerometer.inverse(truth.gravity * u)
    return float(np.max(np.abs(np.linalg.norm(cal.accelerometer.forward(raw), axis=1) - truth.gravity)) / floor)


@pytest.mark.parametrize("seed", [0, 1, 4])
def test_handheld_without_z_is_rejected_and_the_truth_agrees(seed):
    """Hand-held sessions calibrated on their poses with |u_z| < 0.3 (8-11 poses): rejected, naming ±z, and the
    truth's |a| with z up or down is off by more than validate's suspect limit × the floor (validate would not
    accept them either); the same sessions whole, and without only their z faces (|u_z| < 0.9: tilted poses still
    visit z), are accepted and leave no direction unvisited."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = session("handheld", rng=seed)
        full = calibrate(sim, method="tedaldi2014")
        assert full.fit["verdict"] == "accepted", full.fit["verdict_reasons"]
        assert full.fit["accelerometer_unvisited_sigma_to_noise"] == 0.0
        tilted = calibrate(sim, method="tedaldi2014", intervals=_away_from_z(full, sim.recording, 0.9))
        assert tilted.fit["verdict"] == "accepted", tilted.fit["verdict_reasons"]
        assert tilted.fit["accelerometer_unvisited_sigma_to_noise"] == 0.0
        thin = calibrate(sim, method="tedaldi2014", intervals=_away_from_z(full, sim.recording, 0.3))
    assert thin.fit["verdict"] == "rejected"
    assert any(r.startswith("the poses do not visit ±z") for r in thin.fit["verdict_reasons"]), \
        thin.fit["verdict_reasons"]
    ratio = thin.fit["accelerometer_unvisited_sigma_to_noise"]  # None: a parameter the poses do not determine
    assert ratio is None or ratio > REJECT
    floor = thin.fit["accelerometer_noise_floor"]
    assert _true_error_with_z_up_or_down(thin, sim.truth, floor) > THRESHOLDS["residual_to_noise_high"][0]


def test_the_command_line_rejects_a_recording_without_z_with_exit_3(capsys, tmp_path):
    """A recording whose 24 poses all have |u_z| < 0.1 (turned about z, tilted by at most 6°, never on the z faces;
    white noise only): calibrate exits 3 and its reasons name ±z; the same with six more poses on the z faces is
    accepted."""
    from imucalib.cli import EXIT_REJECTED, main
    from imucalib.io import write_csv
    from synth import linear_truth, tedaldi_session

    truth = linear_truth()
    rng = np.random.default_rng(11)
    flat = _directions_without_z(rng, 24, limit=0.1)
    faces = np.array([[0, 0, 1.0], [0.2, 0, 0.98], [0, -0.2, -0.98], [0, 0, -1.0], [0.1, 0.1, 0.99], [0, 0.2, -0.98]])
    for name, dirs, code in (("flat", flat, EXIT_REJECTED), ("faces", np.vstack([flat, faces]), 0)):
        dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
        rec, _, _ = tedaldi_session(truth, seed=2, noise_acc=0.02, noise_gyro=0.003, directions=dirs)
        write_csv(tmp_path / f"{name}.csv", rec)
        got = main(["calibrate", str(tmp_path / f"{name}.csv"), "--method", "tedaldi2014", "-o",
                    str(tmp_path / f"{name}.json")])
        out = capsys.readouterr().out
        assert got == code, out
        assert ("the poses do not visit ±z" in out) == (code == EXIT_REJECTED), out
