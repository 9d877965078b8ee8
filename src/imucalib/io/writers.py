"""Writers: a recording (and its calibrated columns) as CSV.

Two ways, chosen by :func:`write_csv`:

* **copying the source**: a recording read from a CSV file (:func:`imucalib.io.read`)
  carries where that file's rows lie (``metadata["source_layout"]``) and a
  checksum of its bytes as they were parsed (:func:`.csvparse.digest`). While
  the recording still holds the samples read (same checksum of its arrays:
  :func:`.csvparse.fingerprint`), every byte the reader parsed, up to the
  file's size when it was read, is copied as it was written (preamble, header,
  each cell with its precision, integer stamps, IDs, text, columns of the same
  name, the separator, the line ends) and the calibrated columns are appended
  to each row, with their names appended to the header. The copy is checked
  against the parse's checksum before it replaces anything: a file that grew
  since (a logger still writing) is copied up to the end it had when read; one
  rewritten or cut short is not copied. The file is streamed a few megabytes
  at a time: nothing of it is held as Python strings.
* **from the values** otherwise: each column written from the recording's
  arrays; floats with the shortest text that reads back to the same double
  (Python's ``repr``), integers as integers, integer time stamps (ns since the
  epoch) restored exactly.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..recording import Recording
from . import csvparse
from .atomic import atomic_write
from .readers import TIME_UNITS

__all__ = ["ADDED_FORMAT", "calibrated_columns", "write_csv"]

_ROWS = 50_000  # rows formatted at a time
_COPY_BYTES = 1 << 20  # source text copied at a time: its lines as Python objects take ~20× that
#: the calibrated columns' format: 12 significant digits, far finer than any IMU resolves (and 2.5× faster
#: to write than the shortest exact text)
ADDED_FORMAT = "%.12g"


def calibrated_columns(calibrated_acc: np.ndarray | None, calibrated_gyro: np.ndarray | None,
                       calibrated_mag: np.ndarray | None = None, mag_unit: str = "uT") -> dict[str, np.ndarray]:
    """The columns :func:`write_csv` adds: ``acc_x_cal [m/s^2]`` … ``gyro_z_cal [rad/s]`` (… ``mag_z_cal [uT]``)."""
    cols: dict[str, np.ndarray] = {}
    for prefix, unit, values in (("acc", "m/s^2", calibrated_acc), ("gyro", "rad/s", calibrated_gyro),
                                 ("mag", mag_unit, calibrated_mag)):
        if values is not None:
            values = np.asarray(values, dtype=np.float64)
            for i, a in enumerate("xyz"):
                cols[f"{prefix}_{a}_cal [{unit}]"] = values[:, i]
    return cols


def write_csv(
    path: str | Path,
    recording: Recording,
    calibrated_acc: np.ndarray | None = None,
    calibrated_gyro: np.ndarray | None = None,
    calibrated_mag: np.ndarray | None = None,
    mag_unit: str = "uT",
) -> None:
    """Write every row and column of ``recording`` as CSV, then the calibrated columns.

    A recording read from a CSV file that has not changed since is written by
    copying that file's text and appending the calibrated columns (module
    docstring): every input column comes out byte for byte as it went in.
    Otherwise the columns keep the names and order they had in a CSV input
    (``metadata["column_names"]``) and time keeps its original unit, or are
    ``t [s], ax [unit] … gz [unit]``, the temperature if there is one, then
    any extra columns, each value written with the shortest text that reads
    back to the same double. The added columns are ``acc_x_cal [m/s^2]`` …
    and ``gyro_x_cal [rad/s]`` … (and ``mag_x_cal [uT]`` or ``[normalised]`` … for a
    calibrated magnetometer; without the space in a whitespace-separated
    file), with 12 significant digits (:data:`ADDED_FORMAT`).

    The rows go to a temporary file next to ``path``, moved onto ``path`` only
    when all are written (:func:`imucalib.io.atomic.atomic_write`): a failed
    or interrupted write leaves an existing ``path`` as it was. The source's
    bytes are copied only up to the size it had when read, and only if their
    checksum is the parse's (checked before the copy replaces ``path``): a
    source appended to since is copied up to that end; one rewritten (even
    with its size and modification time put back) or cut short is not, and
    the rows are written from the values, which are the samples that were read.

    Parameters
    ----------
    path : str or Path
        The CSV file to write; one ending in ``.gz`` is written gzip-compressed (as the readers read
        ``.csv.gz``).
    recording : Recording
        The recording whose rows are written.
    calibrated_acc, calibrated_gyro : ndarray of shape (N, 3), optional
        The calibrated accelerometer [m/s²] and gyroscope [rad/s] readings, one row per sample of
        ``recording`` (:meth:`imucalib.Calibration.apply`); None leaves their columns out.
    calibrated_mag : ndarray of shape (N, 3), optional
        The calibrated magnetometer, in ``mag_unit``.
    mag_unit : str
        The calibrated magnetometer's unit in its columns' names: ``"uT"`` or ``"normalised"``.

    Returns
    -------
    None
        The file is written.

    Raises
    ------
    ValueError
        A calibrated column with another number of rows than ``recording``.
    OSError
        The file cannot be written (the one at ``path`` is then left as it was).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.io import write_csv
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1)
    >>> calibrated = sim.truth.apply(sim.recording)
    >>> out = Path(tempfile.mkdtemp()) / "calibrated.csv"
    >>> write_csv(out, sim.recording, calibrated.acc, calibrated.gyro)
    >>> out.read_text().splitlines()[0].split(",")[-6:]
    ['acc_x_cal [m/s^2]', 'acc_y_cal [m/s^2]', 'acc_z_cal [m/s^2]',
     'gyro_x_cal [rad/s]', 'gyro_y_cal [rad/s]', 'gyro_z_cal [rad/s]']
    """
    added = calibrated_columns(calibrated_acc, calibrated_gyro, calibrated_mag, mag_unit)
    _check_rows(added, len(recording))
    layout = _source_layout(recording)
    if layout is None or not _copy_source(path, recording, layout, added):
        _write_values(path, recording, added)  # the samples read, whatever their file has become since


def _check_rows(added: dict[str, np.ndarray], n: int) -> None:
    """Each calibrated column has the recording's ``n`` rows."""
    for k, v in added.items():
        if len(v) != n:
            raise ValueError(f"column {k!r} has {len(v)} rows; the recording has {n}")


# ------------------------------------------------------------ copying the source
def _source_layout(rec: Recording) -> csvparse.Layout | None:
    """The layout of the CSV file ``rec`` was read from, when copying its text may write ``rec`` exactly.

    The recording must hold the rows read, unchanged, and the file must be at
    least as long as when it was read; whether its bytes are still the ones
    parsed is checked while they are copied (:func:`_copy_source`).
    """
    info = rec.metadata.get("source_layout")
    if not info or not info.get("digest"):
        return None
    layout = csvparse.Layout.from_dict(info)
    if info.get("rows") != len(rec) or info.get("fingerprint") != csvparse.fingerprint(rec):
        return None
    try:
        if layout.path.stat().st_size < layout.size:
            return None
    except OSError:
        return None
    return layout


def _header_names(rec: Recording, layout: csvparse.Layout) -> list[str]:
    """Names for the columns of a file without a header: the fields they were read as, with units."""
    names = [f"column {j + 1}" for j in range(layout.ncols)]
    units = {"t": rec.metadata.get("time_unit") or "s", "a": rec.acc_unit, "g": rec.gyro_unit}
    columns = rec.metadata.get("columns") or {}
    index = {name: j for j, name in enumerate(rec.metadata.get("column_names") or [])}
    for field in ("gz", "gy", "gx", "az", "ay", "ax", "t"):  # the first field wins a column used twice
        name = columns.get(field)
        if name in index:
            names[index[name]] = f"{field} [{units[field[0]]}]"
    return names


class _SourceChanged(Exception):
    """The source file's bytes are not the ones the recording was read from."""


class _Checked:
    """The open source file read forwards from its start, up to its size as read, each byte fed to a checksum.

    :meth:`as_read` tells whether everything up to that size was read and its
    checksum is the parse's (:func:`.csvparse.digest`).
    """

    def __init__(self, src, layout: csvparse.Layout) -> None:
        self.src, self.size, self.pos = src, layout.size, 0
        self.digest = csvparse.digest()

    def read(self, n: int) -> bytes:
        data = self.src.read(max(0, min(n, self.size - self.pos)))
        self.digest.update(data)
        self.pos += len(data)
        return data

    def readline(self, limit: int) -> bytes:
        data = self.src.readline(max(0, min(limit, self.size - self.pos)))
        self.digest.update(data)
        self.pos += len(data)
        return data

    def seek(self, pos: int) -> None:
        if pos != self.pos:  # every byte goes through the checksum, in order
            raise ValueError(f"the source is read forwards: at byte {self.pos}, asked for {pos}")

    def as_read(self, expected: str) -> bool:
        return self.pos == self.size and self.digest.hexdigest() == expected


def _body_chunks(src, layout: csvparse.Layout, chunk_bytes: int):
    """The body's bytes from the open file ``src`` in pieces of whole lines, never past the body's end as read."""
    src.seek(layout.body[0])
    pos, end = layout.body
    while pos < end:
        data = src.read(min(chunk_bytes, end - pos))
        if not data:
            raise _SourceChanged  # shorter than when it was read
        if pos + len(data) < end and not data.endswith(b"\n"):
            data += src.readline(end - pos - len(data))  # finish the line
        pos += len(data)
        yield data


def _copy_source(path: str | Path, rec: Recording, layout: csvparse.Layout, added: dict[str, np.ndarray]) -> bool:
    """Copy the source's text with the calibrated columns appended; False (nothing written) when it changed.

    Everything is read from one open file, forwards, up to the size it had
    when read, through the checksum the parse took of those bytes
    (:class:`_Checked`); a difference (rewritten, cut short) is found before
    the copy replaces ``path``: the copy is discarded and ``path`` left as it
    was. Bytes appended since the read are never taken.
    """
    sep = layout.sep or " "
    bsep = sep.encode()
    spaced = layout.sep is not None  # names may hold spaces only when a separator other than blanks parts cells
    names = list(added) if spaced else [k.replace(" ", "") for k in added]
    columns = list(added.values())
    row_format = (sep + ADDED_FORMAT) * len(columns)
    expected = rec.metadata["source_layout"]["digest"]
    try:
        src = layout.path.open("rb")
    except OSError:
        return False
    with src:
        checked = _Checked(src, layout)
        try:
            with atomic_write(path, "wb", gzip_by_name=True) as dst:
                _copy_rows(checked, dst, rec, layout, names, columns, row_format, bsep, spaced)
                if not checked.as_read(expected):  # not the bytes parsed: the copy is discarded, path kept
                    raise _SourceChanged
        except _SourceChanged:
            return False
    return True


def _copy_rows(src, dst, rec: Recording, layout: csvparse.Layout, names: list[str], columns: list[np.ndarray],
               row_format: str, bsep: bytes, spaced: bool) -> None:
    sep = bsep.decode()
    src.seek(0)
    if layout.header is not None:
        h0, h1 = layout.header
        dst.write(src.read(h0))  # the preamble
        header = src.read(h1 - h0)
        end = b"\r" if header.endswith(b"\r") else b""
        header = header[:len(header) - len(end)]
        quote = header.lstrip(b"\xef\xbb\xbf \t").startswith(b'"')
        dst.write(header + b"".join(bsep + (f'"{k}"' if quote else k).encode() for k in names) + end)
        dst.write(src.read(layout.body[0] - h1))  # the header's line end
    else:
        dst.write(src.read(layout.body[0]))  # the preamble
        own = _header_names(rec, layout) + names
        own = own if spaced else [k.replace(" ", "") for k in own]
        dst.write(sep.join(own).encode() + b"\n")
    done = 0
    for data in _body_chunks(src, layout, _COPY_BYTES):
        lines = data.split(b"\n")
        last_end = lines.pop() if data.endswith(b"\n") else None  # b"" after a final line end
        rows = [i for i, ln in enumerate(lines) if not ln.lstrip(b" \t").startswith(b"#")] \
            if b"#" in data else range(len(lines))
        if done + len(rows) > len(rec):
            raise _SourceChanged  # more rows than were read
        block = [c[done:done + len(rows)].tolist() for c in columns]
        text = "\n".join(row_format % row for row in zip(*block, strict=True))
        if layout.decimal_comma:
            text = text.replace(".", ",")
        tails = text.encode().split(b"\n") if columns else [b""] * len(rows)
        for i, tail in zip(rows, tails, strict=True):
            ln = lines[i]
            lines[i] = ln[:-1] + tail + b"\r" if ln.endswith(b"\r") else ln + tail
        dst.write(b"\n".join(lines))
        if last_end is not None:
            dst.write(b"\n")
        done += len(rows)
    if done != len(rec):
        raise _SourceChanged  # fewer rows than were read
    src.seek(layout.body[1])
    dst.write(src.read(layout.size - layout.body[1]))  # what follows the last row, up to the end as read


# ------------------------------------------------------------ from the values
def _original_time(rec: Recording) -> np.ndarray:
    kept = rec.metadata.get("time_original")  # blocks whose times restart: the file's own times, as they were
    if kept is not None and len(kept) == len(rec):
        return np.asarray(kept)
    unit = rec.metadata.get("time_unit")
    if not unit:
        return rec.t
    t = rec.t / TIME_UNITS[unit]
    t0 = rec.metadata.get("t0")
    if rec.metadata.get("time_relative"):
        if isinstance(t0, int) and not isinstance(t0, bool):  # integer stamps: exactly as they were
            return np.rint(t).astype(np.int64) + np.int64(t0)
        t = t + t0
    return t


def _columns(rec: Recording) -> dict[str, np.ndarray]:
    cols: dict[str, np.ndarray] = {}
    names = rec.metadata.get("column_names")
    mapping = rec.metadata.get("columns") or {}
    extra = dict(rec.extra)
    if names and mapping:
        source = {"t": _original_time(rec), "ax": rec.acc[:, 0], "ay": rec.acc[:, 1], "az": rec.acc[:, 2]}
        if rec.gyro is not None:
            source |= {"gx": rec.gyro[:, 0], "gy": rec.gyro[:, 1], "gz": rec.gyro[:, 2]}
        mapped = {names.index(v): k for k, v in mapping.items() if v is not None and v in names}
        seen: set[str] = set()
        for j, name in enumerate(names):  # the file's columns in its order, as the reader keyed them
            if j in mapped:
                cols[name] = source[mapped[j]]
                continue
            key = name if name not in seen else f"{name} (column {j + 1})"
            seen.add(name)
            if key in extra:
                cols[key] = extra.pop(key)
    else:
        unit = rec.metadata.get("time_unit") or "s"
        cols[f"t [{unit}]"] = _original_time(rec)
        for i, a in enumerate("xyz"):  # the unit in the name, so that reading the file back keeps it
            cols[f"a{a} [{rec.acc_unit}]"] = rec.acc[:, i]
        for i, a in enumerate("xyz" if rec.gyro is not None else ""):  # none for an accelerometer-only log
            cols[f"g{a} [{rec.gyro_unit}]"] = rec.gyro[:, i]
        if rec.temperature is not None:
            cols["temperature [C]"] = rec.temperature
    cols.update(extra)
    return cols


def _quote(cell: str) -> str:
    if any(c in cell for c in ',"\n\r') or cell != cell.strip():
        return '"' + cell.replace('"', '""') + '"'
    return cell


def _write_values(path: str | Path, rec: Recording, added: dict[str, np.ndarray]) -> None:
    cols = {**_columns(rec), **added}
    n = len(rec)
    for k, v in cols.items():
        if len(v) != n:
            raise ValueError(f"column {k!r} has {len(v)} rows; the recording has {n}")
    arrays: list[np.ndarray] = []
    formats: list[str] = []
    for name, v in cols.items():
        v = np.asarray(v)  # no copies: each block is converted as it is written
        if v.dtype.kind in "iub" or (name not in added and _whole(v)):
            formats.append("%d")  # integers, and floats that hold integers (raw counts): exact and fast
        elif v.dtype.kind == "f":
            formats.append(ADDED_FORMAT if name in added else "%r")  # %r: the shortest text of the same double
        else:
            formats.append("%s")
        arrays.append(v)
    row_format = ",".join(formats)
    text_cols = [j for j, f in enumerate(formats) if f == "%s"]
    with atomic_write(path, "w", encoding="utf-8", newline="\n", gzip_by_name=True) as fh:
        fh.write(",".join(_quote(k) for k in cols) + "\n")
        for start in range(0, n, _ROWS):
            parts = [_block(a[start:start + _ROWS], f) for a, f in zip(arrays, formats, strict=True)]
            for j in text_cols:
                parts[j] = [_quote(c) for c in parts[j]]
            fh.write("\n".join(row_format % row for row in zip(*parts, strict=True)))
            fh.write("\n")


def _whole(v: np.ndarray) -> bool:
    """Whether a float column holds only integers that float64 represents exactly."""
    if v.dtype.kind != "f" or v.size == 0:
        return False
    big = float(np.max(np.abs(v)))
    return big < 2.0**53 and bool(np.all(np.trunc(v) == v))


def _block(a: np.ndarray, fmt: str) -> list:
    if fmt == "%s":
        return a.astype(str).tolist()
    if fmt == "%d" and a.dtype.kind == "f":
        return a.astype(np.int64).tolist()
    return a.tolist()
