"""An accelerometer-only calibration (no gyroscope) through the Python API's exports and the thermal model.

Every export format has a gyroscope part: the API writes the identity there (rates passed through
unchanged) and says so, as the command line does (the command line calls the API). The thermal model
calibrates, combines and applies the accelerometer alone.
"""

import json
import shutil
import warnings

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.export import to_c, to_imutk, to_kalibr, to_openvins
from imucalib.methods import calibrate
from imucalib.models import TriadModel
from imucalib.recording import ImucalibWarning, Recording
from imucalib.scenarios import handheld
from imucalib.thermal import ThermalModel, combine, compensate, decompensate, evaluate

CC = shutil.which("cc") or shutil.which("gcc")
IDENTITY = "is the identity, which passes rates through unchanged"
STEADY = {"turn_on": 0.0, "gyro_drift": 0.0, "gyro_rw": 0.0}


def accelerometer_only(acc_unit="m/s^2", seed=0) -> Calibration:
    """A linear accelerometer calibration with misalignments, scales near the unit's, biases; no gyroscope."""
    rng = np.random.default_rng(seed)
    s_a = {"m/s^2": 1.0, "g": 9.80665, "counts": 9.81 / 4096}[acc_unit]
    ta = np.eye(3)
    for ij in [(0, 1), (0, 2), (1, 2)]:
        ta[ij] = rng.normal(0, 0.03)
    acc = TriadModel(misalignment=ta, scale=s_a * rng.uniform(0.9, 1.1, 3), bias=rng.normal(0, 0.02, 3) / s_a,
                     shape="upper")
    return Calibration(accelerometer=acc, gyroscope=None, method="ellipsoid", gravity=9.81,
                       units={"accelerometer": {"raw": acc_unit, "calibrated": "m/s^2"}})


def with_identity(cal: Calibration) -> Calibration:
    """The same calibration with an explicit identity gyroscope in rad/s, built here apart from the exporter."""
    gyro = TriadModel(misalignment=np.eye(3), scale=np.ones(3), bias=np.zeros(3), shape="full",
                      g_sensitivity=np.zeros((3, 3)))
    return cal.with_(gyroscope=gyro, units={**cal.units, "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}})


# ------------------------------------------------------------------------ exports
def test_the_c_header_corrects_the_accelerometer_and_passes_rates_through(tmp_path):
    cal = accelerometer_only("counts")
    with pytest.warns(ImucalibWarning, match=f"gyroscope part of the C99 header {IDENTITY}"):
        header = to_c(cal)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a calibration with a gyroscope: no note
        assert header == to_c(with_identity(cal))
    assert cal.gyroscope is None  # the caller's calibration is left as it was
    if CC is None:
        pytest.skip("no C compiler on this machine")
    from test_export import _run_c

    rng = np.random.default_rng(1)
    acc_raw, gyro_raw = rng.normal(0, 4096, (50, 3)), rng.normal(0, 3, (50, 3))
    got = _run_c(tmp_path, header, acc_raw, gyro_raw)
    np.testing.assert_allclose(got[:, :3], cal.accelerometer_si(acc_raw), rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(got[:, 3:], gyro_raw)  # the identity, exactly


@pytest.mark.parametrize("convert", [to_openvins, to_kalibr])
def test_openvins_and_kalibr_hold_an_identity_gyroscope_and_say_so(convert):
    yaml = pytest.importorskip("yaml")
    cal = accelerometer_only("g")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # said in the notes, as these functions say everything
        text, notes = convert(cal)
    assert IDENTITY in notes[0]
    assert (text, notes[1:]) == convert(with_identity(cal))
    imu = yaml.safe_load("\n".join(ln for ln in text.splitlines() if not ln.startswith("%YAML")))["imu0"]
    if convert is to_openvins:
        np.testing.assert_allclose(imu["Tw"], np.eye(3), atol=1e-15)
        np.testing.assert_allclose(imu["R_IMUtoGYRO"], np.eye(3), atol=1e-15)
        np.testing.assert_array_equal(imu["Tg"], np.zeros((3, 3)))
    else:  # ω_m = M_g C_gyro_i ω_i with ω_i = R ω (R: the file's frame rotation, C_gyro_i = Rᵀ here)
        gyro = imu["gyroscopes"]
        np.testing.assert_allclose(gyro["M"], np.eye(3), atol=1e-15)
        np.testing.assert_array_equal(gyro["A"], np.zeros((3, 3)))
        c = np.array(gyro["C_gyro_i"])
        np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-12)


def test_imutk_gets_an_identity_gyroscope_file():
    cal = accelerometer_only("m/s^2")
    with pytest.warns(ImucalibWarning, match=f"gyroscope part of the imu_tk parameter files {IDENTITY}"):
        acc_text, gyro_text = to_imutk(cal)
    assert (acc_text, gyro_text) == to_imutk(with_identity(cal))
    numbers = np.array(gyro_text.split(), dtype=float)  # T (9), K (9), B (3)
    np.testing.assert_array_equal(numbers, np.concatenate([np.eye(3).ravel(), np.eye(3).ravel(), np.zeros(3)]))


@pytest.mark.parametrize(("fmt", "what"), [("c", "C99 header"), ("imutk", "imu_tk parameter files"),
                                           ("openvins", "OpenVINS imu0 intrinsics")])
def test_the_command_line_says_what_the_api_says(tmp_path, capsys, fmt, what):
    path = tmp_path / "a.json"
    accelerometer_only("m/s^2").save(path)
    assert main(["export", str(path), "--format", fmt, "-o", str(tmp_path / "out"), "--json"]) == 0
    captured = capsys.readouterr()
    notes = json.loads(captured.out)["notes"]
    assert [n for n in notes if IDENTITY in n and what in n] and f"{what}" in captured.err
    assert sum(IDENTITY in n for n in notes) == 1  # said once


# ------------------------------------------------------------------------ thermal model
def test_a_thermal_accelerometer_only_calibration_applies_sample_by_sample():
    rng = np.random.default_rng(3)
    truth = handheld.consumer_truth(rng)
    coeffs = {k: v for k, v in handheld.datasheet_thermal(rng, truth).items() if k.startswith("accelerometer.")}
    model = ThermalModel(coefficients=coeffs, range_c=(0.0, 50.0))
    full = truth.with_(thermal=model)
    alone = truth.with_(gyroscope=None, units={"accelerometer": truth.units["accelerometer"]}, thermal=model)
    n = 40
    raw = Recording(np.arange(n) * 0.01, rng.normal(size=(n, 3)) * 9000, rng.normal(size=(n, 3)) * 500,
                    temperature=np.linspace(5.0, 45.0, n))
    out = alone.apply(raw)
    assert out.gyro is None
    np.testing.assert_allclose(out.acc, full.apply(raw).acc, rtol=1e-13)  # the same accelerometer
    for i in (0, 21, 39):  # independently: the calibration evaluated at that sample's temperature
        at = evaluate(alone, raw.temperature[i])
        np.testing.assert_allclose(out.acc[i], at.accelerometer_si(raw.acc[i:i + 1])[0], rtol=1e-12)
    acc_only = Recording(raw.t, raw.acc, None, temperature=raw.temperature)
    np.testing.assert_allclose(compensate(alone, acc_only)[1].acc, compensate(full, raw)[1].acc, rtol=1e-13)
    u_a, u_g = decompensate(alone, (raw.acc, None), raw.temperature, np.zeros((n, 3)))
    assert u_g is None
    np.testing.assert_allclose(u_a, decompensate(full, (raw.acc, raw.gyro), raw.temperature,
                                                 np.zeros((n, 3)))[0], rtol=1e-13)


def test_accelerometer_only_calibrations_combine_as_the_accelerometer_of_full_ones():
    base = Calibration()
    full, alone = [], []
    for t in (0.0, 10.0, 20.0, 30.0, 40.0):
        dt = t - 25.0
        cal = base.with_parameters({"accelerometer.bias.x": 5.0 + 0.3 * dt,
                                    "accelerometer.bias.y": 1.0 + 0.02 * dt * dt,
                                    "gyroscope.bias.z": 2.0 + 0.5 * dt})
        unc = dict.fromkeys(base.parameters(), 0.05)
        full.append(cal.with_(fit={"temperature_c": [t, t, t], "uncertainty": unc}))
        alone.append(full[-1].with_(gyroscope=None, units={"accelerometer": cal.units["accelerometer"]}))
    out_full, dec_full = combine(full)
    out_alone, dec_alone = combine(alone)
    assert out_alone.gyroscope is None
    assert dec_alone == {k: v for k, v in dec_full.items() if k.startswith("accelerometer.")}
    assert dec_alone["accelerometer.bias.x"]["order"] == 1 and dec_alone["accelerometer.bias.y"]["order"] == 2
    assert out_alone.thermal.coefficients.keys() == {k for k in out_full.thermal.coefficients
                                                     if k.startswith("accelerometer.")}
    for k, v in out_alone.thermal.coefficients.items():
        np.testing.assert_allclose(v, out_full.thermal.coefficients[k], rtol=1e-12)
    back = Calibration.from_dict(out_alone.to_dict())
    assert back.gyroscope is None and back.thermal.coefficients.keys() == out_alone.thermal.coefficients.keys()
    with pytest.raises(ValueError, match="calibration 2 has no gyroscope and the first has one"):
        combine([full[0], alone[1]])


def test_an_accelerometer_only_warm_up_session_gets_its_accelerometer_slopes():
    rng = np.random.default_rng(0)
    truth = handheld.consumer_truth(rng)
    coeffs = handheld.datasheet_thermal(rng, truth)
    d = handheld.generate(np.random.default_rng(50), truth=truth, thermal=coeffs, ramp=(22.0, 40.0, 150.0),
                          rest=40.0, n_poses=60, **STEADY)
    rec = d["recording"]
    acc_only = Recording(rec.t, rec.acc, None, acc_unit=rec.acc_unit, temperature=rec.temperature)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(acc_only, method="tedaldi2014", temperature_model="linear")
    assert cal.gyroscope is None
    model = cal.thermal
    assert model.source == "ramp" and not [k for k in model.coefficients if k.startswith("gyroscope.")]
    for axis in "xyz":  # the true slopes, within the fit's own 1σ
        name = f"accelerometer.bias.{axis}"
        sd = cal.fit["uncertainty"][f"thermal.{name}.slope"]
        assert abs(model.coefficients[name][0] - coeffs[name][0]) < 4 * sd + 0.05 * abs(coeffs[name][0]), name
