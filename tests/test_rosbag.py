"""ROS bags: sensor_msgs/Imu from ROS 1 and ROS 2 (SQLite, MCAP) bags written here with rosbags."""

import sys
from pathlib import Path

import numpy as np
import pytest

from imucalib.io import ReaderError, read
from imucalib.recording import ImucalibWarning
from synth import tedaldi_session

rosbags = pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin  # noqa: E402
from rosbags.rosbag2 import Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

T0_NS = 1_700_000_000_250_000_000  # a realistic epoch start [ns]


def _messages(ts, t, acc, gyro, frame="imu_link", zero_stamps=False):
    T = ts.types
    for ti, a, w in zip(t, acc, gyro, strict=True):
        ns = 0 if zero_stamps else T0_NS + int(round(ti * 1e9))
        stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        fields = {"stamp": stamp, "frame_id": frame}
        if "seq" in T["std_msgs/msg/Header"].__dataclass_fields__:  # ROS 1
            fields["seq"] = 0
        header = T["std_msgs/msg/Header"](**fields)
        v3 = T["geometry_msgs/msg/Vector3"]
        yield ns, T["sensor_msgs/msg/Imu"](
            header=header, orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.zeros(9), angular_velocity=v3(x=w[0], y=w[1], z=w[2]),
            angular_velocity_covariance=np.zeros(9), linear_acceleration=v3(x=a[0], y=a[1], z=a[2]),
            linear_acceleration_covariance=np.zeros(9))


def write_bag(path, kind, topics, zero_stamps=False):
    """``topics``: {topic: (t, acc, gyro)} or {topic: msgtype} for a non-IMU topic with no messages."""
    path = Path(path)
    if kind == "ros1":
        ts = get_typestore(Stores.ROS1_NOETIC)
        writer = Writer1(path)
    else:
        ts = get_typestore(Stores.ROS2_HUMBLE)
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    msgtype = "sensor_msgs/msg/Imu"
    with writer:
        for topic, content in topics.items():
            if isinstance(content, str):
                writer.add_connection(topic, content, typestore=ts)
                continue
            conn = writer.add_connection(topic, msgtype, typestore=ts)
            ser = ts.serialize_ros1 if kind == "ros1" else ts.serialize_cdr
            for k, (_, msg) in enumerate(_messages(ts, *content, zero_stamps=zero_stamps)):
                # recorded in arrival order, 10 ms apart, whatever the stamps say
                writer.write(conn, T0_NS + 5_000_000 + k * 10_000_000, ser(msg, msgtype))
    return path


@pytest.fixture(scope="module")
def session_si():
    rec, truth, iv = tedaldi_session(seed=3, noise_acc=0.02, noise_gyro=0.003, poses=30)
    si = truth.apply(rec)  # what a driver publishes: m/s² and rad/s
    return si, truth, iv


@pytest.mark.parametrize("kind", ["ros1", "sqlite", "mcap"])
def test_bag_round_trip(tmp_path, session_si, kind):
    si, _, _ = session_si
    name = "s.bag" if kind == "ros1" else "s"
    path = write_bag(tmp_path / name, kind, {"/imu/data": (si.t, si.acc, si.gyro)})
    rec = read(path)  # the format is recognised
    assert rec.metadata["reader"] == "rosbag" and rec.metadata["topic"] == "/imu/data"
    assert rec.acc_unit == "m/s^2" and rec.gyro_unit == "rad/s"
    assert rec.metadata["frame_id"] == ["imu_link"] and rec.metadata["time_source"] == "header.stamp"
    np.testing.assert_allclose(rec.t, si.t - si.t[0], atol=2e-9)  # nanosecond stamps
    np.testing.assert_array_equal(rec.acc, si.acc)
    np.testing.assert_array_equal(rec.gyro, si.gyro)


def test_lone_mcap_file(tmp_path, session_si):
    si, _, _ = session_si
    bag = write_bag(tmp_path / "m", "mcap", {"/imu": (si.t[:50], si.acc[:50], si.gyro[:50])})
    (mcap,) = bag.glob("*.mcap")
    rec = read(mcap)
    assert len(rec) == 50


def test_calibrate_from_a_bag_on_the_command_line(tmp_path, session_si, capsys):
    from imucalib.calibration import Calibration
    from imucalib.cli import main

    si, truth, _ = session_si
    bag = write_bag(tmp_path / "b", "sqlite", {"/imu": (si.t, si.acc, si.gyro), "/camera": "sensor_msgs/msg/Image"})
    assert main(["calibrate", str(bag), "--method", "tedaldi2014", "--gravity", str(truth.gravity),
                 "-o", str(tmp_path / "c.json"), "--json"]) == 0
    cal = Calibration.load(tmp_path / "c.json")
    # the driver's output is already SI: the correction is near the identity
    np.testing.assert_allclose(cal.accelerometer.scale, 1.0, atol=3e-3)
    np.testing.assert_allclose(cal.gyroscope.scale, 1.0, atol=1e-2)
    assert cal.units["accelerometer"]["raw"] == "m/s^2"


def test_topic_choice_and_errors(tmp_path, session_si):
    si, _, _ = session_si
    part = (si.t[:100], si.acc[:100], si.gyro[:100])
    bag = write_bag(tmp_path / "two", "sqlite", {"/imu_a": part, "/imu_b": part, "/odom": "nav_msgs/msg/Odometry"})
    with pytest.raises(ReaderError, match=r"several sensor_msgs/Imu topics \(/imu_a, /imu_b\); choose one with"):
        read(bag)
    assert len(read(bag, topic="/imu_b")) == 100
    with pytest.raises(ReaderError, match="'/odom': it is nav_msgs/msg/Odometry, not sensor_msgs/Imu"):
        read(bag, topic="/odom")
    with pytest.raises(ReaderError, match="'/nope': no such topic"):
        read(bag, topic="/nope")
    with pytest.raises(ReaderError, match="cannot be set"):
        read(bag, acc_unit="g")
    none = write_bag(tmp_path / "none", "sqlite", {"/odom": "nav_msgs/msg/Odometry"})
    with pytest.raises(ReaderError, match=r"no sensor_msgs/Imu topic in the bag; it has: /odom"):
        read(none)
    bad = tmp_path / "bad.bag"
    bad.write_bytes(b"#ROSBAG V2.0\ngarbage")
    with pytest.raises(ReaderError, match="not a readable ROS bag"):
        read(bad)
    with pytest.raises(ReaderError, match="topic applies to ROS bags"):
        p = tmp_path / "x.csv"
        p.write_text("t,ax,ay,az,gx,gy,gz\n0,0,0,1,0,0,0\n0.01,0,0,1,0,0,0\n")
        read(p, topic="/imu")


def test_out_of_order_and_repeated_stamps(tmp_path, session_si):
    si, _, _ = session_si
    t, acc, gyro = si.t[:60].copy(), si.acc[:60].copy(), si.gyro[:60].copy()
    order = np.arange(60)
    order[[10, 11]] = order[[11, 10]]  # two messages swapped
    idx = np.insert(order, 30, order[30])  # one message recorded twice
    bag = write_bag(tmp_path / "o", "sqlite", {"/imu": (t[idx], acc[idx], gyro[idx])})
    with pytest.warns(ImucalibWarning) as rec_warnings:
        rec = read(bag)
    text = " ".join(str(w.message) for w in rec_warnings)
    assert "out of stamp order" in text and "1 repeated messages" in text
    np.testing.assert_array_equal(rec.acc, acc)
    np.testing.assert_allclose(rec.t, t - t[0], atol=2e-9)
    conflict = idx.copy()
    acc2 = acc[conflict].copy()
    acc2[31] += 1.0  # same stamp as message 30, different reading
    bag = write_bag(tmp_path / "c", "sqlite", {"/imu": (t[conflict], acc2, gyro[conflict])})
    with pytest.raises(ReaderError, match="share the stamp .* with different readings"), pytest.warns(ImucalibWarning):
        read(bag)


def test_missing_stamps_fall_back_to_the_record_time(tmp_path, session_si):
    si, _, _ = session_si
    bag = write_bag(tmp_path / "z", "mcap", {"/imu": (si.t[:30], si.acc[:30], si.gyro[:30])}, zero_stamps=True)
    with pytest.warns(ImucalibWarning, match="no header stamps"):
        rec = read(bag)
    assert rec.metadata["time_source"] == "record time"
    np.testing.assert_allclose(rec.t, np.arange(30) * 0.01, atol=1e-12)


def test_without_rosbags_the_error_says_how_to_install(tmp_path, session_si, monkeypatch):
    si, _, _ = session_si
    bag = write_bag(tmp_path / "s.bag", "ros1", {"/imu": (si.t[:20], si.acc[:20], si.gyro[:20])})
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    with pytest.raises(ReaderError, match=r'pip install "imucalib\[ros\]"'):
        read(bag)


@pytest.mark.parametrize("kind", ["ros1", "sqlite", "mcap"])
def test_apply_writes_a_calibrated_bag(tmp_path, session_si, kind, capsys):
    from imucalib.calibration import Calibration
    from imucalib.cli import main
    from imucalib.models import TriadModel

    si, _, _ = session_si
    n = 400
    src = write_bag(tmp_path / ("in.bag" if kind == "ros1" else "in"), kind,
                    {"/imu": (si.t[:n], si.acc[:n], si.gyro[:n]), "/imu_other": (si.t[:5], si.acc[:5], si.gyro[:5])})
    cal = Calibration(
        accelerometer=TriadModel(misalignment=[[1, 0.01, -0.02], [0, 1, 0.03], [0, 0, 1]], scale=[1.01, 0.99, 1.02],
                                 bias=[0.1, -0.2, 0.05], shape="upper"),
        gyroscope=TriadModel(scale=[1.02, 0.98, 1.0], bias=[0.01, 0.0, -0.01], shape="full",
                             g_sensitivity=np.full((3, 3), 1e-3)),
        units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
               "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}})
    cal.save(tmp_path / "c.json")
    dst = tmp_path / ("out.bag" if kind == "ros1" else "out")
    assert main(["apply", str(tmp_path / "c.json"), str(src), "-o", str(dst), "--topic", "/imu", "--json"]) == 0
    summary = __import__("json").loads(capsys.readouterr().out)
    assert summary["corrected"] == n and summary["copied"] == 5
    out = read(dst, topic="/imu")
    expected = cal.apply(read(src, topic="/imu"))
    np.testing.assert_allclose(out.acc, expected.acc, rtol=1e-15, atol=1e-12)
    np.testing.assert_allclose(out.gyro, expected.gyro, rtol=1e-15, atol=1e-12)
    np.testing.assert_array_equal(out.t, expected.t)
    other_in, other_out = read(src, topic="/imu_other"), read(dst, topic="/imu_other")
    np.testing.assert_array_equal(other_out.acc, other_in.acc)  # other topics unchanged
    # never overwrite; a counts calibration does not fit a bag's SI readings
    assert main(["apply", str(tmp_path / "c.json"), str(src), "-o", str(dst), "--topic", "/imu"]) == 2
    assert "never overwritten" in capsys.readouterr().err
    cal.with_(units={"accelerometer": {"raw": "counts", "calibrated": "m/s^2"},
                     "gyroscope": {"raw": "counts", "calibrated": "rad/s"}}).save(tmp_path / "k.json")
    assert main(["apply", str(tmp_path / "k.json"), str(src), "-o", str(tmp_path / "x"), "--topic", "/imu"]) == 2
    assert "expects raw accelerometer readings in counts" in capsys.readouterr().err
    # to CSV as before when asked
    assert main(["apply", str(tmp_path / "c.json"), str(src), "-o", str(tmp_path / "o.csv"), "--topic", "/imu"]) == 0
