"""Test-wide settings: property tests are reproducible by default.

The hypothesis suites draw the same examples on every run (``derandomize``), so a test run on
a clean clone passes or fails the same way each time; ``IMUCALIB_EXPLORE=1`` draws new
examples (and keeps the failing ones in ``.hypothesis/``) to look for new faults.
"""

import os

import pytest

try:
    from hypothesis import settings
except ImportError:  # the test extra is not installed: the property tests skip themselves
    settings = None

if settings is not None:
    settings.register_profile("reproducible", derandomize=True, deadline=None, database=None)
    settings.register_profile("explore", deadline=None)
    settings.load_profile("explore" if os.environ.get("IMUCALIB_EXPLORE") else "reproducible")


@pytest.fixture
def spiky_handheld():
    """A factory: hand-held seed 5 with ``n`` gyroscope spikes (+8000 counts), each mid-way through another
    rotation (rotations 3, 7, 11, … between the poses tedaldi2014 finds), on the axes x, y, z in turn;
    returns ``(sim, recording)``."""
    def make(n: int):
        from imucalib.methods import calibrate
        from imucalib.recording import Recording
        from imucalib.scenarios import session

        sim = session("handheld", rng=5)
        rec = sim.recording
        poses = calibrate(rec, method="tedaldi2014", gravity=sim.truth.gravity).fit["intervals"]
        gyro = rec.gyro.copy()
        for k in range(n):
            gyro[(poses[3 + 4 * k][1] + poses[4 + 4 * k][0]) // 2, k % 3] += 8000
        return sim, Recording(rec.t, rec.acc, gyro, acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit)

    return make
