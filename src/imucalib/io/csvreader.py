"""The CSV reader: a delimited text file (or a pandas DataFrame) with time, accelerometer and gyroscope columns.

The table's layout comes from :func:`.tables.split_table`; the rows go straight into the recording's
arrays (:func:`.tables.parse_table`). A logger's prompt lines inside the rows cut them into blocks, one
pose each (:func:`_prompt_blocks`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..recording import ACC_UNITS, GYRO_UNITS, ImucalibWarning, Recording
from . import csvparse, packets
from .columns import FIELDS
from .columns import TEMP as _TEMP
from .columns import map_columns as _map_columns
from .errors import ReaderError
from .stamps import TIME_UNITS, datetime_cells, read_dated, repair_coarse, to_seconds
from .stamps import guess_unit as _infer_time_unit
from .tables import MILLI_UNITS, Table, is_prompt, parse_block, parse_table, split_table, time_column, unit_in

__all__ = ["BLOCK_GAP_STEPS", "read_csv", "read_frame"]


def _prompt_blocks(path: Path, table: Table) -> tuple[np.ndarray, list[list[int]]]:
    """The rows of a file whose rows are cut into blocks by prompt lines, and each block's rows ``[start, stop)``.

    A logger that pauses between poses ("place the sensor, press a key") writes a prompt before each block:
    every block is a pose. Blank lines beside the prompts are part of the boundary; comments are skipped as
    elsewhere. The rows are parsed line by line (such logs are short) and checked as every row is.
    """
    start, end = table.layout.body
    with csvparse.open_binary(path) as f:
        f.seek(start)
        text = f.read(end - start).decode("utf-8", errors="replace")
    lines = text.splitlines()
    blocks: list[list[int]] = []
    parts: list[np.ndarray] = []
    run: list[str] = []
    run_line = table.first_line
    prompts = 0
    rows = 0

    def close() -> None:
        nonlocal rows
        if run:
            body = [ln.replace(",", ".") for ln in run] if table.layout.decimal_comma else run
            parts.append(parse_block(path, body, run_line, table.ncols, table.sep, table.names))
            blocks.append([rows, rows + len(run)])
            rows += len(run)

    for i, line in enumerate(lines):
        if is_prompt(line, table.sep) or not line.strip():
            prompts += bool(line.strip())
            close()
            run = []
            continue
        if line.lstrip().startswith("#"):
            continue
        if not run:
            run_line = table.first_line + i
        run.append(line)
    close()
    if not parts:
        raise ReaderError(f"{path}: no data rows between the prompt lines")
    warnings.warn(f"{path}: {prompts} line{'s' if prompts > 1 else ''} inside the data that are not rows (a logger's "
                  f"prompts) cut the rows into {len(blocks)} blocks: each block is read as one pose",
                  ImucalibWarning, stacklevel=6)
    return np.concatenate(parts), blocks


#: the gap put between blocks whose times restart [median sampling steps]: a gap the integration never crosses
BLOCK_GAP_STEPS = 100


def _block_times(path: Path, t: np.ndarray, blocks: list[list[int]]) -> np.ndarray:
    """The time column of blocks, each block after one whose time it does not follow moved to start
    :data:`BLOCK_GAP_STEPS` median steps after it (each block keeps its own steps); with a note."""
    t = np.array(t, dtype=np.float64)
    steps = np.concatenate([np.diff(t[a:b]) for a, b in blocks])
    step = float(np.median(steps)) if steps.size else 1.0
    moved = 0
    for (_, prev_stop), (a, b) in zip(blocks[:-1], blocks[1:], strict=True):
        if t[a] <= t[prev_stop - 1]:
            t[a:b] += t[prev_stop - 1] + BLOCK_GAP_STEPS * step - t[a]
            moved += 1
    if moved:
        warnings.warn(f"{path}: the time restarts in {moved} of the {len(blocks)} blocks: each such block was put "
                      f"{BLOCK_GAP_STEPS} sampling steps after the one before (each keeps its own time base; the "
                      "gaps between blocks are not used for integration)",
                      ImucalibWarning, stacklevel=6)
    return t



def read_csv(path: Path, columns, acc_unit, gyro_unit, rate, time_unit, frame=None) -> Recording:
    """One CSV file (or the DataFrame ``frame``) as a recording: its table found, its rows parsed straight
    into the recording's arrays, its times in seconds and its units from the options or the header."""
    table = split_table(path, columns) if frame is None else _frame_table(frame)
    dated = datetime_cells(table.first_row) if frame is None else []
    source = table.layout  # where the file's rows lie: apply copies their text (io.writers)
    parsed: dict = {}
    if dated:  # date-time stamps: read as a DataFrame's datetimes are
        frame = read_dated(path, skiprows=table.skipped, sep=table.sep, dated=dated,
                           has_header=table.header is not None and not datetime_cells(table.header))
        table = _frame_table(frame)
        parsed["digest"] = None if csvparse.is_gzip(path) else csvparse.file_digest(source).hexdigest()
    names = table.names
    mapping = _map_columns(path, names, columns, table.header is not None)
    numeric_cols = sorted({j for j in mapping.values() if j is not None})
    sensors = [mapping[f] for f in (*FIELDS[1:], "mx", "my", "mz") if mapping[f] is not None]
    # the samples go straight into the recording's arrays: no copy of the whole table
    blocks, sparse, plan, rows = _row_source(path, table, frame, numeric_cols, sensors)
    acc, gyro, targets = _sensor_arrays(mapping, rows)
    out: dict[int, np.ndarray] = {}
    for f, view in targets.items():
        out.setdefault(mapping[f], view)
    if blocks is not None:
        cols = {j: blocks[0][:, j] for j in range(table.ncols)}
    elif sparse is not None:
        cols = sparse[1]
    elif frame is None:
        cols = parse_table(path, table, numeric_cols, out=out, plan=plan, facts=parsed)
    else:
        cols, stamps = _frame_columns(path, frame, numeric_cols, out)
        if mapping["t"] in stamps and time_unit is None:
            time_unit = "ns"
    for f, view in targets.items():
        if cols[mapping[f]] is not view:  # a column used for two fields
            view[:] = cols[mapping[f]]
    meta = _column_meta(table, mapping)
    tcol = mapping["t"]
    if blocks is not None:
        _shift_blocks(path, cols, tcol, blocks[1], meta)
    if tcol is None:
        t = _rate_times(path, table, mapping, cols, blocks, rows, rate, meta)
    else:
        if rate is not None:
            raise ReaderError(
                f"{path}: the file has a time column ({names[tcol]!r}) and --rate was given; "
                "pass only one (use --columns with '-' for t to ignore the time column)"
            )
        t, acc, gyro, cols = _column_times(path, table, tcol, cols, (acc, gyro), time_unit, parsed, meta)
    au, gu = _sensor_units(table, mapping, acc_unit, gyro_unit)
    (acc, au), (gyro, gu) = _from_milli(path, acc, au, table, mapping["ax"]), _from_milli(path, gyro, gu, table,
                                                                                         mapping["gx"])
    extra, temperature = _other_columns(table, mapping, cols, meta)
    rec = Recording(t=t, acc=acc, gyro=gyro, acc_unit=au, gyro_unit=gu, temperature=temperature,
                    extra=extra, metadata=meta)
    scaled = any(unit_in(table.names[mapping[f]]) in MILLI_UNITS for f in ("ax", "gx")
                 if table.header is not None and mapping[f] is not None)
    # what apply needs to copy the file's own text (io.writers); a units line under the header, or readings
    # scaled from thousandths of a unit: the file is written anew
    if parsed.get("digest") and not csvparse.is_gzip(path) and not table.units_row and not scaled:
        meta["source_layout"] = {**source.to_dict(), "rows": rows, "fingerprint": csvparse.fingerprint(rec),
                                 "digest": parsed["digest"]}
    return rec


def _sensor_arrays(mapping: dict, rows: int):
    """The accelerometer's array, the gyroscope's (None without its columns) and each field's column of them."""
    acc = np.empty((rows, 3))
    gyro = np.empty((rows, 3)) if mapping["gx"] is not None else None
    targets = {f: (acc if f[0] == "a" else gyro)[:, "xyz".index(f[1])] for f in FIELDS[1:]
               if mapping[f] is not None}
    return acc, gyro, targets


def _column_meta(table: Table, mapping: dict) -> dict:
    """The recording's ``metadata`` from its table: the columns each field reads, the names, the separator."""
    names = table.names
    meta: dict = {"columns": {f: (names[j] if j is not None else None) for f, j in mapping.items()
                              if f in FIELDS or j is not None},
                  "column_names": list(names), "header": table.header is not None, "separator": table.sep or " "}
    if table.skipped:
        meta["preamble_lines"] = table.skipped
    return meta


def _shift_blocks(path: Path, cols: dict, tcol: int | None, blocks: list[list[int]], meta: dict) -> None:
    """The prompt-separated blocks in ``meta``; a time that restarts in a block moved after the block before
    (:func:`_block_times`), the times as written kept for a writer."""
    meta["blocks"] = blocks
    if tcol is not None:
        shifted = _block_times(path, cols[tcol], blocks)
        if not np.array_equal(shifted, cols[tcol]):
            meta["time_original"] = cols[tcol]  # what a writer writes back (imucalib.io.writers)
        cols[tcol] = shifted


def _rate_times(path: Path, table: Table, mapping: dict, cols: dict, blocks, rows: int, rate, meta: dict):
    """The times [s] of a table without a time column: a sample counter's, else the rows at ``rate`` (given
    or written in the preamble), blocks of a logger that paused :data:`BLOCK_GAP_STEPS` steps apart."""
    if rate is None and table.rate is not None:
        rate = table.rate
        meta["rate_from"] = "preamble"
    if mapping["n"] is not None:
        t = packets.counter_times(path, cols[mapping["n"]], table.names[mapping["n"]], rate)
    elif rate is None:
        raise ReaderError(f"{path}: no time column found; pass --rate HZ (the sampling rate)")
    else:  # blocks of a logger that paused: BLOCK_GAP_STEPS steps between them, as between files
        t = (np.arange(rows) + (0 if blocks is None else BLOCK_GAP_STEPS * np.repeat(
            np.arange(len(blocks[1])), [b - a for a, b in blocks[1]]))) / rate
    meta["time_unit"] = None
    return t


def _row_source(path: Path, table: Table, frame, numeric_cols: list[int], sensors: list[int]):
    """Where :func:`read_csv` takes the rows from: the blocks between a logger's prompts, the rows of a table of
    several packets (sparse), or a plan of the file's chunks (else a DataFrame's rows); and their number."""
    blocks = _prompt_blocks(path, table) if frame is None and table.prompts else None
    sparse = (packets.sparse_rows(path, table.layout, table.names, numeric_cols, sensors) if frame is None
              and blocks is None and packets.has_empty_cells(table.sample, table.sep, sensors) else None)
    plan = csvparse.plan(table.layout) if frame is None and blocks is None and sparse is None else None
    rows = (plan.rows if plan is not None else len(frame) if frame is not None else sparse[0] if sparse is not None
            else blocks[0].shape[0])
    if rows == 0:
        raise ReaderError(f"{path}: no data rows after the header")
    return blocks, sparse, plan, rows


def _column_times(path: Path, table: Table, tcol: int, cols: dict, sensors: tuple, time_unit, parsed: dict,
                  meta: dict):
    """The times [s] from the time column (coarse stamps repaired, its unit given, written or inferred), and
    the sensors' arrays and columns without the rows the repair dropped."""
    acc, gyro = sensors
    names = table.names
    raw_t, offset = time_column(cols[tcol])
    rep = repair_coarse(path, raw_t, [acc] + ([gyro] if gyro is not None else []), table.first_line, names[tcol])
    raw_t = rep.t
    if rep.keep is not None:  # repeated rows dropped: every column with them
        acc, gyro = acc[rep.keep], (gyro[rep.keep] if gyro is not None else None)
        cols = {j: c[rep.keep] for j, c in cols.items()}
        parsed.pop("digest", None)  # the rows are no longer the file's: a writer writes them anew
    unit = time_unit or unit_in(names[tcol]) if table.header is not None else time_unit
    if unit not in TIME_UNITS:
        unit = time_unit or _infer_time_unit(raw_t, path, names[tcol])
    t = to_seconds(raw_t, unit, meta)
    if offset:
        meta["t0"] = offset
        meta["time_relative"] = True
    return t, acc, gyro, cols


def _sensor_units(table: Table, mapping: dict, acc_unit, gyro_unit) -> tuple[str, str]:
    """The accelerometer's and gyroscope's units: the option's, else the header's, else counts."""
    has_header, has_gyro = table.header is not None, mapping["gx"] is not None
    au = acc_unit or (unit_in(table.names[mapping["ax"]]) if has_header else None) or "counts"
    gu = gyro_unit or (unit_in(table.names[mapping["gx"]]) if has_header and has_gyro else None) or "counts"
    if au not in ACC_UNITS and au not in MILLI_UNITS:
        au = "counts"
    if gu not in GYRO_UNITS and gu not in MILLI_UNITS:
        gu = "counts"
    return au, gu


def _from_milli(path: Path, values, unit: str, table: Table, column) -> tuple:
    """``values`` in thousandths of a unit (``mg``, ``mdps``, ``mrad/s``: :data:`.tables.MILLI_UNITS`) taken in
    the unit, with a note; other units as they are."""
    if unit not in MILLI_UNITS or values is None:
        return values, unit
    base, factor = MILLI_UNITS[unit]
    values *= factor
    warnings.warn(f"{path}: column {table.names[column]!r} is in {unit}: its readings are taken in {base} "
                  f"(× {factor:g})", ImucalibWarning, stacklevel=5)
    return values, base


def _other_columns(table: Table, mapping: dict, cols: dict, meta: dict):
    """The columns no field reads (``extra``) and the temperature, a column the header names so or a packet's."""
    names = table.names
    used = {j for j in mapping.values() if j is not None}
    extra, temperature = packets.mapped_others(mapping, names, cols, meta)
    for j, name in enumerate(names):
        col = cols.get(j)
        if j in used or col is None or (table.trailing and j == table.ncols - 1):
            continue  # read as a field, not read (another packet's), or the empty cell after a trailing separator
        if temperature is None and table.header is not None and _TEMP.match(name) and col.dtype.kind == "f":
            temperature = col
            meta["temperature_column"] = name
        extra[name if name not in extra else f"{name} (column {j + 1})"] = col
    return extra, temperature


def read_frame(frame, reader, columns, acc_unit, gyro_unit, rate, variable, time_unit, topic) -> Recording:
    """A DataFrame read as a CSV file whose header is the frame's column names."""
    label = Path("DataFrame")
    for name, value, allowed in (("accelerometer", acc_unit, ACC_UNITS), ("gyroscope", gyro_unit, GYRO_UNITS),
                                 ("time", time_unit, tuple(TIME_UNITS))):
        if value is not None and value not in allowed:
            raise ReaderError(f"unknown {name} unit {value!r}; use one of {', '.join(allowed)}")
    if rate is not None and not (np.isfinite(rate) and rate > 0):
        raise ReaderError(f"rate must be a positive number of Hz; got {rate!r}")
    ignored = [n for n, v in (("variable", variable), ("topic", topic)) if v is not None]
    if reader not in (None, "csv") or ignored:
        raise ReaderError(f"a DataFrame is read as a table (the csv reader); {', '.join(ignored) or 'reader'} "
                          "cannot be set")
    rec = read_csv(label, columns, acc_unit, gyro_unit, rate, time_unit, frame=frame)
    rec.metadata["reader"] = "dataframe"
    return rec


def _frame_table(frame) -> Table:
    names = [str(c).strip() for c in frame.columns]
    return Table(names, 1, ",", len(names), None, [])


def _frame_columns(label: Path, frame, required: Sequence[int], out: dict[int, np.ndarray]
                   ) -> tuple[dict[int, np.ndarray], set[int]]:
    """The frame's columns as arrays (numbers, int64 for integers and datetimes, or text) and the datetime ones.

    ``required`` columns must hold finite numbers (else a :class:`ReaderError` naming the row and column).
    """
    names = [str(c).strip() for c in frame.columns]
    cols: dict[int, np.ndarray] = {}
    stamps: set[int] = set()
    for j, name in enumerate(names):
        series = frame.iloc[:, j]
        kind = series.dtype.kind
        if kind in "Mm":  # datetimes and durations: integer nanoseconds
            values = series.to_numpy().astype("datetime64[ns]" if kind == "M" else "timedelta64[ns]")
            cols[j] = values.view(np.int64)
            stamps.add(j)
            if np.any(np.isnat(values)):
                i = int(np.nonzero(np.isnat(values))[0][0])
                raise ReaderError(f"{label}: row {i + 1}, {name}: a missing time (NaT); fix or remove the row")
            continue
        if kind in "iu" and j not in out:
            ints = series.to_numpy().astype(np.int64)
            if ints.size and np.abs(ints).max() >= 10 ** (csvparse.INT_DIGITS - 1):  # as for a CSV file's cells
                cols[j] = ints
                continue
        if kind in "fiub":
            values = series.to_numpy(dtype=np.float64)
        elif j in required:
            values = np.empty(len(series))
            for i, cell in enumerate(series.tolist()):
                try:
                    values[i] = float(cell)
                except (TypeError, ValueError):
                    raise ReaderError(f"{label}: row {i + 1}, {name}: {cell!r} is not a number; fix or remove "
                                      "the row (imucalib never skips rows)") from None
        else:
            cols[j] = series.to_numpy().astype(str)
            continue
        if j in required and not np.all(np.isfinite(values)):
            i = int(np.nonzero(~np.isfinite(values))[0][0])
            raise ReaderError(f"{label}: row {i + 1}, {name}: {values[i]} is not finite (NaN or inf); fix or "
                              "remove the row (imucalib never skips rows)")
        if j in out:
            out[j][:] = values
            values = out[j]
        cols[j] = values
    return cols, stamps
