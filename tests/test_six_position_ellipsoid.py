"""Six-position (Ru 2022 eqs. 8-9) and ellipsoid methods: exact recovery, faces, clear errors."""

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.methods import calibrate
from imucalib.models import TriadModel
from imucalib.segment import find_faces
from synth import linear_truth, tedaldi_session

FACES = [[0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, -1], [1, 1, 0], [0, 1, 1],
         [1, 0, 1], [-1, 1, 1], [1, -1, 1]]


def _directions():
    d = np.array(FACES, dtype=float)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_six_position_exact_without_misalignment():
    lin = linear_truth()
    truth = Calibration(accelerometer=TriadModel(scale=lin.accelerometer.scale, bias=lin.accelerometer.bias,
                                                 shape="upper"), gyroscope=lin.gyroscope)
    rec, _, iv = tedaldi_session(truth, seed=1, directions=_directions())
    cal = calibrate(rec, method="six_position", gravity=truth.gravity, intervals=iv)
    np.testing.assert_allclose(cal.accelerometer.scale, truth.accelerometer.scale, rtol=1e-6)
    np.testing.assert_allclose(cal.accelerometer.bias, truth.accelerometer.bias, rtol=1e-6)
    assert cal.fit["faces"] == {"+z": 0, "+x": 1, "+y": 2, "-x": 3, "-y": 4, "-z": 5}
    np.testing.assert_allclose(cal.gyroscope.scale, truth.gyroscope.scale, rtol=1e-6)


def test_six_position_names_the_missing_faces():
    d = np.delete(_directions(), 3, axis=0)  # no −x face; the nearest pose is 45° away
    raw = 100.0 + 9.8 * d
    with pytest.raises(ValueError, match=r"the poses lack -x \(\d+° off\): record those faces"):
        find_faces(raw, 9.8)


def test_ellipsoid_exact_with_misalignment():
    rec, truth, iv = tedaldi_session(seed=2)
    for refine in (False, True):
        cal = calibrate(rec, method="ellipsoid", gravity=truth.gravity, intervals=iv, refine=refine)
        np.testing.assert_allclose(cal.accelerometer.scale, truth.accelerometer.scale, rtol=1e-6)
        np.testing.assert_allclose(cal.accelerometer.misalignment, truth.accelerometer.misalignment,
                                   atol=1e-8)
        np.testing.assert_allclose(cal.accelerometer.bias, truth.accelerometer.bias, rtol=1e-6)
    # fewer poses than the ellipsoid's 9 parameters: the model they determine, and the verdict says so
    rec, truth, iv = tedaldi_session(seed=3, poses=5)
    cal = calibrate(rec, method="ellipsoid", gravity=truth.gravity, intervals=iv)
    assert cal.fit["accelerometer_model"] == "scale and bias per axis" and cal.fit["verdict"] != "accepted"
    rec, truth, iv = tedaldi_session(seed=3, poses=2)  # 3 poses determine no model: refused
    with pytest.raises(ValueError, match="no accelerometer model is determined by these 3 static poses"):
        calibrate(rec, method="ellipsoid", gravity=truth.gravity, intervals=iv)
