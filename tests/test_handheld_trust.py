"""Can a hand-held calibration's verdict be trusted? Monte Carlo on the ``handheld`` scenario.

Each test replays a way hand-held sessions go wrong in practice and checks that
the verdict (:mod:`imucalib.verdict`) lets no wrong calibration through as
``accepted``, that good sessions are accepted, and that the reported 1σ mean
what they say:

* default hand-held sessions (30 seeds) with ``tedaldi2014`` are all accepted,
  and their normalised errors ``(estimate − truth)/σ`` have an RMS near 1;
* the hand-held Ferraris procedure: right gyroscope scales, or rejected; the
  turn found as a chain of quarter-turns when the hand pauses between them; a
  wrong known angle rejected;
* a thin session (10 short poses) is never accepted, nor is a fit that did not converge;
* sessions like MPU-9150 logs (22 poses, a large turn-on bias, drift between
  poses, creep, turns about the vertical): the gyroscope's gravity-direction error
  is within 1.2× of what the true parameters leave on the same intervals, and the
  gyroscope gate keeps creep and turns about the vertical out of the poses.

The truth's gyroscope bias is the bias at the start of the session; the
scenario then lets it drift. Where a figure should be judged against the bias
the session actually had, the drift comes from a *twin* session: the same seed
with the drift knobs at zero draws the same random numbers, so the two
recordings differ by the drift alone.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.methods import calibrate
from imucalib.metrics import gravity_direction_errors, interval_means
from imucalib.recording import Interval
from imucalib.scenarios import Session, session
from imucalib.segment import detect_intervals

#: seeds of the acceptance Monte Carlo (default knobs)
ACCEPTANCE_SEEDS = tuple(range(30))
#: the hand-held Ferraris procedure with a 13° nudge about the vertical after the rest
FERRARIS = {"procedure": "ferraris", "nudge_deg": 13.0}
#: a thin session: 10 poses of about 3 s after a 36 s rest
THIN = {"n_poses": 10, "dwell": (2.5, 3.5), "rest": 36.0}
#: like the MPU-9150 logs: 22 poses, 1-3 s hand rotations, a turn-on bias offset of a few 0.01 rad/s
#: (σ 1.5 °/s per axis), pose-to-pose changes of the static gyroscope means of ~5e-4 rad/s (drift and
#: random walk), creep at the start of four poses and some turns about the vertical
MPU9150 = {"n_poses": 22, "move": (1.0, 3.0), "turn_on": 1.5, "gyro_drift": 0.05, "gyro_rw": 0.009, "creep": 4,
           "vertical_turns": 0.2}
#: turns about the vertical that the accelerometer cannot see: no hand translation, no lever arm
STILL_HAND_TURNS = {**MPU9150, "creep": 0, "vertical_turns": 0.4, "lin_acc": 0.0, "lever": 0.0}
NO_DRIFT = {"gyro_drift": 0.0, "gyro_rw": 0.0}


def _key(knobs: dict) -> tuple:
    return tuple(sorted(knobs.items()))


@functools.cache
def _session(seed: int, knobs: tuple) -> Session:
    return session("handheld", rng=seed, **dict(knobs))


@pytest.fixture(scope="module", autouse=True)
def _free_sessions():
    """Drop the cached sessions when this module is done (they hold a few hundred MB in all)."""
    yield
    _session.cache_clear()
    _ferraris.cache_clear()


def _sim(seed: int, **knobs) -> Session:
    return _session(seed, _key(knobs))


def _twin(seed: int, **knobs) -> Session:
    """The same session without gyroscope drift (same random numbers, so the same motion, noise and drops)."""
    return _sim(seed, **{**knobs, **NO_DRIFT})


def _intervals(cal: Calibration) -> list[Interval]:
    return [Interval(int(a), int(b), "static") for a, b in cal.fit["intervals"]]


def _drift(sim: Session, twin: Session, intervals: list[Interval]) -> np.ndarray:
    """The gyroscope bias drift [raw] averaged over ``intervals``, one weight per interval."""
    return interval_means(sim.recording.gyro - twin.recording.gyro, intervals).mean(axis=0)


def _with_session_bias(sim: Session, twin: Session, intervals: list[Interval]) -> Calibration:
    """The truth with the gyroscope bias the session had on average over ``intervals``."""
    gyro = sim.truth.gyroscope
    return sim.truth.with_(gyroscope=gyro.with_(bias=gyro.bias + _drift(sim, twin, intervals)))


def _gyro_scale_error(cal: Calibration, truth: Calibration) -> float:
    """Largest relative error of the gyroscope's linear scale factors."""
    return float(np.max(np.abs(cal.gyroscope.scale / truth.gyroscope.scale - 1)))


def _z_scores(cal: Calibration, truth: Calibration, sensor: str) -> list[float]:
    """``(estimate − truth)/σ`` of every ``sensor`` parameter with a finite σ."""
    est, tru = cal.parameters(), truth.parameters()
    return [(est[k] - tru[k]) / s for k, s in cal.fit["uncertainty"].items()
            if k.startswith(sensor + ".") and s is not None and np.isfinite(s) and s > 0 and k in tru]


def _rms(values: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


# --------------------------------------------------------------------- acceptance
@pytest.fixture(scope="module")
def acceptance() -> dict[int, tuple[Session, Session, Calibration]]:
    """``tedaldi2014`` on 30 default hand-held sessions: seed → (session, drift-free twin, calibration)."""
    out = {}
    for seed in ACCEPTANCE_SEEDS:
        sim = session("handheld", rng=seed)
        cal = calibrate(sim.recording, method="tedaldi2014", gravity=sim.truth.gravity)
        out[seed] = (sim, session("handheld", rng=seed, **NO_DRIFT), cal)
    return out


@pytest.mark.slow
def test_default_handheld_sessions_are_all_accepted(acceptance):
    """The acceptance criterion: 30 default hand-held sessions calibrated by tedaldi2014, all accepted."""
    assert len(acceptance) == 30
    refused = {seed: cal.fit["verdict_reasons"] for seed, (_, _, cal) in acceptance.items()
               if cal.fit["verdict"] != "accepted"}
    assert not refused, refused
    # and they are right: the gyroscope scales within 0.2 %, the gravity-direction error no worse than the truth's
    for sim, _, cal in acceptance.values():
        assert _gyro_scale_error(cal, sim.truth) < 2e-3
        true_err = np.degrees(np.mean(gravity_direction_errors(sim.truth, sim.recording, _intervals(cal))))
        assert cal.fit["gyroscope_angle_error_mean_deg"] <= 1.2 * true_err


@pytest.mark.slow
def test_tedaldi_sigmas_are_honest(acceptance):
    """RMS of ``(estimate − truth)/σ`` within 0.6-1.6 per sensor over the 30 sessions.

    The gyroscope's bias is judged against the bias the session had on average
    over the static intervals the fit used (the truth's plus the twin's drift).
    """
    z = {"accelerometer": [], "gyroscope": []}
    for sim, twin, cal in acceptance.values():
        z["accelerometer"] += _z_scores(cal, sim.truth, "accelerometer")
        z["gyroscope"] += _z_scores(cal, _with_session_bias(sim, twin, _intervals(cal)), "gyroscope")
    assert len(z["accelerometer"]) == 30 * 9 and len(z["gyroscope"]) >= 30 * 12
    for sensor, values in z.items():
        assert 0.6 < _rms(values) < 1.6, (sensor, _rms(values))


def _bias_at_fit_time(sim: Session, twin: Session, cal: Calibration) -> Calibration:
    """The truth with the gyroscope bias the session had when the fit's bias holds (the mean of the poses' times)."""
    t = sim.recording.t
    t_ref = cal.fit.get("gyroscope_bias_time_s")
    if t_ref is None:
        t_ref = np.mean([np.mean(t[iv.slice]) for iv in _intervals(cal)])
    near = np.abs(t - t_ref) <= 1.0
    drift = (sim.recording.gyro[near] - twin.recording.gyro[near]).mean(axis=0)
    gyro = sim.truth.gyroscope
    return sim.truth.with_(gyroscope=gyro.with_(bias=gyro.bias + drift))


@pytest.mark.slow
def test_tedaldi_gyroscope_sigmas_against_the_bias_at_the_fits_time(acceptance):
    # the fitted bias is the bias at the poses' mean time, and its 1σ the error of that; against the truth's bias
    # at the start (before the drift) the z-score RMS of gyroscope.bias was 6.6, and with one pose's scatter
    # added to the 1σ to cover the drift, 0.13 against the bias at the fit's time
    z, z_bias = [], []
    for sim, twin, cal in acceptance.values():
        truth = _bias_at_fit_time(sim, twin, cal)
        z += _z_scores(cal, truth, "gyroscope")
        z_bias += _z_scores(cal, truth, "gyroscope.bias")
    assert 0.6 < _rms(z) < 1.6, _rms(z)
    assert 0.6 < _rms(z_bias) < 1.6, _rms(z_bias)


# ------------------------------------------------------------------------ Ferraris
def _ferraris_cal(seed: int, angle: float = 360.0, **knobs) -> tuple[Session, Calibration]:
    """The Ferraris session and its calibration, computed once per module (the tests only read them: seeds 0-9
    are calibrated alike by the tests of wrong calibrations, faces and turns, and quarter-turns)."""
    return _ferraris(seed, angle, _key(knobs))


@functools.cache
def _ferraris(seed: int, angle: float, knobs: tuple) -> tuple[Session, Calibration]:
    sim = _sim(seed, **{**FERRARIS, **dict(knobs)})
    return sim, calibrate(sim.recording, method="ferraris", gravity=sim.truth.gravity, angle=angle)


@pytest.mark.parametrize("knobs", [{}, {"tremor": 0.0}, {"quarter_pause": 2.0}],
                         ids=["default", "no_tremor", "quarter_pause_2s"])
def test_ferraris_handheld_never_accepts_a_wrong_calibration(knobs):
    """Accepted only with every gyroscope scale within 1 % of the truth; a scale off by more is rejected."""
    for seed in range(10):
        sim, cal = _ferraris_cal(seed, **knobs)
        err = _gyro_scale_error(cal, sim.truth)
        verdict = cal.fit["verdict"]
        if verdict == "accepted":
            assert err < 0.01, (seed, err)
        if err >= 0.01:
            assert verdict == "rejected", (seed, err, verdict)


@pytest.mark.parametrize("knobs", [{}, {"tremor": 0.0}], ids=["default", "no_tremor"])
def test_ferraris_handheld_faces_and_turns_are_found(knobs):
    """Hand tremor does not keep the faces from being found; each axis's 360° turn is found, scales within 1 %."""
    for seed in range(10):
        sim, cal = _ferraris_cal(seed, **knobs)
        assert cal.fit["turns"] == {"x": 1, "y": 1, "z": 1}, seed
        assert all(sec["matches"] for sec in cal.fit["turn_sections"]), seed
        assert _gyro_scale_error(cal, sim.truth) < 0.01, seed


@pytest.mark.xfail(strict=True, reason=(
    "hand-held Ferraris with correct gyroscope scales (0.02-0.07 % off) is mostly 'suspect', neither accepted nor "
    "rejected: seeds 0-9 with default knobs give 9 suspect / 1 accepted (seed 3); the gyroscope's gravity-direction "
    "error is 0.26-0.39° (15.7-21.8× the noise prediction, limit 10×, above the 0.25° floor) because the closed form "
    "takes hand-held faces that sit up to 0.8-1.3° off their axis (creep, re-grasp) as exact, leaving 0.36-0.58° "
    "between the calibrated accelerometer and gyroscope frames; with tremor=0 it is 8 suspect / 2 accepted"))
def test_ferraris_handheld_is_accepted_and_right_or_rejected():
    outcomes = {}
    for seed in range(10):
        sim, cal = _ferraris_cal(seed)
        right = _gyro_scale_error(cal, sim.truth) < 0.01
        outcomes[seed] = (cal.fit["verdict"], right)
    assert all((v == "accepted" and right) or v == "rejected" for v, right in outcomes.values()), outcomes


@pytest.mark.parametrize("seed", [
    0, 1,
    2,  # z sits 3.1° off vertical after a re-grasp: the chain is found by the axis's tilt, not the direction
    3, 4, 5, 6, 7])
def test_ferraris_quarter_turns_with_pauses_are_one_turn(seed):
    """Quarter-turns with 2 s pauses (rests the detector sees) are chained into the 360° turn."""
    sim, cal = _ferraris_cal(seed, quarter_pause=2.0)
    assert len(cal.fit["turn_sections"]) == 3
    for sec in cal.fit["turn_sections"]:
        assert sec["matches"] and abs(sec["measured_deg"] / 360 - 1) < 0.2, sec
    assert _gyro_scale_error(cal, sim.truth) < 0.01


def test_ferraris_wrong_known_angle_is_rejected():
    """360° turns declared as 180°: every gyroscope scale is half the truth, and the verdict rejects it."""
    for seed in range(5):
        sim, cal = _ferraris_cal(seed, angle=180.0)
        assert _gyro_scale_error(cal, sim.truth) > 0.4
        assert cal.fit["verdict"] == "rejected", seed
        assert any("known angle 180" in r for r in cal.fit["verdict_reasons"])


# ---------------------------------------------------------------------- thin session
@pytest.fixture(scope="module")
def thin() -> list[Session]:
    return [_sim(seed, **THIN) for seed in range(5)]


def test_thin_session_is_not_accepted_by_tedaldi(thin):
    """10 poses of ~3 s after a 36 s rest: too few poses per parameter, never accepted."""
    for sim in thin:
        assert len([s for s in sim.segments if s.kind == "static"]) == 11
        cal = calibrate(sim.recording, method="tedaldi2014", gravity=sim.truth.gravity)
        assert cal.fit["verdict"] != "accepted", cal.fit
        assert any("per parameter" in r or "over-fit" in r or "do not determine" in r
                   for r in cal.fit["verdict_reasons"])


@pytest.mark.filterwarnings("ignore:zhang2021 model 'all'")
def test_thin_session_is_not_accepted_by_zhang_all(thin):
    for sim in thin:
        cal = calibrate(sim.recording, method="zhang2021", model="all", gravity=sim.truth.gravity)
        assert cal.fit["verdict"] != "accepted", cal.fit["verdict_reasons"]
        assert any("per parameter" in r for r in cal.fit["verdict_reasons"])


@pytest.mark.filterwarnings("ignore:zhang2021 model 'all'")
def test_a_fit_that_did_not_converge_is_never_accepted(thin):
    for sim in thin[:3]:
        for model in ("all", "linear"):
            cal = calibrate(sim.recording, method="zhang2021", model=model, gravity=sim.truth.gravity, max_iter=1)
            assert cal.fit["converged"] is False
            assert cal.fit["verdict"] == "rejected"
            assert any("did not converge" in r for r in cal.fit["verdict_reasons"])


# ------------------------------------------------------------- MPU-9150-like sessions
def test_mpu9150_like_sessions_have_the_logs_features():
    """The knobs give what the logs show: a turn-on offset of a few 0.01 rad/s, ~5e-4 rad/s between poses."""
    offsets, steps = [], []
    for seed in range(6):
        sim, twin = _sim(seed, **MPU9150), _twin(seed, **MPU9150)
        k = sim.truth.gyroscope.scale
        offsets.append(float(np.linalg.norm(np.asarray(sim.options["gyro_turn_on_offset"]) * k)))
        static = [s for s in sim.segments if s.kind == "static"]
        assert len(static) == 23 and len(sim.options["creep_sections"]) == 4
        drift = interval_means(sim.recording.gyro - twin.recording.gyro, static) * k  # rad/s
        steps.append(float(np.median(np.linalg.norm(np.diff(drift, axis=0), axis=1))))
        np.testing.assert_array_equal(sim.recording.acc, twin.recording.acc)  # the twin differs by the drift only
    assert 0.01 < np.median(offsets) < 0.1, offsets
    assert 2e-4 < np.median(steps) < 1.5e-3, steps
    assert sum(len(_sim(s, **MPU9150).options["vertical_turns"]) for s in range(6)) >= 6


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:zhang2021 model 'all'")
@pytest.mark.parametrize("method", ["tedaldi2014", "zhang2021"])
def test_mpu9150_like_gyro_error_within_1_2_of_the_truth(method):
    """The gravity-direction error of the fit ≤ 1.2× the true parameters' on the same intervals.

    Against the truth as it started the session (the issue's criterion), and
    against the truth with the bias the session had on average over those
    intervals (no drift for the fit to beat the truth with).
    """
    for seed in range(6):
        sim, twin = _sim(seed, **MPU9150), _twin(seed, **MPU9150)
        cal = calibrate(sim.recording, method=method, gravity=sim.truth.gravity)
        iv = _intervals(cal)
        fitted = cal.fit["gyroscope_angle_error_mean_deg"]
        for truth in (sim.truth, _with_session_bias(sim, twin, iv)):
            true_err = float(np.degrees(np.mean(gravity_direction_errors(truth, sim.recording, iv))))
            assert fitted <= 1.2 * true_err, (seed, fitted, true_err)
        assert _gyro_scale_error(cal, sim.truth) < 0.01, seed


def _max_rate_inside(sim: Session, twin: Session, intervals: list[Interval], window: float = 0.25) -> float:
    """Largest ``window``-s mean of the true body rate [deg/s] inside ``intervals`` (drift-free gyroscope)."""
    rec = sim.recording
    w = np.degrees(sim.truth.gyroscope_si(twin.recording.gyro, rec.acc))
    n = max(int(round(window * rec.rate)), 1)
    best = 0.0
    kernel = np.ones(n) / n
    for iv in intervals:
        if len(iv) < n:
            continue
        m = np.column_stack([np.convolve(w[iv.slice, j], kernel, mode="valid") for j in range(3)])
        best = max(best, float(np.linalg.norm(m, axis=1).max()))
    return best


@pytest.mark.parametrize("knobs", [MPU9150, STILL_HAND_TURNS], ids=["creep", "turns_about_the_vertical"])
def test_gyro_gate_keeps_turning_samples_out_of_the_poses(knobs):
    """The accelerometer-variance detector alone keeps creep and turns about the vertical inside its poses.

    Shown with Tedaldi 2014's 1 s window (``min_hold=2``): the window of the default 1 s hold (0.5 s) sees
    more of a creep by itself, not all of it nor any turn about the vertical; the gate keeps both out at
    either hold."""
    for seed in range(4):
        sim, twin = _sim(seed, **knobs), _twin(seed, **knobs)
        g = sim.truth.gravity
        for hold in (1.0, 2.0):
            gated = detect_intervals(sim.recording, g, min_hold=hold)[0]
            assert _max_rate_inside(sim, twin, gated) < 1.0, (seed, hold)
        ungated = detect_intervals(sim.recording, g, gyro_gate=False, min_hold=2.0)[0]
        assert _max_rate_inside(sim, twin, ungated) > 1.0, seed


def test_saturated_and_spiking_rotations_are_left_out_not_fitted(spiky_handheld):
    """Rotations through a clipped gyroscope, or holding a spike, are left out of the fit and said so."""
    from imucalib.recording import ImucalibWarning

    with pytest.warns(ImucalibWarning, match="clipped"):  # fast turns: the ±250 °/s range clips
        sim = session("handheld", rng=4, max_rate=None, move=(0.4, 0.8))
    assert sim.options["clipped"]["gyroscope"] > 100
    cal = calibrate(sim.recording, method="tedaldi2014", gravity=sim.truth.gravity)
    left = cal.fit["rotations_left_out"]
    assert len(left) >= 10 and all("saturated" in why for why in left.values())
    np.testing.assert_allclose(cal.gyroscope.scale, sim.truth.gyroscope.scale, rtol=0.005)
    assert cal.fit["verdict"] != "rejected" and cal.fit["gyroscope_angle_error_kept_mean_deg"] < 0.25
    assert any("left out" in note for note in cal.fit["verdict_notes"])

    sim, spiky = spiky_handheld(5)  # five spikes, each in the middle of a different rotation
    cal = calibrate(spiky, method="tedaldi2014", gravity=sim.truth.gravity)
    assert sum("spike" in why for why in cal.fit["rotations_left_out"].values()) == 5
    np.testing.assert_allclose(cal.gyroscope.scale, sim.truth.gyroscope.scale, rtol=0.002)
    assert cal.fit["verdict"] == "accepted"
