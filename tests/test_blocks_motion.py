"""Recordings made of blocks whose blocks hold motion: only the still part of a block is its pose."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import imucalib
from imucalib.fit.accelerometer import fit_determined
from imucalib.metrics import interval_means
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import in_blocks, session
from imucalib.segment import detect_intervals, pose_blocks, still_blocks

PUBLIC = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "public"


def _scale_error(sim, intervals) -> float:
    model = fit_determined(interval_means(sim.recording.acc, intervals), sim.truth.gravity)[0]
    return float(np.max(np.abs(model.scale / sim.truth.accelerometer.scale - 1)))


@pytest.fixture(scope="module", params=[1, 2, 3])
def lifted(request):
    """20 blocks (the rest and 19 holds of 8-10 s), each starting with 1-3 s of the lift onto its pose; block 8
    is motion alone."""
    seed = request.param
    sim = session("handheld", rng=seed, n_poses=19, rest=10.0, dwell=(8.0, 10.0))
    return in_blocks(sim, lead=(1.0, 3.0), moving=(7,), rng=seed)


def test_in_blocks_lays_out_blocks_as_the_readers_do(lifted) -> None:
    rec = lifted.recording
    blocks = pose_blocks(rec)
    assert len(blocks) == 20 and blocks[0].start == 0 and blocks[-1].stop == len(rec)
    assert all(a.stop == b.start for a, b in zip(blocks[:-1], blocks[1:], strict=True))
    assert len(lifted.segments) == 19  # block 8 holds no hold
    # every hold lies inside its block, after the lift (the rest excepted)
    for k, hold in zip([b for b in range(20) if b != 7], lifted.segments, strict=True):
        assert blocks[k].start <= hold.start and hold.stop == blocks[k].stop
        assert (hold.start - blocks[k].start > 0) == (k > 0)


def test_only_the_still_part_is_a_pose(lifted) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImucalibWarning)
        found = still_blocks(lifted.recording)
    assert found.kept == [k for k in range(20) if k != 7]
    assert list(found.left_out) == [7] and "block 8 is never still" in found.left_out[7]
    assert any("block 8 is never still" in str(w.message) for w in caught)
    rate = lifted.recording.rate
    for pose, hold in zip(found.poses, lifted.segments, strict=True):
        assert pose.stop == hold.stop  # the hold runs to the end of its block
        assert hold.start - 0.25 * rate <= pose.start <= hold.start + 1.0 * rate  # the lift's slow end at most
    whole = _scale_error(lifted, pose_blocks(lifted.recording))
    still = _scale_error(lifted, found.poses)
    noise = _scale_error(lifted, lifted.segments)  # the true holds: the noise level of this session
    assert whole > 0.02  # each block averaged whole: percent-level scale errors
    assert still < 2 * noise + 5e-5  # the still parts: the noise level


def test_calibrate_on_blocks_with_motion(lifted) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        cal = imucalib.calibrate(lifted.recording, method="tedaldi2014", gravity=lifted.truth.gravity)
        intervals, mult, rest, _ = detect_intervals(lifted.recording, lifted.truth.gravity)
    assert cal.fit["static_intervals"] == 19 and np.isnan(mult)
    assert rest == intervals[0] and rest.start == 0  # the first block is the rest
    np.testing.assert_allclose(cal.accelerometer.scale, lifted.truth.accelerometer.scale, rtol=1e-3)


def test_fxos8700_blocks_are_still_throughout(tmp_path) -> None:
    """The FXOS8700's 20 blocks of 10 s (read from a copy without the serial monitor's banner): no block moves,
    so each is its pose whole, and the calibration is the whole blocks' to the last digit."""
    path = PUBLIC / "fxos8700_blocks" / "data_sample2.csv"
    if not path.is_file():
        pytest.skip(f"{path} not present (fresh clone): real-data test skipped")
    copy = tmp_path / "blocks.csv"
    copy.write_text("".join(path.read_text().splitlines(keepends=True)[2:]))
    from imucalib.io import read

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        rec = read(copy, rate=400, acc_unit="m/s^2")
        found = still_blocks(rec)
    assert len(found.blocks) == 20 and found.poses == found.blocks and not found.left_out
