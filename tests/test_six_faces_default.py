"""The default method on a session of the six faces only (the Ferraris procedure, as imucal's users record it).

Six orientations give six gravity-norm equations for the accelerometer's nine parameters: tedaldi2014 cannot
determine them and its calibration is rejected. Without ``--method`` the faces' method, ferraris, which takes
the faces' directions as known, is used instead, and says so.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import imucalib
from imucalib.methods import six_faces_only
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import session
from imucalib.scenarios.base import pose_session, turns_between

FACES = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], float)


@pytest.fixture(scope="module")
def six_faces():
    """A rest z up, a full turn about z, then the other faces, with a full turn about x and y where they point up."""
    truth = session("handheld", rng=4).truth
    between = [turns_between(FACES[k:k + 2])[0] for k in range(5)]
    turns = [([0, 0, 1], 2 * np.pi), between[0], between[1], ([1, 0, 0], 2 * np.pi), between[2], between[3],
             ([0, 1, 0], 2 * np.pi), between[4]]
    rec, _ = pose_session(truth, turns, rng=7, hold=3.0, move=2.0)
    return truth, rec


def test_six_faces_are_calibrated_by_their_method_when_the_default_cannot(six_faces):
    truth, rec = six_faces
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        alone = imucalib.calibrate(rec, gravity=truth.gravity, method="tedaldi2014")
    assert alone.fit["verdict"] == "rejected"
    assert six_faces_only(rec, alone.fit["intervals"])
    with pytest.warns(ImucalibWarning, match="only the six faces"):
        cal = imucalib.calibrate(rec, gravity=truth.gravity)
    assert cal.method == "ferraris" and cal.fit["verdict"] == "accepted"
    assert np.abs(cal.accelerometer.scale / truth.accelerometer.scale - 1).max() < 1e-4  # 1.2e-5
    assert np.abs(cal.gyroscope.scale / truth.gyroscope.scale - 1).max() < 1e-4  # 2.7e-5


def test_a_method_named_is_kept_and_other_sessions_are_not_six_faces(six_faces):
    truth, rec = six_faces
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        assert imucalib.calibrate(rec, gravity=truth.gravity, method="tedaldi2014").method == "tedaldi2014"
        sim = session("handheld", rng=1)
        cal = imucalib.calibrate(sim.recording, gravity=sim.truth.gravity)
    assert cal.method == "tedaldi2014" and not six_faces_only(sim.recording, cal.fit["intervals"])
