"""Calibrations that follow temperature (thermal.py) on simulated sensors with datasheet-like coefficients."""

import warnings

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.methods import calibrate
from imucalib.recording import ImucalibWarning, Recording
from imucalib.scenarios import handheld
from imucalib.thermal import ThermalModel, combine, compensate, evaluate
from imucalib.validation import validate

#: a session isolated from the other run-to-run changes of the bias (turn-on offset, drift, random walk),
#: so that what differs between temperatures is the temperature
STEADY = {"turn_on": 0.0, "gyro_drift": 0.0, "gyro_rw": 0.0}


@pytest.fixture(scope="module")
def sensor():
    rng = np.random.default_rng(0)
    truth = handheld.consumer_truth(rng)
    return truth, handheld.datasheet_thermal(rng, truth)


def _figures(cal, rec):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        v = validate(cal, rec)
    return np.array([v["accelerometer_residual_rms"], v["gyroscope_angle_error_mean_deg"]])


def test_apply_follows_each_samples_temperature(sensor):
    truth, coeffs = sensor
    cal = truth.with_(thermal=ThermalModel(coefficients=coeffs, range_c=(0.0, 50.0)))
    rng = np.random.default_rng(4)
    n = 50
    raw = Recording(np.arange(n) * 0.01, rng.normal(size=(n, 3)) * 9000, rng.normal(size=(n, 3)) * 500,
                    temperature=np.linspace(5.0, 45.0, n))
    out = cal.apply(raw)
    for i in (0, 17, 49):  # independently: the calibration evaluated at that sample's temperature
        at = evaluate(cal, raw.temperature[i])
        assert at.thermal is None
        np.testing.assert_allclose(out.acc[i], at.accelerometer_si(raw.acc[i:i + 1])[0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(out.gyro[i], at.gyroscope_si(raw.gyro[i:i + 1], raw.acc[i:i + 1])[0],
                                   rtol=1e-12, atol=1e-15)
    base, comp = compensate(cal, raw)
    assert base.thermal is None
    np.testing.assert_allclose(base.apply(comp).acc, out.acc, rtol=1e-12)


def test_apply_needs_the_temperature_and_warns_outside_the_range(sensor):
    truth, coeffs = sensor
    cal = truth.with_(thermal=ThermalModel(coefficients=coeffs, range_c=(10.0, 40.0)))
    rec = Recording(np.arange(3) * 0.01, np.ones((3, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="no temperature column"):
        cal.apply(rec)
    hot = Recording(rec.t, rec.acc, rec.gyro, temperature=[60.0, 61.0, 62.0])
    with pytest.warns(ImucalibWarning, match="outside the 10.0–40.0 °C"):
        cal.apply(hot)


def test_three_temperatures_combined_validate_at_32_like_the_true_parameters(sensor):
    truth, coeffs = sensor
    cals = []
    for i, temp in enumerate((10.0, 25.0, 40.0)):
        d = handheld.generate(np.random.default_rng(10 + i), truth=truth, thermal=coeffs, temperature=temp, **STEADY)
        cals.append(calibrate(d["recording"], method="tedaldi2014"))
        assert abs(cals[-1].fit["temperature_c"][1] - temp) < 0.05
    thermal, decisions = combine(cals)
    assert thermal.thermal.range_c == pytest.approx((10.0, 40.0), abs=0.05)
    for axis in "xyz":  # the biases move by far the most: a slope each
        assert decisions[f"accelerometer.bias.{axis}"]["order"] >= 1
        assert decisions[f"gyroscope.bias.{axis}"]["order"] >= 1
    assert all(decisions[n]["order"] == 0 for n in decisions if ".misalignment." in n)  # nothing to follow
    d = handheld.generate(np.random.default_rng(99), truth=truth, thermal=coeffs, temperature=32.0, **STEADY)
    rec = d["recording"]
    best = _figures(d["truth"], rec)
    assert np.all(_figures(thermal, rec) <= 1.3 * best), (_figures(thermal, rec) / best)
    assert np.all(_figures(cals[1], rec) >= 2.0 * best)  # the 25 °C calibration alone


@pytest.mark.slow
def test_a_warm_up_session_calibrated_directly(sensor):
    truth, coeffs = sensor
    ramp = {"ramp": (22.0, 40.0, 150.0), "rest": 40.0, "n_poses": 60, **STEADY}
    d = handheld.generate(np.random.default_rng(50), truth=truth, thermal=coeffs, **ramp)
    cal = calibrate(d["recording"], method="tedaldi2014", temperature_model="linear")
    assert cal.fit["verdict"] == "accepted", cal.fit["verdict_reasons"]
    model = cal.thermal
    assert model.source == "ramp" and model.range_c[0] < 24 and model.range_c[1] > 36
    for name in ("gyroscope.bias.x", "gyroscope.bias.y", "gyroscope.bias.z", "accelerometer.bias.x"):
        sd = cal.fit["uncertainty"][f"thermal.{name}.slope"]
        assert abs(model.coefficients[name][0] - coeffs[name][0]) < 4 * sd + 0.05 * abs(coeffs[name][0])
    plain = calibrate(d["recording"], method="tedaldi2014")
    check = handheld.generate(np.random.default_rng(51), truth=truth, thermal=coeffs, **ramp)
    best = _figures(check["truth"], check["recording"])
    assert np.all(_figures(cal, check["recording"]) <= 1.3 * best), (_figures(cal, check["recording"]) / best)
    assert np.all(_figures(plain, check["recording"]) >= 2.0 * best)


def test_order_is_chosen_by_the_uncertainties():
    base = Calibration()
    temps = [0.0, 10.0, 20.0, 30.0, 40.0]
    cals = []
    for t in temps:
        dt = t - 25.0
        values = {"accelerometer.bias.x": 5.0 + 0.3 * dt,  # linear, 0.3 ≫ its 1σ
                  "accelerometer.bias.y": 1.0 + 0.02 * dt * dt,  # quadratic
                  "gyroscope.bias.z": 2.0 + 0.001 * dt}  # a slope far below its 1σ
        cal = base.with_parameters(values)
        unc = dict.fromkeys(base.parameters(), 0.05)
        cals.append(cal.with_(fit={"temperature_c": [t, t, t], "uncertainty": unc}))
    out, decisions = combine(cals)
    assert decisions["accelerometer.bias.x"]["order"] == 1
    assert decisions["accelerometer.bias.y"]["order"] == 2
    assert decisions["gyroscope.bias.z"]["order"] == 0
    assert out.parameters()["accelerometer.bias.x"] == pytest.approx(5.0)
    assert out.thermal.coefficients["accelerometer.bias.x"][0] == pytest.approx(0.3)
    assert out.thermal.coefficients["accelerometer.bias.y"][1] == pytest.approx(0.02)
    assert out.thermal.sigma("accelerometer.bias.x", 25.0) < out.thermal.sigma("accelerometer.bias.x", 60.0)
    back = Calibration.from_dict(out.to_dict())
    assert back.thermal.coefficients.keys() == out.thermal.coefficients.keys()
    np.testing.assert_allclose(back.thermal.coefficients["accelerometer.bias.y"], [0.0, 0.02], atol=1e-12)


def test_what_cannot_be_combined_or_fitted_is_refused(sensor):
    truth, _ = sensor
    one = truth.with_(fit={"temperature_c": [20.0, 20.0, 20.0]})
    with pytest.raises(ValueError, match="two or more"):
        combine([one])
    with pytest.raises(ValueError, match="no temperature"):
        combine([one, truth])
    with pytest.raises(ValueError, match="several °C apart"):
        combine([one, truth.with_(fit={"temperature_c": [20.3, 20.3, 20.3]})])
    with pytest.raises(ValueError, match="another model"):
        combine([one, truth.with_(model="cubic", fit={"temperature_c": [30.0, 30.0, 30.0]})])
    with pytest.raises(ValueError, match="temperature_model"):
        calibrate(Recording(np.arange(10) * 0.01, np.ones((10, 3)), np.ones((10, 3))), method="tedaldi2014",
                  temperature_model="cubic")
    flat = handheld.generate(np.random.default_rng(3), temperature=25.0, **STEADY)
    with pytest.raises(ValueError, match="spans"):
        calibrate(flat["recording"], method="tedaldi2014", temperature_model="linear")
    with pytest.raises(ValueError, match="only biases, scales and misalignments"):
        ThermalModel(coefficients={"gyroscope.g_sensitivity.xy": [1.0, 0.0]})
