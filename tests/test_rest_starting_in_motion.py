"""A recording that starts while the sensor moves has no initial rest, even when its first seconds hold more motion
than stillness (the level the rest's end is judged by is then motion's): refused, not taken as a long 'rest'."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from imucalib.scenarios import session
from imucalib.segment import find_initial_rest


@pytest.fixture(scope="module")
def sim():
    return session("handheld", rng=1, rest=10, n_poses=14)


def test_a_recording_cut_in_the_middle_of_a_turn_is_refused(sim):
    cut = sim.recording[1000:]  # the first turn starts at sample 996
    gyro = np.linalg.norm(cut.gyro[:200] - np.median(sim.recording.gyro[:900], axis=0), axis=1)
    assert gyro.max() > 1000  # it does start in a turn (raw counts; the rest's scatter is ~50)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match=r"are not still .* the recording starts while the sensor moves"):
            find_initial_rest(cut)


def test_a_real_rest_passes_the_check(sim):
    rest = find_initial_rest(sim.recording)
    assert rest.start == 0 and 880 <= rest.stop <= 1000  # the 10 s on the table, less the detector's margin
