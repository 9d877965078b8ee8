"""Delimited text tables: where a file's table starts, its separator, header and units, and its rows as numbers.

:func:`split_table` finds a file's preamble, header (with a line of units under it), separator and the
lines where its rows lie from the file's head and last line; :func:`parse_table` parses the rows a chunk
at a time (:mod:`.csvparse`), and :func:`parse_block` a few lines, naming the first bad cell. Line
numbers are 1-based, as an editor shows them.
"""

from __future__ import annotations

import dataclasses
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..recording import ImucalibWarning
from . import csvparse
from .columns import PATTERNS as _PATTERNS
from .columns import TEMP as _TEMP
from .columns import TIME as _TIME
from .columns import not_number as _not_number
from .errors import ReaderError

__all__ = ["Table", "head_names", "is_prompt", "line_cells", "names_sensor_columns", "parse_block", "parse_table",
           "sensors_named", "sniff_separator", "split_table", "time_column", "unit_in", "MILLI_UNITS"]


def parse_block(path: Path, lines: list[str], first_line: int, ncols: int | None,
                 sep: str | None, names: Sequence[str] | None) -> np.ndarray:
    """Parse text rows into a float array; on failure find the first bad cell."""
    text = "\n".join(lines)
    separators_ok = True
    if sep not in (None, " "):
        # an empty cell would vanish in the whitespace parse: count the separators first
        separators_ok = ncols is not None and text.count(sep) == (ncols - 1) * len(lines)
        text = text.replace(sep, " ")
    try:
        if not separators_ok:
            raise ValueError("separator count")
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # numpy warns (not raises) when it stops at a bad cell
            flat = np.fromstring(text, dtype=np.float64, sep=" ")  # C parser; a bad cell → slow path
        if ncols is not None and flat.size == ncols * len(lines):
            data = flat.reshape(len(lines), ncols)
            if np.all(np.isfinite(data)):
                return data
    except (ValueError, DeprecationWarning):
        pass
    # slow path: locate the first problem precisely
    rows = []
    for i, line in enumerate(lines):
        cells = line.split(sep) if sep not in (None, " ") else line.split()
        cells = [c.strip() for c in cells]
        lineno = first_line + i
        if ncols is not None and len(cells) != ncols:
            raise ReaderError(
                f"{path}: line {lineno}: expected {ncols} values, found {len(cells)} "
                f"({line.strip()[:80]!r}); every row needs the same columns"
            )
        values = []
        for j, cell in enumerate(cells):
            col = names[j] if names is not None and j < len(names) else f"column {j + 1}"
            try:
                v = float(cell)
            except ValueError:
                raise ReaderError(
                    f"{path}: line {lineno}, {col}: {cell!r} is not a number; fix or remove "
                    "the row (imucalib never skips rows)"
                ) from None
            if not np.isfinite(v):
                raise ReaderError(
                    f"{path}: line {lineno}, {col}: {cell!r} is not finite (NaN or inf); "
                    "fix or remove the row (imucalib never skips rows)"
                )
            values.append(v)
        rows.append(values)
    return np.array(rows, dtype=np.float64)



#: thousandths of a unit, as vendors' logs write them: the unit the readings are taken in and the factor to it
MILLI_UNITS = {"mg": ("g", 1e-3), "mdps": ("deg/s", 1e-3), "mrad/s": ("rad/s", 1e-3)}


def unit_in(name: str) -> str | None:
    """A unit written in a column name: ``[m/s^2]``, ``(dps)``, ``_ms``, ``[mg]`` … (:data:`MILLI_UNITS`)."""
    m = re.search(r"[\[\(]\s*([^\]\)]+?)\s*[\]\)]", name)
    tail = m.group(1) if m else re.split(r"[_\s]", name)[-1]
    u = tail.strip().lower().replace(" ", "").replace("²", "^2")
    table = {
        "s": "s", "sec": "s", "ms": "ms", "us": "us", "µs": "us", "ns": "ns",
        "g": "g", "m/s^2": "m/s^2", "m/s2": "m/s^2", "ms^-2": "m/s^2", "ms-2": "m/s^2",
        "deg/s": "deg/s", "dps": "deg/s", "°/s": "deg/s", "rad/s": "rad/s", "rads^-1": "rad/s",
        "rad/sec": "rad/s", "counts": "counts", "lsb": "counts", "raw": "counts",
        "mg": "mg", "mdps": "mdps", "mdeg/s": "mdps", "m°/s": "mdps", "mrad/s": "mrad/s",
    }
    return table.get(u)


def sniff_separator(line: str) -> str | None:
    for sep in (";", "\t"):  # numbers with decimal commas, separated by semicolons or tabs (text cells too)
        if sep in line and "," in line:
            cells = line.split(sep)
            numbers = sum(not _not_number(c.strip().strip('"').replace(",", ".")) for c in cells)
            if numbers > len(cells) / 2 and any(_DECIMAL_COMMA.match(c.strip()) for c in cells):
                return sep
    for sep in (",", ";", "\t"):
        if sep in line:
            return sep
    return None  # whitespace


def line_cells(line: str, sep: str | None) -> list[str]:
    return [c.strip() for c in (line.split(sep) if sep else line.split())]


_RATE = re.compile(
    r"(?:^|[,;:#%\t])\s*(?:fs|f_s|odr|rate|data[\s_]?rate|output[\s_]?data[\s_]?rate|"
    r"sampl(?:e|ing)[\s_]?(?:rate|frequency|freq)|samplerate|frequency)\s*(?:[\[\(]\s*(k?hz)\s*[\]\)])?"
    r"\s*[,;:=\t]\s*\"?\s*([0-9]+(?:\.[0-9]*)?(?:[eE][+-]?[0-9]+)?)\s*(k?hz)?",
    re.I,
)


def _preamble_rate(lines: Sequence[str]) -> float | None:
    """A sampling rate [Hz] written in preamble lines (``Fs,100``, ``sample rate [Hz],100``, ``ODR: 1 kHz`` …)."""
    for line in lines:
        m = _RATE.search(line.strip())
        if m:
            value = float(m.group(2))
            unit = (m.group(1) or m.group(3) or "hz").lower()
            value *= 1000.0 if unit == "khz" else 1.0
            if np.isfinite(value) and value > 0:
                return value
    return None


def sensors_named(cells: Sequence[str]) -> set[str]:
    """The sensors (``acc``, ``gyro``) whose three axes a header names."""
    return {kind for kind, pat in _PATTERNS.items() if sum(bool(pat.match(c.strip())) for c in cells) >= 3}


def names_sensor_columns(cells: Sequence[str]) -> bool:
    hits = sum(bool(_TIME.match(c) or any(p.match(c) for p in _PATTERNS.values())) for c in cells)
    return hits >= 3


def _table_start(lines: list[str]) -> int:
    """Index of the first line of the table (the header or the first row) after a preamble, 0 when none.

    The table's width is that of its last line. Leading lines of another width
    (``key,value`` pairs, free text, comments) are a preamble, provided they do
    not themselves look like a header naming sensor columns (a header of the
    wrong width stays an error) and the table starts in the first half of the file.
    """
    if len(lines) < 3:
        return 0
    last = next((ln for ln in reversed(lines) if not is_prompt(ln, sniff_separator(ln))), lines[-1])
    sep = sniff_separator(last)  # the table's width: its last row's (a logger's prompt may come after it)
    width = len(line_cells(last, sep))
    if width < 2 or len(line_cells(lines[0], sep)) == width:
        return 0
    for k in range(1, len(lines) // 2 + 1):
        if len(line_cells(lines[k], sep)) == width and len(line_cells(lines[k + 1], sep)) == width:
            if any(names_sensor_columns([c.strip('"\'') for c in line_cells(ln, sep)]) for ln in lines[:k]):
                return 0
            return k
    return 0


@dataclass
class Table:
    """A delimited file's parts (line numbers are 1-based) and where its rows lie in it (:class:`.csvparse.Layout`)."""

    header: list[str] | None
    first_line: int
    sep: str | None
    ncols: int
    layout: csvparse.Layout | None  # None for a DataFrame
    first_row: list[str]
    skipped: int = 0
    rate: float | None = None
    prompts: bool = False  # lines with no number inside the rows (a logger's prompts): block boundaries
    sample: list[str] = dataclasses.field(default_factory=list)  # the first rows, as text
    trailing: bool = False  # a separator ends every line: the last column is the empty cell after it
    units_row: bool = False  # a line of units under the header (read into the names; the file is written anew)

    @property
    def names(self) -> list[str]:
        return self.header or [f"column {j + 1}" for j in range(self.ncols)]

    def split(self, line: str) -> list[str]:
        return line_cells(line, self.sep)


def split_table(path: Path, columns: Sequence[str] | None = None) -> Table:
    """Find ``path``'s preamble (skipped with a note), header and rows from its first lines and its last.

    Only the head of the file (1 MB) and its last line are read here; the rows
    are parsed by :func:`parse_table`, a chunk at a time. A first line that
    is a logger's prompt rather than a header (:func:`_prompt_not_header`) is
    part of the preamble even when it has as many cells as the rows.
    """
    head = csvparse.read_head(path)
    if not head.lines:
        raise ReaderError(f"{path}: empty file")
    lines = head.lines if head.complete else [*head.lines, head.last]
    start = _table_start(lines)
    if start + 2 < len(lines) and _prompt_not_header(lines, start, columns):
        start += 1  # a logger's first prompt, as wide as the rows by chance: skipped as a preamble line
    sep = sniff_separator(lines[start])
    header, row0, units = _header_of(head.lines, lines[start], start, sep)
    first_line = row0 + 1
    if row0 >= len(head.lines):
        raise ReaderError(f"{path}: no data rows after the header" if head.complete
                          else f"{path}: no table in the first megabyte of the file")
    row = head.lines[row0]
    # semicolons or tabs between cells, commas as decimal marks
    decimal_comma = sep in (";", "\t") and any(_DECIMAL_COMMA.match(c) for c in line_cells(row, sep))
    first_row = csvparse.split_cells(row.replace(",", ".") if decimal_comma else row, sep)
    if header and len(first_row) == len(header) + 1 and first_row[-1] == "":
        header.append("")  # the rows end with a separator, the header does not
    ncols = len(header) if header else len(first_row)
    hdr = None if header is None else (head.offsets[start], head.offsets[start + 1] - 1)
    layout = csvparse.Layout(path, hdr, (head.offsets[row0], head.end), first_line, sep, decimal_comma, ncols,
                             head.size, head.mtime_ns)
    trailing = first_row[-1:] == [""] and (header is None or header[-1] == "") and sep not in (None, " ")
    table = Table(header, first_line, sep, ncols, layout, first_row, skipped=start, rate=_preamble_rate(lines[:start]),
                  units_row=units is not None,
                  sample=head.lines[row0:row0 + 1000], trailing=trailing,
                  prompts=any(is_prompt(ln, sep) for ln in head.lines[row0:] + ([] if head.complete else
                                                                                 [head.last])))
    if units is not None:
        warnings.warn(f"{path}: line {first_line - 1} gives the columns' units ({', '.join(u for u in units if u)}): "
                      "read as the units of the names above it", ImucalibWarning, stacklevel=4)
    if start:
        what = "" if table.rate is None else f" (they give a sampling rate of {table.rate:g} Hz)"
        warnings.warn(f"{path}: skipped {start} line{'s' if start > 1 else ''} before the "
                      f"{'header' if header is not None else 'data'}{what}", ImucalibWarning, stacklevel=4)
    return table


def _header_of(lines: Sequence[str], line: str, start: int, sep: str | None):
    """The header in ``line`` (``lines[start]``), None when its cells are all numbers; the index of the first
    row; and the cells of a line of units under the names (read into them), else None."""
    first = line_cells(line, sep)
    has_header = any(_not_number(c) for c in first)
    header = [c.strip('"\'').strip() for c in first] if has_header else None
    if header and re.match(r"#\s", header[0]):  # numpy.savetxt's header="…" writes "# " before the names
        header[0] = header[0][1:].strip()
    row0 = start + 1 if has_header else start
    units = _units_row(lines, row0, sep, header) if header else None
    if units is not None:  # a line of units under the names (a vendor's export): read as the names' units
        header = [f"{h} [{u}]" if u else h for h, u in zip(header, units, strict=True)]
        row0 += 1
    return header, row0, units


#: a cell of a units line: a short unit (``s``, ``ms``, ``g``, ``m/s^2``, ``m/s²``, ``deg/s``, ``°/s``, ``[counts]``)
_UNIT_CELL = re.compile(r"^[\[\(]?[A-Za-zµ°/^²0-9.\- ]{1,12}[\]\)]?$")


def _units_row(lines: Sequence[str], row: int, sep: str | None, header: list[str]) -> list[str] | None:
    """The cells of ``lines[row]`` when it is a line of units under the header (every cell a short unit or empty,
    as many as the names, rows of numbers after it), else None."""
    if row + 1 >= len(lines):
        return None
    cells = [c.strip('"\'').strip() for c in line_cells(lines[row], sep)]
    after = [c for c in line_cells(lines[row + 1], sep) if c.strip()]
    if (len(cells) != len(header) or not any(cells) or not after or any(_not_number(c) for c in after)
            or not all(_not_number(c) and _UNIT_CELL.match(c) for c in cells if c)):
        return None
    return [c.strip("[]()") for c in cells]


_DECIMAL_COMMA = re.compile(r'^"?[+-]?\d*,\d+(?:[eE][+-]?\d+)?"?$')
#: how a line of prose starts or ends: a run of marks (``>>>``, ``---``, ``***``), a sentence's last mark
_PROSE = re.compile(r"^[^\w\s\"'#\[\(]{2,}|[.!?:…]$")


def _prompt_not_header(lines: Sequence[str], start: int, columns: Sequence[str] | None) -> bool:
    """Whether the line ``lines[start]`` before rows of numbers is a logger's prompt, not the rows' header.

    A header names columns; a prompt (``>>> Pose 1: gathering data for 10s...``) is text that happens to split
    into as many cells as the rows have. It is a prompt when none of its cells is a column name this reader
    knows (time, accelerometer, gyroscope, temperature) or one ``--columns`` gives, the next line is a row
    (numbers), and it reads as prose (starts with a run of marks, ends like a sentence, or has a cell of three
    words or more) or begins with the word a prompt line inside the rows begins with (the logger's next
    prompts).
    """
    text = lines[start].strip()
    sep = sniff_separator(lines[start + 1])
    cells = [c.strip('"\'').strip() for c in line_cells(text, sep)]
    if not cells or not _not_number(cells[0]) or any(_not_number(c) for c in line_cells(lines[start + 1], sep)):
        return False
    known = {c.strip().lower() for c in columns or ()}
    if any(_TIME.match(c) or _TEMP.match(c) or any(p.match(c) for p in _PATTERNS.values()) or c.lower() in known
           for c in cells):
        return False
    if _PROSE.search(text) or any(len(c.split()) >= 3 for c in cells):
        return True
    word = cells[0].split()[0]
    return any(ln.strip().startswith(word) for ln in lines[start + 1:] if is_prompt(ln, sep))


def is_prompt(line: str, sep: str | None) -> bool:
    """A line inside the rows that is not a row: a logger's prompt (``>>> Gathering data for 10 seconds...``,
    ``--- pose 2 ---``) or a repeated header — its first cell is not a number, whatever numbers follow (a row
    of numbers always starts with one); a comment (``#``) and a blank line are not prompts."""
    text = line.strip()
    if not text or text.startswith("#"):
        return False
    cells = [c for c in line_cells(text, sep) if c]
    return not cells or _not_number(cells[0].strip('"\'').replace(",", "."))


def parse_table(path: Path, table: Table, required: Sequence[int], *, others: bool = True,
                 out: dict[int, np.ndarray] | None = None, plan: csvparse.Plan | None = None,
                 facts: dict | None = None) -> dict[int, np.ndarray]:
    """The rows' columns as arrays (:func:`.csvparse.parse`): ``required`` ones numbers, checked; the others
    (when ``others``) numbers or text as their cells are; int64 for long integers (ns stamps, IDs).
    ``facts``, when given, receives the parse's facts (its ``digest`` of the bytes parsed)."""
    kinds: list[str | None] = csvparse.column_kinds(table.first_row, False)
    if len(kinds) != table.ncols:  # the first row's width is wrong: the line-by-line parser says so
        kinds = (kinds + ["float"] * table.ncols)[:table.ncols]
    for j in range(table.ncols):
        if j in required and kinds[j] == "text":
            kinds[j] = "float"  # the parse names the bad cell
        elif (j not in required and not others) or (table.trailing and j == table.ncols - 1):
            kinds[j] = None
    cols, parsed = csvparse.parse(table.layout, kinds, table.names, required=required, out=out, plan=plan)
    if facts is not None:
        facts.update(parsed)
    if parsed["comment_lines"]:
        n = parsed["comment_lines"]
        warnings.warn(f"{path}: skipped {n} comment line{'s' if n > 1 else ''} (starting with #) between the rows",
                      ImucalibWarning, stacklevel=4)
    return cols


def time_column(col: np.ndarray) -> tuple[np.ndarray, int]:
    """A time column as floats and an integer offset: long integer stamps (beyond float precision) are taken
    relative to the first one, exactly; other columns are returned as they are, with offset 0."""
    if col.dtype.kind == "i":
        return (col - col[0]).astype(np.float64), int(col[0])
    return col, 0



def head_names(path: Path) -> list[str] | None:
    """The cells of the first line when they name columns (not all numbers), else None."""
    if path.is_dir():
        return None
    with csvparse.open_binary(path) as f:
        line = f.readline(1 << 16).decode("utf-8-sig", errors="replace")
    cells = [c.strip('"\'').strip() for c in line_cells(line, sniff_separator(line))]
    return cells if any(_not_number(c) for c in cells) else None
