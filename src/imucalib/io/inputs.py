"""Checks every reader shares, and the Xsens MT Manager text export.

* :func:`check_input_path`: an input that is missing, a symbolic link loop,
  a FIFO, a socket or a device is an error naming what it is (a FIFO would
  block the reader forever);
* :func:`check_text`: a text input that is UTF-16, UTF-32, compressed or binary
  (NUL bytes) is an error saying so (the text readers read UTF-8 and ASCII; the
  CSV reader also gzip-compressed text);
* :func:`check_distinct_columns`: one column named for two fields is an error;
* :func:`check_against_header`: a unit option that contradicts the unit the
  header writes is an error;
* :func:`check_magnitudes`: readings too large for any sensor (beyond 1e15)
  are an error, before arithmetic on them overflows;
* :func:`note_physical_units`: readings taken as counts that look like m/s²,
  g, rad/s or deg/s get a note saying so;
* :func:`xsens_header`, :func:`read_xsens`: MT Manager's export (``//``
  comment lines, then ``PacketCounter SampleTimeFine … Acc_X … Gyr_Z``,
  usually tab-separated). ``SampleTimeFine`` counts ticks of 100 µs (10 kHz)
  in an unsigned 32-bit counter; ``Acc_*`` are in m/s² and ``Gyr_*`` in rad/s
  (Xsens's SI outputs). ``FreeAcc_*`` (gravity removed) cannot calibrate.
"""

from __future__ import annotations

import errno
import io
import os
import re
import stat
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..recording import ImucalibWarning, Recording
from . import csvparse
from .columns import parse_columns
from .errors import ReaderError

__all__ = ["check_against_header", "check_distinct_columns", "check_input_path", "check_magnitudes", "check_text",
           "note_physical_units", "read_xsens", "xsens_header"]

#: readings beyond this are no sensor's (and their squares are near float overflow)
LARGEST_READING = 1e15


# --------------------------------------------------------------------- text
#: the longest line looked at for an Xsens header [characters]: a longer one is no MT Manager export
_LONGEST_HEADER = 1 << 16
#: what a compressed file starts with, and the command that decompresses it
_COMPRESSED = ((b"\x1f\x8b", "gzip", "gunzip -k"), (b"BZh", "bzip2", "bunzip2 -k"),
               (b"\xfd7zXZ\x00", "xz", "unxz -k"), (b"(\xb5/\xfd", "zstd", "unzstd"),
               (b"PK\x03\x04", "zip", "unzip"))


def path_kind(mode: int) -> str | None:
    """What a non-regular, non-directory file is (``os.stat`` mode), or None for a regular file or a directory."""
    for test, name in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device")):
        if test(mode):
            return name
    return None


def check_input_path(path: str | Path, what: str = "file") -> os.stat_result:
    """The ``os.stat`` of an input that a reader can open and read more than once; else a ReaderError.

    ``what`` names the input in the messages (``"file"``, ``"manifest"``).

    Missing files, symbolic link loops (and links to nothing) and anything that is not a regular file or a
    directory (a FIFO would block the reader forever, a device streams without end) are refused here, before
    anything opens them.
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise ReaderError(f"{path}: a symbolic link loop (the link leads back to itself through other links); "
                              f"point it at the {what}") from None
        if exc.errno == errno.ENOENT and os.path.islink(path):
            raise ReaderError(f"{path}: a symbolic link to nothing ({os.readlink(path)} does not exist)") from None
        if exc.errno in (errno.ENOENT, errno.ENOTDIR):
            raise ReaderError(f"{path}: {what} not found") from None
        raise ReaderError(f"{path}: cannot be read ({exc.strerror})") from None
    kind = path_kind(st.st_mode)
    if kind is not None:
        stream = "binary data without end (NUL bytes, random bytes)" if kind.endswith("device") else \
            "a stream that can be read only once, and blocks until a writer comes"
        content = "data" if what == "file" else what
        raise ReaderError(f"{path}: {kind}, not a regular file: its content is {stream}; save the {content} to "
                          "a file and give that")
    return st


def check_text(path: Path, *, gzip_ok: bool = False) -> None:
    """Refuse UTF-16, compressed and binary files before a text reader garbles them.

    With ``gzip_ok`` (a reader that decompresses gzip as it reads:
    :func:`.csvparse.open_binary`) a gzip-compressed file's decompressed text is
    checked instead; the other compressions are refused all the same.
    """
    if path.is_dir():
        return
    with csvparse.open_binary(path) if gzip_ok else path.open("rb") as f:
        head = f.read(4096)
    for magic, name, command in _COMPRESSED:
        if head.startswith(magic):
            raise ReaderError(f"{path}: {name}-compressed; decompress it first ({command} '{path}') and give the "
                              "decompressed file")
    if len(head) >= 8 and head.count(0) == len(head):
        raise ReaderError(f"{path}: binary data (its first {len(head)} bytes are all NUL bytes: a sparse or "
                          "zero-filled file, not text); check that the recording was written out completely")
    # UTF-32 text: a byte-order mark, or ASCII's three NUL bytes in every four (checked before UTF-16, whose
    # little-endian mark starts UTF-32's)
    quarter = len(head) // 4
    nul = [head[k::4].count(0) for k in range(4)]
    utf32 = head.startswith((b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff")) or (
        len(head) >= 16 and sorted(nul)[1] > 0.9 * quarter and min(nul) < 0.1 * quarter)
    if utf32:
        raise ReaderError(f"{path}: the text is UTF-32 encoded; imucalib reads UTF-8 text: save it as UTF-8 "
                          f"(in an editor: Save As, encoding UTF-8; or iconv -f UTF-32 -t UTF-8 '{path}' > "
                          f"'{path.with_name(path.stem + '-utf8' + path.suffix)}')")
    # UTF-16 text: a byte-order mark, or NUL bytes at one parity of the positions (the high byte of ASCII)
    # and hardly any at the other
    half = len(head) // 2
    nul_even, nul_odd = head[0::2].count(0), head[1::2].count(0)
    utf16 = head.startswith((b"\xff\xfe", b"\xfe\xff")) or (
        len(head) >= 8 and max(nul_even, nul_odd) > 0.6 * half and min(nul_even, nul_odd) < 0.1 * half)
    if utf16:
        raise ReaderError(f"{path}: the text is UTF-16 encoded; imucalib reads UTF-8 text: save it as UTF-8 "
                          f"(in a spreadsheet or editor: Save As, encoding UTF-8; or iconv -f UTF-16 -t UTF-8 "
                          f"'{path}' > '{path.with_name(path.stem + '-utf8' + path.suffix)}')")
    if b"\x00" in head:
        raise ReaderError(f"{path}: a binary file, not text (it holds NUL bytes); the text readers take CSV or "
                          "imu_tk text (--reader mat for MATLAB files, a ROS bag is recognised from its content)")


# ------------------------------------------------------------------ columns
def check_distinct_columns(columns: Sequence[str] | None) -> None:
    """Each field ``--columns`` names needs its own column: one column named twice is an error
    (the entries checked first: :func:`.columns.parse_columns`)."""
    if columns is None:
        return

    seen: dict[str, str] = {}
    for field, c in parse_columns(columns).items():
        key = None if c is None else c.strip().lower()
        if key is None:
            continue
        if key in seen:
            raise ReaderError(f"--columns names {c.strip()!r} for both {seen[key]} and {field}; each field needs "
                              "its own column")
        seen[key] = field


def check_against_header(paths: Sequence[Path], reader: str, rec: Recording, acc_unit, gyro_unit, time_unit, *,
                         unit_in: Callable, phone_specs: Callable) -> None:
    """A unit option must agree with a unit the file's header writes (it does not override it).

    ``unit_in(name)`` is the unit a column name writes; ``phone_specs(paths)`` the phone-app layouts.
    """
    given = {"ax": ("--acc-unit", acc_unit), "gx": ("--gyro-unit", gyro_unit), "t": ("--time-unit", time_unit)}
    written: dict[str, tuple[str, str]] = {}
    if reader == "csv" and rec.metadata.get("header"):
        for field, name in (rec.metadata.get("columns") or {}).items():
            if field in given and name is not None and unit_in(name) is not None:
                written[field] = (name, unit_in(name))
    elif reader == "phone":
        specs = phone_specs(paths)
        for spec in specs or []:
            field = "ax" if spec.sensor == "acc" else "gx"
            if spec.unit is not None:
                written[field] = (f"{spec.app} {'accelerometer' if field == 'ax' else 'gyroscope'} file", spec.unit)
    for field, (where, unit) in written.items():
        flag, value = given[field]
        if value is not None and value != unit:
            raise ReaderError(f"{paths[0] if reader != 'phone' else ', '.join(map(str, paths))}: {flag} {value} "
                              f"contradicts the header ({where!r} says {unit}); drop {flag} (the header's unit is "
                              "used) or fix the header")


def check_magnitudes(paths: Sequence[Path], rec: Recording) -> None:
    for name, arr in (("accelerometer", rec.acc), ("angular rate", rec.gyro)):
        if arr is None:  # an accelerometer-only recording
            continue
        big = np.abs(arr) > LARGEST_READING
        if np.any(big):
            i = int(np.nonzero(big.any(axis=1))[0][0])
            raise ReaderError(f"{paths[0]}: sample {i + 1}: an {name} reading of {float(arr[big][0]):.3g} is beyond "
                              "any sensor's range; check the columns and the file")


def note_physical_units(paths: Sequence[Path], rec: Recording) -> None:
    """A note when readings taken as counts look like m/s², g, rad/s or deg/s (static norm ≈ 9.81 or ≈ 1)."""
    if rec.acc_unit != "counts" or len(rec) < 10:
        return
    norm = float(np.median(np.linalg.norm(rec.acc, axis=1)))
    acc = "m/s^2" if 9.0 <= norm <= 10.6 else "g" if 0.9 <= norm <= 1.1 else None
    if acc is None:
        return
    flags = [f"--acc-unit {acc}"]
    looks = [f"the accelerometer like {acc} (median norm {norm:.3g})"]
    if rec.gyro is not None and rec.gyro_unit == "counts":
        rate = float(np.percentile(np.abs(rec.gyro), 99))
        gyro = "rad/s" if rate <= 35.0 else "deg/s" if rate <= 2500.0 else None
        if gyro is not None:
            flags.append(f"--gyro-unit {gyro}")
            looks.append(f"the gyroscope like {gyro} (99% of its readings within {rate:.3g})")
    warnings.warn(f"{', '.join(map(str, paths))}: no unit given or written in a header, so the readings are taken "
                  f"as counts; they look like physical units, {' and '.join(looks)}: if they are, pass "
                  f"{' '.join(flags)}", ImucalibWarning, stacklevel=4)


def note_gyro_unit(paths: Sequence[Path], rec: Recording) -> None:
    """A note when a gyroscope taken as counts holds readings that are not whole numbers (counts are).

    Its unit is then rad/s or deg/s; the note names the one its readings look like (99 % of them within
    35, as :func:`note_physical_units` judges) and the option to pass.
    """
    if rec.gyro is None or rec.gyro_unit != "counts" or len(rec) < 10:
        return
    if np.all(rec.gyro == np.round(rec.gyro)):
        return
    rate = float(np.percentile(np.abs(rec.gyro), 99))
    guess = "rad/s" if rate <= 35.0 else "deg/s"
    warnings.warn(f"{', '.join(map(str, paths))}: no gyroscope unit given or written in the header, so its readings "
                  f"are taken as counts, but they are not whole numbers, so they are not counts: they look like "
                  f"{guess} (99% of them within {rate:.3g}); pass --gyro-unit {guess} (or the unit the logger "
                  "writes)", ImucalibWarning, stacklevel=4)


# -------------------------------------------------------------------- Xsens
_XSENS_FIELDS = ("SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z")


def xsens_header(path: Path) -> list[str] | None:
    """The column names of an MT Manager text export (after its ``//`` lines), or None when it is not one."""
    if path.is_dir() or path.suffix.lower() == ".mat":
        return None
    with csvparse.open_binary(path) as raw, io.TextIOWrapper(raw, encoding="utf-8-sig", errors="replace") as f:
        for _ in range(200):
            line = f.readline(_LONGEST_HEADER)
            if not line:
                return None
            if len(line) >= _LONGEST_HEADER and not line.endswith("\n"):
                return None  # a line this long is no MT Manager header (and is not split into cells here)
            if line.startswith("//") or not line.strip():
                continue
            names = [c.strip().strip('"') for c in re.split(r"[\t,;]", line.strip())]
            return names if "SampleTimeFine" in names and ("PacketCounter" in names or "Acc_X" in names) else None
    return None


def read_xsens(path: Path, names: list[str], acc_unit, gyro_unit, rate, time_unit, *, read_csv: Callable) -> Recording:
    """An MT Manager export, read by ``read_csv(path, columns, acc_unit, gyro_unit, rate, time_unit)``."""
    missing = [n for n in _XSENS_FIELDS[1:] if n not in names]
    if missing:
        free = " (FreeAcc is the acceleration with gravity taken out, which cannot calibrate)" \
            if "FreeAcc_X" in names else ""
        raise ReaderError(f"{path}: an Xsens MT Manager export without {', '.join(missing)}{free}; export "
                          "Acc_X..Acc_Z (acceleration) and Gyr_X..Gyr_Z (rate of turn) with SampleTimeFine")
    if rate is not None or time_unit is not None:
        raise ReaderError(f"{path}: an Xsens MT Manager export carries its own time (SampleTimeFine, 100 us "
                          "ticks); drop --rate and --time-unit")
    with warnings.catch_warnings():  # the skipped // lines are this format's, not worth a note
        warnings.filterwarnings("ignore", message=".*skipped .* lines? before the", category=ImucalibWarning)
        rec = read_csv(path, list(_XSENS_FIELDS), acc_unit or "m/s^2", gyro_unit or "rad/s", None, "us")
    ticks = rec.t * 1e6  # read as µs: the tick counts themselves
    seconds = (ticks - ticks[0]) * 1e-4  # SampleTimeFine: 10 kHz
    meta = {**rec.metadata, "format": "Xsens MT Manager", "time_unit": "100us", "t0": float(ticks[0]) * 1e-4}
    return Recording(seconds, rec.acc, rec.gyro, acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit,
                     temperature=rec.temperature, extra=rec.extra, metadata=meta)
