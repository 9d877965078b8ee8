"""The readers' entry: :func:`read` checks the inputs and options, picks the format (:func:`guess_reader`) and
hands the files to its reader — generic CSV and DataFrames (:mod:`.csvreader`), imu_tk's two-file text
format (:mod:`.imutk`), phone apps' two-file CSV (:mod:`.phonepair`), MATLAB ``.mat`` (:mod:`.matfile`),
ROS bags (:mod:`.rosbag`), several files as blocks of one recording (:mod:`.fileblocks`) — then checks
the recording against the header and notes units that look wrong.

Every reader returns a :class:`~imucalib.recording.Recording` and reports bad
input with a :class:`ReaderError` naming the file, the line (1-based, as an
editor shows it) and the column, and saying how to fix it. Nothing is silently
dropped: a bad row is an error, never skipped.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path

import numpy as np

from ..recording import ACC_UNITS, GYRO_UNITS, ImucalibWarning, Recording
from . import inputs
from .csvreader import read_csv, read_frame
from .errors import ReaderError
from .fileblocks import read_file_blocks
from .imutk import read_imutk
from .matfile import read_mat
from .phonepair import phone_specs, read_phone
from .stamps import TIME_UNITS, note_held_samples
from .tables import head_names, names_sensor_columns, sensors_named, unit_in

# ROS bags (.rosbag) and phone apps' files (.phone) are read by modules imported when such a file is met

__all__ = ["READERS", "ReaderError", "guess_reader", "is_frame", "read"]

READERS = ("csv", "imutk", "mat", "phone", "rosbag")


# ------------------------------------------------------------------ entry
def read(
    paths: str | Path | Sequence[str | Path],
    *,
    reader: str | None = None,
    columns: Sequence[str] | None = None,
    acc_unit: str | None = None,
    gyro_unit: str | None = None,
    rate: float | None = None,
    variable: str | None = None,
    time_unit: str | None = None,
    topic: str | None = None,
    progress=None,
) -> Recording:
    """Read a recording.

    Parameters
    ----------
    paths : path, sequence of paths, or pandas.DataFrame
        One CSV or MAT file, two imu_tk files (accelerometer, then gyroscope),
        a phone app's accelerometer and gyroscope files (phyphox, Sensor Logger:
        see :mod:`.phone`), or one ROS bag (a ROS 1 ``.bag``, a ROS 2 bag
        directory, an ``.mcap``); or a pandas DataFrame, read as a CSV file
        with its column names as the header (same names, units and options;
        a datetime64 time column is taken in nanoseconds).
    reader : {"csv", "imutk", "mat", "phone", "rosbag"}, optional
        The format; guessed from the file(s) when omitted (:func:`guess_reader`).
    columns : sequence of str, optional
        Column names (or 0-based indices as strings) in the order
        ``t, ax, ay, az, gx, gy, gz``; ``"-"`` for ``t`` means no time column.
    acc_unit : {"counts", "g", "m/s^2"}, optional
        Accelerometer unit (default: from the header, else counts).
    gyro_unit : {"counts", "deg/s", "rad/s"}, optional
        Gyroscope unit (default: from the header, else counts).
    rate : float, optional
        Sampling rate [Hz]; required when there is no time column, refused when
        there is one.
    variable : str, optional
        Name of the matrix in a MATLAB file.
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of the time column (default: from the header, else inferred from
        the median step: see :func:`_infer_time_unit`).
    topic : str, optional
        ROS bags: the ``sensor_msgs/Imu`` topic, when the bag has several.
    progress : callable, optional
        ``progress(done, total)`` while a long input is read (ROS bags: messages).

    Returns
    -------
    Recording
        Times [s], the accelerometer and gyroscope readings in the units taken, the temperature and any
        other columns (``extra``), and ``metadata`` (reader, units, source file).

    Raises
    ------
    ReaderError
        A file that cannot be read as this reader has it (no such file, no table, a column missing, a
        unit or option that does not apply), saying what is wrong and which option fixes it.

    Notes
    -----
    Xsens MT Manager text exports (``//`` comment lines, then ``PacketCounter
    SampleTimeFine … Acc_X … Gyr_Z``) are recognised from their header:
    ``SampleTimeFine`` counts 100 µs ticks, the readings are in m/s² and rad/s.
    A unit option that contradicts a unit written in the header wins over it,
    with a warning saying which of the two the accelerometer's magnitude
    supports; with no unit given or written, readings that look like m/s², g, rad/s or
    deg/s are still taken as counts, with a note saying so.

    Examples
    --------
    A small CSV file with a header (time, accelerometer in g, gyroscope in deg/s):

    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.io import read
    >>> path = Path(tempfile.mkdtemp()) / "imu.csv"
    >>> _ = path.write_text(chr(10).join(["t,ax,ay,az,gx,gy,gz",
    ...     "0.00,0.01,-0.02,1.00,0.1,0.0,-0.1",
    ...     "0.01,0.02,-0.01,1.01,0.0,0.1,-0.1", "0.02,0.00,-0.02,0.99,0.1,0.1,0.0"]))
    >>> rec = read(path, acc_unit="g", gyro_unit="deg/s")
    >>> rec.acc.shape, rec.acc_unit, rec.gyro_unit, round(rec.rate)
    ((3, 3), 'g', 'deg/s', 100)
    >>> read(path.with_name("missing.csv"))
    Traceback (most recent call last):
        ...
    imucalib.io.errors.ReaderError: .../missing.csv: file not found
    """
    if is_frame(paths):
        return read_frame(paths, reader, columns, acc_unit, gyro_unit, rate, variable, time_unit, topic)
    paths = _input_paths(paths)
    _check_units(acc_unit, gyro_unit, time_unit, rate)
    reader = _chosen_reader(paths, reader)
    if reader in ("csv", "mat") and len(paths) > 1:  # one file per pose (per face): blocks of one recording
        return read_file_blocks(paths, reader, columns, acc_unit, gyro_unit, rate, variable, time_unit, topic,
                                read=read)
    _check_options(paths, reader, columns, acc_unit, gyro_unit, rate, variable, time_unit, topic)
    paths = _pair_order(paths, reader)
    rec = _format_reader(paths, reader, columns, acc_unit, gyro_unit, rate, variable, time_unit, topic, progress)()
    return _finished(paths, reader, rec, acc_unit, gyro_unit, time_unit)


def _input_paths(paths: str | Path | Sequence[str | Path]) -> list[Path]:
    """The input paths, each an existing file or a ROS 2 bag directory (:func:`read`)."""
    if isinstance(paths, str | Path):
        paths = [paths]
    paths = [Path(p) for p in paths]
    if not paths:
        raise ReaderError("no data file given")
    for p in paths:
        inputs.check_input_path(p)
        if p.is_dir() and not _is_rosbag(p):
            raise ReaderError(f"{p}: is a directory, not a data file (a ROS 2 bag directory holds metadata.yaml)")
    return paths


def _check_units(acc_unit, gyro_unit, time_unit, rate) -> None:
    """The unit options are units this package knows, the rate a positive number (:func:`read`)."""
    if acc_unit is not None and acc_unit not in ACC_UNITS:
        raise ReaderError(f"unknown accelerometer unit {acc_unit!r}; use one of {', '.join(ACC_UNITS)}")
    if gyro_unit is not None and gyro_unit not in GYRO_UNITS:
        raise ReaderError(f"unknown gyroscope unit {gyro_unit!r}; use one of {', '.join(GYRO_UNITS)}")
    if time_unit is not None and time_unit not in TIME_UNITS:
        raise ReaderError(f"unknown time unit {time_unit!r}; use one of {', '.join(TIME_UNITS)}")
    if rate is not None and not (np.isfinite(rate) and rate > 0):
        raise ReaderError(f"rate must be a positive number of Hz; got {rate!r}")


def _chosen_reader(paths: Sequence[Path], reader: str | None) -> str:
    """The reader given, checked, or the one :func:`guess_reader` finds."""
    if reader is None:
        reader = guess_reader(paths)
    if reader not in READERS:
        raise ReaderError(f"unknown reader {reader!r}; use one of {', '.join(READERS)}")
    return reader


def _check_options(paths: Sequence[Path], reader: str, columns, acc_unit, gyro_unit, rate, variable, time_unit,
                   topic) -> None:
    """The number of files the reader takes, text files where it reads text, and only the options it uses."""
    expected = 2 if reader in ("imutk", "phone") else 1
    if len(paths) != expected:
        what = ("two files: the accelerometer file, then the gyroscope file" if expected == 2
                else "one file")
        raise ReaderError(f"the {reader} reader takes {what}; got {len(paths)}")
    if reader in ("csv", "imutk", "phone"):
        for p in paths:
            inputs.check_text(p, gzip_ok=reader == "csv")
    inputs.check_distinct_columns(columns)
    if reader == "rosbag":
        ignored = [name for name, v in (("columns", columns), ("acc_unit", acc_unit), ("gyro_unit", gyro_unit),
                                        ("rate", rate), ("variable", variable), ("time_unit", time_unit))
                   if v is not None]
        if ignored:
            raise ReaderError(f"a ROS bag's sensor_msgs/Imu fixes the fields, units and time; "
                              f"{', '.join(ignored)} cannot be set")
    elif topic is not None:
        raise ReaderError(f"topic applies to ROS bags; the {reader} reader has none")
    elif reader == "phone":
        ignored = [name for name, v in (("columns", columns), ("rate", rate), ("variable", variable))
                   if v is not None]
        if ignored:
            raise ReaderError(f"a phone app's files name their columns and carry their own time; "
                              f"{', '.join(ignored)} cannot be set")


def _pair_order(paths: list[Path], reader: str) -> list[Path]:
    """imu_tk's pair in the order accelerometer, gyroscope: swapped, with a warning, when the headers say so."""
    if reader == "imutk" and [sensors_named(head_names(p) or []) for p in paths] == [{"gyro"}, {"acc"}]:
        warnings.warn(f"{paths[0]} names the gyroscope's axes and {paths[1]} the accelerometer's: read as the "
                      "accelerometer's file, then the gyroscope's", ImucalibWarning, stacklevel=3)
        return [paths[1], paths[0]]
    return paths


def _format_reader(paths: Sequence[Path], reader: str, columns, acc_unit, gyro_unit, rate, variable, time_unit,
                   topic, progress) -> Callable[[], Recording]:
    """The reader of the format, its arguments bound: :func:`read` calls it (a partial adds no frame, so the
    readers' warnings still point at the caller of :func:`read`)."""
    if reader == "rosbag":
        from .rosbag import read_rosbag  # imported when a bag is met (the note at the top): 12 ms at start-up

        return partial(read_rosbag, paths[0], topic=topic, progress=progress)
    if reader == "phone":
        return partial(read_phone, paths, acc_unit, gyro_unit, time_unit)
    if reader == "imutk":
        return partial(read_imutk, paths[0], paths[1], acc_unit, gyro_unit, time_unit)
    if reader == "mat":
        return partial(read_mat, paths[0], columns, acc_unit, gyro_unit, rate, variable, time_unit)
    if columns is None and (xsens := inputs.xsens_header(paths[0])) is not None:
        return partial(inputs.read_xsens, paths[0], xsens, acc_unit, gyro_unit, rate, time_unit, read_csv=read_csv)
    return partial(read_csv, paths[0], columns, acc_unit, gyro_unit, rate, time_unit)


def _finished(paths: Sequence[Path], reader: str, rec: Recording, acc_unit, gyro_unit, time_unit) -> Recording:
    """The recording checked against its header and its magnitudes, with the notes on its units, and
    ``metadata`` saying where it came from (:func:`read`)."""
    acc_unit, gyro_unit, time_unit = _flags_over_header(paths, reader, rec, acc_unit, gyro_unit, time_unit)
    inputs.check_against_header(paths, reader, rec, acc_unit, gyro_unit, time_unit, unit_in=unit_in,
                                phone_specs=phone_specs)
    inputs.check_magnitudes(paths, rec)
    if reader in ("csv", "mat") and len(rec) > 1:
        note_held_samples(paths[0], rec.acc, rec.gyro, rec.rate)
    named = (rec.metadata.get("columns") or {}) if rec.metadata.get("header") else {}
    written = any(unit_in(named.get(f) or "") for f in ("ax", "gx"))  # a header's "[counts]" is an answer
    if acc_unit is None and gyro_unit is None and reader in ("csv", "imutk", "mat") and not written:
        inputs.note_physical_units(paths, rec)
    elif gyro_unit is None and reader in ("csv", "imutk", "mat") and not unit_in(named.get("gx") or ""):
        inputs.note_gyro_unit(paths, rec)
    rec.metadata.setdefault("source", [str(p) for p in paths])
    rec.metadata["reader"] = reader
    return rec


def _written_units(paths: Sequence[Path], reader: str, rec: Recording) -> dict[str, tuple[str, str]]:
    """Field (``ax``, ``gx``, ``t``) → (where, unit) for each unit the file's header writes."""
    written: dict[str, tuple[str, str]] = {}
    if reader == "csv" and rec.metadata.get("header"):
        for field, name in (rec.metadata.get("columns") or {}).items():
            if field in ("ax", "gx", "t") and name is not None and unit_in(name) is not None:
                written[field] = (name, unit_in(name))
    elif reader == "phone":
        for spec in phone_specs(paths) or []:
            if spec.unit is not None:
                field = "ax" if spec.sensor == "acc" else "gx"
                written[field] = (f"{spec.app} {'accelerometer' if field == 'ax' else 'gyroscope'} file", spec.unit)
    return written


def _flags_over_header(paths: Sequence[Path], reader: str, rec: Recording, acc_unit, gyro_unit, time_unit):
    """A unit option that contradicts the header wins, with a warning; the options left to check against it.

    The readers already read the data in the option's unit. For the accelerometer the warning says which
    of the two units the readings' magnitude supports: the median norm of the static-ish samples is g in
    either unit, so about 9.8 in m/s² and about 1 in g.
    """
    given = {"ax": ("--acc-unit", acc_unit), "gx": ("--gyro-unit", gyro_unit), "t": ("--time-unit", time_unit)}
    where_file = ", ".join(map(str, paths)) if reader == "phone" else str(paths[0])
    overridden = set()
    for field, (where, unit) in _written_units(paths, reader, rec).items():
        flag, value = given[field]
        if value is None or value == unit:
            continue
        overridden.add(field)
        told = ""
        if field == "ax" and rec.acc is not None and len(rec):
            norm = float(np.median(np.linalg.norm(rec.acc, axis=1)))
            looks = {"m/s^2": 9.0 <= norm <= 10.6, "g": 0.9 <= norm <= 1.1}
            if looks.get(value):
                told = f"; the readings' median norm, {norm:.3g}, is gravity in {value}: the option is right"
            elif looks.get(unit):
                told = (f"; but the readings' median norm, {norm:.3g}, is gravity in {unit}: the header looks "
                        f"right, drop {flag}")
            elif value in looks:
                told = f"; the readings' median norm, {norm:.3g}, is gravity in neither unit: check the column"
        warnings.warn(f"{where_file}: {flag} {value} overrides the header ({where!r} says {unit}): the readings are "
                      f"taken in {value}{told}", ImucalibWarning, stacklevel=4)
    return tuple(None if f in overridden else given[f][1] for f in ("ax", "gx", "t"))


def _is_rosbag(path: Path) -> bool:
    """:func:`.rosbag.is_rosbag`, its module imported on first use."""
    from .rosbag import is_rosbag  # imported when a folder is met (the note at the top): 12 ms at start-up

    return is_rosbag(path)


def guess_reader(paths: Sequence[Path]) -> str:
    r"""The reader for ``paths``, from their content.

    ``"rosbag"`` for ROS bags, ``"mat"`` for MATLAB files; for two files,
    ``"phone"`` when both headers are a phone app's (phyphox, Sensor Logger:
    :mod:`.phone`), ``"imutk"`` unless both have headers naming sensor
    columns; else ``"csv"`` (several files are then blocks of one recording).

    Parameters
    ----------
    paths : sequence of Path
        The input files (the first one's first 128 bytes tell a MATLAB file; the headers of two tell a
        phone app's pair or imu_tk's).

    Returns
    -------
    str
        One of :data:`READERS`: ``"csv"``, ``"imutk"``, ``"mat"``, ``"phone"`` or ``"rosbag"``.

    Raises
    ------
    OSError
        The first file cannot be opened.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.io import guess_reader
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "imu.csv").write_text(chr(10).join(["t,ax,ay,az", "0.0,0.01,-0.02,1.00"]))
    >>> guess_reader([folder / "imu.csv"])
    'csv'
    >>> # two files without a header: imu_tk's pair
    >>> _ = (folder / "acc.txt").write_text("0.00 102 -55 16420" + chr(10))
    >>> _ = (folder / "gyro.txt").write_text("0.00 3 -1 2" + chr(10))
    >>> guess_reader([folder / "acc.txt", folder / "gyro.txt"])
    'imutk'
    """
    if _is_rosbag(paths[0]):
        return "rosbag"
    with paths[0].open("rb") as f:
        head = f.read(128)
    if head.startswith(b"MATLAB") or (head[:4] in (b"\x00\x00\x00\x00",) and paths[0].suffix == ".mat"):
        return "mat"
    if len(paths) == 2 and phone_specs(paths) is not None:
        return "phone"
    if len(paths) == 2 and not all(names_sensor_columns(head_names(p) or []) for p in paths):
        return "imutk"  # two files without headers naming the sensors: imu_tk's accelerometer and gyroscope
    if len(paths) == 2 and [sensors_named(head_names(p) or []) for p in paths] in ([{"acc"}, {"gyro"}],
                                                                                  [{"gyro"}, {"acc"}]):
        return "imutk"  # a table of the accelerometer's axes and one of the gyroscope's: the same pair
    return "csv"


# ------------------------------------------------------------- DataFrames
def is_frame(obj) -> bool:
    """Whether ``obj`` is a pandas DataFrame (without importing pandas)."""
    return type(obj).__module__.split(".")[0] == "pandas" and hasattr(obj, "columns") and hasattr(obj, "iloc")


