"""Files that phones and loggers write, read with no flags: phyphox and Sensor Logger pairs,
headerless serial logs, logger preambles, EuRoC/TUM-VI ``imu0/data.csv``.

Each file is written here exactly as the app writes it, from a simulated session
converted to SI with its true calibration, and must read back as the same data
(and give the same calibration) as one plain CSV of that session.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib import cli, methods, scenarios
from imucalib.io import ReaderError, read
from imucalib.recording import ImucalibWarning, Recording

EPOCH_NS = 1_698_501_144_401_773_000  # a Sensor Logger start time (ns since the epoch)
GYRO_SHIFT = 0.0037  # s: the gyroscope's own time grid, 3.7 ms after the accelerometer's


@pytest.fixture(scope="module")
def si() -> Recording:
    """A handheld session in m/s² and rad/s, through its true calibration."""
    ses = scenarios.session("handheld", rng=1)
    return ses.truth.apply(ses.recording)


@pytest.fixture(scope="module")
def plain(si, tmp_path_factory) -> tuple[Path, Recording]:
    """The session as one plain CSV, and that CSV read back."""
    path = tmp_path_factory.mktemp("plain") / "plain.csv"
    table = np.column_stack([si.t, si.acc, si.gyro])
    np.savetxt(path, table, fmt="%.10g", delimiter=",", comments="",
               header="t [s],ax [m/s^2],ay [m/s^2],az [m/s^2],gx [rad/s],gy [rad/s],gz [rad/s]")
    return path, read(path)


@pytest.fixture(scope="module")
def plain_calibration(plain):
    return methods.calibrate(plain[1], method="tedaldi2014")


def _gyro_on_own_grid(si: Recording) -> tuple[np.ndarray, np.ndarray]:
    """The gyroscope as a phone logs it: on its own time grid, shifted from the accelerometer's."""
    t = si.t + GYRO_SHIFT
    return t, np.column_stack([np.interp(t, si.t, si.gyro[:, k]) for k in range(3)])


def _same_calibration(cal, ref) -> None:
    """Each parameter within a quarter of its own 1σ (the fit's uncertainty) of the reference.

    The gyroscope written on its own grid and interpolated back onto the
    accelerometer's is linearly interpolated twice: a low-pass of about one
    sample that leaves biases and scale factors of slow motion as they are and
    changes the integrated rotations by far less than the noise does. A
    difference of a quarter of the fit's 1σ is a change no user could see in
    the verdict or the corrected data; reading errors (a swapped axis, a wrong
    unit, a time off by a factor) change parameters by orders of magnitude more.
    """
    sigma = ref.fit["uncertainty"]
    for sensor in ("accelerometer", "gyroscope"):
        a, b = getattr(cal, sensor), getattr(ref, sensor)
        for name in ("scale", "bias"):
            for k, axis in enumerate("xyz"):
                tol = 0.25 * sigma[f"{sensor}.{name}.{axis}"]
                assert abs(getattr(a, name)[k] - getattr(b, name)[k]) < tol, (sensor, name, axis)
        np.testing.assert_allclose(a.misalignment, b.misalignment, atol=0.25 * min(
            v for k, v in sigma.items() if k.startswith(f"{sensor}.misalignment")))


def _cli_calibrates(paths, tmp_path, *extra) -> dict:
    out = tmp_path / "cal.json"
    code = cli.main(["calibrate", *map(str, paths), *extra, "-o", str(out), "--json"])
    assert code in (0, 3)  # accepted, or rejected by the verdict; never a reader error (2)
    return json.loads(out.read_text())


# ------------------------------------------------------------ Sensor Logger
def _sensor_logger(dirpath: Path, name: str, t: np.ndarray, xyz: np.ndarray) -> Path:
    """A Sensor Logger motion file: ``time`` (ns since the epoch), ``seconds_elapsed``, then z, y, x."""
    ns = EPOCH_NS + np.round(t * 1e9).astype(np.int64)
    lines = ["time,seconds_elapsed,z,y,x"]
    lines += [f"{n},{(n - EPOCH_NS) / 1e9},{v[2]!r},{v[1]!r},{v[0]!r}"
              for n, v in zip(ns.tolist(), xyz.tolist(), strict=True)]
    path = dirpath / name
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def sensor_logger(si, tmp_path_factory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("sensorlogger")
    tg, gyro = _gyro_on_own_grid(si)
    return _sensor_logger(d, "TotalAcceleration.csv", si.t, si.acc), _sensor_logger(d, "Gyroscope.csv", tg, gyro)


def test_sensor_logger_pair_read_with_no_flags(sensor_logger, plain):
    with pytest.warns(ImucalibWarning) as caught:
        rec = read(list(sensor_logger))
    notes = " | ".join(str(w.message) for w in caught)
    assert "Sensor Logger's accelerometer (m/s^2) and gyroscope (rad/s)" in notes
    assert "written in the order z,y,x in both files, were put in x,y,z order" in notes
    assert "gyroscope was linearly interpolated" in notes
    ref = plain[1]
    # the first accelerometer sample precedes the gyroscope's first: left out
    assert len(rec) == len(ref) - 1
    np.testing.assert_allclose(rec.acc, ref.acc[1:], rtol=1e-9, atol=1e-9)  # the plain CSV has 10 digits
    np.testing.assert_allclose(rec.t - rec.t[0], ref.t[1:] - ref.t[1], atol=1e-9)
    assert (rec.acc_unit, rec.gyro_unit) == ("m/s^2", "rad/s")
    # interpolated twice (onto the gyroscope's grid by the test, back by the reader): within the noise
    noise = np.std(np.diff(ref.gyro[:2000], axis=0), axis=0) / np.sqrt(2)
    assert np.all(np.median(np.abs(rec.gyro - ref.gyro[1:]), axis=0) < noise)


def test_sensor_logger_pair_calibrates_as_the_plain_csv(sensor_logger, plain_calibration, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        rec = read(list(sensor_logger))
        _same_calibration(methods.calibrate(rec, method="tedaldi2014"), plain_calibration)
        doc = _cli_calibrates(sensor_logger, tmp_path)
    assert doc["method"] == "tedaldi2014"


def test_sensor_logger_files_in_either_order(sensor_logger):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        a = read(list(sensor_logger))
        b = read(list(reversed(sensor_logger)))
    np.testing.assert_array_equal(a.acc, b.acc)
    np.testing.assert_array_equal(a.gyro, b.gyro)


def test_sensor_logger_gravity_free_accelerometer_is_refused(si, sensor_logger, tmp_path, capsys):
    # Accelerometer.csv is the acceleration without gravity: take gravity (the slow part) out
    kernel = np.ones(301) / 301
    slow = np.column_stack([np.convolve(si.acc[:, k], kernel, mode="same") for k in range(3)])
    lin = _sensor_logger(tmp_path, "Accelerometer.csv", si.t, si.acc - slow)
    with pytest.raises(ReaderError, match=r"Accelerometer.csv is the acceleration without gravity.*"
                                          r"pass TotalAcceleration.csv"):
        read([lin, sensor_logger[1]])
    assert cli.main(["calibrate", str(lin), str(sensor_logger[1]), "--json"]) == 2
    assert "TotalAcceleration.csv" in capsys.readouterr().err
    grav = _sensor_logger(tmp_path, "Gravity.csv", si.t, slow)
    with pytest.raises(ReaderError, match="Gravity file holds the phone's estimate of gravity only"):
        read([grav, sensor_logger[1]])


def test_sensor_logger_uncalibrated_accelerometer_in_g(si, sensor_logger, tmp_path, plain):
    # iOS writes AccelerometerUncalibrated.csv in g
    acc = _sensor_logger(tmp_path, "AccelerometerUncalibrated.csv", si.t, si.acc / 9.80665)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        rec = read([acc, sensor_logger[1]])
    assert rec.acc_unit == "g"
    np.testing.assert_allclose(rec.in_si().acc, plain[1].acc[1:], rtol=1e-9, atol=1e-9)


# ------------------------------------------------------------------ phyphox
def _phyphox(path: Path, header: list[str], t: np.ndarray, xyz: np.ndarray, sep: str = ",",
             decimal: str = ".") -> Path:
    """A phyphox export: quoted header, time in s since the start, x, y, z, then the magnitude."""
    path.parent.mkdir(parents=True, exist_ok=True)
    table = np.column_stack([t, xyz, np.linalg.norm(xyz, axis=1)])
    lines = [sep.join(f'"{h}"' for h in header)]
    lines += [sep.join(f"{v:.9E}".replace(".", decimal) for v in row) for row in table]
    path.write_text("\n".join(lines) + "\n")
    return path


PHYPHOX_ACC = ["Time (s)", "Acceleration x (m/s^2)", "Acceleration y (m/s^2)", "Acceleration z (m/s^2)",
               "Absolute acceleration (m/s^2)"]
PHYPHOX_GYRO = ["Time (s)", "Gyroscope x (rad/s)", "Gyroscope y (rad/s)", "Gyroscope z (rad/s)",
                "Absolute (rad/s)"]


@pytest.fixture(scope="module")
def phyphox(si, tmp_path_factory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("phyphox")
    tg, gyro = _gyro_on_own_grid(si)
    t0 = si.t[0]  # phyphox counts from the start of the experiment
    return (_phyphox(d / "Acceleration with g" / "Raw Data.csv", PHYPHOX_ACC, si.t - t0, si.acc),
            _phyphox(d / "Gyroscope" / "Raw Data.csv", PHYPHOX_GYRO, tg - t0, gyro))


def test_phyphox_pair_read_with_no_flags(phyphox, plain):
    with pytest.warns(ImucalibWarning) as caught:
        rec = read(list(phyphox))
    notes = " | ".join(str(w.message) for w in caught)
    assert "phyphox's accelerometer (m/s^2) and gyroscope (rad/s)" in notes
    assert "gyroscope was linearly interpolated" in notes
    ref = plain[1]
    np.testing.assert_allclose(rec.acc, ref.acc[1:], rtol=1e-9, atol=1e-9)  # 10 significant digits written
    np.testing.assert_allclose(rec.t - rec.t[0], ref.t[1:] - ref.t[1], atol=1e-9)


def test_phyphox_pair_calibrates_as_the_plain_csv(phyphox, plain_calibration, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        _same_calibration(methods.calibrate(read(list(phyphox)), method="tedaldi2014"), plain_calibration)
        _cli_calibrates(phyphox, tmp_path)


def test_phyphox_semicolons_and_decimal_commas(si, tmp_path):
    n = 500
    acc = _phyphox(tmp_path / "a.csv", PHYPHOX_ACC, si.t[:n], si.acc[:n], sep=";", decimal=",")
    gyro = _phyphox(tmp_path / "g.csv", PHYPHOX_GYRO, si.t[:n], si.gyro[:n], sep=";", decimal=",")
    with pytest.warns(ImucalibWarning, match="phyphox"):
        rec = read([acc, gyro])
    np.testing.assert_allclose(rec.acc, si.acc[:n], rtol=1e-9)
    np.testing.assert_allclose(rec.gyro, si.gyro[:n], rtol=1e-9, atol=1e-15)


def test_phyphox_linear_acceleration_is_refused(si, phyphox, tmp_path):
    header = ["Time (s)"] + [f"Linear Acceleration {a} (m/s^2)" for a in "xyz"] + ["Absolute acceleration (m/s^2)"]
    lin = _phyphox(tmp_path / "lin.csv", header, si.t[:300], si.acc[:300] * 0.01)
    with pytest.raises(ReaderError, match="'Linear Acceleration' leaves gravity out.*Acceleration with g"):
        read([lin, phyphox[1]])


# ------------------------------------------------------- headerless serial logs
def test_headerless_six_columns_with_rate(si, plain, tmp_path):
    path = tmp_path / "serial.txt"
    np.savetxt(path, np.column_stack([si.acc, si.gyro]), fmt="%.10g", delimiter=" ")
    with pytest.warns(ImucalibWarning, match="no header and 6 columns: they were taken as ax,ay,az,gx,gy,gz"):
        rec = read(path, rate=100.0)
    np.testing.assert_array_equal(rec.acc, plain[1].acc)
    np.testing.assert_array_equal(rec.gyro, plain[1].gyro)
    np.testing.assert_allclose(np.diff(rec.t), 0.01)
    with pytest.raises(ReaderError, match="no time column found; pass --rate"), \
            pytest.warns(ImucalibWarning, match="no header and 6 columns"):
        read(path)
    _cli_calibrates([path], tmp_path, "--rate", "100")


def test_headerless_seven_columns(si, plain, tmp_path):
    path = tmp_path / "serial7.txt"
    np.savetxt(path, np.column_stack([si.t, si.acc, si.gyro])[:400], fmt="%.10g", delimiter=" ")
    with pytest.warns(ImucalibWarning, match="no header: the columns were taken as t,ax"):
        rec = read(path)
    np.testing.assert_array_equal(rec.gyro, plain[1].gyro[:400])


# ------------------------------------------------------------ logger preambles
PREAMBLES = {
    "Fs": "Fs,100\nLogging type,continuous\nDevice,IMU logger v2\n",
    "sample rate [Hz]": "device: logger 7\nsample rate [Hz],100\n",
    "free text": "Logger started 2026-11-23 10:00\nSampling rate: 100 Hz\nfirmware 1.2.3 build 7\n",
}


@pytest.mark.parametrize("key", list(PREAMBLES))
def test_preamble_skipped_and_its_rate_used(key, si, plain, tmp_path):
    path = tmp_path / "logger.csv"
    body = np.column_stack([si.acc, si.gyro])
    text = PREAMBLES[key] + "acc_x,acc_y,acc_z,gyro_x,gyro_y,gyro_z\n"
    text += "\n".join(",".join(f"{v:.10g}" for v in row) for row in body) + "\n"
    path.write_text(text)
    nlines = PREAMBLES[key].count("\n")
    with pytest.warns(ImucalibWarning, match=f"skipped {nlines} lines before the header "
                                             r"\(they give a sampling rate of 100 Hz\)"):
        rec = read(path, acc_unit="m/s^2", gyro_unit="rad/s")
    assert rec.metadata["preamble_lines"] == nlines and rec.metadata["rate_from"] == "preamble"
    np.testing.assert_array_equal(rec.acc, plain[1].acc)
    np.testing.assert_allclose(rec.t, np.arange(len(rec)) / 100.0)


def test_preamble_before_a_header_with_time(si, plain, tmp_path):
    path = tmp_path / "logger_t.csv"
    rows = np.column_stack([si.t, si.acc, si.gyro])[:300]
    path.write_text("# logger export\n# rate, 100\n" + "t [s],ax [m/s^2],ay [m/s^2],az [m/s^2],"
                    "gx [rad/s],gy [rad/s],gz [rad/s]\n"
                    + "\n".join(",".join(f"{v:.10g}" for v in r) for r in rows) + "\n")
    with pytest.warns(ImucalibWarning, match="skipped 2 lines before the header"):
        rec = read(path)
    np.testing.assert_array_equal(rec.t, plain[1].t[:300])
    assert "rate_from" not in rec.metadata


def test_bad_rows_are_still_errors_not_a_preamble(si, tmp_path):
    path = tmp_path / "bad.csv"
    rows = np.column_stack([si.t, si.acc, si.gyro])[:50]
    lines = ["t,ax,ay,az,gx,gy,gz"] + [",".join(f"{v:.10g}" for v in r) for r in rows]
    lines[1] = lines[1] + ",7"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ReaderError, match=r"line 2: expected 7 values, found 8"):
        read(path)
    # a header of the wrong width is not skipped as a preamble
    lines = ["t,ax,ay,az,gx,gy,gz,temp"] + [",".join(f"{v:.10g}" for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ReaderError, match="expected 8 values, found 7"):
        read(path)


# ------------------------------------------------------------- EuRoC / TUM-VI
def test_euroc_imu0_data_csv(si, plain, plain_calibration, tmp_path):
    path = tmp_path / "mav0" / "imu0" / "data.csv"
    path.parent.mkdir(parents=True)
    ns = 1_403_636_579_758_555_392 + np.round(si.t * 1e9).astype(np.int64)
    header = ("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
              "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]")
    lines = [header] + [f"{n}," + ",".join(f"{v:.10g}" for v in (*g, *a))
                        for n, g, a in zip(ns, si.gyro, si.acc, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    rec = read(path)
    assert (rec.acc_unit, rec.gyro_unit, rec.metadata["time_unit"]) == ("m/s^2", "rad/s", "ns")
    np.testing.assert_array_equal(rec.acc, plain[1].acc)
    np.testing.assert_array_equal(rec.gyro, plain[1].gyro)
    np.testing.assert_allclose(rec.t - rec.t[0], plain[1].t - plain[1].t[0], atol=1e-9)
    cal = methods.calibrate(rec, method="tedaldi2014")
    np.testing.assert_allclose(cal.gyroscope.scale, plain_calibration.gyroscope.scale, rtol=1e-9)
    np.testing.assert_allclose(cal.accelerometer.bias, plain_calibration.accelerometer.bias, atol=1e-9)


def test_phone_reader_named_explicitly(sensor_logger, si, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        assert read(list(sensor_logger), reader="phone").metadata["app"] == "Sensor Logger"
        _cli_calibrates(sensor_logger, tmp_path, "--reader", "phone")
    a, g = tmp_path / "a.txt", tmp_path / "g.txt"
    for p in (a, g):
        np.savetxt(p, np.column_stack([si.t, si.acc])[:50], fmt="%.10g")
    with pytest.raises(ReaderError, match="not a pair of phone-app files"):
        read([a, g], reader="phone")
    with pytest.raises(ReaderError, match="rate cannot be set"):
        read(list(sensor_logger), rate=100.0)
