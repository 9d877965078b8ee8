"""Recordings in the shapes people have, each compared with the same data in the plain form.

Short initial rests, accelerometer-only logs (with and without a time
column), pose blocks separated by prompt lines, one file per face, thin
hand-held sessions whose poses wobble, and headers whose units disagree
with the data.
"""

import json
import warnings

import numpy as np
import pytest

from imucalib.cli import main
from imucalib.io import write_csv
from imucalib.methods import calibrate
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import session
from imucalib.segment import find_initial_rest

G = 9.80665


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


# ---------------------------------------------------------------- short initial rest
@pytest.fixture(scope="module")
def short_rest():
    return session("handheld", rng=7, rest=1.5, n_poses=20)


def test_short_rest_is_found_with_a_note(short_rest):
    rec = short_rest.recording
    true_end = short_rest.segments[0].stop  # the first motion starts here
    with pytest.warns(ImucalibWarning, match=r"initial rest is about 1\.[0-9]* s, shorter than the 2 s"):
        rest = find_initial_rest(rec)
    assert 1.0 * rec.rate <= rest.stop <= true_end  # never reaches into the motion
    for too_short in (0.7,):
        sim = session("handheld", rng=7, rest=too_short, n_poses=3)
        with pytest.raises(ValueError, match="at least 1 s at rest"):
            find_initial_rest(sim.recording)


def test_long_rest_is_found_as_before():
    sim = session("handheld", rng=8, rest=30.0, n_poses=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImucalibWarning)  # no note for a rest the detector likes
        rest = find_initial_rest(sim.recording)
    # the first look's margin: the first motion less a full window (1 s)
    end, rate = sim.segments[0].stop, sim.recording.rate
    assert end - 1.5 * rate <= rest.stop <= end - 0.5 * rate


def test_short_rest_calibrates_as_with_init_static(short_rest):
    rec = short_rest.recording
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        auto = calibrate(rec, method="tedaldi2014")
        given = calibrate(rec, method="tedaldi2014", init_static=1.2)  # the plain form: the rest's length given
    truth = short_rest.truth
    for cal in (auto, given):
        np.testing.assert_allclose(cal.accelerometer.scale, truth.accelerometer.scale, rtol=5e-3)
    assert auto.fit["static_intervals"] == given.fit["static_intervals"]
    np.testing.assert_allclose(auto.accelerometer.scale, given.accelerometer.scale, rtol=1e-3)


def test_noise_and_compare_take_init_static(capsys, tmp_path, short_rest):
    path = tmp_path / "short.csv"
    write_csv(path, short_rest.recording)
    code, out, err = run(capsys, "noise", path, "--init-static", "1.2", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["samples"] == int(round(1.2 * short_rest.recording.rate))
    code, out, err = run(capsys, "noise", path, "--json")  # found automatically, with the note
    assert code == 0, err
    assert "shorter than the 2 s the detector would like" in err
    code, out, err = run(capsys, "compare", path, "--init-static", "1.2", "--methods", "ellipsoid",
                         "--folds", "2", "--json")
    assert code == 0, err
    assert json.loads(out)["methods"][0]["ok"]


# ---------------------------------------------------------------- a header that disagrees with the data
def _si_csv(path, rec, acc_name):
    """``rec`` (m/s², rad/s) as a CSV file whose accelerometer columns are named ``acc_name.format(axis)``."""
    header = ",".join(["t [s]", *(acc_name.format(a) for a in "XYZ"), *(f"g{a} [rad/s]" for a in "xyz")])
    np.savetxt(path, np.column_stack([rec.t, rec.acc, rec.gyro]), fmt="%.10g", delimiter=",", header=header,
               comments="")


def test_a_unit_option_wins_over_a_mislabelled_header(capsys, tmp_path):
    sim = session("handheld", rng=3, n_poses=16, rest=5.0)
    truth = sim.truth
    si = truth.apply(sim.recording)  # the same session in m/s^2 and rad/s
    _si_csv(tmp_path / "plain.csv", si, "a{} (m/s^2)")
    _si_csv(tmp_path / "wrong.csv", si, "a{} (g)")  # the header says g over values in m/s^2
    code, out, err = run(capsys, "calibrate", tmp_path / "plain.csv", "--method", "ellipsoid", "--json")
    assert code in (0, 3), err
    plain = json.loads(out)
    code, out, err = run(capsys, "calibrate", tmp_path / "wrong.csv", "--method", "ellipsoid", "--acc-unit", "m/s^2",
                         "--json")
    assert code in (0, 3), err
    assert "--acc-unit m/s^2 overrides the header" in err and "the option is right" in err, err
    assert json.loads(out)["accelerometer"] == plain["accelerometer"]
    code, out, err = run(capsys, "calibrate", tmp_path / "wrong.csv", "--method", "ellipsoid", "--json")
    assert "raw |a| at rest is" in json.dumps(json.loads(out)["fit"]["verdict_reasons"])  # read as g: told
    code, out, err = run(capsys, "calibrate", tmp_path / "plain.csv", "--method", "ellipsoid", "--acc-unit", "g")
    assert "the header looks right, drop --acc-unit" in err, err


# ---------------------------------------------------------------- accelerometer-only logs
@pytest.fixture(scope="module")
def acc_only(tmp_path_factory):
    """A hand-held session as the plain file (with the gyroscope) and as accelerometer-only logs."""
    d = tmp_path_factory.mktemp("acc_only")
    sim = session("handheld", rng=3, n_poses=20, rest=5.0)
    rec = sim.recording
    write_csv(d / "plain.csv", rec)
    np.savetxt(d / "acc_t.csv", np.column_stack([rec.t, rec.acc]), fmt="%.10g", delimiter=",",
               header="t,ax,ay,az", comments="")
    np.savetxt(d / "acc.txt", rec.acc, fmt="%.10g")  # no header, no time: 100 Hz
    return d, sim


def _calibrate_json(capsys, *args):
    code, out, err = run(capsys, "calibrate", *args, "--json")
    assert code in (0, 3), err
    return json.loads(out), err


@pytest.mark.parametrize("method", ["ellipsoid", "tedaldi2014"])
def test_accelerometer_only_calibrates_as_the_plain_file(capsys, acc_only, method):
    d, sim = acc_only
    plain, _ = _calibrate_json(capsys, d / "plain.csv", "--method", method)
    timed, err = _calibrate_json(capsys, d / "acc_t.csv", "--method", method)
    assert "no gyroscope columns" in err and "accelerometer-only" in err
    untimed, _ = _calibrate_json(capsys, d / "acc.txt", "--columns", "-,0,1,2", "--rate", "100", "--method", method)
    truth = sim.truth.accelerometer.scale
    for doc in (timed, untimed):
        assert doc["gyroscope"] is None and "gyroscope" not in doc["units"]
        assert doc["fit"]["verdict"] == "accepted", doc["fit"]["verdict_reasons"]
        assert any("no gyroscope" in n for n in doc["fit"]["verdict_notes"])
        # the same poses as the plain file's, less the gyroscope's gate: scales agree to 0.01 %
        np.testing.assert_allclose(doc["accelerometer"]["scale"], plain["accelerometer"]["scale"], rtol=1e-4)
        np.testing.assert_allclose(doc["accelerometer"]["bias"], plain["accelerometer"]["bias"], atol=1.0)  # counts
        np.testing.assert_allclose(doc["accelerometer"]["scale"], truth, rtol=1e-3)
    assert plain["gyroscope"] is not None


def test_accelerometer_only_six_position_matches_the_plain_file():
    sim = session("handheld", rng=4, procedure="ferraris")
    rec = sim.recording
    from imucalib.recording import Recording

    acc = Recording(t=rec.t, acc=rec.acc, gyro=None, acc_unit=rec.acc_unit)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        plain = calibrate(rec, method="six_position")
        alone = calibrate(acc, method="six_position")
    assert alone.gyroscope is None and plain.gyroscope is not None
    np.testing.assert_allclose(alone.accelerometer.scale, plain.accelerometer.scale, rtol=1e-4)
    np.testing.assert_allclose(alone.accelerometer.scale, sim.truth.accelerometer.scale, rtol=5e-3)


def test_accelerometer_only_commands(capsys, acc_only, tmp_path):
    d, sim = acc_only
    code, out, err = run(capsys, "calibrate", d / "acc_t.csv", "--method", "ellipsoid", "-o", tmp_path / "a.json")
    assert code == 0, err
    assert "gyroscope: none (an accelerometer-only recording)" in out
    from imucalib.calibration import Calibration

    cal = Calibration.load(tmp_path / "a.json")  # the file format reads it back
    assert cal.gyroscope is None
    code, out, err = run(capsys, "apply", tmp_path / "a.json", d / "acc_t.csv", "-o", tmp_path / "out.csv")
    assert code == 0, err
    out_csv = np.genfromtxt(tmp_path / "out.csv", delimiter=",", names=True)
    np.testing.assert_allclose(np.column_stack([out_csv[f"acc_{a}_cal_ms2"] for a in "xyz"]),
                               cal.accelerometer_si(sim.recording.acc), rtol=1e-9)
    assert "gyro" not in "".join(out_csv.dtype.names)
    code, out, err = run(capsys, "apply", tmp_path / "a.json", d / "acc.txt", "--columns", "-,0,1,2", "--rate", "100",
                         "-o", tmp_path / "out2.csv")
    assert code == 0, err
    code, out, err = run(capsys, "export", tmp_path / "a.json", "-o", tmp_path / "a.h")
    assert code == 0 and "the gyroscope part of the C99 header is the identity" in err, err
    code, out, err = run(capsys, "noise", d / "acc_t.csv", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert "gyroscope" not in doc and len(doc["accelerometer"]["white_noise_density"]) == 3
    code, out, err = run(capsys, "compare", d / "acc_t.csv", "--folds", "2", "--json")
    assert code == 0, err
    doc = json.loads(out)
    ran = {r["method"] for r in doc["methods"] if r["ok"]}
    assert ran == {"ellipsoid", "tedaldi2014"} and doc["best"] in ran  # six_position: no faces in these poses
    assert all(r["cv_gyroscope_angle_error_mean_deg"] is None for r in doc["methods"])
    code, out, err = run(capsys, "calibrate", d / "acc_t.csv", "--method", "zhang2021")
    assert code == 2 and "accelerometer-only; the methods that take it are ellipsoid, six_position, tedaldi2014" \
        in err, err


def test_columns_for_an_accelerometer_only_log_are_checked(capsys, acc_only):
    d, _ = acc_only
    for columns, words in (("t,ax,ay", "--columns needs 7 entries"), ("t,ax,-,az", "the accelerometer's columns"),
                           ("t,ax,ay,az,gx,-,-", "give all three gyroscope columns")):
        code, out, err = run(capsys, "calibrate", d / "plain.csv", "--columns", columns)
        assert code == 2 and words in err, err


# ---------------------------------------------------------------- pose blocks: prompt lines, one file per face
FACES = ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a")  # x up, x down, … as MATLAB's accelcal(XUP, XDOWN, …) takes them


@pytest.fixture(scope="module")
def faces(tmp_path_factory):
    """The six faces of a hand-held session as six files, as one file of prompt-separated blocks, and the plain
    result: six_position on the same samples given as intervals of the whole recording's accelerometer (with
    the rotations between the faces, six_position also estimates the accelerometer's misalignment, which the
    blocks, recorded without them, cannot)."""
    from dataclasses import replace

    from imucalib.recording import Interval

    d = tmp_path_factory.mktemp("faces")
    # no hold creeps: each face's file is then still throughout and its pose is the whole file (a block whose
    # start holds the hand's settle is cut to its still part: tests/test_blocks_motion.py)
    sim = session("handheld", rng=4, procedure="ferraris", creep=0)
    rec = sim.recording
    ivs = [Interval(*sim.options["sections"][k]) for k in FACES]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        plain = calibrate(replace(rec, gyro=None), method="six_position",
                          intervals=sorted(ivs, key=lambda iv: iv.start))
    files = []
    with open(d / "prompts.csv", "w") as log:
        log.write("t,ax,ay,az,gx,gy,gz\n")
        for k, iv in zip(FACES, ivs, strict=True):
            part = rec[iv]
            files.append(d / f"{k}.csv")  # each face's file with its own time base, from 0
            np.savetxt(files[-1], np.column_stack([part.t - part.t[0], part.acc]), fmt="%.10g", delimiter=",",
                       header="t,ax,ay,az", comments="")
            log.write(f">>> Place the board with {k} and press a key. Gathering data for 5 seconds...\n")
            np.savetxt(log, np.column_stack([part.t - part.t[0], part.acc, part.gyro]), fmt="%.10g", delimiter=",")
            log.write("--- done ---\n")
    return d, sim, ivs, plain, files


def test_six_face_files_are_six_poses(capsys, faces):
    d, sim, ivs, plain, files = faces
    code, out, err = run(capsys, "calibrate", *files, "--method", "six_position", "--json")
    assert code == 0, err
    assert "read 6 files as blocks of one recording, one pose each" in err
    doc = json.loads(out)
    assert doc["fit"]["static_intervals"] == 6 and doc["gyroscope"] is None
    assert [b - a for a, b in doc["fit"]["intervals"]] == [len(iv) for iv in ivs]  # each file is one pose, whole
    # the same samples as the plain recording's faces: the same means, the same calibration
    np.testing.assert_allclose(doc["accelerometer"]["scale"], plain.accelerometer.scale, rtol=1e-12)
    np.testing.assert_allclose(doc["accelerometer"]["bias"], plain.accelerometer.bias, rtol=0, atol=1e-9)
    np.testing.assert_allclose(doc["accelerometer"]["scale"], sim.truth.accelerometer.scale, rtol=5e-3)


def test_prompt_lines_cut_blocks(capsys, faces, tmp_path):
    d, sim, ivs, plain, _ = faces
    code, out, err = run(capsys, "calibrate", d / "prompts.csv", "--method", "six_position", "--json",
                         "-o", tmp_path / "c.json")
    assert code == 0, err
    assert "12 lines inside the data that are not rows (a logger's prompts) cut the rows into 6 blocks" in err
    assert "the time restarts in 5 of the 6 blocks" in err
    doc = json.loads(out)
    assert doc["fit"]["static_intervals"] == 6
    np.testing.assert_allclose(doc["accelerometer"]["scale"], plain.accelerometer.scale, rtol=1e-12)
    # no rotations were recorded between the blocks: the gyroscope is left out, and the verdict says why
    assert doc["gyroscope"] is None
    assert any("separate blocks" in n for n in doc["fit"]["verdict_notes"])
    code, out, err = run(capsys, "apply", tmp_path / "c.json", d / "prompts.csv", "-o", tmp_path / "out.csv")
    assert code == 0 and "gyroscope columns are copied uncalibrated" in err, err
    written = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)
    rows = np.concatenate([sim.recording[iv].acc for iv in ivs])
    np.testing.assert_array_equal(written[:, 1:4], rows)  # every row, in the file's order
    np.testing.assert_allclose(written[:len(ivs[0]), 0], sim.recording[ivs[0]].t - sim.recording[ivs[0]].t[0],
                               atol=1e-9)  # the file's own times, not the shifted ones


@pytest.mark.parametrize("method", ["ellipsoid", "tedaldi2014"])
def test_fewer_poses_than_the_model_needs_reduce_it(faces, method):
    """Six faces determine a scale and a bias per axis, not the misalignment: the model the poses determine."""
    from imucalib.io import read

    d, sim, ivs, plain, files = faces
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(read(files), method=method)
    assert cal.fit["accelerometer_model"] == "scale and bias per axis"
    assert cal.fit["verdict"] == "suspect"
    assert any("reduced to scale and bias per axis" in r for r in cal.fit["verdict_reasons"])
    np.testing.assert_array_equal(cal.accelerometer.misalignment, np.eye(3))
    # six faces determine it exactly: the same numbers as six_position's eqs. 8-9 with their tilt correction
    np.testing.assert_allclose(cal.accelerometer.scale, plain.accelerometer.scale, rtol=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        with pytest.raises(ValueError, match="no accelerometer model is determined by these 3 static poses"):
            calibrate(read(files[:3]), method=method)


# ---------------------------------------------------------------- a thin hand-held session whose poses wobble
@pytest.fixture(scope="module")
def wobbly(tmp_path_factory):
    """10 hand-held poses held with 1 °/s of tremor, in raw counts; as a logger's file with 4 preamble rows."""
    d = tmp_path_factory.mktemp("wobbly")
    sim = session("handheld", rng=1, n_poses=10, tremor=1.0, rest=5.0)
    rec = sim.recording
    write_csv(d / "plain.csv", rec)
    text = (d / "plain.csv").read_text()
    (d / "mpu6050.csv").write_text("MPU-6050 logger\nFs,100\naccel range,2g\ngyro range,250dps\n" + text)
    return d, sim


def test_the_gate_drops_wobbly_poses(wobbly):
    """What the calibration has to cope with: the gyroscope's gate alone leaves too few poses."""
    from imucalib.segment import detect_intervals, gyro_still
    from imucalib.segment.detect import make_detector as _detector
    from imucalib.segment.detect import scan_thresholds as _scan

    _, sim = wobbly
    rec = sim.recording
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        intervals, _, rest, model = detect_intervals(rec, G)
    assert len(intervals) >= 10  # every hand-held pose and the rest, kept for the accelerometer
    from imucalib.fit.gyroscope import rough_scale

    scale = rough_scale(rec, intervals, model, rec.gyro[rest.slice].mean(axis=0))
    still = gyro_still(rec, rest, scale, intervals)
    with pytest.raises(ValueError, match="too few static intervals"):
        _scan(_detector(rec, rest, 1.0, 1.0), G, rec, range(2, 11), 1.0, still, reduce=False)


@pytest.mark.parametrize("method", ["tedaldi2014", "ellipsoid"])
def test_wobbly_poses_are_kept_for_the_accelerometer(capsys, wobbly, method):
    d, sim = wobbly
    code, out, err = run(capsys, "calibrate", d / "mpu6050.csv", "--method", method, "--json")
    assert code == 0, err  # calibrated, not refused
    assert "skipped 4 lines before the header" in err
    doc = json.loads(out)
    plain, _ = _calibrate_json(capsys, d / "plain.csv", "--method", method)
    assert doc["accelerometer"] == plain["accelerometer"] and doc["gyroscope"] == plain["gyroscope"]
    assert doc["fit"]["static_intervals"] >= 10
    np.testing.assert_allclose(doc["accelerometer"]["scale"], sim.truth.accelerometer.scale, rtol=5e-3)
    np.testing.assert_allclose(doc["gyroscope"]["scale"], sim.truth.gyroscope.scale, rtol=2e-2)
    # a thin session is not trusted blindly: the verdict says why
    assert doc["fit"]["verdict"] == "suspect"
    assert any("static poses for 9 accelerometer parameters" in r for r in doc["fit"]["verdict_reasons"])


def test_pose_weights_follow_the_scatter(wobbly):
    from imucalib.segment import pose_scatter

    _, sim = wobbly
    rec = sim.recording
    static = [s for s in sim.segments if s.kind == "static"]
    sigma = pose_scatter(rec.acc, static)
    # independent: the standard error of each pose's mean, axis by axis
    for iv, s in zip(static, sigma, strict=True):
        se = rec.acc[iv.slice].std(axis=0) / np.sqrt(len(iv))
        assert s == pytest.approx(float(np.linalg.norm(se)), rel=1e-9)
    assert sigma[1:].min() > sigma[0]  # the tremor of the hand-held poses, not on the table at rest


def test_an_edge_that_creeps_is_left_out_of_the_gyroscope_only():
    """A pose whose start settles by about 1° biases the rotations that touch it, not its mean."""
    from imucalib.segment import unreliable_transitions, unsteady_poses

    sim = session("handheld", rng=2, n_poses=12, creep=3, tremor=0.15, rest=5.0)
    rec = sim.recording
    static = [s for s in sim.segments if s.kind == "static"]
    found = unsteady_poses(rec, static)
    creeping = {c["static"] for c in sim.options["creep_sections"]}  # indices of the static segments
    assert all(static[c["static"]].start == c["range"][0] for c in sim.options["creep_sections"])
    assert len(creeping) == 3 and set(found) == creeping  # and no pose held without creeping
    ex = unreliable_transitions(rec, static)
    for k in creeping:
        assert k - 1 in ex and (k in ex or k == len(static) - 1)


def test_a_mat_file_uses_its_magnetometer_and_temperature_and_names_what_it_leaves(tmp_path):
    from scipy.io import savemat

    from imucalib.io import read
    from imucalib.reading import read as read_data

    sim = session("handheld", rng=6, n_poses=3, rest=3.0, magnetometer=True)
    rec = sim.recording
    temp = 25.0 + 0.01 * np.arange(len(rec))
    imu = np.column_stack([rec.t, rec.acc, rec.gyro, rec.acc[:, :2]])  # two columns no field reads
    savemat(tmp_path / "s.mat", {"imu": imu, "mag": rec.mag, "temperature": temp[:, None], "note": "bench 3"})
    with pytest.warns(ImucalibWarning, match=r"not used: columns 7, 8 \(0-based\) of 'imu'.*the variable 'note'"):
        got = read_data(tmp_path / "s.mat", variable="imu")
    np.testing.assert_array_equal(got.mag, rec.mag)  # the plain form: the same samples as the recording's
    np.testing.assert_array_equal(got.temperature, temp)
    np.testing.assert_array_equal(got.acc, rec.acc)
    savemat(tmp_path / "acc.mat", {"acc": np.column_stack([rec.t, rec.acc])})  # an accelerometer-only matrix
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        alone = read(tmp_path / "acc.mat", columns=["0", "1", "2", "3"])
    assert alone.gyro is None
    np.testing.assert_array_equal(alone.acc, rec.acc)


def test_validate_takes_an_accelerometer_only_calibration(capsys, acc_only, tmp_path):
    d, _ = acc_only
    code, out, err = run(capsys, "calibrate", d / "acc_t.csv", "--method", "ellipsoid", "-o", tmp_path / "a.json")
    assert code == 0, err
    code, out, err = run(capsys, "validate", tmp_path / "a.json", d / "acc_t.csv", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["verdict"] == "accepted"


def test_prompts_with_numbers_in_a_blank_separated_log_are_block_boundaries(tmp_path, faces):
    """A logger's prompt that holds numbers ("Gathering data for 10 seconds", "pose 3 of 6, 10 s") is a boundary
    in a blank-separated log too: the same six blocks, the same numbers as the comma-separated file."""
    from imucalib.io import read

    d, sim, ivs, plain, files = faces
    path = tmp_path / "prompts.txt"
    with open(path, "w") as log:
        for i, iv in enumerate(ivs):
            part = sim.recording[iv]
            log.write(f">>> Pose {i + 1} of 6, hold still. Gathering data for 10 seconds...\n")
            np.savetxt(log, np.column_stack([part.t - part.t[0], part.acc, part.gyro]), fmt="%.10g", delimiter=" ")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImucalibWarning)
        rec = read(path)
    # the first prompt stands before the data (a preamble); the five others cut the rows into six blocks
    assert any("5 lines inside the data that are not rows (a logger's prompts) cut the rows into 6 blocks"
               in str(w.message) for w in caught), [str(w.message) for w in caught]
    _same_six_position(rec, plain)


def _same_six_position(rec, plain):
    """six_position on ``rec`` gives the plain per-face result to 1e-12."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(rec, method="six_position")
    np.testing.assert_allclose(cal.accelerometer.scale, plain.accelerometer.scale, rtol=1e-12)
    np.testing.assert_allclose(cal.accelerometer.bias, plain.accelerometer.bias, rtol=1e-12)


@pytest.mark.parametrize("sep, prompt", [
    (" ", ">>> Pose {i}: gathering data for 10s..."),  # seven words, like the seven numbers of a row
    (",", "Pose {i},hold,it,still,then,press,enter"),  # seven cells, no prose marks: begins as the later prompts do
])
def test_a_first_prompt_as_wide_as_the_rows_is_not_a_header(tmp_path, faces, sep, prompt):
    """A headerless log whose first line is a prompt that splits into as many cells as the rows: none of its
    cells names a column, so it is skipped like any line before the data, not taken for a header (which named
    no sensor column and stopped the read); the six blocks give the plain result."""
    from imucalib.io import read

    d, sim, ivs, plain, files = faces
    path = tmp_path / "prompts.log"
    with open(path, "w") as log:
        for i, iv in enumerate(ivs):
            part = sim.recording[iv]
            log.write(prompt.format(i=i + 1) + "\n")
            np.savetxt(log, np.column_stack([part.t - part.t[0], part.acc, part.gyro]), fmt="%.10g", delimiter=sep)
    assert len(prompt.format(i=1).split(sep if sep != " " else None)) == 7
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImucalibWarning)
        rec = read(path)
    messages = [str(w.message) for w in caught]
    assert any("skipped 1 line before the data" in m for m in messages), messages
    assert any("5 lines inside the data that are not rows (a logger's prompts) cut the rows into 6 blocks" in m
               for m in messages), messages
    assert not rec.metadata["header"] and len(rec) == sum(len(iv) for iv in ivs)
    _same_six_position(rec, plain)


@pytest.mark.parametrize("header, columns", [
    ("t,ax,ay,az,gx,gy,gz", None),  # the reader's own vocabulary
    ("stamp,x,y,z,wx,wy,wz", ["stamp", "x", "y", "z", "wx", "wy", "wz"]),  # names only --columns knows
])
def test_a_real_header_before_prompt_blocks_stays_a_header(tmp_path, faces, header, columns):
    from imucalib.io import read

    d, sim, ivs, plain, files = faces
    path = tmp_path / "log.csv"
    with open(path, "w") as log:
        log.write(header + "\n")
        for i, iv in enumerate(ivs):
            part = sim.recording[iv]
            if i:
                log.write(f">>> Pose {i + 1}: gathering data for 10s...\n")
            np.savetxt(log, np.column_stack([part.t - part.t[0], part.acc, part.gyro]), fmt="%.10g", delimiter=",")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        rec = read(path, columns=columns)
    assert rec.metadata["header"] and rec.metadata["column_names"] == header.split(",")
    assert len(rec.metadata["blocks"]) == 6
    np.testing.assert_array_equal(rec.acc, np.concatenate([sim.recording[iv].acc for iv in ivs]))


@pytest.mark.parametrize("gyro", [False, True])
def test_joined_face_files_are_said_once_not_flagged_as_gaps(capsys, faces, tmp_path, gyro):
    """Six files, one per face (accelerometer only, or with the gyroscope that separate blocks cannot
    calibrate): the gaps at the file boundaries are where they were joined, said once as such, with no
    "sampling gap" quality flag per boundary; a prompt-cut log the same."""
    d, sim, ivs, plain, files = faces
    if gyro:
        files = []
        for k, iv in zip(FACES, ivs, strict=True):
            part = sim.recording[iv]
            files.append(tmp_path / f"{k}.csv")
            np.savetxt(files[-1], np.column_stack([part.t - part.t[0], part.acc, part.gyro]), fmt="%.10g",
                       delimiter=",", header="t,ax,ay,az,gx,gy,gz", comments="")
    code, out, err = run(capsys, "calibrate", *files, "--method", "six_position", "--json")
    assert code == 0, err
    assert err.count("6 files joined: the gaps between them are not used for integration") == 1, err
    doc = json.loads(out)
    assert not [f for f in doc["fit"].get("quality_flags", []) if "sampling gap" in f]
    assert "sampling gap" not in err
    code, out, err = run(capsys, "calibrate", d / "prompts.csv", "--method", "six_position", "--json")
    assert code == 0 and "the gaps between blocks are not used for integration" in err, err
    assert not [f for f in json.loads(out)["fit"].get("quality_flags", []) if "sampling gap" in f]
