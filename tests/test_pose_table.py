"""Tables of averaged poses: reading their layouts, calibrating the accelerometer from them, applying a calibration.

The truth is a simulated sensor (bias, scale factors, misalignment) whose poses are averaged with white noise
of a known σ over a known number of samples; the real case is the MPU-9150 session of
``shared/data/public/mpu9150_mikov`` averaged over the static poses the full calibration finds.
"""

import json
from pathlib import Path

import numpy as np
import pytest

import imucalib
from imucalib.cli import main
from imucalib.io import ReaderError, read_pose_table
from imucalib.io.posetable import PoseTable
from imucalib.models import TriadModel

G = 9.80665
DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
MIKOV = DATA / "public" / "mpu9150_mikov" / "imu0.log"
#: the simulated sensor in g: scale factors [m/s² per g], biases [g], upper-triangular misalignment
SCALE = G * np.array([1.02, 0.985, 1.01])
BIAS = np.array([0.03, -0.02, 0.05])
MISALIGNMENT = np.array([[1.0, 0.004, -0.006], [0.0, 1.0, 0.003], [0.0, 0.0, 1.0]])
SIGMA_G = 0.004  # one sample's noise [g]


def _truth(unit: str = "g", misaligned: bool = True) -> TriadModel:
    f = 1.0 if unit == "g" else G  # m/s²: the same sensor's readings × g
    return TriadModel(misalignment=MISALIGNMENT if misaligned else np.eye(3), scale=SCALE / f, bias=BIAS * f,
                      shape="upper")


def _directions(m: int, rng) -> np.ndarray:
    """The six faces, then random directions over the sphere."""
    d = np.vstack([np.eye(3), -np.eye(3), rng.normal(size=(max(m - 6, 0), 3))])[:m]
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def simulate(seed: int, m: int, unit: str = "g", misaligned: bool = True):
    """(truth, raw means, n, σ of one sample per axis as a table would estimate it)."""
    rng = np.random.default_rng(seed)
    truth = _truth(unit, misaligned)
    raw = truth.inverse(G * _directions(m, rng))
    n = rng.integers(200, 1000, size=m)
    sigma = SIGMA_G * (1.0 if unit == "g" else G)
    means = raw + rng.normal(size=(m, 3)) * sigma / np.sqrt(n)[:, None]
    # the samples' standard deviation as estimated from n samples: σ √(χ²_{n−1} / (n − 1))
    s = sigma * np.sqrt(rng.chisquare(n[:, None] - 1, size=(m, 3)) / (n[:, None] - 1))
    return truth, means, n, s


def z_scores(cal, truth) -> np.ndarray:
    est, unc, true = cal.parameters(), cal.fit["uncertainty"], truth.parameters("accelerometer")
    return np.array([(est[k] - true[k]) / unc[k] for k in unc])


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


# ------------------------------------------------------------------ the fit
def test_the_fit_recovers_the_truth_within_its_1_sigma_and_is_accepted():
    zs = []
    for seed, m in enumerate(range(12, 27)):
        truth, means, n, s = simulate(seed, m)
        cal = imucalib.calibrate(PoseTable(acc=means, acc_unit="g", n=n, acc_sigma=s))
        assert cal.method == "pose_table" and cal.gyroscope is None
        assert cal.fit["accelerometer_model"] == "linear" and len(cal.fit["uncertainty"]) == 9
        z = z_scores(cal, truth)
        assert np.all(np.abs(z) < 4), (m, z)
        zs.append(z)
        if m >= 14:  # 12 or 13 poses for 9 parameters are too few by the verdict's own rule (1.5 per parameter)
            assert cal.fit["verdict"] == "accepted", (m, cal.fit["verdict_reasons"])
        else:
            assert any("per parameter" in r for r in cal.fit["verdict_reasons"])
    rms = float(np.sqrt(np.mean(np.concatenate(zs) ** 2)))
    assert 0.8 < rms < 1.2, rms  # 135 z-scores: the 1σ are the errors' size, neither too small nor too large


def test_without_sigma_the_residual_scatter_weighs_and_the_verdict_says_so():
    truth, means, _, _ = simulate(3, 20)
    cal = imucalib.calibrate(PoseTable(acc=means, acc_unit="g"))
    assert np.all(np.abs(z_scores(cal, truth)) < 4)
    assert "accelerometer_noise_floor" not in cal.fit
    assert any("the table gives no σ" in note for note in cal.fit["verdict_notes"])
    assert cal.fit["verdict"] == "accepted"


def test_six_faces_fit_a_scale_and_a_bias_per_axis_as_eqs_8_9_and_say_so():
    truth, means, n, s = simulate(4, 6, misaligned=False)
    cal = imucalib.calibrate(PoseTable(acc=means, acc_unit="g", n=n, acc_sigma=s))
    assert cal.fit["accelerometer_model"] == "scale and bias per axis"
    assert np.array_equal(cal.accelerometer.misalignment, np.eye(3))
    assert set(cal.fit["uncertainty"]) == {f"accelerometer.{k}.{a}" for k in ("scale", "bias") for a in "xyz"}
    assert cal.fit["verdict"] == "suspect"
    assert any("reduced to scale and bias per axis" in r for r in cal.fit["verdict_reasons"])
    assert np.all(np.abs(z_scores(cal, truth)) < 4)
    # Ru 2022, eqs. (8)-(9) on the faces: b = (u₊ + u₋)/2, k = 2g/(u₊ − u₋), to the noise's second order
    up, down = means[np.arange(3), np.arange(3)], means[3 + np.arange(3), np.arange(3)]
    assert np.allclose(cal.accelerometer.bias, (up + down) / 2, rtol=0, atol=1e-6)
    assert np.allclose(cal.accelerometer.scale, 2 * G / (up - down), rtol=1e-6)


def test_poses_in_one_hemisphere_make_the_verdict_name_the_side_not_visited():
    truth, means, n, s = simulate(5, 24)
    keep = means[:, 2] > 0.0  # z never down
    cal = imucalib.calibrate(PoseTable(acc=means[keep], acc_unit="g", n=n[keep], acc_sigma=s[keep]))
    assert cal.fit["verdict"] in ("suspect", "rejected")
    assert any("do not visit −z" in r for r in cal.fit["verdict_reasons"])


def test_a_pose_table_takes_no_other_method():
    _, means, _, _ = simulate(6, 12)
    with pytest.raises(ValueError, match="pose means"):
        imucalib.calibrate(PoseTable(acc=means, acc_unit="g"), method="ellipsoid")


# ------------------------------------------------------------------ layouts
def _write(path: Path, rows: list[list[str]], sep: str, header: list[str] | None = None) -> Path:
    lines = ([sep.join(header)] if header else []) + [sep.join(r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_layouts_in_g_with_a_header_and_in_si_without_one_give_the_same_sensor(tmp_path):
    truth, means, n, s = simulate(7, 18)
    g_rows = [[f"P{k}", *(f"{v:.7f}" for v in means[k]), str(n[k]), *(f"{v:.6f}" for v in s[k])]
              for k in range(18)]
    g_path = _write(tmp_path / "g.csv", g_rows, ",",
                    ["pose", "ax [g]", "ay [g]", "az [g]", "n", "std_ax", "std_ay", "std_az"])
    si_rows = [[*(f"{G * v:.7f}" for v in means[k]), str(n[k]), f"{G * s[k].mean():.6f}"] for k in range(18)]
    si_path = _write(tmp_path / "si.tsv", si_rows, "\t")
    plain = _write(tmp_path / "plain.txt", [[f"{v:.7f}" for v in means[k]] for k in range(18)], " ")

    g = read_pose_table(g_path)
    assert g.acc_unit == "g" and g.labels[0] == "P0" and g.n[3] == n[3] and g.notes == ()
    assert np.allclose(g.acc_sigma, s, atol=1e-6)
    si = imucalib.read(si_path, poses=True)
    assert isinstance(si, PoseTable) and si.acc_unit == "m/s^2" and si.source.sep == "\t"
    assert any("no header" in note and "ax ay az n sigma" in note for note in si.notes)
    assert any("recognised from the poses' norms" in note for note in si.notes)
    assert np.allclose(si.acc_sigma[:, 0], si.acc_sigma[:, 2])  # one σ column for the three axes
    bare = read_pose_table(plain)
    assert bare.acc_unit == "g" and bare.n is None and bare.acc_sigma is None
    assert read_pose_table(plain, acc_unit="counts").acc_unit == "counts"

    cal_g, cal_si = imucalib.calibrate(g), imucalib.calibrate(si)
    assert cal_g.units["accelerometer"]["raw"] == "g" and cal_si.units["accelerometer"]["raw"] == "m/s^2"
    assert np.all(np.abs(z_scores(cal_g, truth)) < 4)
    assert np.all(np.abs(z_scores(cal_si, _truth("m/s^2"))) < 4)
    # the same sensor: the two calibrations map the same readings (× g) to the same specific force
    assert np.allclose(cal_g.accelerometer_si(means), cal_si.accelerometer_si(G * means), atol=3e-3)


def test_header_names_units_and_a_gyroscope(tmp_path):
    _, means, n, s = simulate(8, 15)
    gyro = np.full((15, 3), 0.5) + np.random.default_rng(8).normal(size=(15, 3)) * 0.01
    rows = [[*(f"{v:.7f}" for v in means[k]), *(f"{v:.5f}" for v in gyro[k]), str(n[k]), f"{s[k, 0]:.6f}"]
            for k in range(15)]
    path = _write(tmp_path / "t.csv", rows, ";",
                  ["acc_x (g)", "acc_y (g)", "acc_z (g)", "gyro_x [deg/s]", "gyro_y [deg/s]", "gyro_z [deg/s]",
                   "samples", "sigma"])
    table = read_pose_table(path)
    assert (table.acc_unit, table.gyro_unit) == ("g", "deg/s") and table.notes == ()
    cal = imucalib.calibrate(table)
    assert cal.gyroscope is None and "no rotation" in cal.fit["gyroscope_not_calibrated"]
    assert np.allclose(cal.fit["gyroscope_rest_mean"], gyro.mean(axis=0), atol=1e-5)
    assert np.allclose(cal.fit["gyroscope_rest_mean_sigma"], gyro.std(axis=0, ddof=1) / np.sqrt(15), rtol=1e-3)
    assert cal.fit["gyroscope_rest_mean_unit"] == "deg/s"


def test_a_headerless_table_with_a_gyroscope_n_and_a_sigma_per_axis(tmp_path):
    _, means, n, s = simulate(11, 10)
    gyro = np.random.default_rng(11).normal(size=(10, 3)) * 0.01
    rows = [[*(f"{v:.7f}" for v in means[k]), *(f"{v:.5f}" for v in gyro[k]), str(n[k]),
             *(f"{v:.6f}" for v in s[k])] for k in range(10)]
    table = read_pose_table(_write(tmp_path / "t.csv", rows, ","), gyro_unit="rad/s")
    assert table.source.names == ("ax", "ay", "az", "gx", "gy", "gz", "n", "sigma_x", "sigma_y", "sigma_z")
    assert np.array_equal(table.n, n) and np.allclose(table.gyro, gyro, atol=1e-5)
    assert np.allclose(table.acc_sigma, s, atol=1e-6) and table.gyro_unit == "rad/s"
    bare = _write(tmp_path / "n.csv", [[*(f"{v:.7f}" for v in means[k]), str(n[k])] for k in range(10)], ",")
    assert read_pose_table(bare).source.names == ("ax", "ay", "az", "n")


def test_tables_that_cannot_be_read_say_where_and_why(tmp_path):
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("ax,ay,az\n0.1,0.0,1.0\n0.0,1.0\n")
    with pytest.raises(ReaderError, match="line 3: 2 columns where the first pose has 3"):
        read_pose_table(ragged)
    nameless = tmp_path / "nameless.csv"
    nameless.write_text("a,b,c\n0.1,0.0,1.0\n")
    with pytest.raises(ReaderError, match="no column named ax or ay or az"):
        read_pose_table(nameless)
    text = tmp_path / "text.csv"
    text.write_text("ax,ay,az\n0.1,0.0,1.0\n0.1,oops,1.0\n")
    with pytest.raises(ReaderError, match="line 3: the column 'ay' holds 'oops'"):
        read_pose_table(text)


# ------------------------------------------------------------------ command line, apply
def test_calibrate_and_apply_round_trip_through_the_command_line(tmp_path, capsys):
    truth, means, n, s = simulate(9, 20)
    rows = [[*(f"{v:.8f}" for v in means[k]), str(n[k]), *(f"{v:.6f}" for v in s[k])] for k in range(20)]
    table = _write(tmp_path / "poses.tsv", rows, "\t",
                   ["ax [g]", "ay [g]", "az [g]", "n", "sigma_x", "sigma_y", "sigma_z"])
    cal_path, out = tmp_path / "cal.json", tmp_path / "corrected.tsv"
    code, text, _ = run(capsys, "calibrate", table, "--poses", "-o", cal_path)
    assert code == 0 and "verdict: ACCEPTED" in text and "method: pose_table" in text
    api = imucalib.calibrate(imucalib.read(table, poses=True))
    saved = imucalib.Calibration.load(cal_path)
    assert saved.parameters() == pytest.approx(api.parameters(), rel=1e-12, abs=1e-15)

    code, text, _ = run(capsys, "apply", cal_path, table, "--poses", "-o", out)
    assert code == 0 and "wrote 20 calibrated poses" in text
    source, written = table.read_text().splitlines(), out.read_text().splitlines()
    assert written[0] == source[0] + "\tacc_x_cal [m/s^2]\tacc_y_cal [m/s^2]\tacc_z_cal [m/s^2]"
    assert all(w.startswith(r + "\t") for r, w in zip(source[1:], written[1:], strict=True))
    calibrated = np.array([[float(c) for c in w.split("\t")[-3:]] for w in written[1:]])
    sigma_r = G * SIGMA_G / np.sqrt(n)
    assert np.all(np.abs(np.linalg.norm(calibrated, axis=1) - G) < 5 * sigma_r)
    # the corrected table reads back as a pose table (its calibrated columns not read as means)
    assert np.array_equal(read_pose_table(out).acc, read_pose_table(table).acc)

    code, _, err = run(capsys, "apply", cal_path, table, "--poses", "-o", table)
    assert code == 2 and "error" in err
    code, _, err = run(capsys, "apply", cal_path, table, "--poses", "--acc-unit", "m/s^2", "-o", out)
    assert code == 2 and "--acc-unit g" in err


def test_apply_writes_a_headerless_table_with_a_header_of_its_own(tmp_path, capsys):
    _, means, _, _ = simulate(10, 16)
    table = _write(tmp_path / "bare.txt", [[f"{v:.8f}" for v in means[k]] for k in range(16)], " ")
    table.write_text("% six and more poses, in g\n" + table.read_text())
    cal_path, out = tmp_path / "cal.json", tmp_path / "out.txt"
    assert run(capsys, "calibrate", table, "--poses", "-o", cal_path)[0] == 0
    assert run(capsys, "apply", cal_path, table, "--poses", "-o", out)[0] == 0
    lines = out.read_text().splitlines()
    assert lines[0] == "% six and more poses, in g"
    assert lines[1] == "ax[g] ay[g] az[g] acc_x_cal[m/s^2] acc_y_cal[m/s^2] acc_z_cal[m/s^2]"
    assert len(lines) == 18


# ------------------------------------------------------------------ real data
def test_a_table_of_a_real_sessions_poses_gives_the_full_calibrations_accelerometer(tmp_path, capsys):
    if not MIKOV.exists():
        pytest.skip(f"{MIKOV} not present (fresh clone): real-data test skipped")
    full_path = tmp_path / "full.json"
    code, _, _ = run(capsys, "calibrate", MIKOV, "--rate", 100, "--acc-unit", "m/s^2", "--gyro-unit", "rad/s",
                     "-o", full_path)
    assert code == 0
    full = imucalib.Calibration.load(full_path)
    samples = np.loadtxt(MIKOV)
    rows = []
    for a, b in full.fit["intervals"]:
        pose = samples[a:b]
        rows.append([*(repr(float(v)) for v in pose.mean(axis=0)), str(b - a),
                     *(repr(float(v)) for v in pose[:, :3].std(axis=0, ddof=1))])
    table = _write(tmp_path / "poses.csv", rows, ",",
                   ["ax", "ay", "az", "gx", "gy", "gz", "n", "sigma_ax", "sigma_ay", "sigma_az"])
    cal_path = tmp_path / "table.json"
    code, text, _ = run(capsys, "calibrate", table, "--poses", "--acc-unit", "m/s^2", "--gyro-unit", "rad/s",
                        "-o", cal_path)
    assert code == 0 and "verdict: ACCEPTED" in text
    cal = imucalib.Calibration.load(cal_path)
    assert cal.fit["static_intervals"] == len(full.fit["intervals"]) >= 20
    unc, mine, theirs = cal.fit["uncertainty"], cal.parameters(), full.parameters()
    assert len(unc) == 9
    for name, sigma in unc.items():
        assert abs(mine[name] - theirs[name]) < 2 * sigma, (name, mine[name], theirs[name], sigma)
    # the gyroscope's rest mean over the poses is the full calibration's bias, within its standard error
    rest, se = np.array(cal.fit["gyroscope_rest_mean"]), np.array(cal.fit["gyroscope_rest_mean_sigma"])
    assert np.all(np.abs(rest - full.gyroscope.bias) < 3 * se)
    assert json.loads(cal_path.read_text())["units"] == {"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"}}
    # the full calibration applied to the table (its units taken from the calibration, the header having none):
    # the poses' calibrated |a| is g to its residual, their calibrated rate at rest nil to the rests' scatter
    out = tmp_path / "corrected.csv"
    code, _, err = run(capsys, "apply", full_path, table, "--poses", "-o", out)
    assert code == 0 and "warning" not in err
    lines = out.read_text().splitlines()
    assert lines[0].endswith(",gyro_x_cal [rad/s],gyro_y_cal [rad/s],gyro_z_cal [rad/s]")
    cells = np.array([[float(c) for c in line.split(",")[-6:]] for line in lines[1:]])
    assert np.sqrt(np.mean((np.linalg.norm(cells[:, :3], axis=1) - G) ** 2)) < 2 * full.fit[
        "accelerometer_residual_rms"]
    assert np.all(np.abs(cells[:, 3:].mean(axis=0)) < 3 * se)
