"""A sensor_msgs/MagneticField topic beside the IMU topic of a bag, calibrated like the simulated session."""

import warnings

import numpy as np
import pytest

from imucalib.cli import main
from imucalib.io import read
from imucalib.io.errors import ReaderError
from imucalib.io.rosbag import add_magnetic_field
from imucalib.methods import calibrate
from imucalib.recording import ImucalibWarning
from imucalib.scenarios import handheld

pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
from rosbags.rosbag2 import (
    StoragePlugin,  # noqa: E402
    Writer,  # noqa: E402
)
from rosbags.typesys import Stores, get_typestore  # noqa: E402

T0 = 1_700_000_000_000_000_000


def _bag(path, rec, mag_ut, mag_every=2):
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    v3, hdr, stamp = T["geometry_msgs/msg/Vector3"], T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]

    def header(ns):
        return hdr(stamp=stamp(sec=ns // 10**9, nanosec=ns % 10**9), frame_id="imu")

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        imu = w.add_connection("/imu", "sensor_msgs/msg/Imu", typestore=ts)
        mag = w.add_connection("/mag", "sensor_msgs/msg/MagneticField", typestore=ts)
        for k, (t, a, g) in enumerate(zip(rec.t, rec.acc, rec.gyro, strict=True)):
            ns = T0 + int(round(t * 1e9))
            msg = T["sensor_msgs/msg/Imu"](
                header=header(ns), orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                orientation_covariance=np.zeros(9), angular_velocity=v3(x=g[0], y=g[1], z=g[2]),
                angular_velocity_covariance=np.zeros(9), linear_acceleration=v3(x=a[0], y=a[1], z=a[2]),
                linear_acceleration_covariance=np.zeros(9))
            w.write(imu, ns, ts.serialize_cdr(msg, "sensor_msgs/msg/Imu"))
            if k % mag_every == 0:  # the magnetometer at half the rate, in tesla
                m = T["sensor_msgs/msg/MagneticField"](header=header(ns), magnetic_field=v3(
                    x=mag_ut[k, 0] * 1e-6, y=mag_ut[k, 1] * 1e-6, z=mag_ut[k, 2] * 1e-6),
                    magnetic_field_covariance=np.zeros(9))
                w.write(mag, ns, ts.serialize_cdr(m, "sensor_msgs/msg/MagneticField"))
    return path


def test_a_magnetic_field_topic_is_read_and_calibrated(tmp_path):
    d = handheld.generate(np.random.default_rng(5), magnetometer={"noise_uT": 0.0}, quantise=False,
                          full_scale=None, truth=handheld.consumer_truth(np.random.default_rng(5)))
    rec = d["recording"]
    si = d["truth"].with_(magnetometer=None).apply(rec)  # what a driver publishes: m/s^2, rad/s
    mag_ut = rec.mag * 0.15  # counts → µT as the simulated die reads them
    path = _bag(tmp_path / "s.mcap", si, mag_ut)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        got = add_magnetic_field(read(path, topic="/imu"), path, "/mag")
    assert got.mag_unit == "uT" and got.metadata["mag_topic"] == "/mag"
    np.testing.assert_allclose(got.mag[::2], mag_ut[: len(got)][::2], atol=1e-4)  # where a message is: its value
    cal = calibrate(got, method="tedaldi2014")
    assert cal.fit["verdict"] == "accepted", cal.fit["verdict_reasons"]
    assert cal.magnetometer.unit == "uT" and cal.magnetometer.axes()[0] == ["+y", "+x", "-z"]
    assert abs(cal.fit["magnetometer_dip_deg"] - 60.0) < 0.2
    assert main(["calibrate", str(path), "--topic", "/imu", "--mag-topic", "/mag", "--json"]) == 0
    with pytest.raises(ReaderError, match="MagneticField topics: /mag"):
        add_magnetic_field(read(path, topic="/imu"), path, "/imu")
