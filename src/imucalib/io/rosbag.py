"""ROS bags: ``sensor_msgs/Imu`` messages from ROS 1 ``.bag`` files and ROS 2 bags (SQLite or MCAP).

Reading uses the ``rosbags`` library (pure Python, no ROS installation), an
optional dependency: ``pip install "imucalib[ros]"``. A ``sensor_msgs/Imu``
carries ``linear_acceleration`` in m/s² and ``angular_velocity`` in rad/s
(REP 103/145), so the recording is in SI units; a calibration of such data
corrects a driver's own calibration rather than raw counts.

Time is the message's ``header.stamp`` (the sensor's sampling time); a topic
whose stamps are all zero falls back to the time each message was recorded,
with a warning. Messages whose stamps arrive out of order are put in order
(with a warning saying how many); a stamp repeated with different readings is
an error, a repeated identical message is dropped with a warning. Nothing else
is changed.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..recording import ImucalibWarning, Recording
from .atomic import atomic_create
from .errors import ReaderError

__all__ = ["read_rosbag", "is_rosbag", "write_calibrated_bag"]

IMU_TYPE = "sensor_msgs/msg/Imu"


def is_rosbag(path: Path) -> bool:
    """A ROS 1 bag file, an MCAP file, or a ROS 2 bag directory (it holds ``metadata.yaml``)."""
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    try:
        with path.open("rb") as f:
            head = f.read(13)
    except OSError:
        return False
    return head.startswith(b"#ROSBAG V2.0") or head.startswith(b"\x89MCAP0\r\n")


def _reader_error(message: str) -> ReaderError:
    return ReaderError(message)


def _choose_topic(reader, topic: str | None, path: Path) -> str:
    """The IMU topic: the one given (checked) or the bag's only ``sensor_msgs/Imu`` topic."""
    imu = sorted({c.topic for c in reader.connections if c.msgtype == IMU_TYPE})
    if topic is None:
        if not imu:
            types = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})
            raise _reader_error(f"{path}: no sensor_msgs/Imu topic in the bag; it has: "
                                f"{', '.join(types) or 'no topics'}")
        if len(imu) > 1:
            raise _reader_error(f"{path}: several sensor_msgs/Imu topics ({', '.join(imu)}); "
                                "choose one with --topic")
        return imu[0]
    if topic not in imu:
        others = {c.topic: c.msgtype for c in reader.connections}
        why = f"it is {others[topic]}, not sensor_msgs/Imu" if topic in others else "no such topic"
        raise _reader_error(f"{path}: topic {topic!r}: {why}; IMU topics: {', '.join(imu) or 'none'}")
    return topic


def _imu_messages(reader, connections):
    """``(record time [ns], message)`` of the given connections, in record order."""
    for conn, log_ns, raw in reader.messages(connections=connections):
        yield log_ns, reader.deserialize(raw, conn.msgtype)


def _readings(m) -> tuple[float, ...]:
    a, w = m.linear_acceleration, m.angular_velocity
    return a.x, a.y, a.z, w.x, w.y, w.z


def _open(path: Path):
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise _reader_error(f"{path}: reading ROS bags needs the 'rosbags' package: "
                            'pip install "imucalib[ros]"') from None
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:  # the library's own errors (corrupt file, unknown storage)
        raise _reader_error(f"{path}: not a readable ROS bag ({exc})") from None
    return reader


def read_rosbag(path: str | Path, *, topic: str | None = None) -> Recording:
    """Read the IMU messages of one topic of a ROS bag.

    Parameters
    ----------
    path : path
        A ROS 1 ``.bag`` file, a ROS 2 bag directory, or an ``.mcap`` file.
    topic : str, optional
        The ``sensor_msgs/Imu`` topic; needed only when the bag has several.
    """
    path = Path(path)
    reader = _open(path)
    try:
        topic = _choose_topic(reader, topic, path)
        conns = [c for c in reader.connections if c.topic == topic]
        n = sum(c.msgcount for c in conns)
        stamp = np.empty(n, dtype=np.int64)
        logged = np.empty(n, dtype=np.int64)
        data = np.empty((n, 6))
        frames = set()
        i = 0
        for log_ns, m in _imu_messages(reader, conns):
            stamp[i] = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
            logged[i] = log_ns
            data[i] = _readings(m)
            frames.add(m.header.frame_id)
            i += 1
    finally:
        reader.close()
    stamp, logged, data = stamp[:i], logged[:i], data[:i]
    if i < 2:
        raise _reader_error(f"{path}: topic {topic!r} has {i} message(s); a recording needs more")
    if not np.all(np.isfinite(data)):
        k = int(np.nonzero(~np.all(np.isfinite(data), axis=1))[0][0])
        raise _reader_error(f"{path}: topic {topic!r}, message {k + 1}: a reading is not a finite number")
    source = "header.stamp"
    if not np.any(stamp):
        warnings.warn(f"{path}: topic {topic!r} has no header stamps (all zero); using the time each "
                      "message was recorded, which includes transport delays", ImucalibWarning, stacklevel=2)
        stamp, source = logged, "record time"
    order = np.argsort(stamp, kind="stable")
    moved = int(np.count_nonzero(order != np.arange(i)))
    if moved:
        warnings.warn(f"{path}: topic {topic!r}: {moved} messages arrived out of stamp order and were "
                      "put in order", ImucalibWarning, stacklevel=2)
        stamp, data = stamp[order], data[order]
    same = np.nonzero(np.diff(stamp) == 0)[0]
    if same.size:
        differ = same[np.any(data[same] != data[same + 1], axis=1)]
        if differ.size:
            k = int(differ[0])
            raise _reader_error(f"{path}: topic {topic!r}: two messages share the stamp {stamp[k]} ns with "
                                "different readings; the bag mixes two sources or the driver's clock is broken")
        keep = np.ones(i, dtype=bool)
        keep[same + 1] = False
        warnings.warn(f"{path}: topic {topic!r}: {same.size} repeated messages (same stamp, same readings) "
                      "dropped", ImucalibWarning, stacklevel=2)
        stamp, data = stamp[keep], data[keep]
    t = (stamp - stamp[0]) * 1e-9
    return Recording(t, data[:, :3], data[:, 3:], acc_unit="m/s^2", gyro_unit="rad/s",
                     metadata={"topic": topic, "frame_id": sorted(frames), "time_source": source,
                               "start_time_ns": int(stamp[0])})


def write_calibrated_bag(source: str | Path, destination: str | Path, calibration, *,
                         topic: str | None = None) -> dict:
    """Copy a ROS bag with the IMU topic's readings replaced by their calibrated values.

    Every other topic, every message's stamp, record time, frame and
    covariances are copied unchanged; only ``linear_acceleration`` and
    ``angular_velocity`` of the chosen ``sensor_msgs/Imu`` topic change, by
    :meth:`~imucalib.calibration.Calibration.apply`'s model (the bag's SI
    readings are the calibration's raw input, so the calibration must have
    been made from this driver's output: units ``m/s^2`` and ``rad/s``). A
    ROS 1 bag is written as a ROS 1 bag, a ROS 2 bag as a ROS 2 bag directory
    (MCAP storage when the source is MCAP, else SQLite).

    The bag is written under a hidden temporary name next to ``destination``
    and renamed to it only when complete (:func:`imucalib.io.atomic.atomic_create`),
    so a failed or interrupted write leaves nothing at ``destination`` and
    nothing that blocks the next run; an existing ``destination`` is refused.

    Returns a summary: the topic, the messages corrected and copied.
    """
    source, destination = Path(source), Path(destination)
    for sensor, unit in (("accelerometer", "m/s^2"), ("gyroscope", "rad/s")):
        raw = calibration.units[sensor]["raw"]
        if raw != unit:
            raise _reader_error(f"the calibration expects raw {sensor} readings in {raw}; a sensor_msgs/Imu "
                                f"holds {unit}: calibrate from a recording of this bag's topic")
    if destination.exists():
        raise _reader_error(f"{destination}: exists; choose a new name (a bag is never overwritten)")
    reader = _open(source)
    try:
        topic = _choose_topic(reader, topic, source)
        imu_conns = [c for c in reader.connections if c.topic == topic]
        raw = np.asarray([_readings(m) for _, m in _imu_messages(reader, imu_conns)], dtype=float).reshape(-1, 6)
        acc = calibration.accelerometer_si(raw[:, :3])
        gyro = calibration.gyroscope.forward(raw[:, 3:], acc)
        with atomic_create(destination) as building:
            writer, serialize = _writer_like(reader, source, building)
            copied = corrected = 0
            with writer:
                out = {}
                for c in reader.connections:
                    out[c.id] = _add_connection_like(writer, c, reader.is2)
                for conn, log_ns, data in reader.messages():
                    if conn.topic == topic:
                        m = reader.deserialize(data, conn.msgtype)
                        a, w = acc[corrected], gyro[corrected]
                        m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z = map(float, a)
                        m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z = map(float, w)
                        data = serialize(m, conn.msgtype)
                        corrected += 1
                    else:
                        copied += 1
                    writer.write(out[conn.id], log_ns, data)
    finally:
        reader.close()
    return {"topic": topic, "corrected": corrected, "copied": copied, "output": str(destination)}


def _writer_like(reader, source: Path, destination: Path):
    """A writer of the source's kind, and the matching message serializer."""
    if not reader.is2:
        from rosbags.rosbag1 import Writer

        return Writer(destination), reader.typestore.serialize_ros1
    from rosbags.rosbag2 import StoragePlugin, Writer

    mcap = source.suffix == ".mcap" or (source.is_dir() and any(source.glob("*.mcap")))
    plugin = StoragePlugin.MCAP if mcap else StoragePlugin.SQLITE3
    return Writer(destination, version=9, storage_plugin=plugin), reader.typestore.serialize_cdr


def _add_connection_like(writer, c, is2: bool):
    if not is2:
        return writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data, md5sum=c.digest,
                                     callerid=c.ext.callerid, latching=c.ext.latching)
    return writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data,
                                 rihs01=c.digest if c.digest.startswith("RIHS01_") else None,
                                 serialization_format=c.ext.serialization_format,
                                 offered_qos_profiles=c.ext.offered_qos_profiles)
