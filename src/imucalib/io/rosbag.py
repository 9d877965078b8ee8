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

__all__ = ["read_rosbag", "is_rosbag"]

IMU_TYPE = "sensor_msgs/msg/Imu"


def is_rosbag(path: Path) -> bool:
    """A ROS 1 bag file, an MCAP file, or a ROS 2 bag directory (it holds ``metadata.yaml``)."""
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    try:
        head = path.open("rb").read(13)
    except OSError:
        return False
    return head.startswith(b"#ROSBAG V2.0") or head.startswith(b"\x89MCAP0\r\n")


def _reader_error(message: str):
    from .readers import ReaderError

    return ReaderError(message)


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
    try:
        imu = sorted({c.topic for c in reader.connections if c.msgtype == IMU_TYPE})
        if topic is None:
            if not imu:
                types = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})
                raise _reader_error(f"{path}: no sensor_msgs/Imu topic in the bag; it has: "
                                    f"{', '.join(types) or 'no topics'}")
            if len(imu) > 1:
                raise _reader_error(f"{path}: several sensor_msgs/Imu topics ({', '.join(imu)}); "
                                    "choose one with --topic")
            topic = imu[0]
        elif topic not in imu:
            others = {c.topic: c.msgtype for c in reader.connections}
            why = (f"it is {others[topic]}, not sensor_msgs/Imu" if topic in others
                   else "no such topic")
            raise _reader_error(f"{path}: topic {topic!r}: {why}; IMU topics: {', '.join(imu) or 'none'}")
        conns = [c for c in reader.connections if c.topic == topic]
        n = sum(c.msgcount for c in conns)
        stamp = np.empty(n, dtype=np.int64)
        logged = np.empty(n, dtype=np.int64)
        data = np.empty((n, 6))
        frames = set()
        i = 0
        for conn, log_ns, raw in reader.messages(connections=conns):
            m = reader.deserialize(raw, conn.msgtype)
            stamp[i] = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
            logged[i] = log_ns
            a, w = m.linear_acceleration, m.angular_velocity
            data[i] = (a.x, a.y, a.z, w.x, w.y, w.z)
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
