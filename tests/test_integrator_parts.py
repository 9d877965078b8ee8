"""Calibrations whose short rotations are integrated a part at a time are those of one part, bit for bit.

A recording of hours of short turns has its short intervals integrated in
several parts (:data:`imucalib.kinematics.integrator.PART_STEPS` padded steps each), so
that the temporaries do not follow how many turns it holds; a smaller part
size here puts the Xsens session's and a simulated Zhang 2021 session's
rotations in many parts, through every fit that integrates them.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib import kinematics as kin
from imucalib.io import read
from imucalib.methods import calibrate
from imucalib.scenarios import session

XSENS = Path(__file__).resolve().parents[2] / "shared" / "data" / "xsens_imu_tk"


def _numbers(cal) -> dict:
    d = cal.to_dict()
    d.pop("created", None)
    return json.loads(json.dumps(d))


def _parts_used(monkeypatch) -> list[int]:
    """Record how many parts each integrator built (the path under test is the one taken)."""
    counts: list[int] = []
    init = kin.IntervalIntegrator.__init__

    def counting(self, *args, **kwargs):
        init(self, *args, **kwargs)
        counts.append(len(self._parts))

    monkeypatch.setattr(kin.IntervalIntegrator, "__init__", counting)
    return counts


@pytest.mark.skipif(not XSENS.is_dir(), reason=f"{XSENS} not present (needs ../shared/data)")
def test_xsens_tedaldi2014_in_parts_is_the_same(monkeypatch) -> None:
    rec = read([str(XSENS / "xsens_acc.mat"), str(XSENS / "xsens_gyro.mat")], reader="imutk")
    one = _numbers(calibrate(rec, method="tedaldi2014", gravity=9.81744))
    monkeypatch.setattr(kin.integrator, "PART_STEPS", 1024)
    counts = _parts_used(monkeypatch)
    parts = _numbers(calibrate(rec, method="tedaldi2014", gravity=9.81744))
    assert max(counts) > 10
    assert parts == one


def test_zhang2021_in_parts_is_the_same(monkeypatch) -> None:
    sim = session("zhang2021", rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        one = _numbers(calibrate(sim, method="zhang2021", model="all", gravity=sim.truth.gravity))
        monkeypatch.setattr(kin.integrator, "PART_STEPS", 512)
        counts = _parts_used(monkeypatch)
        parts = _numbers(calibrate(sim, method="zhang2021", model="all", gravity=sim.truth.gravity))
    assert max(counts) > 3
    assert parts == one
    assert np.isfinite(parts["gyroscope"]["bias"]).all()
