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
