"""A calibration worse than the raw readings is never passed as usable (imucalib.verdict.raw).

Readings in physical units are a calibration already, the identity one (no bias, the unit's nominal scale, no
misalignment). Whenever the verdict is ``accepted`` or ``suspect``, the calibrated ``|a| − g`` RMS over the
poses and the gravity-direction error over every rotation between them are no larger than the raw readings'
(docs/guide/verdict.rst, "What a verdict promises").
"""

import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib import Calibration, Recording
from imucalib.fitreport import FitReport, UncertaintyReport
from imucalib.methods import calibrate
from imucalib.metrics import gravity_direction_errors
from imucalib.models import TriadModel
from imucalib.recording import ImucalibWarning, Interval
from imucalib.scenarios import session
from imucalib.validation import validate
from imucalib.verdict import assess

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "public"
G = 9.80665
SI = {"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"}, "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}}


def _good_sensor(rng) -> Calibration:
    """A sensor already calibrated in physical units: per-mille scales and misalignments, small biases."""
    ta = np.eye(3)
    ta[0, 1], ta[0, 2], ta[1, 2] = rng.uniform(-5e-4, 5e-4, 3)
    tg = np.eye(3)
    for (i, j), v in zip(((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)), rng.uniform(-1e-3, 1e-3, 6), strict=True):
        tg[i, j] = v
    acc = TriadModel(misalignment=ta, scale=1 + rng.uniform(-5e-4, 5e-4, 3), bias=rng.uniform(-0.01, 0.01, 3),
                     shape="upper")
    gyro = TriadModel(misalignment=tg, scale=1 + rng.uniform(-2e-3, 2e-3, 3), bias=rng.uniform(-2e-3, 2e-3, 3),
                      shape="full")
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=G, method="truth", units=SI)


def _with_spikes(rec: Recording, rng, count: int) -> Recording:
    """``count`` one-sample gyroscope spikes of 3 rad/s at random times after the first fifth."""
    gyro = rec.gyro.copy()
    for k in rng.choice(np.arange(len(rec) // 5, len(rec) - 10), count, replace=False):
        gyro[k] += rng.choice([-1.0, 1.0], 3) * 3.0
    return Recording(rec.t, rec.acc, gyro, acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit, metadata=rec.metadata)


def _faulty_session(seed: int, poses: tuple[int, int] = (5, 12)) -> Recording:
    """A hand-held session of a well calibrated sensor in m/s² and rad/s: ``poses`` (low, high) poses, thin by
    default, and 0-5 spikes."""
    rng = np.random.default_rng(100 + seed)
    poses, spikes = int(rng.integers(*poses)), int(rng.integers(0, 6))
    sim = session("handheld", rng=seed, truth=_good_sensor(rng), n_poses=poses, quantise=False, full_scale=None,
                  turn_on=0.05)
    return _with_spikes(sim.recording, rng, spikes) if spikes else sim.recording


def _identity(cal: Calibration) -> Calibration:
    """The raw readings as a calibration, built here from the units (m/s² and rad/s: unit scales)."""
    assert cal.units["accelerometer"]["raw"] == "m/s^2" and cal.units["gyroscope"]["raw"] == "rad/s"
    return cal.with_(accelerometer=TriadModel(shape="upper"), gyroscope=TriadModel(shape="full"), thermal=None)


def _figures(cal: Calibration, rec: Recording) -> tuple[float, float, np.ndarray]:
    """|a| − g RMS over the fit's poses (plain numpy), the mean and every gravity-direction error [deg]."""
    iv = [Interval(int(a), int(b)) for a, b in cal.fit["intervals"]]
    means = np.array([rec.acc[i.slice].mean(axis=0) for i in iv])
    rms = float(np.sqrt(np.mean((np.linalg.norm(cal.accelerometer_si(means), axis=1) - cal.gravity) ** 2)))
    errors = np.degrees(gravity_direction_errors(cal, rec, iv))
    return rms, float(errors.mean()), errors


def _raw_reason(cal: Calibration) -> str | None:
    return next((r for r in cal.fit["verdict_reasons"] if "worse than the raw readings" in r), None)


@pytest.mark.slow
def test_accepted_or_suspect_is_never_worse_than_raw():
    """The promise, over simulated thin sessions with spikes: usable calibrations beat the raw readings."""
    verdicts, rejected_for_raw = [], 0
    for seed, poses in [(seed, (5, 12)) for seed in range(26)] + [(seed, (14, 22)) for seed in range(26, 32)]:
        rec = _faulty_session(seed, poses)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ImucalibWarning)
            cal = calibrate(rec, method="tedaldi2014", gravity=G)
        rms, angle, _ = _figures(cal, rec)
        rms_raw, angle_raw, _ = _figures(_identity(cal).with_(fit=cal.fit), rec)
        np.testing.assert_allclose(cal.fit["accelerometer_residual_rms_raw"], rms_raw, rtol=1e-9)
        np.testing.assert_allclose(cal.fit["gyroscope_angle_error_mean_deg_raw"], angle_raw, rtol=1e-9)
        verdicts.append(cal.fit["verdict"])
        if cal.fit["verdict"] in ("accepted", "suspect"):
            assert rms <= rms_raw and angle <= angle_raw, (seed, rms, rms_raw, angle, angle_raw)
        else:
            worse = rms > rms_raw or angle > angle_raw
            assert worse == (_raw_reason(cal) is not None), seed
            rejected_for_raw += worse
    # no side of the promise is empty: calibrations accepted, suspect, and worse than raw
    assert {"accepted", "suspect"} <= set(verdicts) and rejected_for_raw >= 5, (verdicts, rejected_for_raw)


def test_the_seed_once_suspect_while_worse_than_raw_is_rejected_with_both_figures(monkeypatch):
    """Five spikes in ten rotations: the fit kept five and was suspect only for that; over all ten it is worse."""
    rec = _faulty_session(25)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(rec, method="tedaldi2014", gravity=G)
    fit = cal.fit
    assert len(fit["rotations_left_out"]) == 5
    assert fit["verdict"] == "rejected"
    reason = _raw_reason(cal)
    assert f"{fit['gyroscope_angle_error_mean_deg']:.3g}° (mean) calibrated against " \
           f"{fit['gyroscope_angle_error_mean_deg_raw']:.3g}° raw" in reason
    # without the comparison with the raw readings the same checks find it only suspect
    import imucalib.verdict

    monkeypatch.setattr(imucalib.verdict, "raw_checks", lambda calibration, found, fitted: ([], FitReport()))
    without = assess(cal.with_(fit={k: v for k, v in fit.items() if not k.startswith("verdict")}), rec)
    assert without["verdict"] == "suspect"
    assert without["verdict_reasons"] == [r for r in fit["verdict_reasons"] if r != reason]


def test_the_angle_error_is_over_every_rotation_and_the_noise_check_counts_the_fits_outliers():
    """gyroscope_angle_error_mean_deg is over all rotations (those left out included), not over the kept."""
    rec = _faulty_session(0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(rec, method="tedaldi2014", gravity=G)
    left = {int(k) for k in cal.fit["rotations_left_out"]}
    assert left
    _, angle, errors = _figures(cal, rec)
    assert cal.fit["gyroscope_angle_error_mean_deg"] == pytest.approx(angle, rel=1e-12)
    kept = np.array([k not in left for k in range(len(errors))])
    assert cal.fit["gyroscope_angle_error_kept_mean_deg"] == pytest.approx(errors[kept].mean(), rel=1e-12)
    assert abs(errors[kept].mean() - angle) > 0.05 * angle  # the two figures differ here


def test_a_gyroscope_good_on_the_rotations_it_kept_is_judged_on_all():
    """The fit leaves out, as outliers, the rotations its gyroscope does not explain: it is judged on them too."""
    rng = np.random.default_rng(7)
    sim = session("handheld", rng=7, truth=_good_sensor(rng), n_poses=16, quantise=False, full_scale=None,
                  turn_on=0.05)
    rec = sim.recording
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(rec, method="tedaldi2014", gravity=G)
    assert cal.fit["verdict"] == "accepted" and not cal.fit.get("rotations_left_out")
    iv = [Interval(int(a), int(b)) for a, b in cal.fit["intervals"]]
    # the z axis's scale 8 % off: rotations about z go wrong, the others stay right
    bad = cal.with_(gyroscope=cal.gyroscope.with_(scale=cal.gyroscope.scale * [1.0, 1.0, 1.08]))
    errors = np.degrees(gravity_direction_errors(bad, rec, iv))
    worst = np.argsort(-errors)[: len(errors) // 3]  # as many as the fit's robust step may leave out, and more
    left = {str(int(k)): f"its gravity-direction error {errors[k]:.2f}° is far from the others'" for k in worst}
    fit = {k: v for k, v in cal.fit.items() if not k.startswith("verdict")}
    fit |= {"rotations_left_out": left, "gyroscope_angle_error_mean_deg": float(errors.mean()),
            "gyroscope_angle_error_max_deg": float(errors.max())}
    got = assess(bad.with_(fit=fit), rec)
    kept = np.delete(errors, worst)
    assert got["gyroscope_angle_error_kept_mean_deg"] == pytest.approx(kept.mean())
    # judged on every rotation: its error over all of them, far above the noise and the raw readings'
    assert got["verdict"] == "rejected"
    assert got["gyroscope_angle_error_mean_deg_raw"] < errors.mean()
    assert any("worse than the raw readings" in r for r in got["verdict_reasons"])
    assert got["gyroscope_error_to_noise"] == pytest.approx(errors.mean() / got["gyroscope_angle_error_predicted_deg"])


def test_counts_skip_the_comparison_with_a_note():
    sim = session("handheld", rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(sim.recording, method="tedaldi2014", gravity=sim.truth.gravity)
    assert cal.units["accelerometer"]["raw"] == "counts"
    assert "accelerometer_residual_rms_raw" not in cal.fit and "gyroscope_angle_error_mean_deg_raw" not in cal.fit
    note = [n for n in cal.fit["verdict_notes"] if "not compared with the raw readings" in n]
    assert len(note) == 1 and "counts" in note[0]


def test_units_recognised_from_a_header_count_as_physical():
    """No unit option: the header's units are the readings' units, and the raw readings are compared."""
    pd = pytest.importorskip("pandas")
    from imucalib.io import read

    rng = np.random.default_rng(11)
    rec = session("handheld", rng=11, truth=_good_sensor(rng), n_poses=14, quantise=False, full_scale=None,
                  turn_on=0.05).recording
    frame = pd.DataFrame({"time [s]": rec.t, **{f"acc_{a} [m/s^2]": rec.acc[:, i] for i, a in enumerate("xyz")},
                          **{f"gyro_{a} [rad/s]": rec.gyro[:, i] for i, a in enumerate("xyz")}})
    read_back = read(frame)
    assert (read_back.acc_unit, read_back.gyro_unit) == ("m/s^2", "rad/s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(read_back, method="tedaldi2014", gravity=G)
    rms_raw, angle_raw, _ = _figures(_identity(cal).with_(fit=cal.fit), read_back)
    assert cal.fit["accelerometer_residual_rms_raw"] == pytest.approx(rms_raw, rel=1e-9)
    assert cal.fit["gyroscope_angle_error_mean_deg_raw"] == pytest.approx(angle_raw, rel=1e-9)
    assert not any("not compared with the raw readings" in n for n in cal.fit["verdict_notes"])


def _real(*parts):
    path = DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{path} not present (fresh clone): real-data test skipped")
    return path


def test_real_sessions_beat_their_raw_readings_and_validate_agrees():
    """imu_tk's data2: accepted by calibrate and, on the same recording, by validate (it once said suspect:
    validate judged the five spiking rotations the fit left out, calibrate did not)."""
    from imucalib.io import read

    base = _real("imutk_sessions", "data2")
    rec = read([base / "acc_data.txt", base / "gyro_data.txt"], acc_unit="m/s^2", gyro_unit="rad/s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(rec, method="tedaldi2014", gravity=9.81744)
        checked = validate(cal, rec)
    fit = cal.fit
    assert fit["verdict"] == checked["verdict"] == "accepted"
    # the calibration beats the raw readings by far, on both figures, in both commands
    assert fit["accelerometer_residual_rms"] < 0.05 * fit["accelerometer_residual_rms_raw"]
    assert fit["gyroscope_angle_error_mean_deg"] < 0.6 * fit["gyroscope_angle_error_mean_deg_raw"]
    assert checked["accelerometer_residual_rms"] < 0.05 * checked["accelerometer_residual_rms_raw"]
    assert checked["gyroscope_angle_error_mean_deg"] < 0.6 * checked["gyroscope_angle_error_mean_deg_raw"]
    # the same rotations judged against the noise on the fit's own poses, by both purposes
    again = assess(cal.with_(fit={k: v for k, v in fit.items() if not k.startswith("verdict")}), rec,
                   purpose="validate")
    assert again["gyroscope_error_to_noise"] == pytest.approx(fit["gyroscope_error_to_noise"], rel=1e-12)


def test_the_ferraris_session_fitted_as_poses_is_never_usable():
    """imucal's Ferraris session calibrated by tedaldi2014: six orientations for nine accelerometer parameters.
    With the full model its gyroscope left 18.9° over all rotations against 3.8° raw (rejected, worse than raw);
    with the misalignment the faces do not determine held at none it leaves less than raw, and is rejected for
    what the poses do not determine. Either way not usable; the raw figure is the identity's, computed here."""
    from imucalib.io import read

    rec = read(_real("ferraris_imucal", "example_ferraris_session.csv"), rate=102.4, acc_unit="m/s^2",
               gyro_unit="deg/s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(rec, method="tedaldi2014")
    fit = cal.fit
    _, angle_raw, _ = _figures(cal.with_(accelerometer=TriadModel(shape="upper"),
                                         gyroscope=TriadModel(shape="full", scale=np.full(3, np.pi / 180))), rec)
    assert fit["gyroscope_angle_error_mean_deg_raw"] == pytest.approx(angle_raw, rel=1e-9)
    assert fit["verdict"] == "rejected"
    worse = (fit["gyroscope_angle_error_mean_deg"] > angle_raw
             or fit["accelerometer_residual_rms"] > fit["accelerometer_residual_rms_raw"])
    assert (_raw_reason(cal) is not None) == worse
    assert any("do not determine" in r for r in fit["verdict_reasons"])


def test_calibrate_and_validate_judge_the_same_rotations_and_residual_alike():
    """On the same recording and poses the two purposes share their figures and limits: the gyroscope's noise check
    over the same rotations (spiking ones set aside by both), an exact method's residual judged by both."""
    from imucalib.metrics import fit_summary

    rec = _faulty_session(0)  # four of ten rotations spike
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(rec, method="tedaldi2014", gravity=G)
    fit = {k: v for k, v in cal.fit.items() if not k.startswith("verdict")}
    made, checked = assess(cal.with_(fit=fit), rec), assess(cal.with_(fit=fit), rec, purpose="validate")
    for key in ("gyroscope_error_to_noise", "gyroscope_angle_error_reliable_mean_deg",
                "accelerometer_residual_rms_raw", "gyroscope_angle_error_mean_deg_raw"):
        assert made[key] == checked[key], key

    sim = session("handheld", rng=1, procedure="ferraris")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        exact = calibrate(sim, method="six_position")
    iv = [Interval(int(a), int(b)) for a, b in exact.fit["intervals"]]
    # the z scale 2 % off: the residual over the faces tens of times the noise floor
    off = exact.with_(accelerometer=exact.accelerometer.with_(scale=exact.accelerometer.scale * [1, 1, 1.02]))
    fit = fit_summary(off, sim.recording, iv).add(UncertaintyReport(unavailable=exact.fit.uncertainty.unavailable))
    assert fit["accelerometer_residual_to_noise"] > 40
    made = assess(off.with_(fit=fit), sim.recording, iv)
    checked = assess(off.with_(fit=fit), sim.recording, iv, purpose="validate")
    assert made["verdict"] == checked["verdict"] == "rejected"
    floor = [r for r in made["verdict_reasons"] if "white-noise floor" in r]
    assert floor and floor == [r for r in checked["verdict_reasons"] if "white-noise floor" in r]


def test_validate_rejects_a_calibration_worse_than_the_new_recordings_raw_readings():
    """A calibration of one sensor (biased by 0.2 m/s², scales 1 % off) on another, already right in m/s² and
    rad/s: on the new recording it is worse than the raw readings, and validate says the sensor changed."""
    rng = np.random.default_rng(3)
    off = _good_sensor(rng)
    off = off.with_(accelerometer=off.accelerometer.with_(bias=[0.2, -0.15, 0.1], scale=[1.01, 0.99, 1.01]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        first = session("handheld", rng=3, truth=off, n_poses=16, quantise=False, full_scale=None, turn_on=0.05)
        cal = calibrate(first.recording, method="tedaldi2014", gravity=G)
        right = Calibration(units=SI, gravity=G)  # the identity: raw readings that need no calibration
        other = session("handheld", rng=4, truth=right, n_poses=8, quantise=False, full_scale=None, turn_on=0.05)
        checked = validate(cal, other.recording)
    assert cal.fit["verdict"] == "accepted"
    assert checked["verdict"] == "rejected"
    assert checked["accelerometer_residual_rms"] > 10 * checked["accelerometer_residual_rms_raw"]
    reason = next(r for r in checked["verdict_reasons"] if "worse than the raw readings" in r)
    assert "the sensor has changed since it was calibrated" in reason
