"""Exports for OpenVINS, Kalibr and imu_tk: each file applied the way its tool documents matches Calibration.apply.

The consumers' formulas are written out here from their documentation and source, independently of
the exporter:

* OpenVINS (docs "IMU Intrinsic Models"; VioManagerOptions.h, Propagator.cpp of v2.7): D = T⁻¹ keeping the
  lower (model kalibr) or upper (rpng) triangle; a_I = R_IMUtoACCᵀ Da (a_m − b_a),
  ω_I = R_IMUtoGYROᵀ Dw (ω_m − b_g − Tg a_I);
* Kalibr (IccSensors.py, IccScaledMisalignedImu): α_m = M_a a_i + b_a, ω_m = M_g C_gyro_i ω_i + A C_gyro_i a_i + b_g,
  solved for a_i, ω_i; its frame i may differ from imucalib's by a rotation, found here by Kabsch;
* imu_tk (calibration.h, CalibratedTriad_): X' = T K (X − B), files read as 9 + 9 + 3 numbers.
"""

import json
import re
import zlib

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.export import ExportError, read_noise, to_imutk, to_kalibr, to_openvins
from imucalib.export.linear import rotation_times_triangular, triangular_times_rotation
from imucalib.models import TriadModel
from imucalib.recording import Recording

yaml = pytest.importorskip("yaml")

G_N = 9.80665
TO_SI = {"m/s^2": 1.0, "g": G_N, "rad/s": 1.0, "deg/s": np.pi / 180, "counts": None}


def random_calibration(rng, acc_unit="m/s^2", gyro_unit="rad/s", *, g_sensitivity=True, output_bias=False,
                       flip=False, acc_shape="upper") -> Calibration:
    """A linear calibration with misalignments of a few degrees, scales near the unit's and biases."""
    s_a = {"m/s^2": 1.0, "g": G_N, "counts": 9.81 / 4096}[acc_unit]
    s_g = {"rad/s": 1.0, "deg/s": np.pi / 180, "counts": 1 / 900}[gyro_unit]
    ta = np.eye(3)
    free = {"upper": [(0, 1), (0, 2), (1, 2)], "lower": [(1, 0), (2, 0), (2, 1)]}[acc_shape]
    for ij in free:
        ta[ij] = rng.normal(0, 0.03)
    tg = np.eye(3) + rng.normal(0, 0.03, (3, 3)) * (1 - np.eye(3))
    ka = s_a * rng.uniform(0.9, 1.1, 3)
    kg = s_g * rng.uniform(0.9, 1.1, 3)
    if flip:
        kg[1] = -kg[1]  # a left-handed gyroscope axis
    acc = TriadModel(misalignment=ta, scale=ka, bias=rng.normal(0, 0.2, 3) / s_a * 0.1, shape=acc_shape,
                     output_bias=rng.normal(0, 0.05, 3) if output_bias else np.zeros(3))
    gyro = TriadModel(misalignment=tg, scale=kg, bias=rng.normal(0, 0.01, 3) / s_g, shape="full",
                      g_sensitivity=rng.normal(0, 2e-3, (3, 3)) / s_g if g_sensitivity else np.zeros((3, 3)),
                      output_bias=rng.normal(0, 0.01, 3) if output_bias else np.zeros(3))
    return Calibration(accelerometer=acc, gyroscope=gyro, method="test", gravity=9.81,
                       units={"accelerometer": {"raw": acc_unit, "calibrated": "m/s^2"},
                              "gyroscope": {"raw": gyro_unit, "calibrated": "rad/s"}})


def raw_samples(rng, cal: Calibration, n=300) -> Recording:
    """Raw readings of random motion (|a| up to 30 m/s², |ω| up to 6 rad/s) in the calibration's raw units."""
    a = rng.normal(0, 10, (n, 3))
    w = rng.normal(0, 2, (n, 3))
    u_a = cal.accelerometer.inverse(a)
    u_g = cal.gyroscope.inverse(w, a)
    return Recording(np.arange(n) * 0.01, u_a, u_g, acc_unit=cal.units["accelerometer"]["raw"],
                     gyro_unit=cal.units["gyroscope"]["raw"])


def load_yaml(text: str) -> dict:
    lines = text.splitlines()
    if lines and lines[0].startswith("%YAML:"):  # OpenCV's header, which PyYAML does not take
        lines = lines[1:]
    return yaml.safe_load("\n".join(lines))


def assert_rotation(r):
    r = np.asarray(r, dtype=float)
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-12)


def published(rec: Recording, scale):
    """What the driver publishes: raw × (m/s², rad/s per raw unit)."""
    return rec.acc * scale[0], rec.gyro * scale[1]


def effective_bias(m: TriadModel):
    return m.bias - m.output_bias / m.scale  # T (K (u − b) + d) = T K (u − (b − d/k))


def close(got, expected, scale):
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * scale)


# ------------------------------------------------------------------------- OpenVINS
def openvins_apply(doc: dict, a_m, w_m, b_a, b_g):
    imu = doc["imu0"]
    tri = np.tril if imu["model"] in ("kalibr", "calibrated") else np.triu
    da = tri(np.linalg.inv(np.array(imu["Ta"])))
    dw = tri(np.linalg.inv(np.array(imu["Tw"])))
    r_acc_to_imu = np.array(imu["R_IMUtoACC"]).T
    r_gyro_to_imu = np.array(imu["R_IMUtoGYRO"]).T
    tg = np.array(imu["Tg"])
    a_i = (a_m - b_a) @ (r_acc_to_imu @ da).T
    w_i = (w_m - b_g - a_i @ tg.T) @ (r_gyro_to_imu @ dw).T
    return a_i, w_i


@pytest.mark.parametrize("model", ["kalibr", "rpng"])
@pytest.mark.parametrize("units", [("m/s^2", "rad/s"), ("g", "deg/s"), ("counts", "counts")])
def test_openvins_file_applied_as_openvins_does_matches_apply(model, units):
    rng = np.random.default_rng(zlib.crc32(f"{model} {units}".encode()))
    cal = random_calibration(rng, *units, output_bias=units[0] == "g")
    rec = raw_samples(rng, cal)
    scale = (9.81 / 4096 * 1.01, 1 / 900 * 0.98) if units[0] == "counts" else None
    text, _ = to_openvins(cal, model=model, raw_scale=scale)
    doc = load_yaml(text)
    imu = doc["imu0"]
    s = scale or (TO_SI[units[0]], TO_SI[units[1]])
    a_m, w_m = published(rec, s)
    # OpenVINS estimates the biases online; here they are given the values they converge to
    b_a = effective_bias(cal.accelerometer) * s[0]
    b_g = effective_bias(cal.gyroscope) * s[1]
    a_i, w_i = openvins_apply(doc, a_m, w_m, b_a, b_g)
    expected = cal.apply(rec)
    close(a_i, expected.acc, 30)
    close(w_i, expected.gyro, 6)
    tri_other = np.triu if model == "kalibr" else np.tril
    for key in ("Ta", "Tw"):
        t = np.array(imu[key])
        assert np.all(tri_other(t, 1 if model == "kalibr" else -1) == 0), f"{key} must be triangular for {model}"
        assert np.all(np.diag(t) > 0)
    for key in ("R_IMUtoACC", "R_IMUtoGYRO"):
        assert_rotation(imu[key])
    if model == "rpng":  # the canonical T_a is upper triangular already
        assert np.array_equal(np.array(imu["R_IMUtoACC"]), np.eye(3))
    assert imu["model"] == model


def test_openvins_left_handed_gyroscope_still_gets_a_proper_rotation():
    rng = np.random.default_rng(11)
    cal = random_calibration(rng, flip=True)
    rec = raw_samples(rng, cal)
    doc = load_yaml(to_openvins(cal)[0])
    assert_rotation(doc["imu0"]["R_IMUtoGYRO"])
    a_i, w_i = openvins_apply(doc, rec.acc, rec.gyro, effective_bias(cal.accelerometer),
                              effective_bias(cal.gyroscope))
    close(w_i, cal.apply(rec).gyro, 6)


def test_decompositions():
    rng = np.random.default_rng(5)
    for lower in (False, True):
        for sign in (1, -1):
            m = rng.normal(size=(3, 3))
            m *= sign * np.sign(np.linalg.det(m))
            r, d = rotation_times_triangular(m, lower=lower)
            np.testing.assert_allclose(r @ d, m, atol=1e-14)
            assert_rotation(r)
            assert np.all((np.triu(d, 1) if lower else np.tril(d, -1)) == 0)
            assert (np.diag(d) > 0).sum() == (3 if sign > 0 else 2)
            d2, r2 = triangular_times_rotation(m, lower=lower)
            np.testing.assert_allclose(d2 @ r2, m, atol=1e-14)
            assert_rotation(r2)
            assert np.all((np.triu(d2, 1) if lower else np.tril(d2, -1)) == 0)


# --------------------------------------------------------------------------- Kalibr
def kabsch(p, q):
    """The proper rotation R minimising ‖p − q Rᵀ‖ (rows are vectors)."""
    u, _, vt = np.linalg.svd(q.T @ p)
    d = np.sign(np.linalg.det(u @ vt))
    return (u @ np.diag([1, 1, d]) @ vt).T


@pytest.mark.parametrize("units", [("m/s^2", "rad/s"), ("counts", "counts")])
def test_kalibr_model_applied_as_kalibr_does_matches_apply_up_to_its_frame(units):
    rng = np.random.default_rng(3)
    cal = random_calibration(rng, *units)
    rec = raw_samples(rng, cal)
    scale = (0.002, 0.001) if units[0] == "counts" else None
    text, notes = to_kalibr(cal, raw_scale=scale)
    imu = load_yaml(text)["imu0"]
    assert imu["model"] == "scale-misalignment" and any("rotation" in n for n in notes)
    m_a = np.array(imu["accelerometers"]["M"])
    m_g, a_sens = np.array(imu["gyroscopes"]["M"]), np.array(imu["gyroscopes"]["A"])
    c_gi = np.array(imu["gyroscopes"]["C_gyro_i"])
    assert np.all(np.triu(m_a, 1) == 0) and np.all(np.triu(m_g, 1) == 0)  # Kalibr's lower-triangular M
    assert_rotation(c_gi)
    s = scale or (1.0, 1.0)
    alpha_m, w_m = published(rec, s)
    b_a = effective_bias(cal.accelerometer) * s[0]
    b_g = effective_bias(cal.gyroscope) * s[1]
    a_i = np.linalg.solve(m_a, (alpha_m - b_a).T).T  # α_m = M_a a_i + b_a
    w_i = np.linalg.solve(m_g, (w_m - b_g - a_i @ (a_sens @ c_gi).T).T).T @ c_gi  # C_gyro_iᵀ M_g⁻¹ (…)
    expected = cal.apply(rec)
    r = kabsch(np.vstack([a_i, w_i]), np.vstack([expected.acc, expected.gyro]))
    assert_rotation(r)
    close(a_i, expected.acc @ r.T, 30)
    close(w_i, expected.gyro @ r.T, 6)
    np.testing.assert_allclose(np.linalg.norm(a_i, axis=1), np.linalg.norm(expected.acc, axis=1), rtol=1e-12)
    # the rotation between the frames is the one the exporter names
    said = float(re.search(r"rotation of ([0-9.e-]+) deg", " ".join(notes)).group(1))
    assert np.degrees(np.arccos((np.trace(r) - 1) / 2)) == pytest.approx(said, rel=1e-3)


# --------------------------------------------------------------------------- imu_tk
def imutk_apply(text: str, x):
    v = np.array(text.split(), dtype=float)
    assert v.size == 21
    t, k, b = v[:9].reshape(3, 3), v[9:18].reshape(3, 3), v[18:]
    return (x - b) @ (t @ k).T, t, k


@pytest.mark.parametrize("units", [("counts", "counts"), ("g", "deg/s")])
def test_imutk_files_applied_as_imutk_does_match_apply(units):
    rng = np.random.default_rng(8)
    cal = random_calibration(rng, *units, g_sensitivity=False, output_bias=True)
    rec = raw_samples(rng, cal)
    acc_text, gyro_text = to_imutk(cal)
    a, t_a, k_a = imutk_apply(acc_text, rec.acc)
    w, t_g, k_g = imutk_apply(gyro_text, rec.gyro)
    expected = cal.apply(rec)
    close(a, expected.acc, 30)
    close(w, expected.gyro, 6)
    for t, k in ((t_a, k_a), (t_g, k_g)):
        np.testing.assert_allclose(np.diag(t), 1.0, rtol=0, atol=1e-15)
        assert np.all(k == np.diag(np.diag(k)))
    assert acc_text.count("\n\n") == 3  # three blocks, as CalibratedTriad_::save writes them


# --------------------------------------------------------------------------- refusals
def test_shapes_a_format_cannot_hold_are_refused():
    rng = np.random.default_rng(2)
    cal = random_calibration(rng)
    cubic = cal.with_(accelerometer=cal.accelerometer.with_(scale_cubic=np.array([1e-5, 0, 0])))
    for export in (to_openvins, to_kalibr, lambda c: to_imutk(c.with_(gyroscope=c.gyroscope.with_(
            g_sensitivity=np.zeros((3, 3)))))):
        with pytest.raises(ExportError, match="linear model only.*accelerometer.*--model linear"):
            export(cubic)
    with pytest.raises(ExportError, match="imu_tk has no gyroscope g-sensitivity"):
        to_imutk(cal)
    counts = random_calibration(rng, "counts", "counts")
    with pytest.raises(ExportError, match="--raw-scale"):
        to_openvins(counts)
    with pytest.raises(ExportError, match="--raw-scale is for raw counts"):
        to_kalibr(cal, raw_scale=(1.0, 1.0))
    with pytest.raises(ExportError, match="model must be one of kalibr, rpng"):
        to_openvins(cal, model="imu2")


def test_wang_lower_triangular_accelerometer_exports_exactly():
    rng = np.random.default_rng(4)
    cal = random_calibration(rng, acc_shape="lower")
    rec = raw_samples(rng, cal)
    for model in ("kalibr", "rpng"):
        doc = load_yaml(to_openvins(cal, model=model)[0])
        a_i, _ = openvins_apply(doc, rec.acc, rec.gyro, effective_bias(cal.accelerometer),
                                effective_bias(cal.gyroscope))
        close(a_i, cal.apply(rec).acc, 30)


# ---------------------------------------------------------------------------- noise
def test_noise_entries_from_kalibr_yaml_and_from_noise_json(tmp_path):
    from imucalib.noise import kalibr_yaml

    acc = {"white_noise_density": [1e-3, 2e-3, 1.5e-3], "random_walk": [3e-4, 1e-4, 2e-4]}
    gyro = {"white_noise_density": [1e-4, 3e-4, 2e-4], "random_walk": [2e-5, 1e-5, 4e-5]}
    (tmp_path / "imu.yaml").write_text(kalibr_yaml(acc, gyro, 200.0, topic="/imu/data_raw")[0])
    doc = {"rate_hz": 200.0, "accelerometer": {"unit": "m/s^2", **acc}, "gyroscope": {"unit": "rad/s", **gyro}}
    (tmp_path / "noise.json").write_text(json.dumps(doc))
    cal = random_calibration(np.random.default_rng(1))
    for name in ("imu.yaml", "noise.json"):
        noise, _ = read_noise(tmp_path / name)
        imu = load_yaml(to_openvins(cal, noise=noise, rostopic="/imu0" if name == "noise.json" else None)[0])["imu0"]
        assert imu["accelerometer_noise_density"] == pytest.approx(2e-3, rel=1e-6)
        assert imu["accelerometer_random_walk"] == pytest.approx(3e-4, rel=1e-6)
        assert imu["gyroscope_noise_density"] == pytest.approx(3e-4, rel=1e-6)
        assert imu["gyroscope_random_walk"] == pytest.approx(4e-5, rel=1e-6)
        assert imu["update_rate"] == 200.0
        assert imu["rostopic"] == ("/imu/data_raw" if name == "imu.yaml" else "/imu0")
    doc["gyroscope"]["unit"] = "counts"
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with pytest.raises(ExportError, match="needs m/s\\^2 and rad/s.*--calibration"):
        read_noise(tmp_path / "bad.json")
    (tmp_path / "two.yaml").write_text("imu0:\n  gyroscope_noise_density: 1\nimu1:\n  gyroscope_noise_density: 2\n")
    with pytest.raises(ExportError, match="more than once"):
        read_noise(tmp_path / "two.yaml")


# ----------------------------------------------------------------------- command line
def test_export_command_writes_each_format(tmp_path, capsys):
    from imucalib.cli import main

    rng = np.random.default_rng(6)
    cal = random_calibration(rng, "counts", "counts", g_sensitivity=False)
    cal.save(tmp_path / "c.json")
    c = str(tmp_path / "c.json")
    assert main(["export", c, "--format", "openvins", "--raw-scale", "0.002,0.001", "--rostopic", "/imu",
                 "-o", str(tmp_path / "kalibr_imu_chain.yaml")]) == 0
    assert load_yaml((tmp_path / "kalibr_imu_chain.yaml").read_text())["imu0"]["rostopic"] == "/imu"
    assert main(["export", c, "--format", "kalibr", "--raw-scale", "1,1", "-o", str(tmp_path / "k.yaml")]) == 0
    assert "scale-misalignment" in (tmp_path / "k.yaml").read_text()
    assert main(["export", c, "-o", str(tmp_path / "xs.calib")]) == 0  # the suffix names imu_tk
    assert (tmp_path / "xs_acc.calib").is_file() and (tmp_path / "xs_gyro.calib").is_file()
    assert main(["export", c, "-o", str(tmp_path / "c.h")]) == 0
    assert "imucalib_apply(" in (tmp_path / "c.h").read_text()
    capsys.readouterr()
    for argv, message in (
            (["-o", str(tmp_path / "x.yaml")], "say which format"),
            (["--format", "openvins", "--prefix", "imu"], "--prefix does not apply to --format openvins"),
            (["--format", "openvins"], "give --raw-scale"),
            (["--format", "imutk"], "two files: give -o NAME"),
            (["--format", "kalibr", "--raw-scale", "1", "-o", str(tmp_path / "y.yaml")], "two numbers"),
            (["--format", "c", "-o", c], "input")):
        with pytest.raises(SystemExit) if "two numbers" in message else _nothing():
            code = main(["export", c, *argv])
            assert code == 2
        err = capsys.readouterr().err
        assert message in err, (argv, err)


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_notes_on_large_biases_and_noise_in_other_units_than_published():
    rng = np.random.default_rng(12)
    cal = random_calibration(rng, "counts", "counts")
    cal = cal.with_(accelerometer=cal.accelerometer.with_(bias=np.full(3, 32768.0)))  # an offset-binary zero
    noise = dict.fromkeys(("accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
                           "gyroscope_random_walk"), 1e-3)
    _, notes = to_openvins(cal, raw_scale=(9.81 / 4096, 1 / 900), noise=noise)
    assert any("biases are large" in n for n in notes)
    assert not any("off SI" in n for n in notes)  # the published readings are within 10 % of SI
    _, notes = to_kalibr(cal, raw_scale=(1.0, 1.0), noise=noise)
    assert any("accelerometer's published readings" in n and "off SI" in n for n in notes)
