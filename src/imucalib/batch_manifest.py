"""The manifest of a batch run (:mod:`imucalib.batch`): the CSV file read and every entry checked.

:func:`read_manifest` reads a manifest into :class:`Row` s, one per recording, and reports every problem with
its line before anything runs. The columns, and what a manifest can make the batch do, are described in
:mod:`imucalib.batch`.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .calibration import check_device
from .io.errors import ReaderError
from .io.inputs import check_input_path
from .methodinfo import DEFAULT_METHOD, declared
from .recording import STANDARD_GRAVITY
from .store import parse_time

__all__ = ["MANIFEST_COLUMNS", "ManifestError", "Row", "is_url", "read_manifest", "url_protocols", "url_schemes"]

#: the manifest's columns; ``device`` and ``files`` are required
MANIFEST_COLUMNS = ("device", "files", "method", "model", "reader", "columns", "acc_unit", "gyro_unit",
                    "time_unit", "rate", "topic", "variable", "gravity", "recorded_at", "temperature_c")
_READERS = ("csv", "imutk", "mat", "phone", "rosbag", "session")
_UNITS = {"acc_unit": ("counts", "g", "m/s^2"), "gyro_unit": ("counts", "deg/s", "rad/s"),
          "time_unit": ("s", "ms", "us", "ns")}


class ManifestError(ValueError):
    """A manifest that cannot be read or has invalid entries; the message names the file and lines.

    Examples
    --------
    >>> from imucalib.batch import ManifestError, read_manifest
    >>> try:
    ...     read_manifest("no_such_manifest.csv")
    ... except ManifestError as exc:
    ...     print(exc)
    no_such_manifest.csv: manifest not found
    """


@dataclass(frozen=True)
class Row:
    """One recording of a manifest, checked: what :func:`~imucalib.batch.run_row` calibrates.

    ``files`` are absolute local paths or URLs; ``recorded_at`` is normalised (:func:`imucalib.store.parse_time`).

    Examples
    --------
    :func:`read_manifest` gives them, one per line, with the defaults where the line leaves a cell empty:

    >>> from imucalib.batch import Row
    >>> row = Row(line=2, device="imu1", files=("/data/imu1.csv",))
    >>> row.method, row.gravity, row.reader
    ('tedaldi2014', 9.80665, None)
    """

    line: int
    device: str
    files: tuple[str, ...]
    method: str = DEFAULT_METHOD
    model: str | None = None
    reader: str | None = None
    columns: tuple[str, ...] | None = None
    acc_unit: str | None = None
    gyro_unit: str | None = None
    time_unit: str | None = None
    rate: float | None = None
    topic: str | None = None
    variable: str | None = None
    gravity: float = STANDARD_GRAVITY
    recorded_at: str | None = None
    temperature_c: float | None = None

    def settings(self) -> dict[str, Any]:
        """Everything but the device, time and files: the rest of a record's identity."""
        return {"method": self.method, "model": self.model, "reader": self.reader,
                "columns": list(self.columns) if self.columns else None, "acc_unit": self.acc_unit,
                "gyro_unit": self.gyro_unit, "time_unit": self.time_unit, "rate": self.rate, "topic": self.topic,
                "variable": self.variable, "gravity": self.gravity, "temperature_c": self.temperature_c}

    def reader_options(self) -> dict[str, Any]:
        """The keyword options of :func:`imucalib.read`."""
        return {"reader": self.reader, "columns": list(self.columns) if self.columns else None,
                "acc_unit": self.acc_unit, "gyro_unit": self.gyro_unit, "time_unit": self.time_unit,
                "rate": self.rate, "topic": self.topic, "variable": self.variable}


def is_url(path: str) -> bool:
    """True for ``scheme://…`` (read through fsspec), False for a local path."""
    head, sep, _ = path.partition("://")
    return bool(sep) and head.isidentifier() and len(head) > 1


def url_schemes(allow_urls: bool | str | Sequence[str] | None) -> frozenset[str] | None:
    """The URL schemes a manifest may use: None for any (``True``), an empty set for none (``False``).

    ``allow_urls`` is a bool, a list of schemes, or a comma-separated text of them (``"s3,gcs"``).
    """
    if allow_urls is True:
        return None
    if not allow_urls:
        return frozenset()
    names = allow_urls.split(",") if isinstance(allow_urls, str) else list(allow_urls)
    schemes = frozenset(n.strip().lower() for n in names if n.strip())
    bad = sorted(n for n in schemes if not (n.isidentifier() and len(n) > 1))
    if bad:
        raise ValueError(f"not a URL scheme: {', '.join(bad)} (schemes are names such as s3, gcs, https)")
    return schemes


def url_protocols(name: str) -> list[str]:
    """Every protocol an fsspec URL reads through, outermost first: ``zip://rec.csv::ftp://host/a.zip`` reads a
    zip through FTP (``["zip", "ftp"]``). A chained part without ``://`` names a protocol (``simplecache::``),
    or, last, a local file (``file``)."""
    parts = name.split("::")
    out = []
    for i, part in enumerate(parts):
        head, sep, _ = part.partition("://")
        out.append(head.lower() if sep else "file" if i == len(parts) - 1 else part.strip().lower())
    return out


def _check_url(name: str, schemes: frozenset[str] | None) -> None:
    """Every protocol of ``name``'s chain allowed (:func:`url_protocols`), else a ValueError naming the first not."""
    protocols = url_protocols(name)
    if schemes is None or all(p in schemes for p in protocols):
        return
    if not schemes:
        raise ValueError(f"{name}: a URL; a manifest's URLs are read only when allowed (imucalib batch "
                         f"--allow-urls, or --allow-urls {','.join(dict.fromkeys(protocols))} for this URL alone): "
                         "allow them for manifests you trust, since the batch connects to the hosts they name")
    refused = next(p for p in protocols if p not in schemes)
    chain = f" (the URL reads through {'::'.join(protocols)}: each must be allowed)" if len(protocols) > 1 else ""
    raise ValueError(f"{name}: the URL scheme {refused} is not among those allowed "
                     f"({', '.join(sorted(schemes))}){chain}")


def _local(base: Path, name: str) -> str:
    """A manifest's local path, absolute (symbolic links resolved when they lead somewhere)."""
    path = base / Path(name).expanduser()
    try:
        return str(path.resolve())
    except (RuntimeError, OSError):  # a symbolic link loop: the row's error says so when it runs
        return os.path.abspath(path)


def _positive(text: str, what: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ValueError(f"{what} must be a number; got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{what} must be a positive number; got {text!r}")
    return v


def _row(cells: dict[str, str], line: int, base: Path, methods: Sequence[str],
         schemes: frozenset[str] | None = frozenset()) -> Row:
    """One manifest line checked into a :class:`Row` (ValueError naming the column on a bad entry)."""
    device = cells.get("device", "")
    if not device:
        raise ValueError("device is empty")
    check_device(device)  # what the calibration and the store read back accept
    names = [f.strip() for f in cells.get("files", "").split(";") if f.strip()]
    if not names:
        raise ValueError("files is empty (one or more paths, ';'-separated)")
    for n in names:
        if is_url(n):
            _check_url(n, schemes)
    files = tuple(n if is_url(n) else _local(base, n) for n in names)
    opts: dict[str, Any] = {}
    method = cells.get("method") or DEFAULT_METHOD
    if method not in methods:
        raise ValueError(f"method {method!r} is unknown; choose one of {', '.join(methods)}")
    opts["method"] = method
    opts["model"] = cells.get("model") or None
    if opts["model"] is not None and opts["model"] not in methods[method].models:
        raise ValueError(f"model {opts['model']!r} is not one of {method}'s: {', '.join(methods[method].models)}")
    reader = cells.get("reader") or None
    if reader is not None and reader not in _READERS:
        raise ValueError(f"reader {reader!r} is unknown; choose one of {', '.join(_READERS)}")
    opts["reader"] = reader
    if cells.get("columns"):
        opts["columns"] = tuple(c.strip() for c in cells["columns"].replace(";", ",").split(","))
    for key, allowed in _UNITS.items():
        value = cells.get(key) or None
        if value is not None and value not in allowed:
            raise ValueError(f"{key} {value!r} is unknown; choose one of {', '.join(allowed)}")
        opts[key] = value
    if cells.get("rate"):
        opts["rate"] = _positive(cells["rate"], "rate")
    for key in ("topic", "variable"):
        opts[key] = cells.get(key) or None
    if cells.get("gravity"):
        opts["gravity"] = _positive(cells["gravity"], "gravity")
    opts["recorded_at"] = parse_time(cells.get("recorded_at"), what="recorded_at")[0]
    if cells.get("temperature_c"):
        try:
            t = float(cells["temperature_c"])
        except ValueError:
            raise ValueError(f"temperature_c must be a number of °C; got {cells['temperature_c']!r}") from None
        if not math.isfinite(t):
            raise ValueError(f"temperature_c must be a finite number of °C; got {cells['temperature_c']!r}")
        opts["temperature_c"] = t
    return Row(line=line, device=device, files=files, **opts)


def _manifest_table(path: Path) -> tuple[list[int], list[list[str]]]:
    """The manifest's line numbers and cells, comments and blank lines left out (:func:`read_manifest`)."""
    try:
        check_input_path(path, "manifest")
    except ReaderError as exc:
        if "not found" not in str(exc):
            raise ManifestError(str(exc)) from None
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ManifestError(f"{path}: manifest not found") from None
    except IsADirectoryError:
        raise ManifestError(f"{path}: is a directory; the manifest is a CSV file") from None
    except UnicodeDecodeError as exc:
        raise ManifestError(f"{path}: not a text file (UTF-8): {exc.reason} at byte {exc.start}") from None
    lines = [(i, line) for i, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise ManifestError(f"{path}: the manifest is empty (a header line with device,files and one line per "
                            "recording expected)")
    numbers = [i for i, _ in lines]
    return numbers, list(csv.reader([line for _, line in lines]))


def _check_header(path: Path, header: list[str], number: int) -> None:
    """The header's columns: the required ones present, none unknown or named twice (:func:`read_manifest`)."""
    missing = [c for c in ("device", "files") if c not in header]
    unknown = [h for h in header if h not in MANIFEST_COLUMNS]
    duplicated = sorted({h for h in header if header.count(h) > 1})
    if missing or unknown or duplicated:
        raise ManifestError(
            f"{path}, line {number} (the header): "
            + "; ".join(filter(None, (
                f"missing column(s) {', '.join(missing)}" if missing else "",
                f"unknown column(s) {', '.join(unknown)} (known: {', '.join(MANIFEST_COLUMNS)})" if unknown else "",
                f"column(s) named twice: {', '.join(duplicated)}" if duplicated else ""))))


def _manifest_rows(path: Path, header: list[str], numbers: list[int], table: list[list[str]],
                   schemes) -> tuple[list[Row], list[str]]:
    """The manifest's rows, each checked, and the problems of those that are not (:func:`read_manifest`)."""

    base = path.resolve().parent
    methods = declared()
    rows, problems = [], []
    for number, cells in zip(numbers[1:], table[1:], strict=True):
        if len(cells) > len(header):
            problems.append(f"line {number}: {len(cells)} cells for {len(header)} columns (quote a cell that "
                            "holds a comma)")
            continue
        values = {h: (cells[k].strip() if k < len(cells) else "") for k, h in enumerate(header)}
        try:
            rows.append(_row(values, number, base, methods, schemes))
        except ValueError as exc:
            problems.append(f"line {number}: {exc}")
    return rows, problems


def read_manifest(path: str | Path, *, allow_urls: bool | str | Sequence[str] = False) -> list[Row]:
    """The rows of the manifest CSV ``path``, every entry checked (the columns: :mod:`imucalib.batch`).

    Parameters
    ----------
    path : str or Path
        The manifest.
    allow_urls : bool, str or sequence of str
        URLs in the ``files`` column: refused (default), any (True), or those of the schemes listed
        (``["s3", "gcs"]`` or ``"s3,gcs"``).

    Returns
    -------
    list of Row
        One per line of the manifest, in order, each entry parsed and checked.

    Raises
    ------
    ManifestError
        The file cannot be read, a required column is missing, a column is unknown, or entries are
        invalid: every problem found, each with its line.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.batch import read_manifest
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "run1.csv").write_text("t,ax,ay,az,gx,gy,gz" + chr(10))
    >>> manifest = folder / "manifest.csv"
    >>> _ = manifest.write_text(chr(10).join(["device,files,method,gravity",
    ...                                       "imu1,run1.csv,ellipsoid,9.81"]))
    >>> [(row.line, row.device, row.method, row.gravity) for row in read_manifest(manifest)]
    [(2, 'imu1', 'ellipsoid', 9.81)]
    >>> _ = manifest.write_text(chr(10).join(["device,files,methd", "imu1,run1.csv,ellipsoid"]))
    >>> read_manifest(manifest)
    Traceback (most recent call last):
        ...
    imucalib.batch_manifest.ManifestError: ...manifest.csv, line 1 (the header): unknown column(s) methd ...
    """
    path = Path(path)
    schemes = url_schemes(allow_urls)
    numbers, table = _manifest_table(path)
    header = [h.strip().lower() for h in table[0]]
    _check_header(path, header, numbers[0])
    rows, problems = _manifest_rows(path, header, numbers, table, schemes)
    if problems:
        shown = problems[:20] + ([f"… and {len(problems) - 20} more"] if len(problems) > 20 else [])
        raise ManifestError(f"{path}: {len(problems)} invalid line(s), nothing was run:\n  " + "\n  ".join(shown))
    if not rows:
        raise ManifestError(f"{path}: the manifest has a header but no recordings")
    return rows
