"""A sensor read faster than it updates: every reading held for several rows (the FXOS8700 log of the public
recordings holds each for about 4 rows). The gravity-norm residual's noise floor counts the updates, not the
rows, so the residual-to-noise figure does not grow with how often the same reading was written down."""

from __future__ import annotations

import warnings

import numpy as np

from imucalib.methods import calibrate
from imucalib.metrics import HELD_FRACTION, gravity_noise_floor
from imucalib.recording import Interval, Recording
from imucalib.scenarios import session


def _held(rec: Recording, k: int) -> Recording:
    t = rec.t[0] + np.arange(len(rec) * k) * (rec.t[1] - rec.t[0]) / k
    return Recording(t, np.repeat(rec.acc, k, axis=0), np.repeat(rec.gyro, k, axis=0), acc_unit=rec.acc_unit,
                     gyro_unit=rec.gyro_unit)


def test_the_noise_floor_of_held_readings_is_that_of_their_updates():
    sim = session("handheld", rng=3)
    rec = sim.recording
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = calibrate(rec, gravity=sim.truth.gravity)
    poses = [Interval(a, b) for a, b in cal.fit["intervals"]]
    floor = gravity_noise_floor(cal, rec, poses)
    for k in (2, 4):
        held = _held(rec, k)
        held_poses = [Interval(iv.start * k, iv.stop * k) for iv in poses]
        # the same readings, each written k times: the same information, the same floor (to the variance's
        # ddof: n-1 of the updates against kn-1 of the rows)
        assert abs(gravity_noise_floor(cal, held, held_poses) / floor - 1) < 0.01, k
    assert HELD_FRACTION < 0.5  # a reading held twice repeats half of the rows: taken as held


def test_chance_repeats_of_a_coarse_sensor_are_not_taken_as_held():
    """Readings that repeat by chance (a quantised, quiet sensor) keep their rows' count."""
    rng = np.random.default_rng(0)
    n = 2000
    acc = np.round(np.array([0.0, 0.0, 4096.0]) + rng.normal(0, 1.2, (n, 3)))  # ~1 LSB of noise
    rec = Recording(np.arange(n) / 100.0, acc, np.zeros((n, 3)))
    cal = session("handheld", rng=3).truth
    repeats = np.mean(np.all(acc[1:] == acc[:-1], axis=1))
    assert repeats < HELD_FRACTION
    floor = gravity_noise_floor(cal, rec, [Interval(0, n)])
    along = acc @ (cal.accelerometer.scale * (cal.accelerometer.misalignment.T @ np.array([0, 0, 1.0])))
    assert np.isclose(floor, np.std(along, ddof=1) / np.sqrt(n), rtol=1e-3)
