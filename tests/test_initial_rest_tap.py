"""An initial rest cut by a tap is still found; --init-static checks that the sensor is still over its seconds."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import imucalib
from imucalib.cli import main
from imucalib.io import write_csv
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import session, with_tap
from imucalib.segment import find_initial_rest, initial_rest, moves_within, rest_after_taps


@pytest.fixture(scope="module")
def plain():
    return session("handheld", rng=4, n_poses=20, rest=10.0)


@pytest.mark.parametrize("at", [0.3, 0.8, 1.5])
def test_a_tap_early_in_the_rest_is_stepped_over(plain, at) -> None:
    sim = with_tap(plain, at, rng=1)
    rec, rate = sim.recording, sim.recording.rate
    tap_end = sim.options["tap"]["samples"][1]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImucalibWarning)
        rest = find_initial_rest(rec)
    notes = [str(w.message) for w in caught if "a tap or a knock" in str(w.message)]
    assert len(notes) == 1, notes
    start, stop = (float(x) for x in re.search(r"knock: ([\d.]+)-([\d.]+) s\)", notes[0]).groups())
    assert at - 0.1 <= start <= at + 0.05 and stop <= at + 0.15 + 0.1  # the tap rings for 0.15 s
    true_rest = plain.segments[0]
    assert tap_end <= rest.start <= tap_end + 0.6 * rate  # after the tap and half a window
    assert rest.stop <= true_rest.stop and rest.stop >= true_rest.stop - 0.5 * rate
    # the rest's noise level is the sensor's, not the tap's: as over the untapped rest's same samples
    tapped, clean = np.var(rec.acc[rest.slice], axis=0), np.var(plain.recording.acc[rest.slice], axis=0)
    np.testing.assert_allclose(tapped, clean, rtol=0.05)
    assert np.linalg.norm(np.var(rec.acc[: true_rest.stop], axis=0)) > 3 * np.linalg.norm(clean)


def test_without_looking_past_taps_the_early_tap_is_an_error(plain) -> None:
    rec = with_tap(plain, 0.3, rng=1).recording
    with pytest.raises(ValueError, match="no initial rest found"):
        find_initial_rest(rec, taps=False)


def test_a_session_without_taps_is_as_before(plain) -> None:
    rec = plain.recording
    assert rest_after_taps(rec) is None
    assert find_initial_rest(rec) == find_initial_rest(rec, taps=False)


def test_a_tap_does_not_hide_a_real_movement(plain) -> None:
    """The first motion after the rest turns the sensor: it ends the rest, it is no tap."""
    rec = plain.recording
    found = rest_after_taps(with_tap(plain, 0.3, rng=1).recording)
    assert found is not None and len(found.taps) == 1
    assert found.rest.stop <= plain.segments[0].stop  # the search stopped at the first pose change
    assert moves_within(rec, plain.segments[0].stop - 10) is None


def test_the_calibration_goes_through_a_tapped_rest(plain) -> None:
    sim = with_tap(plain, 0.3, rng=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = imucalib.calibrate(sim.recording, method="tedaldi2014", gravity=sim.truth.gravity)
    np.testing.assert_allclose(cal.accelerometer.scale, sim.truth.accelerometer.scale, rtol=1e-3)
    assert cal.fit["initial_rest_seconds"] > 8.5


def test_init_static_is_checked(plain, capsys, tmp_path) -> None:
    sim = with_tap(plain, 3.0, rng=1)
    rec = sim.recording
    assert initial_rest(rec, 2.5).stop == round(2.5 * rec.rate)
    for seconds in (5.0, 12.0):
        with pytest.raises(ValueError, match=r"--init-static .* moves at 2\.\d+-3\.\d+ s.*--init-static 2\.\d"):
            initial_rest(rec, seconds)
    path = tmp_path / "tapped.csv"
    write_csv(path, rec)
    code = main(["calibrate", str(path), "--init-static", "5", "--gravity", str(sim.truth.gravity)])
    err = capsys.readouterr().err
    assert code == 2 and "the sensor is not still over those seconds" in err
