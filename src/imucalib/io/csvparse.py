"""The rows of a delimited text file (CSV, TSV, whitespace), parsed fast and in bounded memory.

:mod:`.readers` decides what a file is (preamble, separator, header, which
column is which, units: the header logic); this module finds where its parts
lie in the file (:func:`read_head`, :func:`plan`) and reads the rows into
preallocated arrays (:func:`parse`), a few megabytes of text at a time, by a C
parser:

* a whitespace-separated table of numbers written with fixed widths (every
  line the same length, as MATLAB and many loggers write them, imu_tk's files
  among them) by array arithmetic over its bytes (:func:`.fixedcells.fixed_chunk`:
  the correctly rounded numbers, about 3.5 times as fast as ``numpy.loadtxt``);
* ``numpy.loadtxt`` (numpy ≥ 1.23 parses in C) always;
* pandas' C parser (``pandas.read_csv(engine="c")``) for large files when
  pandas is installed (the ``pandas`` extra).

Why pandas is not a core dependency (measured on this project's 2-core
machine, figures in ``benchmarks/results/``):

* reading 1 M rows of 7 columns with :func:`imucalib.io.read`
  (``benchmarks/bench_io.py``, medians of 3): integer counts (31 MB) 1.79 s
  with the reader of imucalib 0.1 (``numpy.fromstring`` over the whole text),
  0.88 s with ``numpy.loadtxt``, 0.35 s with pandas once imported (its import
  takes another 0.4–0.6 s); readings with 9 significant digits (83 MB)
  2.19 s, 1.14 s and 0.61 s;
* calibrating a one-hour 1 kHz recording (3.6 M samples,
  ``benchmarks/bench_long.py``, medians of 3): 11.9 s and 0.37 GB peak with
  numpy's parser, 11.9 s and 0.41 GB with pandas'; 10 M samples 29.8 s and
  0.99 GB, 24.8 s and 1.03 GB.

numpy's parser alone meets the goals for long recordings (≤ 20 s, ≤ 0.6 GB
for 3.6 M samples); pandas reads 2–2.5× faster again but installs 84 MB, costs
0.4–0.6 s to import and more memory, and changes a calibration's time only
beyond a few million samples. So it stays an optional extra, used when it is
installed and the body is at least :data:`PANDAS_MIN_BYTES`; both parsers
round correctly and give the same arrays, bit for bit (tested).

Every value is checked: a row with another number of cells, a cell that is not
a number, NaN or inf in a sensor column, a blank line. When the C parser
refuses a chunk or its result fails a check, the chunk is read again line by
line in Python (:func:`_python_chunk`), which names the first bad line and
column in a :class:`~.errors.ReaderError`; it also parses what the C parsers
cannot (a separator inside a quoted text cell). Nothing is skipped silently:
full-line comments (``#`` first) are the only lines that are not rows, and
they are counted.

Quoting: cells may be quoted with ``"`` (a separator inside quotes belongs to
the cell). Decimal commas: with ``;`` or tab separators, ``,`` is read as the
decimal mark (:attr:`Layout.decimal_comma`).

Gzip-compressed files (``.csv.gz``, ``.txt.gz``; recognised from their first
bytes, not their name) are read the same way through :func:`open_binary`,
which decompresses as it reads: byte offsets are those of the decompressed
text, :attr:`Layout.size` its length, and memory stays that of a chunk. A
truncated or corrupt stream is a :class:`~.errors.ReaderError`.
"""

from __future__ import annotations

import contextlib
import csv
import gzip
import hashlib
import io
import re
import warnings
import zlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import ReaderError
from .expansion import open_gzip  # its decompressed text bounded (a decompression bomb is refused)
from .fixedcells import fixed_chunk

__all__ = ["CHUNK_BYTES", "ENGINE", "Chunk", "Head", "Layout", "PANDAS_MIN_BYTES", "Plan", "chunks", "column_kinds",
           "digest", "plan", "engine_for", "fingerprint", "is_gzip", "open_binary", "pandas_available", "parse",
           "read_head", "split_cells"]

#: body text parsed at a time [bytes] (about 100 000 rows of 7 columns)
CHUNK_BYTES = 1 << 23
#: bodies at least this large go through pandas when it is installed (import cost vs. speed: module docstring)
PANDAS_MIN_BYTES = 1 << 25
#: the parser: ``"auto"`` (pandas for large bodies when installed, else numpy), ``"numpy"``,
#: ``"pandas"`` or ``"python"`` (the line-by-line reference; slow)
ENGINE = "auto"
#: a column whose first cell is an integer of this many digits or more is read as int64
#: (16 digits reach 2⁵³, beyond which float64 is not exact: nanosecond stamps, IDs)
INT_DIGITS = 16

_INT = re.compile(r"^[+-]?\d+$")
_COMMENT = re.compile(rb"(?m)^[ \t]*#")
_HEAD_BYTES = 1 << 20


# ------------------------------------------------------------------ opening
#: the first bytes of a gzip stream (RFC 1952, §2.3.1)
GZIP_MAGIC = b"\x1f\x8b"


def is_gzip(path: Path) -> bool:
    """Whether ``path`` is a gzip-compressed file (from its first two bytes)."""
    try:
        with Path(path).open("rb") as f:
            return f.read(2) == GZIP_MAGIC
    except (IsADirectoryError, FileNotFoundError):
        return False


@contextlib.contextmanager
def open_binary(path: Path) -> Iterator[io.BufferedIOBase]:
    """``path`` opened for reading bytes; a gzip-compressed file decompressed as it is read.

    A gzip stream seeks forwards by decompressing and backwards by starting
    over, so the readers read it front to back. A stream that ends early (a
    copy cut short) or whose data or checksum is wrong raises a
    :class:`~.errors.ReaderError` naming the file, whichever read meets it.
    """
    path = Path(path)
    if not is_gzip(path):
        with path.open("rb") as f:
            yield f
        return


    try:
        with open_gzip(path) as f:
            yield f
    except EOFError:
        raise ReaderError(f"{path}: the gzip-compressed file is cut short (its stream ends before its end "
                          "marker): the copy or download is incomplete; compress the recording again or give "
                          "the uncompressed file") from None
    except (gzip.BadGzipFile, zlib.error) as exc:
        raise ReaderError(f"{path}: the gzip-compressed file is corrupt ({exc}); compress the recording again or "
                          "give the uncompressed file") from None


def _size_and_tail(f, size: int | None, tail_bytes: int, head: bytes) -> tuple[int, bytes, int]:
    """The length of the open file ``f`` whose first bytes ``head`` were just read (``size`` when known, else
    read to the end: a decompressed stream) and its last ``tail_bytes`` with their offset."""
    if size is not None:
        tail_start = max(0, size - tail_bytes)
        f.seek(tail_start)
        return size, f.read(), tail_start
    pos, tail = len(head), head[-tail_bytes:]
    while True:
        block = f.read(CHUNK_BYTES)
        if not block:
            return pos, tail, pos - len(tail)
        pos += len(block)
        tail = (tail + block)[-tail_bytes:]


# ------------------------------------------------------------------ the file's parts
@dataclass(frozen=True)
class Head:
    """The first lines of a file and its last line, as text, with their byte offsets.

    ``lines[i]`` starts at byte ``offsets[i]`` and has no line end; when the
    file is longer than what was read (``complete`` False), ``lines`` ends with
    the last whole line read, and ``last`` is the file's last non-blank line.
    ``end`` is the byte offset just after the last non-blank line's text.
    """

    lines: list[str]
    offsets: list[int]
    complete: bool
    last: str
    end: int
    size: int
    mtime_ns: int
    bom: int


def read_head(path: Path, max_bytes: int = _HEAD_BYTES) -> Head:
    """The first ``max_bytes`` of ``path`` split into lines, and its last non-blank line."""
    st = path.stat()
    size = None if is_gzip(path) else st.st_size  # a compressed file's text is as long as its stream decompresses
    with open_binary(path) as f:
        head = f.read(max_bytes)
        if head.startswith((b"\xff\xfe", b"\xfe\xff")) or (len(head) > 1 and head.count(b"\x00") > len(head) // 4):
            raise ReaderError(f"{path}: the file is UTF-16 (or binary) text; save it as UTF-8 (or plain ASCII) text")
        bom = 3 if head.startswith(b"\xef\xbb\xbf") else 0
        complete = len(head) < max_bytes or (size is not None and len(head) >= size)
        if complete:
            tail, tail_start = head, 0
            size = len(head) if size is None else size
        else:
            size, tail, tail_start = _size_and_tail(f, size, 1 << 16, head)
            complete = size <= len(head)
            if complete:
                tail, tail_start = head, 0
    # the end of the last non-blank line
    stripped = tail[:len(tail.rstrip()) + (tail[len(tail.rstrip()):][:1] == b"\t")]  # a row's trailing tab is a cell
    if not stripped or tail_start + len(stripped) <= bom:
        end = bom
        last = ""
    else:
        end = tail_start + len(stripped)
        cut = stripped.rfind(b"\n")
        last = _decode(stripped[cut + 1:])
        if not complete and cut < 0:
            raise ReaderError(f"{path}: the last line is longer than 64 kB; is this a text table?")
    if b"\n" not in head[:max_bytes] and head.count(b"\r") > 1:
        raise ReaderError(f"{path}: its lines end with a carriage return alone (CR, as classic Mac OS wrote them), "
                          "not a line feed: convert them first, e.g. tr '\\r' '\\n' < IN > OUT")
    if not complete and b"\n" not in head:
        cells = max(head.count(b","), head.count(b";"), head.count(b"\t")) + 1
        raise ReaderError(f"{path}: the first line is longer than {max_bytes >> 20} MB (more than {cells} cells); "
                          "a recording's header and rows are short lines: is this a text table?")
    body = head[bom:] if complete else head[bom:head.rfind(b"\n") + 1]
    if complete:
        body = body[:end - bom]
    raw_lines = body.split(b"\n")
    if raw_lines and raw_lines[-1] == b"":
        raw_lines.pop()
    offsets, pos = [], bom
    for ln in raw_lines:
        offsets.append(pos)
        pos += len(ln) + 1
    lines = [_decode(ln.rstrip(b"\r")) for ln in raw_lines]
    return Head(lines, offsets, complete, last, end, size, st.st_mtime_ns, bom)


def _decode(raw: bytes) -> str:
    return raw.decode("utf-8", errors="replace")


@dataclass(frozen=True)
class Layout:
    """Where a text table's parts lie in its file (byte offsets), and how its cells are written.

    Attributes
    ----------
    path : Path
    header : (int, int) or None
        Byte range of the header line's text (no line end), None without a header.
    body : (int, int)
        Byte range from the first row to the end of the last non-blank line's text.
    first_line : int
        1-based line number of the first row (as an editor shows it).
    sep : str or None
        The separator (None: runs of whitespace).
    decimal_comma : bool
        ``,`` is the decimal mark (``;`` or tab separators).
    ncols : int
        Cells in every row.
    size, mtime_ns : int
        The file's size and modification time when it was scanned.
    """

    path: Path
    header: tuple[int, int] | None
    body: tuple[int, int]
    first_line: int
    sep: str | None
    decimal_comma: bool
    ncols: int
    size: int
    mtime_ns: int

    def to_dict(self) -> dict:
        return {"path": str(self.path), "header": None if self.header is None else list(self.header),
                "body": list(self.body), "first_line": self.first_line, "sep": self.sep,
                "decimal_comma": self.decimal_comma, "ncols": self.ncols, "size": self.size,
                "mtime_ns": self.mtime_ns}

    @classmethod
    def from_dict(cls, d: dict) -> Layout:
        return cls(Path(d["path"]), None if d["header"] is None else tuple(d["header"]), tuple(d["body"]),
                   int(d["first_line"]), d["sep"], bool(d["decimal_comma"]), int(d["ncols"]), int(d["size"]),
                   int(d["mtime_ns"]))


def split_cells(line: str, sep: str | None) -> list[str]:
    """The cells of one line, stripped of blanks and of the quotes around a quoted cell."""
    if '"' in line and sep is not None:
        cells = next(csv.reader([line], delimiter=sep, skipinitialspace=True), [])
        return [c.strip() for c in cells]
    return [c.strip().strip('"') for c in (line.split(sep) if sep else line.split())]


# ------------------------------------------------------------------ chunks
@dataclass
class Chunk:
    data: bytes      # whole lines, the last one's line end included when it has one
    first_line: int  # 1-based line number of its first line
    lines: int       # lines in it
    comments: int    # full-line comments among them


@dataclass(frozen=True)
class Plan:
    """The body cut into chunks of whole lines: each chunk's byte length, lines and comment lines."""

    pieces: tuple[tuple[int, int, int], ...]

    @property
    def rows(self) -> int:
        return sum(lines - comments for _, lines, comments in self.pieces)

    @property
    def comments(self) -> int:
        return sum(comments for *_, comments in self.pieces)


def chunks(layout: Layout, chunk_bytes: int | None = None, plan: Plan | None = None,
           digest=None) -> Iterator[Chunk]:
    """The body of ``layout``'s file in pieces of whole lines (about ``chunk_bytes``, default
    :data:`CHUNK_BYTES`, or as ``plan`` cut it), each with its first line number.

    With ``digest`` (a :mod:`hashlib` object), the file's bytes up to its size
    as scanned (:attr:`Layout.size`) are fed to it in order, from the same open
    file: what precedes the body, each chunk as it is yielded, what follows the
    body (once the last chunk has been consumed).
    """
    chunk_bytes = chunk_bytes or CHUNK_BYTES
    start, end = layout.body
    line = layout.first_line
    known = iter(plan.pieces) if plan is not None else None
    with open_binary(layout.path) as f:
        if digest is not None:
            _feed(digest, f, start)
        f.seek(start)
        pos = start
        while pos < end:
            if known is not None:
                size, n, comments = next(known)
                data = f.read(size)
            else:
                data = f.read(min(chunk_bytes, end - pos))
                if pos + len(data) < end and not data.endswith(b"\n"):
                    data += f.readline()  # finish the line
                if pos + len(data) > end:
                    data = data[:end - pos]
                n = data.count(b"\n") + (0 if data.endswith(b"\n") else 1)
                comments = len(_COMMENT.findall(data)) if b"#" in data else 0
            pos += len(data)
            if digest is not None:
                digest.update(data)
            yield Chunk(data, line, n, comments)
            line += n
        if digest is not None:
            f.seek(pos)
            _feed(digest, f, layout.size - pos)


def _feed(digest, f, n: int) -> None:
    """Feed the next ``n`` bytes of the open file ``f`` (fewer at its end) to ``digest``."""
    while n > 0:
        data = f.read(min(n, CHUNK_BYTES))
        if not data:
            return
        digest.update(data)
        n -= len(data)


def digest() -> hashlib.blake2b:
    """The checksum of a file's bytes as parsed (:func:`parse`'s ``facts["digest"]``), fed as it is read.

    BLAKE2b over every byte, not the size, modification time and first and
    last blocks: a rewrite of the same size in the middle of the rows, within
    the timestamp's resolution (1–2 s on some file systems) or with the time
    put back (``cp -p``, ``rsync -t``, ``touch -r``), leaves those unchanged
    but not this. It streams at about 0.6 GB/s on one core: reading 1 M rows
    of 7 columns (80 MB) took 0.98 s instead of 0.79 s without it (medians of
    7, pandas' parser). A CRC (4× faster) would catch accidents as well but
    can be forged by whoever rewrites the file.
    """
    return hashlib.blake2b(digest_size=16)


def file_digest(layout: Layout):
    """:func:`digest` of the file of ``layout``, its ``layout.size`` bytes, as a parse would have fed it."""
    d = digest()
    with open_binary(layout.path) as f:
        _feed(d, f, layout.size)
    return d


def plan(layout: Layout, chunk_bytes: int | None = None) -> Plan:
    """One pass over the body: where its chunks end, and their lines (rows to allocate before parsing)."""
    return Plan(tuple((len(ch.data), ch.lines, ch.comments) for ch in chunks(layout, chunk_bytes)))


# ------------------------------------------------------------------ parse
def engine_for(layout: Layout) -> str:
    """The parser :func:`parse` uses for ``layout`` (see :data:`ENGINE`)."""
    if ENGINE != "auto":
        return ENGINE
    if layout.body[1] - layout.body[0] >= PANDAS_MIN_BYTES and pandas_available():
        return "pandas"
    return "numpy"


def pandas_available() -> bool:
    """Whether pandas can be imported (the ``pandas`` extra)."""
    try:
        import pandas  # noqa: F401  # optional: pip install imucalib[pandas]
    except ImportError:
        return False
    return True


class _Demote(Exception):
    """A column read as ``kind`` holds a cell that is not one: read it as ``to`` instead."""

    def __init__(self, col: int, to: str) -> None:
        self.col, self.to = col, to


def parse(layout: Layout, kinds: Sequence[str | None], names: Sequence[str], *, required: Sequence[int] = (),
          out: dict[int, np.ndarray] | None = None, plan: Plan | None = None,
          chunk_bytes: int | None = None, checksum: bool = True) -> tuple[dict[int, np.ndarray], dict]:
    """Read the body's columns into arrays, one chunk at a time.

    Parameters
    ----------
    layout : Layout
    kinds : sequence of {"float", "int", "text", None}
        What each column holds; None skips it. A column that is not
        ``required`` is read as float when an "int" cell is not an integer, and
        as text when a "float" cell is not a number.
    names : sequence of str
        Column names, for messages.
    required : sequence of int
        Columns that must hold finite numbers in every row (else an error).
    out : dict of int to (rows,) float64 arrays, optional
        Arrays (may be strided views) to fill for some float columns; the
        others are allocated here.
    plan : Plan, optional
        The body's chunks when already known (:func:`plan`): saves a pass over the file.
    checksum : bool, default True
        Take the :func:`digest` of the file's bytes; False for a caller that never
        copies the file's text (the checksum costs about as much as a fifth of the parse).

    Returns
    -------
    columns : dict of int to ndarray
        Column index → float64, int64 or str array of one entry per row.
    facts : dict
        ``rows``, ``comment_lines``, ``engine``, ``kinds`` (after any demotion) and
        ``digest``: the hex :func:`digest` of the file's bytes up to :attr:`Layout.size`,
        the body's being exactly the bytes parsed (None without ``checksum``).
    """
    kinds = list(kinds)
    if plan is None:
        plan = globals()["plan"](layout, chunk_bytes)
    rows = plan.rows
    engine = engine_for(layout)
    while True:
        cols = {j: _allocate(kind, rows, (out or {}).get(j)) for j, kind in enumerate(kinds) if kind is not None}
        taken = digest() if checksum else None
        try:
            done = 0
            comments = 0
            for ch in chunks(layout, chunk_bytes, plan, taken):
                n = ch.lines - ch.comments
                if done + n > rows:
                    raise ReaderError(_CHANGED.format(path=layout.path))
                part = _parse_chunk(layout, ch, kinds, names, required, engine)
                if any(len(arr) != n for arr in part.values()):  # the planned chunk is no longer what is there
                    raise ReaderError(_CHANGED.format(path=layout.path))
                for j, arr in part.items():
                    if cols[j].dtype.kind == "U" and arr.dtype.itemsize > cols[j].dtype.itemsize:
                        wider = np.empty(rows, dtype=arr.dtype)  # a longer text than seen so far
                        wider[:done] = cols[j][:done]
                        cols[j] = wider
                    cols[j][done:done + n] = arr
                done += n
                comments += ch.comments
            if done != rows:
                raise ReaderError(_CHANGED.format(path=layout.path))
        except _Demote as d:
            kinds[d.col] = d.to
            continue
        return cols, {"rows": rows, "comment_lines": comments, "engine": engine, "kinds": kinds,
                      "digest": taken.hexdigest() if taken is not None else None}


#: a file whose rows changed between the passes over it (a logger still writing it, a copy in progress)
_CHANGED = ("{path}: the file changed while it was read (is it still being written or copied?); read it again "
            "once it is complete, or read a copy of it")


def _allocate(kind: str, rows: int, given: np.ndarray | None) -> np.ndarray:
    if kind == "float":
        return given if given is not None else np.empty(rows, dtype=np.float64)
    if kind == "int":
        return np.empty(rows, dtype=np.int64)
    return np.empty(rows, dtype="<U1")


def _lines(data: bytes) -> list[bytes]:
    """The lines of a chunk without their line ends (``\n`` or ``\r\n``)."""
    lines = data.split(b"\n")
    if data.endswith(b"\n"):
        lines.pop()
    return [ln[:-1] if ln.endswith(b"\r") else ln for ln in lines]


def _strip_comments(data: bytes) -> bytes:
    return b"\n".join(ln for ln in _lines(data) if not ln.lstrip(b" \t").startswith(b"#")) + b"\n"


def _parse_chunk(layout: Layout, ch: Chunk, kinds: list, names: Sequence[str], required: Sequence[int],
                 engine: str) -> dict[int, np.ndarray]:
    """One chunk's columns: the C parser, checked; line by line when it fails or a check does."""
    n = ch.lines - ch.comments
    if engine != "python":
        data = _strip_comments(ch.data) if ch.comments else ch.data
        if layout.decimal_comma:
            data = data.replace(b",", b".")
        sep = layout.sep
        if sep is None and not layout.decimal_comma and all(k == "float" for k in kinds):
            fixed = fixed_chunk(data, layout.ncols)  # a fixed layout: array arithmetic, the same numbers
            if fixed is not None and fixed.shape[0] == n and all(np.isfinite(fixed[:, j]).all() for j in required):
                return {j: fixed[:, j] for j in range(layout.ncols)}
        # every row has ncols cells: numpy's parser checks it when it reads every column as numbers; else count
        # the separators (a separator inside quotes fails this: line by line)
        checked = engine == "numpy" and all(k == "float" for k in kinds)
        if checked or (_cell_count(data) == layout.ncols * n if sep is None
                       else data.count(sep.encode()) == (layout.ncols - 1) * n):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    part = (_pandas_chunk if engine == "pandas" else _numpy_chunk)(data, layout, kinds)
            except Exception:  # noqa: BLE001  any refusal of the C parser: the line-by-line parser says why
                part = None
            if part is not None and all(a.shape == (n,) for a in part.values()) and all(
                    np.isfinite(part[j]).all() for j in required if kinds[j] == "float"):
                return part
    return _python_chunk(layout, ch, kinds, names, required)


def _cell_count(data: bytes) -> int:
    """Cells of whitespace-separated text: the starts of runs of non-blank bytes."""
    b = np.frombuffer(data, dtype=np.uint8)
    if b.size == 0:
        return 0
    blank = (b == 32) | (b == 9) | (b == 10) | (b == 13)
    return int(np.count_nonzero(blank[:-1] & ~blank[1:])) + int(not blank[0])


def _numpy_chunk(data: bytes, layout: Layout, kinds: list) -> dict[int, np.ndarray]:
    numeric = [j for j, k in enumerate(kinds) if k in ("float", "int")]
    text = [j for j, k in enumerate(kinds) if k == "text"]
    out: dict[int, np.ndarray] = {}
    common = {"delimiter": layout.sep, "comments": None, "quotechar": '"', "encoding": "utf-8", "ndmin": 1}
    if numeric:
        if all(kinds[j] == "float" for j in numeric):
            every = len(numeric) == layout.ncols  # all columns: loadtxt checks each row's width too
            arr = np.loadtxt(io.BytesIO(data), dtype=np.float64, usecols=None if every else numeric, ndmin=2,
                             **{k: v for k, v in common.items() if k != "ndmin"})
            if arr.shape[1] != len(numeric):
                raise ValueError("width")
            out.update({j: arr[:, i] for i, j in enumerate(numeric)})
        else:
            dt = np.dtype([(f"c{j}", np.int64 if kinds[j] == "int" else np.float64) for j in numeric])
            arr = np.loadtxt(io.BytesIO(data), dtype=dt, usecols=numeric, **common)
            out.update({j: arr[f"c{j}"] for j in numeric})
    for j in text:
        out[j] = np.loadtxt(io.BytesIO(data), dtype=str, usecols=(j,), **common)
    return out


def _pandas_chunk(data: bytes, layout: Layout, kinds: list) -> dict[int, np.ndarray]:
    import pandas as pd  # optional: pip install imucalib[pandas]

    used = [j for j, k in enumerate(kinds) if k is not None]
    dtypes = {j: {"float": np.float64, "int": np.int64, "text": object}[kinds[j]] for j in used}
    extra = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
    df = pd.read_csv(io.BytesIO(data), sep=layout.sep or r"\s+", header=None, names=list(range(layout.ncols)),
                     usecols=used, dtype=dtypes, quotechar='"', engine="c", na_filter=False,
                     skip_blank_lines=False, encoding="utf-8", encoding_errors="replace", **extra)
    out = {}
    for j in used:
        col = df[j].to_numpy()
        out[j] = col.astype(str) if kinds[j] == "text" else col
    return out


def _python_chunk(layout: Layout, ch: Chunk, kinds: list, names: Sequence[str],
                  required: Sequence[int]) -> dict[int, np.ndarray]:
    """The reference parser: every line in Python; the first bad line is an error naming it."""
    path, ncols = layout.path, layout.ncols
    values: dict[int, list] = {j: [] for j, k in enumerate(kinds) if k is not None}
    required = set(required)
    for i, raw in enumerate(_lines(ch.data)):
        line = _decode(raw)
        lineno = ch.first_line + i
        if not line.strip():
            raise ReaderError(f"{path}: line {lineno} is empty; remove blank lines")
        if line.lstrip().startswith("#"):
            continue
        if layout.decimal_comma:
            line = line.replace(",", ".")
        cells = split_cells(line, layout.sep)
        if len(cells) != ncols:
            raise ReaderError(
                f"{path}: line {lineno}: expected {ncols} values, found {len(cells)} "
                f"({line.strip()[:80]!r}); every row needs the same columns"
            )
        for j, vals in values.items():
            kind, cell = kinds[j], cells[j]
            if kind == "text":
                vals.append(cell)
                continue
            if kind == "int" and _INT.match(cell):
                vals.append(int(cell))
                continue
            try:
                v = float(cell)
            except ValueError:
                if j not in required:
                    raise _Demote(j, "text") from None
                raise ReaderError(
                    f"{path}: line {lineno}, {names[j]}: {cell!r} is not a number; fix or remove "
                    "the row (imucalib never skips rows)"
                ) from None
            if kind == "int":
                raise _Demote(j, "float")
            if not np.isfinite(v) and j in required:
                raise ReaderError(
                    f"{path}: line {lineno}, {names[j]}: {cell!r} is not finite (NaN or inf); "
                    "fix or remove the row (imucalib never skips rows)"
                )
            vals.append(v)
    out = {}
    for j, vals in values.items():
        try:
            out[j] = np.array(vals, dtype={"float": np.float64, "int": np.int64, "text": str}[kinds[j]])
        except OverflowError:  # an integer beyond int64
            raise _Demote(j, "float") from None
    return out


def column_kinds(cells: Sequence[str], decimal_comma: bool) -> list[str]:
    """What each cell of a first row suggests its column holds: "int", "float" or "text"."""
    kinds = []
    for cell in cells:
        c = cell.replace(",", ".") if decimal_comma else cell
        if _INT.match(c) and len(c.lstrip("+-")) >= INT_DIGITS:
            kinds.append("int")
            continue
        try:
            float(c)
            kinds.append("float")
        except ValueError:
            kinds.append("text")
    return kinds


def fingerprint(recording) -> int:
    """A checksum (CRC-32) of a recording's arrays: a writer copies the source's text only while it matches.

    About 0.06 s for 3.6 M samples.
    """
    crc = 0
    arrays = [recording.t, recording.acc, *([] if recording.gyro is None else [recording.gyro]),
              *recording.extra.values()]
    if recording.temperature is not None:
        arrays.append(recording.temperature)
    for a in arrays:
        a = np.ascontiguousarray(a)
        crc = zlib.crc32(str((a.dtype.str, a.shape)).encode(), crc)
        crc = zlib.crc32(a.view(np.uint8).reshape(-1) if a.size else b"", crc)
    return crc
