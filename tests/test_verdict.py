"""The verdict: mix-ups a user makes with real data are rejected, the real session as recorded is accepted."""

from pathlib import Path

import numpy as np
import pytest

from imucalib.io import read
from imucalib.methods import calibrate
from imucalib.recording import Recording
from imucalib.verdict import THRESHOLDS, predicted_direction_error

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"
needs_data = pytest.mark.skipif(not DATA.is_dir(), reason=f"real data not present: {DATA} (needs ../shared/data)")
G = 9.81744


@pytest.fixture(scope="module")
def xsens():
    return read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk")


def _si(rec: Recording, acc_unit: str = "m/s^2", gyro_unit: str = "rad/s", gyro_factor: float = 1.0) -> Recording:
    """The session in SI units through imu_tk's own parameters' nominal factors."""
    acc = (rec.acc - [33124.2, 33275.2, 32364.4]) * [0.00241278, 0.00242712, 0.00241168]
    gyro = (rec.gyro - [32777.14, 32459.80, 32511.85]) * 2.095e-4 * gyro_factor
    return Recording(rec.t, acc, gyro, acc_unit=acc_unit, gyro_unit=gyro_unit)


@needs_data
@pytest.mark.parametrize("method", ["tedaldi2014", "ellipsoid"])
def test_the_real_session_is_accepted(xsens, method):
    cal = calibrate(xsens, method=method, gravity=G)
    assert cal.fit["verdict"] == "accepted", cal.fit["verdict_reasons"]
    # the gyroscope's error is within a few times what its noise predicts (figures the verdict rests on)
    assert 0.5 < cal.fit["gyroscope_error_to_noise"] < THRESHOLDS["gyro_error_to_noise"][0]
    cal = calibrate(_si(xsens), method=method, gravity=G)
    assert cal.fit["verdict"] == "accepted", cal.fit["verdict_reasons"]


@needs_data
def test_a_time_base_no_imu_records_at_is_refused(xsens):
    with pytest.raises(ValueError, match="sampling rate is 0.1 Hz, outside 5-50000 Hz"):
        calibrate(Recording(xsens.t * 1000, xsens.acc, xsens.gyro), method="tedaldi2014", gravity=G)


@needs_data
def test_turn_speeds_no_hand_makes_are_rejected(xsens):
    # time in units 20× too long still gives a plausible 5 Hz rate: the accelerometer's angles between poses
    # over the time between them (0.5-2 deg/s) say the time base is wrong
    cal = calibrate(Recording(xsens.t * 20, xsens.acc, xsens.gyro), method="tedaldi2014", gravity=G, window=20,
                    min_interval=20)
    assert cal.fit["verdict"] != "accepted"
    assert any("time base" in r for r in cal.fit["verdict_reasons"]), cal.fit["verdict_reasons"]


@needs_data
@pytest.mark.parametrize("case, words", [
    ("gravity typo", "declared gravity 9.18"),
    ("accelerometer x and y swapped", "gravity-direction error"),
    ("accelerometer y mirrored", "gravity-direction error"),
    ("deg/s declared rad/s", "nominal factor of the declared unit 'rad/s'"),
    ("m/s² declared g", "nominal factor of the declared unit 'g'"),
    ("gravity 1", "declared gravity 1 m/s²"),
])
def test_mix_ups_are_rejected(xsens, case, words):
    rec, gravity = xsens, G
    if case == "gravity typo":
        gravity = 9.18
    elif case == "accelerometer x and y swapped":
        rec = Recording(rec.t, rec.acc[:, [1, 0, 2]], rec.gyro)
    elif case == "accelerometer y mirrored":
        rec = Recording(rec.t, rec.acc * [1, -1, 1] + [0, 65536, 0], rec.gyro)
    elif case == "deg/s declared rad/s":
        rec = _si(rec, gyro_factor=180 / np.pi)
    elif case == "m/s² declared g":
        rec = _si(rec, acc_unit="g")
    elif case == "gravity 1":
        rec, gravity = _si(rec), 1.0
    cal = calibrate(rec, method="tedaldi2014", gravity=gravity)
    assert cal.fit["verdict"] == "rejected"
    assert any(words in r for r in cal.fit["verdict_reasons"]), cal.fit["verdict_reasons"]


def test_noise_prediction_matches_a_simulated_noise_only_session():
    """The predicted mean direction error is what pure noise gives when the true parameters are used."""
    from imucalib.metrics import gravity_direction_errors
    from synth import linear_truth, tedaldi_session

    truth = linear_truth()
    ratios = []
    for seed in range(3):
        rec, _, iv = tedaldi_session(truth, seed=seed, noise_acc=0.02, noise_gyro=0.003, poses=30)
        observed = np.mean(gravity_direction_errors(truth, rec, iv))
        ratios.append(observed / np.mean(predicted_direction_error(truth, rec, iv)))
    assert 0.7 < np.mean(ratios) < 1.4, ratios
