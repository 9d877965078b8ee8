"""Raw message bytes of one topic of a ROS bag, in blocks of numpy arrays, and the ``sensor_msgs/Imu`` layout.

:mod:`.rosbag` reads bags with the ``rosbags`` library, whose per-message Python
iteration and deserialisation take ~20 µs a message (a 1-hour 400 Hz topic,
1.44 M messages, ~30 s). This module reads the same bytes in bulk:

* the bag's own indexes give every message's position (ROS 1: the IndexData
  records after each chunk, 12 bytes a message; MCAP: the Message Index
  records named by the summary's Chunk Index records, 16 bytes a message;
  ROS 2 SQLite: one query), so a whole chunk's messages are located with
  numpy and no per-message Python;
* :func:`decode_imu` reads the fields of a ``sensor_msgs/Imu`` from the
  serialised bytes with numpy: the message has a fixed layout once the
  length of ``header.frame_id`` is known (ROS 1 serialisation: packed little
  endian; ROS 2 CDR: 8-byte aligned doubles after a 4-byte encapsulation
  header).

Formats (the layouts are those of the published specifications: the ROS 1
bag format 2.0, the MCAP specification, the rosbag2 SQLite schema, CDR of
the OMG DDS-XTypes standard):

ROS 1 record     ``u32 header_len, header (u32 len + "name=value" fields), u32 data_len, data``
MCAP record      ``u8 opcode, u64 length, content``
sensor_msgs/Imu  ``header{[u32 seq], stamp{sec, nanosec}, frame_id}``, ``orientation`` (4 f8),
                 9 f8, ``angular_velocity`` (3 f8), 9 f8, ``linear_acceleration`` (3 f8), 9 f8

Every function here returns None when a file is not of the shape it
expects (an unindexed or compressed-with-an-unknown-codec bag, a message
of another layout); the caller then uses ``rosbags``' own reader, which
is the reference (the tests check both paths agree to the bit).
"""

from __future__ import annotations

import contextlib
import sqlite3
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .expansion import Budget, decompress_chunk

__all__ = ["IMU_FIELDS_BYTES", "Block", "ImuBlock", "BagConnection", "Ros1Index", "decode_imu", "joined",
           "mcap_blocks", "ros1_blocks", "ros1_index", "rosbag2_sqlite", "sqlite_blocks"]

#: bytes of a sensor_msgs/Imu after header.frame_id's characters (and CDR's alignment padding)
IMU_FIELDS_BYTES = 37 * 8
_ANGULAR = np.arange(104, 128)  # angular_velocity x, y, z after the header (4 + 9 doubles in)
_LINEAR = np.arange(200, 224)  # linear_acceleration x, y, z (4 + 9 + 3 + 9 doubles in)
_ROS1_INDEX = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("offset", "<u4")])
_MCAP_INDEX = np.dtype([("log_time", "<u8"), ("offset", "<u8")])
_MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass
class Block:
    """Messages of one topic: their bytes laid end to end and where each one is.

    ``data[starts[k]:starts[k] + lengths[k]]`` is message ``k``; ``logged`` its
    record time [ns].
    """

    data: np.ndarray  # uint8
    starts: np.ndarray  # int64
    lengths: np.ndarray  # int64
    logged: np.ndarray  # int64

    def __len__(self) -> int:
        return self.starts.size

    def message(self, k: int) -> bytes:
        return self.data[self.starts[k]:self.starts[k] + self.lengths[k]].tobytes()


@dataclass
class ImuBlock:
    """The fields of a block of ``sensor_msgs/Imu`` messages.

    ``readings`` is (N, 6): linear_acceleration x, y, z [m/s²], then
    angular_velocity x, y, z [rad/s]; ``fields_at`` is where each message's
    orientation starts in its own bytes (what a writer patches).
    """

    stamp: np.ndarray  # int64 ns
    readings: np.ndarray  # (N, 6) float64
    frames: set
    fields_at: np.ndarray  # int64


def _gather(data: np.ndarray, at: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Bytes ``data[at[k] + columns]`` for every k, as a contiguous (N, len(columns)) uint8 array."""
    return data[at[:, None] + columns]


def _u32(data: np.ndarray, at: np.ndarray) -> np.ndarray:
    return _gather(data, at, np.arange(4)).view("<u4")[:, 0].astype(np.int64)


def decode_imu(block: Block, ros1: bool) -> ImuBlock | None:
    """The ``sensor_msgs/Imu`` fields of every message of ``block``, or None when one is not of that layout.

    ROS 1: ``u32 seq, u32 sec, u32 nsec, u32 n, n chars``, then the 37 doubles
    packed. ROS 2 (CDR, little endian): the 4-byte encapsulation header
    ``00 01 00 00``, ``i32 sec, u32 nanosec, u32 n, n chars`` (with the
    terminating NUL), padding to a multiple of 8 counted from the end of the
    encapsulation header, then the 37 doubles.
    """
    n = len(block)
    if n == 0:
        return ImuBlock(np.empty(0, np.int64), np.empty((0, 6)), set(), np.empty(0, np.int64))
    data, starts, lengths = block.data, block.starts, block.lengths
    if lengths.min() < 16 + IMU_FIELDS_BYTES:
        return None
    if not ros1:
        kind = _gather(data, starts, np.arange(2))
        if np.any(kind[:, 0] != 0) or np.any(kind[:, 1] != 1):  # CDR, little endian
            return None
    text = _u32(data, starts + 12)
    if ros1:
        fields_at = 16 + text
    else:
        if np.any(text == 0):  # a CDR string holds at least its NUL
            return None
        fields_at = 4 + (12 + text + 7) // 8 * 8
    if np.any(fields_at + IMU_FIELDS_BYTES != lengths):
        return None
    at = starts + fields_at
    values = _gather(data, at, np.concatenate([_LINEAR, _ANGULAR])).view("<f8")
    times = _gather(data, starts, np.arange(4, 12))
    sec = times[:, :4].view("<u4" if ros1 else "<i4")[:, 0].astype(np.int64)
    nsec = times[:, 4:].view("<u4")[:, 0].astype(np.int64)
    frames = set()
    chars = text if ros1 else text - 1
    for size in np.unique(chars):
        rows = _gather(data, starts[chars == size] + 16, np.arange(int(size)))
        distinct = rows[:1] if np.all(rows == rows[0]) else np.unique(rows, axis=0)  # one frame: no sort
        for row in distinct:
            frames.add(row.tobytes().decode("utf-8", errors="replace"))
    return ImuBlock(sec * 1_000_000_000 + nsec, values.astype(np.float64), frames, fields_at)


# ---------------------------------------------------------------- ROS 2 SQLite
def sqlite_blocks(files: list[Path], topic: str, size: int = 100_000) -> Iterator[Block] | None:
    """Blocks of the messages of ``topic`` in rosbag2 SQLite files; None when a file is not readable so.

    Each block is two queries over a range of row ids: the record times and
    lengths as one text, the messages' bytes as one concatenation, so no
    Python object is made per message.
    """
    plans = []
    for f in files:
        try:
            con = sqlite3.connect(f"file:{f}?mode=ro", uri=True)
            con.text_factory = bytes
            if con.execute("PRAGMA encoding").fetchone()[0] != b"UTF-8":
                raise sqlite3.DatabaseError("the text of this database is not bytes as stored")
            ids = [r[0] for r in con.execute("SELECT id FROM topics WHERE name = ?", (topic,))]
            lo, hi = con.execute("SELECT min(id), max(id) FROM messages").fetchone()
        except sqlite3.Error:
            return None
        plans.append((con, ids, lo, hi))

    def blocks():
        for con, ids, lo, hi in plans:
            with contextlib.closing(con):
                if not ids or lo is None:
                    continue
                where = f"topic_id IN ({','.join('?' * len(ids))}) AND id >= ? AND id < ?"
                for first in range(lo, hi + 1, size):
                    args = (*ids, first, first + size)
                    times, sizes, data = con.execute(
                        "SELECT group_concat(timestamp, ','), group_concat(length(data), ','), "
                        f"group_concat(CAST(data AS TEXT), '') FROM (SELECT timestamp, data FROM messages "
                        f"WHERE {where} ORDER BY id)", args).fetchone()
                    if times is None:
                        continue
                    logged = np.array(times.split(b","), dtype=np.int64)
                    lengths = np.array(sizes.split(b","), dtype=np.int64)
                    if lengths.size != logged.size or int(lengths.sum()) != len(data):
                        raise ValueError("messages and their lengths disagree")
                    starts = np.zeros(lengths.size, np.int64)
                    np.cumsum(lengths[:-1], out=starts[1:])
                    yield Block(np.frombuffer(data, np.uint8), starts, lengths, logged)

    return blocks()


def _joined(raws: list[bytes], logged: np.ndarray) -> Block:
    lengths = np.fromiter(map(len, raws), np.int64, len(raws))
    starts = np.zeros(len(raws), np.int64)
    np.cumsum(lengths[:-1], out=starts[1:])
    return Block(np.frombuffer(b"".join(raws), np.uint8), starts, lengths, logged)


def joined(raws: list[bytes], logged: list[int]) -> Block:
    """A block of messages given one by one (``rosbags``' iteration)."""
    return _joined(raws, np.asarray(logged, dtype=np.int64))


def rosbag2_sqlite(path: Path) -> tuple[list[BagConnection], list[Path]] | None:
    """Topics (with their message counts) and SQLite files of an uncompressed rosbag2 directory, from its
    ``metadata.yaml``; None when it is another kind (or ``ruamel.yaml``, which rosbags brings, is missing)."""
    try:
        from ruamel.yaml import YAML  # optional: its absence is handled here

        info = YAML(typ="safe").load((path / "metadata.yaml").read_text(encoding="utf-8"))
        info = info["rosbag2_bagfile_information"]
        if info.get("storage_identifier") != "sqlite3" or (info.get("compression_mode") or "").lower() not in (
                "", "none"):
            return None
        files = [path / Path(name).name for name in info["relative_file_paths"]]
        conns = [BagConnection(k, str(t["topic_metadata"]["name"]), str(t["topic_metadata"]["type"]), "",
                               int(t["message_count"])) for k, t in enumerate(info["topics_with_message_count"])]
    except Exception:  # any other layout: rosbags' reader decides
        return None
    if not files or not all(f.is_file() for f in files):
        return None
    return conns, files


# ----------------------------------------------------------------------- ROS 1
def _ros1_fields(header: bytes) -> dict[str, bytes]:
    out, pos = {}, 0
    while pos + 4 <= len(header):
        (size,) = struct.unpack_from("<I", header, pos)
        field = header[pos + 4:pos + 4 + size]
        name, _, value = field.partition(b"=")
        out[name.decode("ascii", errors="replace")] = value
        pos += 4 + size
    return out


def _ros1_record(f, pos: int) -> tuple[dict[str, bytes], int, int]:
    """The header fields of the record at ``pos``, where its data starts, and its data length."""
    f.seek(pos)
    head = f.read(4)
    (hlen,) = struct.unpack("<I", head)
    header = f.read(hlen)
    (dlen,) = struct.unpack("<I", f.read(4))
    if len(header) != hlen:
        raise ValueError("truncated record")
    return _ros1_fields(header), pos + 8 + hlen, dlen


def _chunk(codec: str, data: bytes, size: int, budget: Budget, where: int) -> np.ndarray:
    """A chunk's bytes, decompressed to at most the ``size`` it declares within the file's ``budget``
    (:mod:`.expansion`: a decompression bomb is a ReaderError); a ValueError for an unknown codec."""
    if codec in ("", "none"):
        return np.frombuffer(data, np.uint8)
    out = decompress_chunk(codec, data, size, budget, where)  # zstd: what rosbags itself decompresses with
    if out is None:
        raise ValueError(f"chunk compression {codec!r}")
    return np.frombuffer(out, np.uint8)


@dataclass
class BagConnection:
    """A connection (topic) of a bag as its index section or metadata describe it."""

    id: int
    topic: str
    msgtype: str  # "sensor_msgs/msg/Imu", as rosbags spells types
    md5sum: str  # ROS 1; "" for ROS 2
    msgcount: int = 0


@dataclass
class Ros1Index:
    """The index section of a ROS 1 bag: its connections and chunks (position, connections in it)."""

    connections: list[BagConnection]
    chunks: list[tuple[int, int]]


def ros1_index(path: Path) -> Ros1Index | None:
    """Connections and chunks of a ROS 1 bag from its index section; None when it has none (or is damaged)."""
    try:
        with path.open("rb") as f:
            if f.read(13) != b"#ROSBAG V2.0\n":
                return None
            fields, _, _ = _ros1_record(f, 13)
            if fields.get("op") != b"\x03":
                return None
            (index_pos,) = struct.unpack("<Q", fields["index_pos"])
            (chunk_count,) = struct.unpack("<I", fields["chunk_count"])
            if index_pos == 0:
                return None  # not closed properly: only rosbags' reader (or a reindex) can tell
            conns, chunks, pos = {}, [], index_pos
            end = path.stat().st_size
            while pos < end:
                fields, data_at, dlen = _ros1_record(f, pos)
                op = fields.get("op")
                if op == b"\x07":
                    f.seek(data_at)
                    info = _ros1_fields(f.read(dlen))
                    cid = struct.unpack("<I", fields["conn"])[0]
                    pkg, _, name = info["type"].decode("utf-8", errors="replace").partition("/")
                    conns[cid] = BagConnection(cid, fields["topic"].decode("utf-8", errors="replace"),
                                                f"{pkg}/msg/{name}", info["md5sum"].decode("ascii", "replace"))
                elif op == b"\x06":
                    (chunk_pos,) = struct.unpack("<Q", fields["chunk_pos"])
                    (count,) = struct.unpack("<I", fields["count"])
                    f.seek(data_at)
                    pairs = np.frombuffer(f.read(dlen), "<u4").reshape(-1, 2)
                    if pairs.shape[0] != count:
                        return None
                    for cid, n in pairs:
                        conns[int(cid)].msgcount += int(n)
                    chunks.append((chunk_pos, count))
                else:
                    return None
                pos = data_at + dlen
            if len(chunks) != chunk_count:
                return None
    except (OSError, ValueError, KeyError, struct.error):
        return None
    return Ros1Index(sorted(conns.values(), key=lambda c: c.id), sorted(chunks))


def ros1_blocks(path: Path, index: Ros1Index, topic: str) -> Iterator[Block]:
    """Blocks (one a chunk) of the messages of ``topic`` in a ROS 1 bag, located through its ``index``.

    Raises ValueError (or OSError) where the bag does not match its index, a ReaderError where its chunks
    expand past their budget (:mod:`.expansion`).
    """
    ids = {c.id for c in index.connections if c.topic == topic}
    budget = Budget(path, path.stat().st_size, "bag's compressed chunks", "rosbag decompress")
    with path.open("rb") as f:
        for chunk_pos, nconn in index.chunks:
            fields, data_at, dlen = _ros1_record(f, chunk_pos)
            if fields.get("op") != b"\x05":
                raise ValueError(f"no chunk at byte {chunk_pos}")
            compression = fields["compression"].decode("ascii", errors="replace")
            (size,) = struct.unpack("<I", fields["size"])
            entries, pos = [], data_at + dlen
            for _ in range(nconn):  # the IndexData records that follow the chunk, one a connection
                ifields, idata_at, ilen = _ros1_record(f, pos)
                if ifields.get("op") != b"\x04":
                    raise ValueError(f"no index data at byte {pos}")
                if struct.unpack("<I", ifields["conn"])[0] in ids:
                    f.seek(idata_at)
                    entries.append(np.frombuffer(f.read(ilen), _ROS1_INDEX))
                pos = idata_at + ilen
            if not entries:
                continue
            entry = np.concatenate(entries)
            f.seek(data_at)
            content = _chunk(compression, f.read(dlen), size, budget, chunk_pos)
            if content.size != size:
                raise ValueError(f"chunk at byte {chunk_pos} has {content.size} bytes, not {size}")
            offset = entry["offset"].astype(np.int64)
            if offset.max() + 8 > size:
                raise ValueError("index points past its chunk")
            data_len_at = offset + 4 + _u32(content, offset)  # u32 header length, header, u32 data length
            if data_len_at.max() + 4 > size:
                raise ValueError("record past its chunk")
            lengths = _u32(content, data_len_at)
            starts = data_len_at + 4
            if np.max(starts + lengths) > size:
                raise ValueError("message past its chunk")
            logged = entry["sec"].astype(np.int64) * 1_000_000_000 + entry["nsec"]
            yield Block(content, starts, lengths, logged)


# ------------------------------------------------------------------------ MCAP
def _mcap_string(buf: bytes, pos: int) -> tuple[str, int]:
    (size,) = struct.unpack_from("<I", buf, pos)
    return buf[pos + 4:pos + 4 + size].decode("utf-8", errors="replace"), pos + 4 + size


def _mcap_summary(summary: bytes, topic: str) -> tuple[set[int], list[tuple]]:
    """The channels of ``topic`` and the chunk indexes (start, length, channel → message index offset,
    compression, compressed and uncompressed sizes) in an MCAP file's summary section."""
    channels, indexes, pos = set(), [], 0
    while pos + 9 <= len(summary):
        op, size = summary[pos], struct.unpack_from("<Q", summary, pos + 1)[0]
        body = pos + 9
        if op == 0x04:  # Channel: u16 id, u16 schema, topic, encoding, metadata
            (cid,) = struct.unpack_from("<H", summary, body)
            name, _ = _mcap_string(summary, body + 4)
            if name == topic:
                channels.add(cid)
        elif op == 0x08:  # Chunk Index
            _, _, start, length, map_len = struct.unpack_from("<QQQQI", summary, body)
            offsets = {}
            for k in range(map_len // 10):
                cid, at = struct.unpack_from("<HQ", summary, body + 36 + 10 * k)
                offsets[cid] = at
            p = body + 36 + map_len + 8
            compression, p = _mcap_string(summary, p)
            compressed, uncompressed = struct.unpack_from("<QQ", summary, p)
            indexes.append((start, length, offsets, compression, compressed, uncompressed))
        pos = body + size
    return channels, indexes


def mcap_blocks(path: Path, topic: str) -> Iterator[Block] | None:
    """Blocks (one a chunk) of the messages of ``topic`` in an MCAP file, from its summary; None if not indexed."""
    f = path.open("rb")
    try:
        if f.read(8) != _MCAP_MAGIC:
            raise ValueError("not MCAP")
        end = f.seek(0, 2)
        f.seek(end - 37)
        footer = f.read(37)
        if footer[:9] != b"\x02\x14\x00\x00\x00\x00\x00\x00\x00" or footer[29:] != _MCAP_MAGIC:
            raise ValueError("no footer")
        (summary_start,) = struct.unpack_from("<Q", footer, 9)
        if not 8 < summary_start < end - 37:
            raise ValueError("no summary")
        f.seek(summary_start)
        summary = f.read(end - 37 - summary_start)
        channels, indexes = _mcap_summary(summary, topic)
        if not indexes:
            raise ValueError("no chunk index")
    except (OSError, ValueError, struct.error, IndexError):
        f.close()
        return None

    def blocks():
        budget = Budget(path, end, "MCAP file's compressed chunks", "mcap recover, uncompressed")
        with f:
            for start, _length, offsets, compression, compressed, uncompressed in sorted(indexes):
                wanted = [at for cid, at in offsets.items() if cid in channels]
                if not wanted:
                    continue
                entries = []
                for at in wanted:  # Message Index: u8 op, u64 len, u16 channel, u32 n, n × (u64, u64)
                    f.seek(at)
                    head = f.read(15)
                    if head[0] != 0x07:
                        raise ValueError(f"no message index at byte {at}")
                    (nbytes,) = struct.unpack_from("<I", head, 11)
                    entries.append(np.frombuffer(f.read(nbytes), _MCAP_INDEX))
                index = np.concatenate(entries)
                f.seek(start)
                head = f.read(9 + 28)
                if head[0] != 0x06:
                    raise ValueError(f"no chunk at byte {start}")
                f.seek(start + 9 + 28)
                (clen,) = struct.unpack("<I", f.read(4))
                f.seek(start + 9 + 28 + 4 + clen + 8)
                content = _chunk(compression, f.read(compressed), uncompressed, budget, start)
                if content.size != uncompressed:
                    raise ValueError(f"chunk at byte {start} has {content.size} bytes, not {uncompressed}")
                offset = index["offset"].astype(np.int64)
                if offset.size and offset.max() + 31 > uncompressed:
                    raise ValueError("index points past its chunk")
                if np.any(content[offset] != 0x05):
                    raise ValueError("index points to a record that is not a message")
                size = _gather(content, offset + 1, np.arange(8)).view("<u8")[:, 0].astype(np.int64)
                starts = offset + 31  # op, length, u16 channel, u32 sequence, u64 log, u64 publish
                lengths = size - 22
                if np.any(lengths < 0) or np.max(starts + lengths) > uncompressed:
                    raise ValueError("message past its chunk")
                yield Block(content, starts, lengths, index["log_time"].astype(np.int64))

    return blocks()
