"""``Calibration.apply(DataFrame)`` keeps the magnetometer, as ``imucalib apply`` does for the same file."""

import warnings

import numpy as np
import pytest

from imucalib import read
from imucalib.cli import main
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import session

pd = pytest.importorskip("pandas")



def _mag_columns(frame) -> list[str]:
    return [c for c in frame.columns if c.startswith("mag_") and "_cal [" in c]


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """A simulated hand-held session with a magnetometer: its raw CSV file and its true calibration."""
    sim = session("handheld", rng=3, n_poses=6, magnetometer=True)
    rec = sim.recording
    folder = tmp_path_factory.mktemp("applymag")
    path = folder / "raw.csv"
    np.savetxt(path, np.column_stack([rec.t, rec.acc, rec.gyro, rec.mag]), delimiter=",", fmt="%.17g",
               header="t,ax,ay,az,gx,gy,gz,mx,my,mz", comments="")
    sim.truth.save(folder / "truth.json")
    return path, sim, folder / "truth.json"


def test_a_dataframe_gets_the_calibrated_magnetometer(simulated):
    path, sim, _ = simulated
    assert sim.truth.magnetometer is not None and sim.recording.mag is not None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        frame = pd.read_csv(path)
        out = sim.truth.apply(frame, mag_unit=sim.recording.mag_unit)
        expected = sim.truth.apply(read(path, mag_unit=sim.recording.mag_unit))
    mag = _mag_columns(out)
    assert mag == [f"mag_{a}_cal [{expected.mag_unit}]" for a in "xyz"] == list(out.columns[-3:])
    np.testing.assert_array_equal(out[mag].to_numpy(), expected.mag)
    # the true calibration maps the raw readings onto the simulated field: the same strength at every sample
    strength = np.linalg.norm(out[mag].to_numpy(), axis=1)
    assert np.std(strength) < 0.05 * np.mean(strength)


def test_the_library_and_the_command_line_add_the_same_magnetometer_columns(simulated, tmp_path):
    path, sim, truth = simulated
    written = tmp_path / "cal.csv"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        assert main(["apply", str(truth), str(path), "--mag-unit", sim.recording.mag_unit, "-o", str(written)]) == 0
        out = sim.truth.apply(pd.read_csv(path), mag_unit=sim.recording.mag_unit)
    cli = pd.read_csv(written)
    assert _mag_columns(cli) == _mag_columns(out) and len(_mag_columns(out)) == 3
    np.testing.assert_allclose(out[_mag_columns(out)].to_numpy(), cli[_mag_columns(cli)].to_numpy(), rtol=1e-12,
                               atol=1e-12)
