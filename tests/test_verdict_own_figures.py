"""The verdict of ``calibrate`` reads the figures its fit found on the same poses (``own_figures``): the noise floor,
the rotations the data do not allow and each rotation's error. Judged afresh, the same calibration and recording
give the same verdict and figures. (A calibration changed after its fit, judged without ``own_figures``, is judged
on its own numbers: ``test_never_worse_than_raw.py``.)"""

from __future__ import annotations

import math
import warnings

import numpy as np

from imucalib import ImucalibWarning
from imucalib.methods import calibrate
from imucalib.metrics import gravity_direction_errors, gravity_noise_floor
from imucalib.recording import Interval
from imucalib.segment import unreliable_transitions
from imucalib.verdict import assess


def _figures(report) -> dict:
    return {k: v for k, v in report.to_flat().items() if isinstance(v, (int, float, str, list))}


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-13, abs_tol=1e-15)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return a == b


def test_own_figures_are_what_the_verdict_would_find(spiky_handheld):
    sim, rec = spiky_handheld(2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = calibrate(rec, method="tedaldi2014", gravity=sim.truth.gravity)
    iv = [Interval(int(a), int(b)) for a, b in cal.fit.poses.intervals]
    # the figures the fit holds are those the verdict would find
    assert cal.fit.gyroscope.rotations_unreliable == unreliable_transitions(rec, iv)
    assert len(cal.fit.gyroscope.rotations_unreliable) >= 2  # the two spikes' rotations
    assert cal.fit.accelerometer.noise_floor == gravity_noise_floor(cal, rec, iv)
    np.testing.assert_allclose(cal.fit.gyroscope.angle_errors_deg, np.degrees(gravity_direction_errors(cal, rec, iv)),
                               rtol=1e-13)
    afresh, own = assess(cal, rec), assess(cal, rec, own_figures=True)
    a, b = _figures(afresh), _figures(own)
    assert a.keys() == b.keys() and a["verdict"] == b["verdict"]
    assert all(_same(a[k], b[k]) for k in a), [k for k in a if not _same(a[k], b[k])]
