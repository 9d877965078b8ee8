"""The Python API is the command line's path: ``imucalib.read`` + ``imucalib.calibrate`` + ``save`` write the file
``imucalib calibrate FILE -o OUT`` writes, for every source the command line takes."""

import json
import warnings

import numpy as np
import pytest

import imucalib
from imucalib.cli import main
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import handheld


def _document(path) -> dict:
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc.pop("created", None)
    return doc


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        return fn(*args, **kwargs)


@pytest.fixture(scope="module")
def mag_csv(tmp_path_factory):
    """A hand-held session with a magnetometer, as a CSV file with ``mx,my,mz`` columns."""
    rec = handheld.generate(np.random.default_rng(12), magnetometer=True)["recording"]
    path = tmp_path_factory.mktemp("api") / "session.csv"
    np.savetxt(path, np.column_stack([rec.t, rec.acc, rec.gyro, rec.mag]), delimiter=",", fmt="%.17g",
               header="t,ax,ay,az,gx,gy,gz,mx,my,mz", comments="")
    return path


def test_a_csv_with_a_magnetometer_gives_the_command_lines_file(mag_csv, tmp_path):
    cli_out, api_out = tmp_path / "cli.json", tmp_path / "api.json"
    assert _quiet(main, ["calibrate", str(mag_csv), "-o", str(cli_out)]) in (0, 3)
    data = _quiet(imucalib.read, mag_csv)
    assert data.mag is not None and data.mag_unit == "counts"
    cal = _quiet(imucalib.calibrate, data)  # the command line's default method
    assert cal.method == imucalib.DEFAULT_METHOD == "tedaldi2014"
    assert cal.magnetometer is not None
    cal.save(api_out)
    cli, api = _document(cli_out), _document(api_out)
    assert cli["magnetometer"] is not None
    assert api == cli
    loaded = imucalib.Calibration.load(api_out)
    assert loaded.magnetometer is not None
    np.testing.assert_array_equal(loaded.magnetometer.matrix, cal.magnetometer.matrix)


def test_the_lower_reader_leaves_the_magnetometer_to_imucalib_read(mag_csv):
    """``imucalib.io.read`` reads the file's columns only; ``imucalib.read`` attaches the magnetometer."""
    low = _quiet(imucalib.io.read, mag_csv)
    high = _quiet(imucalib.read, mag_csv)
    assert low.mag is None and "mx" in low.extra
    np.testing.assert_array_equal(high.acc, low.acc)
    np.testing.assert_array_equal(high.mag, np.column_stack([low.extra["mx"], low.extra["my"], low.extra["mz"]]))


def test_a_session_directory(tmp_path):
    folder = tmp_path / "sim"
    assert main(["simulate", "--scenario", "handheld", "--seed", "4", "-o", str(folder)]) == 0
    cli_out, api_out = tmp_path / "cli.json", tmp_path / "api.json"
    assert _quiet(main, ["calibrate", str(folder), "--method", "ellipsoid", "-o", str(cli_out)]) in (0, 3)
    session = imucalib.read(folder)
    assert not isinstance(session, imucalib.Recording) and isinstance(session.recording, imucalib.Recording)
    _quiet(imucalib.calibrate, session, method="ellipsoid").save(api_out)
    assert _document(api_out) == _document(cli_out)


def test_several_files_are_blocks_and_a_frame_is_a_file(mag_csv, tmp_path):
    text = mag_csv.read_text().splitlines()
    header, rows = text[0], text[1:]
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    first.write_text("\n".join([header, *rows[:2000]]) + "\n")
    second.write_text("\n".join([header, *rows[2000:4000]]) + "\n")
    rec = _quiet(imucalib.read, [first, second])
    assert len(rec.t) == 4000 and len(rec.metadata["blocks"]) == 2 and rec.mag is not None
    pd = pytest.importorskip("pandas")
    frame = pd.read_csv(mag_csv)
    from_frame, from_file = _quiet(imucalib.read, frame), _quiet(imucalib.read, mag_csv)
    np.testing.assert_array_equal(from_frame.mag, from_file.mag)
    np.testing.assert_array_equal(from_frame.acc, from_file.acc)


def test_the_public_names_are_the_libraries_own():
    from imucalib.comparison import compare
    from imucalib.methods import calibrate
    from imucalib.reading import read as read_data
    from imucalib.validation import validate

    assert imucalib.read is read_data and imucalib.calibrate is calibrate
    assert imucalib.validate is validate and imucalib.compare is compare
    assert {"read", "calibrate", "validate", "compare", "Calibration"} <= set(imucalib.__all__)
