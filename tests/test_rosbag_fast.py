"""The bulk ROS bag reader (the bags' own indexes + numpy over the sensor_msgs/Imu layout) against rosbags."""

import numpy as np
import pytest

rosbags = pytest.importorskip("rosbags", reason="the ros extra (rosbags) is not installed")
from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin  # noqa: E402
from rosbags.rosbag2 import Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

import imucalib.io.rosbag as rosbag  # noqa: E402
from imucalib.io import bagraw, read  # noqa: E402

T0_NS = 1_700_000_000_000_000_000


def _imu(ts, ns, acc, gyro, frame, seq=0):
    T = ts.types
    fields = {"stamp": T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), "frame_id": frame}
    if "seq" in T["std_msgs/msg/Header"].__dataclass_fields__:
        fields["seq"] = seq
    v3 = T["geometry_msgs/msg/Vector3"]
    rng = np.random.default_rng(seq)
    return T["sensor_msgs/msg/Imu"](
        header=T["std_msgs/msg/Header"](**fields),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.1, y=0.2, z=0.3, w=0.9),
        orientation_covariance=rng.normal(size=9), angular_velocity=v3(x=gyro[0], y=gyro[1], z=gyro[2]),
        angular_velocity_covariance=rng.normal(size=9), linear_acceleration=v3(x=acc[0], y=acc[1], z=acc[2]),
        linear_acceleration_covariance=rng.normal(size=9))


def _bag(path, kind, n=700, frames=("imu_link",), compression=None):
    """Two IMU topics, interleaved, and a topic of another type; frame ids cycling through ``frames``."""
    rng = np.random.default_rng(4)
    if kind == "ros1":
        ts = get_typestore(Stores.ROS1_NOETIC)
        writer = Writer1(path)
        writer.chunk_threshold = 20_000  # many chunks
        if compression:
            writer.set_compression(getattr(Writer1.CompressionFormat, compression))
        ser = ts.serialize_ros1
    else:
        ts = get_typestore(Stores.ROS2_HUMBLE)
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
        if compression:
            writer.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
        ser = ts.serialize_cdr
    truth = {}
    with writer:
        conns = {t: writer.add_connection(t, "sensor_msgs/msg/Imu", typestore=ts) for t in ("/imu", "/imu2")}
        other = writer.add_connection("/status", "std_msgs/msg/String", typestore=ts)
        for k in range(n):
            for topic, conn in conns.items():
                ns = T0_NS + k * 2_500_000 + (7 if topic == "/imu2" else 0)
                acc, gyro = rng.normal(size=3) * 9.8, rng.normal(size=3)
                frame = frames[k % len(frames)]
                writer.write(conn, ns + 1000, ser(_imu(ts, ns, acc, gyro, frame, k), "sensor_msgs/msg/Imu"))
                truth.setdefault(topic, []).append((ns, *acc, *gyro))
            if k % 50 == 0:
                writer.write(other, T0_NS + k * 2_500_000 + 3, ser(ts.types["std_msgs/msg/String"](data="ok"),
                                                                   "std_msgs/msg/String"))
    return path, {t: np.array(v) for t, v in truth.items()}


def _library_only(monkeypatch):
    """Read as before the bulk path: rosbags' iteration and its deserialiser for every message."""
    monkeypatch.setattr(rosbag, "_fast_blocks", lambda *a: None)
    monkeypatch.setattr(rosbag, "_open_for_reading", rosbag._open)
    monkeypatch.setattr(bagraw, "decode_imu", lambda *a: None)


KINDS = [("ros1", None), ("ros1", "BZ2"), ("ros1", "LZ4"), ("sqlite", None), ("mcap", None), ("sqlite", "zstd"),
         ("mcap", "zstd")]


@pytest.mark.parametrize(("kind", "compression"), KINDS)
def test_the_bulk_reader_gives_what_rosbags_gives(tmp_path, monkeypatch, kind, compression):
    frames = ("imu", "", "a_much_longer_frame_name", "imu_link")  # every CDR padding
    path, truth = _bag(tmp_path / ("b.bag" if kind == "ros1" else "b"), kind, frames=frames,
                       compression=compression)
    library = []

    def count(*a, **k):
        library.append(1)
        return original(*a, **k)

    original = rosbag._library_blocks
    monkeypatch.setattr(rosbag, "_library_blocks", count)
    fast = {t: read(path, topic=t) for t in ("/imu", "/imu2")}
    assert bool(library) == bool(compression and kind != "ros1")  # only compressed ROS 2 messages need rosbags
    monkeypatch.undo()
    _library_only(monkeypatch)
    for topic, rec in fast.items():
        ref = read(path, topic=topic)
        np.testing.assert_array_equal(rec.t, ref.t)
        np.testing.assert_array_equal(rec.acc, ref.acc)
        np.testing.assert_array_equal(rec.gyro, ref.gyro)
        assert rec.metadata["frame_id"] == ref.metadata["frame_id"] == sorted(frames)
        assert rec.metadata["start_time_ns"] == ref.metadata["start_time_ns"] == truth[topic][0, 0]
        np.testing.assert_array_equal(rec.acc, truth[topic][:, 1:4])  # and both are the truth
        np.testing.assert_array_equal(rec.gyro, truth[topic][:, 4:7])


def test_a_lone_mcap_file_and_progress(tmp_path):
    path, truth = _bag(tmp_path / "m", "mcap", n=300)
    (mcap,) = path.glob("*.mcap")
    calls = []
    rec = rosbag.read_rosbag(mcap, topic="/imu", progress=lambda done, total: calls.append((done, total)))
    np.testing.assert_array_equal(rec.acc, truth["/imu"][:, 1:4])
    assert calls[-1] == (300, 300)


def test_the_layout_agrees_with_the_deserialiser_message_by_message():
    rng = np.random.default_rng(0)
    for store, ros1 in ((Stores.ROS1_NOETIC, True), (Stores.ROS2_HUMBLE, False)):
        ts = get_typestore(store)
        ser = ts.serialize_ros1 if ros1 else ts.serialize_cdr
        de = ts.deserialize_ros1 if ros1 else ts.deserialize_cdr
        raws = []
        for k in range(40):
            frame = "x" * int(rng.integers(0, 20))
            ns = int(rng.integers(0, 2**31)) * 10**9 + int(rng.integers(0, 10**9))
            raws.append(bytes(ser(_imu(ts, ns, rng.normal(size=3), rng.normal(size=3), frame, k),
                                  "sensor_msgs/msg/Imu")))
        block = bagraw.joined(raws, list(range(40)))
        fast = bagraw.decode_imu(block, ros1)
        for k, raw in enumerate(raws):
            m = de(raw, "sensor_msgs/msg/Imu")
            a, w = m.linear_acceleration, m.angular_velocity
            assert tuple(fast.readings[k]) == (a.x, a.y, a.z, w.x, w.y, w.z)
            assert fast.stamp[k] == m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
        # a message of another length is not taken for an Imu
        assert bagraw.decode_imu(bagraw.joined([raws[0] + b"\0"], [0]), ros1) is None


def test_apply_patches_only_the_readings(tmp_path):
    from imucalib.calibration import Calibration
    from imucalib.models import TriadModel

    for kind in ("ros1", "mcap"):
        src, truth = _bag(tmp_path / ("in.bag" if kind == "ros1" else f"in_{kind}"), kind, n=200, frames=("f", "ff"))
        cal = Calibration(accelerometer=TriadModel(scale=[1.01, 0.99, 1.02], bias=[0.1, -0.2, 0.05], shape="upper"),
                          gyroscope=TriadModel(scale=[1.02, 0.98, 1.0], bias=[0.01, 0.0, -0.01], shape="full"),
                          units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
                                 "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}})
        dst = tmp_path / ("out.bag" if kind == "ros1" else f"out_{kind}")
        rosbag.write_calibrated_bag(src, dst, cal, topic="/imu")
        out, ref = read(dst, topic="/imu"), cal.apply(read(src, topic="/imu"))
        np.testing.assert_array_equal(out.acc, ref.acc)
        np.testing.assert_array_equal(out.gyro, ref.gyro)
        np.testing.assert_array_equal(read(dst, topic="/imu2").acc, truth["/imu2"][:, 1:4])
        # every other byte of every IMU message is the source's
        r_in, r_out = rosbag._open(src), rosbag._open(dst)
        try:
            a = [raw for c, _, raw in r_in.messages() if c.topic == "/imu"]
            b = [raw for c, _, raw in r_out.messages() if c.topic == "/imu"]
        finally:
            r_in.close()
            r_out.close()
        for x, y in zip(a, b, strict=True):
            x, y = np.frombuffer(x, np.uint8), np.frombuffer(y, np.uint8)
            o = x.size - bagraw.IMU_FIELDS_BYTES
            keep = np.ones(x.size, bool)
            keep[o + 104:o + 128] = keep[o + 200:o + 224] = False
            np.testing.assert_array_equal(x[keep], y[keep])
