"""ROS bags: ``sensor_msgs/Imu`` messages from ROS 1 ``.bag`` files and ROS 2 bags (SQLite or MCAP).

Reading uses the ``rosbags`` library (pure Python, no ROS installation), an
optional dependency: ``pip install "imucalib[ros]"``. The IMU topic itself is
read in bulk (:mod:`.bagraw`: the bag's own indexes locate every message, numpy
reads the fields of the fixed ``sensor_msgs/Imu`` layout, checked against
rosbags' deserialiser on the first and last message of every block; timed by
``benchmarks/bench_rosbag.py``); bags without indexes, compressed ROS 2 messages or
another layout go through rosbags' own reader message by message. A damaged
bag is a :class:`~imucalib.io.errors.ReaderError` naming the file, the topic
and the message. A ``sensor_msgs/Imu``
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

import contextlib
import itertools
import os
import re
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..recording import ImucalibWarning, Recording
from .atomic import atomic_create
from .errors import ReaderError
from .expansion import check_ros1_chunks

if TYPE_CHECKING:
    from . import bagraw

__all__ = ["MAG_TYPE", "add_magnetic_field", "is_rosbag", "read_rosbag", "write_calibrated_bag"]

IMU_TYPE = "sensor_msgs/msg/Imu"
#: the magnetometer's message type (field in tesla)
MAG_TYPE = "sensor_msgs/msg/MagneticField"


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


def _readings(m) -> tuple[float, ...]:
    a, w = m.linear_acceleration, m.angular_velocity
    return a.x, a.y, a.z, w.x, w.y, w.z


def _open(path: Path):
    try:
        from rosbags.highlevel import AnyReader  # optional: pip install imucalib[ros]
        from rosbags.typesys import Stores, get_typestore  # optional: pip install imucalib[ros]
    except ImportError:
        raise _reader_error(f"{path}: reading ROS bags needs the 'rosbags' package: "
                            'pip install "imucalib[ros]"') from None
    check_ros1_chunks(path)  # the library decompresses a chunk whole: a decompression bomb is refused first
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:  # the library's own errors (corrupt file, unknown storage)
        raise _reader_error(f"{path}: not a readable ROS bag ({_why(exc)})") from None
    return reader


def _why(exc: BaseException) -> str:
    """The library's words for a failure, or its kind when it has none (a bare AssertionError)."""
    text = str(exc).strip()
    return text if text else f"{type(exc).__name__} in the rosbags library"


def _damaged(path: Path, topic: str, k: int, exc: BaseException) -> ReaderError:
    return _reader_error(f"{path}: topic {topic!r}, message {k + 1}: the bag is damaged there and cannot be read "
                         f"({_why(exc)}); if it was copied or cut short, copy it again")


# ---------------------------------------------------------------- reading
_BLOCK = 65536


def _storage_files(path: Path, suffix: str) -> list[Path]:
    if path.is_file():
        return [path] if path.suffix == suffix else []
    meta = path / "metadata.yaml"
    text = meta.read_text(encoding="utf-8", errors="replace") if meta.is_file() else ""
    mode = re.search(r"compression_mode:\s*['\"]?(\w*)", text)
    if mode and mode.group(1).lower() not in ("", "none"):
        return []  # compressed files or messages: rosbags decompresses them
    return sorted(path.glob(f"*{suffix}"))


def _fast_blocks(reader, path: Path, topic: str):
    """Raw blocks from the bag's own indexes (:mod:`.bagraw`), or None when this bag needs rosbags' reader."""
    from . import bagraw  # the bag's own index readers: loaded when a bag is read (12 ms)
    if not reader.is2:
        index = reader.index if isinstance(reader, _LightBag) else bagraw.ros1_index(path)
        return None if index is None else bagraw.ros1_blocks(path, index, topic)
    mcaps = _storage_files(path, ".mcap")
    if mcaps:
        parts = [bagraw.mcap_blocks(f, topic) for f in mcaps]
        return None if any(p is None for p in parts) else itertools.chain.from_iterable(parts)
    dbs = reader.files if isinstance(reader, _LightBag) else _storage_files(path, ".db3")
    return bagraw.sqlite_blocks(dbs, topic) if dbs else None


class _LightBag:
    """A bag opened from its own index or metadata alone (rosbags' reader builds an object per message).

    Used only to read standard ``sensor_msgs/Imu`` topics; anything else goes through rosbags.
    """

    def __init__(self, connections, deserialize, is2: bool, *, index=None, files=None) -> None:
        self.connections, self._deserialize, self.is2 = connections, deserialize, is2
        self.index, self.files = index, files

    def deserialize(self, raw: bytes, msgtype: str):
        return self._deserialize(raw, msgtype)

    def close(self) -> None:
        pass


def _open_for_reading(path: Path):
    """A light reader for an indexed ROS 1 bag or an uncompressed SQLite rosbag2 whose IMU topics are
    standard, else rosbags' own reader."""
    from . import bagraw  # the bag's own index readers: loaded when a bag is read (12 ms)
    try:
        import rosbags.highlevel  # noqa: F401  (the reader of everything else; the same extra)
        from rosbags.typesys import Stores, get_typestore  # optional: pip install imucalib[ros]
    except ImportError:
        return _open(path)  # says how to install it
    if path.is_file() and path.suffix != ".mcap":
        index = bagraw.ros1_index(path)
        if index is not None:
            store = get_typestore(Stores.ROS1_NOETIC)
            standard = store.generate_msgdef(IMU_TYPE)[1]
            if all(c.md5sum == standard for c in index.connections if c.msgtype == IMU_TYPE):
                return _LightBag(index.connections, store.deserialize_ros1, False, index=index)
    elif path.is_dir():
        found = bagraw.rosbag2_sqlite(path)
        if found is not None:
            store = get_typestore(Stores.ROS2_HUMBLE)
            return _LightBag(found[0], store.deserialize_cdr, True, files=found[1])
    return _open(path)


def _library_blocks(reader, conns, seen: list[int] | None = None):
    """Raw blocks through rosbags' own iteration (any bag it reads); ``seen[0]`` counts the messages met."""
    from . import bagraw  # the bag's own index readers: loaded when a bag is read (12 ms)
    seen = [0] if seen is None else seen
    raws, logged = [], []
    for _conn, log_ns, raw in reader.messages(connections=conns):
        raws.append(raw)
        logged.append(log_ns)
        seen[0] += 1
        if len(raws) == _BLOCK:
            yield bagraw.joined(raws, logged)
            raws, logged = [], []
    if raws:
        yield bagraw.joined(raws, logged)


def _decoded(reader, block: bagraw.Block, msgtype: str, first: int, path: Path, topic: str) -> bagraw.ImuBlock:
    """The block's readings: numpy over the fixed layout, checked against the deserialiser on its first and
    last message; message by message through the deserialiser when the layout is not the standard one."""
    from . import bagraw  # the bag's own index readers: loaded when a bag is read (12 ms)
    fast = bagraw.decode_imu(block, not reader.is2)
    if fast is not None:
        try:
            for k in {0, len(block) - 1}:
                m = reader.deserialize(block.message(k), msgtype)
                stamp = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
                if (stamp != fast.stamp[k] or m.header.frame_id not in fast.frames
                        or _readings(m) != tuple(fast.readings[k])):
                    fast = None
                    break
        except Exception:  # the deserialiser's verdict comes below, message by message
            fast = None
    if fast is not None:
        return fast
    n = len(block)
    stamp, readings, frames = np.empty(n, np.int64), np.empty((n, 6)), set()
    for k in range(n):
        try:
            m = reader.deserialize(block.message(k), msgtype)
            stamp[k] = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
            readings[k] = _readings(m)
        except Exception as exc:
            raise _damaged(path, topic, first + k, exc) from None
        frames.add(m.header.frame_id)
    return bagraw.ImuBlock(stamp, readings, frames, np.full(n, -1, np.int64))


def _read_topic(reader, path: Path, topic: str, progress=None):
    """Record time [ns], stamp [ns], readings (N, 6), frames and field offsets of a topic, in record order.

    The bag's own indexes first (:mod:`.bagraw`); rosbags' iteration when the
    bag has none, or when what they give disagrees with the bag.
    """
    conns = [c for c in reader.connections if c.topic == topic]
    msgtype = conns[0].msgtype
    total = sum(c.msgcount for c in conns)
    with contextlib.ExitStack() as stack:
        for source in ("index", "library"):
            decoder, seen = reader, [0]
            if source == "index":
                blocks = _fast_blocks(reader, path, topic)
                if blocks is None:
                    continue
            else:
                if isinstance(reader, _LightBag):
                    decoder = _open(path)
                    stack.callback(decoder.close)
                blocks = _library_blocks(decoder, [c for c in decoder.connections if c.topic == topic], seen)
            parts, done = [], 0
            try:
                for block in blocks:
                    parts.append((block.logged, _decoded(decoder, block, msgtype, done, path, topic)))
                    done += len(block)
                    if progress is not None:
                        progress(done, total)
            except ReaderError:
                raise
            except Exception as exc:  # a damaged bag: the library's reader says where, or fails itself
                if source == "index":
                    continue
                raise _damaged(path, topic, max(seen[0] - 1, done), exc) from None
            if source == "library" or done == total:
                break  # (an index that disagrees with the bag's message count: read it the library's way)
    if not parts:
        return (np.empty(0, np.int64), np.empty(0, np.int64), np.empty((0, 6)), set(), np.empty(0, np.int64))
    logged = np.concatenate([p[0] for p in parts])
    order = np.argsort(logged, kind="stable")  # record order, as rosbags yields
    stamp = np.concatenate([p[1].stamp for p in parts])[order]
    readings = np.concatenate([p[1].readings for p in parts])[order]
    fields_at = np.concatenate([p[1].fields_at for p in parts])[order]
    frames = set().union(*(p[1].frames for p in parts))
    return logged[order], stamp, readings, frames, fields_at


def read_rosbag(path: str | Path, *, topic: str | None = None, progress=None, mag_topic: str | None = None
                ) -> Recording:
    """Read the IMU messages of one topic of a ROS bag.

    Parameters
    ----------
    path : path
        A ROS 1 ``.bag`` file, a ROS 2 bag directory, or an ``.mcap`` file.
    topic : str, optional
        The ``sensor_msgs/Imu`` topic; needed only when the bag has several.
    progress : callable, optional
        ``progress(done, total)`` as messages are read (e.g. :class:`imucalib.progress.Progress`).
    mag_topic : str, optional
        A ``sensor_msgs/MagneticField`` topic beside it (:func:`add_magnetic_field`).
    """
    rec = _read_imu(Path(path), topic, progress)
    return rec if mag_topic is None else add_magnetic_field(rec, path, mag_topic)


def add_magnetic_field(recording: Recording, path: str | Path, mag_topic: str) -> Recording:
    """``recording`` (read from the bag ``path``) with the field of a ``sensor_msgs/MagneticField`` topic.

    The field [T → µT] is interpolated linearly onto the IMU's stamps; IMU messages outside the span
    the magnetometer covers are left out, with a note.
    """
    if "start_time_ns" not in recording.metadata:
        raise ValueError("a magnetometer topic goes with a recording read from the same ROS bag")
    stamp, field = _read_magnetic_field(Path(path), mag_topic)
    imu_ns = recording.metadata["start_time_ns"] + np.round(recording.t * 1e9)
    keep = (imu_ns >= stamp[0]) & (imu_ns <= stamp[-1])
    if not np.any(keep):
        raise _reader_error(f"{path}: the magnetometer topic {mag_topic!r} and the IMU topic do not overlap in time")
    if not np.all(keep):
        warnings.warn(f"{path}: {int((~keep).sum())} IMU messages outside the span of {mag_topic!r} were left out",
                      ImucalibWarning, stacklevel=2)
    sel = np.nonzero(keep)[0]
    sub = recording[int(sel[0]):int(sel[-1]) + 1]
    x = (imu_ns[sel] - stamp[0]) * 1e-9
    xs = (stamp - stamp[0]) * 1e-9
    mag = np.column_stack([np.interp(x, xs, field[:, k]) for k in range(3)]) * 1e6  # T → µT
    return Recording(sub.t, sub.acc, sub.gyro, acc_unit=sub.acc_unit, gyro_unit=sub.gyro_unit,
                     metadata={**sub.metadata, "mag_topic": mag_topic}, mag=mag, mag_unit="uT")


def _read_magnetic_field(path: Path, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """Stamps [ns] (increasing) and fields [T] (N, 3) of a ``sensor_msgs/MagneticField`` topic."""
    reader = _open(path)
    try:
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns or any(c.msgtype != MAG_TYPE for c in conns):
            mags = sorted({c.topic for c in reader.connections if c.msgtype == MAG_TYPE})
            why = "no such topic" if not conns else f"it is {conns[0].msgtype}, not sensor_msgs/MagneticField"
            raise _reader_error(f"{path}: magnetometer topic {topic!r}: {why}; MagneticField topics: "
                                f"{', '.join(mags) or 'none'}")
        rows = []
        for k, (conn, log_ns, raw) in enumerate(reader.messages(connections=conns)):
            try:
                m = reader.deserialize(raw, conn.msgtype)
            except Exception as exc:  # the library's own errors on damaged bytes
                raise _damaged(path, topic, k, exc) from None
            ns = int(m.header.stamp.sec) * 10**9 + int(m.header.stamp.nanosec) or int(log_ns)
            f = m.magnetic_field
            rows.append((ns, f.x, f.y, f.z))
    finally:
        reader.close()
    if len(rows) < 2:
        raise _reader_error(f"{path}: magnetometer topic {topic!r} has {len(rows)} message(s)")
    data = np.array(rows, dtype=np.float64)
    stamp = np.array([r[0] for r in rows], dtype=np.int64)
    order = np.argsort(stamp, kind="stable")
    stamp, field = stamp[order], data[order, 1:]
    keep = np.concatenate([[True], np.diff(stamp) > 0])
    if not np.all(np.isfinite(field[keep])):
        raise _reader_error(f"{path}: magnetometer topic {topic!r}: a reading is not a finite number")
    return stamp[keep], field[keep]


def _read_imu(path: Path, topic: str | None, progress) -> Recording:
    reader = _open_for_reading(path)
    try:
        topic = _choose_topic(reader, topic, path)
        logged, stamp, data, frames, _ = _read_topic(reader, path, topic, progress)
    finally:
        reader.close()
    i = stamp.size
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
            raise _reader_error(f"{path}: topic {topic!r}: two messages share the stamp {int(stamp[k])} ns with "
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
                         topic: str | None = None, progress=None) -> dict:
    """Copy a ROS bag with the IMU topic's readings replaced by their calibrated values.

    Every other topic, every message's stamp, record time, frame and
    covariances are copied unchanged; only ``linear_acceleration`` and
    ``angular_velocity`` of the chosen ``sensor_msgs/Imu`` topic change, by
    :meth:`~imucalib.calibration.Calibration.apply`'s model (the bag's SI
    readings are the calibration's raw input, so the calibration must have
    been made from this driver's output: units ``m/s^2`` and ``rad/s``). A
    ROS 1 bag is written as a ROS 1 bag, a ROS 2 bag as a ROS 2 bag directory
    (MCAP storage when the source is MCAP, else SQLite), a lone ``.mcap``
    file as a lone ``.mcap`` file. The IMU messages keep every byte but the
    six doubles that change (written in place in the serialised message when
    it has the standard layout, else deserialised and serialised again).

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
        raw, fields_at = _raw_imu(reader, [c for c in reader.connections if c.topic == topic], source, topic)
        acc = calibration.accelerometer_si(raw[:, :3])
        gyro = calibration.gyroscope.forward(raw[:, 3:], acc)
        total = sum(c.msgcount for c in reader.connections)
        lone_mcap = reader.is2 and source.is_file()
        with atomic_create(destination) as building:
            target = building.with_name(building.name + ".bag") if lone_mcap else building
            writer, serialize = _writer_like(reader, source, target)
            with writer:
                out = {}
                for c in reader.connections:
                    out[c.id] = _add_connection_like(writer, c, reader)
                copied, corrected = _copy_messages(reader, writer, out, serialize, topic, fields_at, (acc, gyro),
                                                   progress, total, source)
            if lone_mcap:
                os.rename(target / f"{target.name}.mcap", building)
            if progress is not None:
                progress(copied + corrected, total)
    finally:
        reader.close()
    return {"topic": topic, "corrected": corrected, "copied": copied, "output": str(destination)}


def _raw_imu(reader, imu_conns: list, source: Path, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """The topic's raw readings (messages × 6: accelerometer, gyroscope) in the order the copy meets them, and
    where each message's fields lie in its bytes (−1 where the layout is not the standard one)."""
    msgtype = imu_conns[0].msgtype
    raw_parts, offsets, done = [], [], 0
    try:  # rosbags' own order, the order the copy below meets the messages in
        for block in _library_blocks(reader, imu_conns):
            decoded = _decoded(reader, block, msgtype, done, source, topic)
            raw_parts.append(decoded.readings)
            offsets.append(decoded.fields_at)
            done += len(block)
    except ReaderError:
        raise
    except Exception as exc:
        raise _damaged(source, topic, done, exc) from None
    raw = np.concatenate(raw_parts) if raw_parts else np.empty((0, 6))
    fields_at = np.concatenate(offsets) if offsets else np.empty(0, np.int64)
    return raw, fields_at


def _copy_messages(reader, writer, out: dict, serialize, topic: str, fields_at: np.ndarray, calibrated: tuple,
                   progress, total: int, source: Path) -> tuple[int, int]:
    """Every message written to ``writer``, the topic's with the calibrated readings; (copied, corrected)."""
    acc, gyro = calibrated
    acc_bytes, gyro_bytes = acc.astype("<f8"), gyro.astype("<f8")
    copied = corrected = 0
    try:
        for conn, log_ns, data in reader.messages():
            if conn.topic == topic:
                k, o = corrected, int(fields_at[corrected])
                if o >= 0:  # the standard layout: the six doubles in place
                    b = bytearray(data)
                    b[o + 104:o + 128] = gyro_bytes[k].tobytes()
                    b[o + 200:o + 224] = acc_bytes[k].tobytes()
                    data = bytes(b)
                else:
                    m = reader.deserialize(data, conn.msgtype)
                    la, av = m.linear_acceleration, m.angular_velocity
                    la.x, la.y, la.z = map(float, acc[k])
                    av.x, av.y, av.z = map(float, gyro[k])
                    data = serialize(m, conn.msgtype)
                corrected += 1
            else:
                copied += 1
            writer.write(out[conn.id], log_ns, data)
            if progress is not None and (copied + corrected) % 10_000 == 0:
                progress(copied + corrected, total)
    except (ReaderError, OSError):
        raise
    except Exception as exc:
        raise _reader_error(f"{source}: the bag is damaged and cannot be copied past message "
                            f"{copied + corrected + 1} ({_why(exc)})") from None
    return copied, corrected


def _writer_like(reader, source: Path, destination: Path):
    """A writer of the source's kind, and the matching message serializer."""
    if not reader.is2:
        from rosbags.rosbag1 import Writer  # optional: pip install imucalib[ros]

        return Writer(destination), reader.typestore.serialize_ros1
    from rosbags.rosbag2 import StoragePlugin, Writer  # optional: pip install imucalib[ros]

    mcap = source.suffix == ".mcap" or (source.is_dir() and any(source.glob("*.mcap")))
    plugin = StoragePlugin.MCAP if mcap else StoragePlugin.SQLITE3
    return Writer(destination, version=9, storage_plugin=plugin), reader.typestore.serialize_cdr


def _add_connection_like(writer, c, reader):
    if not reader.is2:
        return writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data, md5sum=c.digest,
                                     callerid=c.ext.callerid, latching=c.ext.latching)
    qos = {"serialization_format": c.ext.serialization_format, "offered_qos_profiles": c.ext.offered_qos_profiles}
    if c.digest.startswith("RIHS01_"):
        return writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data, rihs01=c.digest, **qos)
    # a lone .mcap names no type hash: the reader's type store (which holds the bag's own definitions) does
    return writer.add_connection(c.topic, c.msgtype, typestore=reader.typestore, **qos)
