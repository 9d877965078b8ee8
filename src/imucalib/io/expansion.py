"""Compressed input read in bounded memory: a decompression bomb is refused before it fills the memory.

A compressed recording is decompressed as it is read, and the bytes it
expands to are counted against a budget fixed by what went in::

    budget = max(EXPANSION_FLOOR, EXPANSION_RATIO × compressed bytes)

Past the budget the read stops with a one-line :class:`~.errors.ReaderError`
(nothing more is decompressed or kept). Real recordings compress far less than
:data:`EXPANSION_RATIO`: the public recordings in the test data compress 2.8–21×
with gzip -9, 3.4–25× with bzip2 -9, 4.6–4.7× as the doubles of a MATLAB file
(zlib); a crafted file of repeated bytes 1000× (gzip, zlib) to millions of times
(bzip2). A file refused here that is a real recording is read after it is
decompressed by hand (its plain form is read without this limit: its size on
disk is then what the user gave).

Where the budget is counted:

* gzip text (``.csv.gz``): :func:`open_gzip`, a :class:`gzip.GzipFile` whose every
  read checks the position reached in the decompressed text;
* MATLAB v5 files: :func:`check_mat` walks the file's top-level elements before
  scipy loads it and decompresses each zlib-compressed (``miCOMPRESSED``) one
  into nothing but a count (scipy would decompress a variable whole);
* ROS 1 bag chunks (bz2, lz4) and MCAP chunks (zstd, lz4): :func:`decompress_chunk`
  decompresses at most the size a chunk declares and refuses more, and
  :func:`check_ros1_chunks` checks every chunk that way (count only) before the
  ``rosbags`` library, which decompresses chunks whole, opens a bag. A
  :class:`Budget` is shared by all the chunks of one file.
"""

from __future__ import annotations

import bz2
import contextlib
import gzip
import os
import struct
import zlib
from collections.abc import Callable
from pathlib import Path

from .errors import ReaderError

__all__ = ["EXPANSION_FLOOR", "EXPANSION_RATIO", "Budget", "check_mat", "check_ros1_chunks", "decompress_chunk",
           "open_gzip"]

#: the most a compressed input may expand to per compressed byte: twice the most that real recordings do
#: (3–25×, module docstring)
EXPANSION_RATIO = 50
#: what any compressed input may expand to whatever its size [bytes] (a small file of few distinct values)
EXPANSION_FLOOR = 64 << 20
#: decompressed bytes produced at a time while counting
_STEP = 1 << 20


class Budget:
    """The decompressed bytes one compressed input may still produce (module docstring)."""

    def __init__(self, path: str | Path, compressed: int, what: str, command: str) -> None:
        self.path, self.what, self.command = Path(path), what, command
        self.compressed = int(compressed)
        self.limit = max(EXPANSION_FLOOR, EXPANSION_RATIO * self.compressed)
        self.used = 0

    def take(self, n: int) -> None:
        """Count ``n`` more decompressed bytes; a ReaderError past the budget."""
        self.used += int(n)
        if self.used > self.limit:
            raise self.refusal()

    def refusal(self) -> ReaderError:
        floor = EXPANSION_FLOOR >> 20
        return ReaderError(
            f"{self.path}: the {self.what} expands to more than {self.limit / 1e6:.0f} MB, over {EXPANSION_RATIO} "
            f"times its {self.compressed} compressed bytes (imucalib reads compressed input up to "
            f"{EXPANSION_RATIO}x or {floor} MiB, whichever is more; recordings compress 3-25x): a decompression "
            f"bomb, or no recording; if it is one, decompress it yourself ({self.command}) and give the "
            "decompressed file")


# --------------------------------------------------------------------- gzip
class _BoundedGzip(gzip.GzipFile):
    """A gzip file whose reads stop with a ReaderError once the position passes its budget."""

    budget: Budget

    def _check(self, out):
        if self._buffer.tell() > self.budget.limit:
            raise self.budget.refusal()
        return out

    def read(self, size=-1):
        if size is None or size < 0:  # read in steps, so that a bomb stops at its budget
            parts = []
            while block := self.read(_STEP):
                parts.append(block)
            return b"".join(parts)
        return self._check(super().read(size))

    def read1(self, size=-1):
        return self._check(super().read1(_STEP if size is None or size < 0 else size))

    def peek(self, n):
        return self._check(super().peek(n))

    def readline(self, size=-1):
        if size is None or size < 0:  # a line without end: in steps as well
            parts = []
            while (part := self.readline(_STEP)) and not part.endswith(b"\n"):
                parts.append(part)
            return b"".join([*parts, part])
        return self._check(super().readline(size))

    def seek(self, offset, whence=os.SEEK_SET):
        if whence == os.SEEK_SET and offset > self.budget.limit:
            raise self.budget.refusal()
        return self._check(super().seek(offset, whence))


def open_gzip(path: str | Path) -> gzip.GzipFile:
    """The gzip file ``path`` opened for reading, its decompressed text bounded by a :class:`Budget`."""
    path = Path(path)
    f = _BoundedGzip(path, "rb")
    f.budget = Budget(path, os.stat(path).st_size, "gzip-compressed file", f"gunzip -k '{path}'")
    return f


# ------------------------------------------------------------------ MATLAB
#: MAT v5 data types (MATLAB's MAT-file format, Table 1-1): miCOMPRESSED holds a zlib stream
_MI_COMPRESSED = 15


def check_mat(path: str | Path) -> None:
    """Refuse a MATLAB v5 file whose compressed variables expand past their :class:`Budget`.

    The file's top-level data elements (a 128-byte header, then per element an 8-byte tag: type, size; a
    small element packs both in 4 bytes with its data) are walked; each ``miCOMPRESSED`` one is
    decompressed :data:`_STEP` bytes at a time and counted, never kept. A file of another version, or
    one whose elements do not parse, is left to scipy (which reports it).
    """
    path = Path(path)
    size = os.stat(path).st_size
    budget = Budget(path, size, "MATLAB file's compressed data", "in MATLAB: save(NAME, VARIABLE, '-v7', "
                    "'-nocompression')")
    with path.open("rb") as f:
        head = f.read(128)
        if len(head) < 128 or head[126:128] not in (b"IM", b"MI"):
            return
        order = "<" if head[126:128] == b"IM" else ">"
        pos = 128
        while pos + 8 <= size:
            f.seek(pos)
            tag = f.read(8)
            kind, nbytes = struct.unpack(order + "II", tag)
            if kind >> 16:  # a small data element: 4 bytes of data in the tag
                pos += 8
                continue
            if kind == _MI_COMPRESSED:
                _count_zlib(f, nbytes, budget)
                pos += 8 + nbytes  # compressed elements are not padded
            else:
                pos += 8 + nbytes + (-nbytes % 8)


def _count_zlib(f, nbytes: int, budget: Budget) -> None:
    """Decompress the next ``nbytes`` of ``f`` (a zlib stream), counting the output against ``budget``."""
    d = zlib.decompressobj()
    left = nbytes
    with contextlib.suppress(zlib.error):  # a corrupt stream: scipy names it
        while left > 0 and not d.eof:
            data = f.read(min(left, _STEP))
            if not data:
                return
            left -= len(data)
            while data and not d.eof:
                budget.take(len(d.decompress(data, _STEP)))
                data = d.unconsumed_tail


# ------------------------------------------------------------- bag chunks
def _decompressors(name: str) -> Callable[[], object] | None:
    """A factory of incremental decompressors (``decompress(data, max_length)``, ``eof``) for a chunk codec."""
    if name == "bz2":
        return bz2.BZ2Decompressor
    if name == "lz4":
        try:
            from lz4.frame import LZ4FrameDecompressor  # optional: its absence is handled here
        except ImportError:
            return None
        return LZ4FrameDecompressor
    if name == "zstd":
        try:
            from compression.zstd import ZstdDecompressor  # optional: its absence is handled here
        except ImportError:
            try:
                from backports.zstd import ZstdDecompressor  # optional: its absence is handled here
            except ImportError:
                return None
        return ZstdDecompressor
    return None


def decompress_chunk(codec: str, data: bytes, size: int, budget: Budget, where: int) -> bytes | None:
    """A chunk's ``data`` decompressed with ``codec``, at most its declared ``size`` bytes; None for an unknown
    codec. A chunk that declares more than ``budget`` leaves, or holds more than it declares, is a ReaderError.
    """
    factory = _decompressors(codec)
    if factory is None:
        return None
    budget.take(size)
    d = factory()
    try:
        out = d.decompress(data, size)
        more = bool(d.unused_data) if d.eof else len(out) == size and bool(d.decompress(b"", 1))
    except Exception:  # noqa: BLE001  (a damaged stream: the caller reads the bag the library's way)
        return b""
    if more:
        raise _overfull(budget, codec, where, size)
    return out


def _ros1_header(f) -> tuple[dict[str, bytes], int] | None:
    """The fields of the ROS 1 record at ``f``'s position and its data length, or None at the file's end."""
    raw = f.read(4)
    if len(raw) < 4:
        return None
    (hlen,) = struct.unpack("<I", raw)
    header = f.read(hlen)
    raw = f.read(4)
    if len(header) < hlen or len(raw) < 4:
        return None
    fields, i = {}, 0
    while i + 4 <= hlen:
        (n,) = struct.unpack_from("<I", header, i)
        name, _, value = header[i + 4:i + 4 + n].partition(b"=")
        fields[name.decode("latin-1")] = value
        i += 4 + n
    return fields, struct.unpack("<I", raw)[0]


def check_ros1_chunks(path: str | Path) -> None:
    """Refuse a ROS 1 bag whose compressed chunks expand past their :class:`Budget` (counted, not kept).

    Run before the ``rosbags`` library opens a bag: it decompresses a chunk whole. A file that is no ROS 1
    bag, or whose records do not parse, is left to it.
    """
    path = Path(path)
    if not path.is_file():
        return
    budget = Budget(path, os.stat(path).st_size, "bag's compressed chunks", "rosbag decompress")
    with path.open("rb") as f:
        if f.read(13) != b"#ROSBAG V2.0\n":
            return
        while (record := _ros1_header(f)) is not None:
            fields, dlen = record
            start = f.tell()
            codec = fields.get("compression", b"none").decode("latin-1")
            if fields.get("op") == b"\x05" and codec not in ("", "none") and len(fields.get("size", b"")) == 4:
                (size,) = struct.unpack("<I", fields["size"])
                budget.take(size)
                factory = _decompressors(codec)
                if factory is not None:
                    _count_stream(f, dlen, factory, size, budget, codec, start)
            f.seek(start + dlen)


def _count_stream(f, nbytes: int, factory, size: int, budget: Budget, codec: str, where: int) -> None:
    """Decompress ``nbytes`` of ``f`` with decompressors from ``factory`` (one per concatenated stream, as the
    library decompresses them), counting the output; more than ``size`` is a ReaderError.

    A damaged stream ends the count silently: the library that reads the bag next names it.
    """
    out, left, d, data = 0, nbytes, factory(), b""
    while out <= size:
        if not data:
            if left <= 0:
                break
            data = f.read(min(left, _STEP))
            if not data:
                break
            left -= len(data)
        try:
            if d.eof:  # a further stream after the first (bz2.decompress reads them all)
                d, data = factory(), d.unused_data + data
            out += len(d.decompress(data, _STEP))
            while out <= size and not d.eof and not d.needs_input:
                out += len(d.decompress(b"", _STEP))
        except Exception:  # noqa: BLE001  (each codec has its own error types)
            return
        data = d.unused_data if d.eof else b""
    if out > size:
        raise _overfull(budget, codec, where, size)


def _overfull(budget: Budget, codec: str, where: int, size: int) -> ReaderError:
    return ReaderError(f"{budget.path}: the {codec} chunk at byte {where} holds more than the {size} bytes it "
                       "declares: the bag is damaged or crafted; record it again, or decompress it (rosbag "
                       "decompress) and check what it holds")
