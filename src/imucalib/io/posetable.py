"""Tables of averaged poses: one row per orientation, as MATLAB's ``accelcal`` and many lab scripts keep them.

A pose table holds, for each static orientation, the accelerometer's mean
``ax ay az`` and optionally the gyroscope's mean ``gx gy gz``, the number of
samples averaged ``n`` and their standard deviation ``σ`` (one column, or one
per accelerometer axis). It is not a recording: it has no time and no motion
between the poses, so only the accelerometer can be calibrated from it
(:func:`imucalib.methods._pose_table.calibrate_pose_table`).

Layouts read (:func:`read_pose_table`):

* separated by commas, semicolons, tabs or blanks; lines starting with ``#``
  or ``%`` (MATLAB) are comments; a column of text (a pose's name, ``XP``,
  ``+z up``) is kept as the poses' labels;
* with a header naming the columns (``ax``, ``acc_x``, ``accel_x [g]``, ``gx``,
  ``gyro_x (deg/s)``, ``n``/``count``/``samples``, ``sigma``/``std``/``σ``, or
  ``std_ax``/``ax_std``… per axis), the units in brackets or parentheses;
* or without one, the numbers in the order ``ax ay az [gx gy gz] [n] [σ or σx σy σz]``
  (a fourth column of whole numbers ≥ 1 is ``n``, else the gyroscope).

The accelerometer's unit is the one given (``acc_unit``), else the header's,
else recognised from the poses' norms (a median ``|a|`` near 1: g; near 9.8:
m/s²; else raw counts), with a note saying so (:attr:`PoseTable.notes`).
:func:`write_pose_table` writes the table again with calibrated columns appended.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..constants import STANDARD_GRAVITY
from .atomic import atomic_write
from .errors import ReaderError
from .jsontext import SmallFileError, read_small_text

__all__ = ["ACC_UNITS", "GYRO_UNITS", "MAX_TABLE_BYTES", "PoseTable", "TableText", "guess_acc_unit",
           "read_pose_table", "write_pose_table"]

#: the largest pose table read (a table of thousands of poses is a few hundred kB)
MAX_TABLE_BYTES = 16 << 20
#: the accelerometer and gyroscope units a pose table may be in (those of :func:`imucalib.io.read`)
ACC_UNITS = ("counts", "g", "m/s^2")
GYRO_UNITS = ("counts", "deg/s", "rad/s")
#: a median pose norm within these bounds is read as g, or as m/s² (±20 %: a bias of a tenth of g and more
#: still falls inside, and no unit's nominal norm lies within another's bounds)
_G_NORM = (0.8, 1.2)
_SI_NORM = (0.8 * STANDARD_GRAVITY, 1.2 * STANDARD_GRAVITY)

_FIELDS = ("ax", "ay", "az", "gx", "gy", "gz", "n", "sigma", "sigma_x", "sigma_y", "sigma_z")


@dataclass(frozen=True)
class TableText:
    """Where a pose table's rows lie in the text it was read from, to write it again with columns appended."""

    lines: tuple[str, ...]  # every line, its line end kept
    header: int | None  # the header's line, or None
    rows: tuple[int, ...]  # the line of each pose, in order
    sep: str | None  # the separator, None for blanks
    names: tuple[str, ...]  # each column's field (``ax`` …, ``label``) or ``""`` for one not read


@dataclass(frozen=True)
class PoseTable:
    """Averaged static poses: the accelerometer's mean of each, and what the table says of its noise.

    Attributes
    ----------
    acc : (M, 3) ndarray
        The accelerometer's mean in each pose, in ``acc_unit``.
    acc_unit : str
        One of :data:`ACC_UNITS`.
    gyro : (M, 3) ndarray or None
        The gyroscope's mean in each pose, in ``gyro_unit``.
    gyro_unit : str or None
        One of :data:`GYRO_UNITS` where there is a gyroscope.
    n : (M,) ndarray or None
        The samples averaged in each pose.
    acc_sigma : (M, 3) ndarray or None
        The standard deviation of one accelerometer sample about each pose's mean, per axis (one ``σ``
        column is taken for the three axes), in ``acc_unit``.
    labels : tuple of str or None
        The poses' names, from a column of text.
    notes : tuple of str
        How the table was read where it did not say (a unit recognised from the norms, columns left out).
    source : TableText or None
        The text it was read from (:func:`write_pose_table` keeps its layout).

    Examples
    --------
    A table is read from a file (:func:`read_pose_table`) or made from arrays, here 14 poses of an
    accelerometer reading 2 % high with a bias of 0.03 g:

    >>> import itertools
    >>> import numpy as np
    >>> from imucalib.io.posetable import PoseTable
    >>> corners = np.array(list(itertools.product((-1, 1), repeat=3))) / np.sqrt(3)
    >>> up = np.vstack([np.eye(3), -np.eye(3), corners])  # 14 directions of gravity
    >>> table = PoseTable(acc=1.02 * up + 0.03, acc_unit="g")
    >>> len(table.acc), table.gyro is None
    (14, True)
    """

    acc: np.ndarray
    acc_unit: str
    gyro: np.ndarray | None = None
    gyro_unit: str | None = None
    n: np.ndarray | None = None
    acc_sigma: np.ndarray | None = None
    labels: tuple[str, ...] | None = None
    notes: tuple[str, ...] = ()
    source: TableText | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        acc = np.array(self.acc, dtype=np.float64)
        if acc.ndim != 2 or acc.shape[1] != 3 or len(acc) == 0:
            raise ValueError(f"a pose table's acc holds one row of three means per pose; got shape {acc.shape}")
        m = len(acc)
        if self.acc_unit not in ACC_UNITS:
            raise ValueError(f"acc_unit must be one of {', '.join(ACC_UNITS)}; got {self.acc_unit!r}")
        gyro = None if self.gyro is None else np.array(self.gyro, dtype=np.float64)
        if gyro is not None:
            if gyro.shape != (m, 3):
                raise ValueError(f"gyro must have shape ({m}, 3), as acc; got {gyro.shape}")
            if self.gyro_unit not in GYRO_UNITS:
                raise ValueError(f"gyro_unit must be one of {', '.join(GYRO_UNITS)}; got {self.gyro_unit!r}")
        n = None if self.n is None else np.array(self.n, dtype=np.float64).reshape(-1)
        if n is not None and (n.shape != (m,) or not np.all(np.isfinite(n) & (n >= 1))):
            raise ValueError(f"n must hold one sample count ≥ 1 per pose ({m}); got {self.n!r}")
        sigma = None if self.acc_sigma is None else np.array(self.acc_sigma, dtype=np.float64)
        if sigma is not None:
            if sigma.ndim == 1:
                sigma = np.repeat(sigma[:, None], 3, axis=1)
            if sigma.shape != (m, 3) or not np.all(np.isfinite(sigma) & (sigma >= 0)):
                raise ValueError(f"acc_sigma must hold one standard deviation ≥ 0 per pose (or per pose and "
                                 f"axis) for the {m} poses; got shape {sigma.shape}")
        for name, a in (("acc", acc), ("gyro", gyro)):
            if a is not None and not np.all(np.isfinite(a)):
                raise ValueError(f"the pose table's {name} means are not all finite numbers")
        if self.labels is not None and len(self.labels) != m:
            raise ValueError(f"labels must name each of the {m} poses; got {len(self.labels)}")
        for name, a in (("acc", acc), ("gyro", gyro), ("n", n), ("acc_sigma", sigma)):
            if a is not None:
                a.flags.writeable = False
            object.__setattr__(self, name, a)
        object.__setattr__(self, "notes", tuple(self.notes))

    def __len__(self) -> int:
        return len(self.acc)

    def mean_sigma(self) -> np.ndarray | None:
        """The standard error of each pose's mean per axis, ``σ/√n`` (σ itself where ``n`` is not given), or None.

        The samples of a pose are taken as independent: a hand's tremor correlates them, so this is a
        lower bound (the calibration's fit says when its residuals exceed it).
        """
        if self.acc_sigma is None:
            return None
        n = np.ones(len(self)) if self.n is None else self.n
        return self.acc_sigma / np.sqrt(n)[:, None]


# ------------------------------------------------------------------ reading
def guess_acc_unit(acc: np.ndarray) -> tuple[str, float]:
    """The accelerometer unit the poses' norms say (g, m/s² or counts) and their median norm."""
    norm = float(np.median(np.linalg.norm(np.asarray(acc, dtype=float), axis=1)))
    if _G_NORM[0] <= norm <= _G_NORM[1]:
        return "g", norm
    if _SI_NORM[0] <= norm <= _SI_NORM[1]:
        return "m/s^2", norm
    return "counts", norm


_UNIT_IN_NAME = re.compile(r"[\[(]([^\])]*)[\])]")
_AXIS = r"_?([xyz])"
_PATTERNS = (
    ("sigma_", re.compile(r"^(?:σ|sigma|std|sd|stdev|std_dev)_?(?:a|acc|accel|accelerometer)?" + _AXIS + "$")),
    ("sigma_", re.compile(r"^(?:a|acc|accel|accelerometer)?_?([xyz])_(?:σ|sigma|std|sd|stdev|std_dev)$")),
    ("sigma", re.compile(r"^(?:σ|sigma|std|sd|stdev|std_dev|noise)(?:_(?:a|acc|accel|accelerometer))?$|"
                         r"^(?:a|acc|accel|accelerometer)_(?:σ|sigma|std|sd|stdev|std_dev)$")),
    ("gyro_sigma", re.compile(r"^(?:(?:σ|sigma|std|sd|stdev)_?(?:g|w|gyr|gyro|gyroscope)_?[xyz]?|"
                              r"(?:g|w|gyr|gyro|gyroscope)_?[xyz]?_(?:σ|sigma|std|sd|stdev))$")),
    ("a", re.compile(r"^(?:mean_|avg_)?(?:a|acc|accel|accelerometer)" + _AXIS + r"(?:_(?:mean|avg|raw))?$|^([xyz])$")),
    ("g", re.compile(r"^(?:mean_|avg_)?(?:g|w|gyr|gyro|gyroscope|omega|ω)" + _AXIS + r"(?:_(?:mean|avg|raw))?$")),
    ("n", re.compile(r"^(?:n|count|counts|samples|n_samples|nsamples|num_samples|number_of_samples)$")),
)
_ACC_UNIT_NAMES = {"g": "g", "m/s^2": "m/s^2", "m/s2": "m/s^2", "m/s²": "m/s^2", "m s^-2": "m/s^2",
                   "ms^-2": "m/s^2", "counts": "counts", "count": "counts", "lsb": "counts", "raw": "counts",
                   "adc": "counts"}
_GYRO_UNIT_NAMES = {"deg/s": "deg/s", "dps": "deg/s", "°/s": "deg/s", "degrees/s": "deg/s", "rad/s": "rad/s",
                    "counts": "counts", "count": "counts", "lsb": "counts", "raw": "counts", "adc": "counts"}


def _column(cell: str) -> tuple[str | None, str | None]:
    """A header cell's field (``ax`` …, ``n``, ``sigma``, ``sigma_x`` …; ``gyro_sigma`` read and not used) and unit."""
    cell = cell.strip().strip('"').strip()
    found = _UNIT_IN_NAME.search(cell)
    unit = found.group(1).strip().lower() if found else None
    name = _UNIT_IN_NAME.sub("", cell).strip().lower()
    name = re.sub(r"[\s\-.]+", "_", name).strip("_")
    for kind, pattern in _PATTERNS:
        hit = pattern.match(name)
        if hit is None:
            continue
        axis = next((g for g in hit.groups() if g), "")
        return (kind + axis if kind in ("a", "g", "sigma_") else kind), unit
    return None, unit


def _cells(line: str, sep: str | None) -> list[str]:
    return [c.strip().strip('"').strip() for c in (line.split() if sep is None else line.split(sep))]


def _number(cell: str) -> float | None:
    try:
        v = float(cell)
    except ValueError:
        return None
    return v


def _separator(line: str) -> str | None:
    for sep in (",", "\t", ";"):
        if sep in line:
            return sep
    return None


def read_pose_table(path: str | Path, *, acc_unit: str | None = None, gyro_unit: str | None = None,
                    fallback_acc_unit: str | None = None, fallback_gyro_unit: str | None = None) -> PoseTable:
    """A table of averaged poses from a text file (module docstring: the layouts read).

    Parameters
    ----------
    path : str or Path
        The table.
    acc_unit, gyro_unit : str, optional
        The units of the means (and of ``σ``), when the header does not say them (or to overrule it); the
        accelerometer's is recognised from the norms otherwise, the gyroscope's taken as counts.
    fallback_acc_unit, fallback_gyro_unit : str, optional
        The unit where neither ``acc_unit`` (``gyro_unit``) nor the header gives one, instead of recognising it
        from the norms (taking counts): ``imucalib apply`` gives the calibration's.

    Returns
    -------
    PoseTable
        One row per pose: the mean accelerometer (and gyroscope) reading, its σ and sample count where
        the table gives them, in the units taken.

    Raises
    ------
    ReaderError
        A file that is not such a table, naming the line and what to change.

    Examples
    --------
    Six poses, the accelerometer's means in g (the unit is recognised from their norms, and a note says so):

    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.io import read_pose_table
    >>> path = Path(tempfile.mkdtemp()) / "poses.csv"
    >>> _ = path.write_text(chr(10).join(["ax,ay,az", "0.01,0.02,1.00", "0.02,-0.01,-1.01",
    ...     "1.00,0.01,0.02",
    ...     "-0.99,0.00,0.01", "0.00,1.01,-0.02", "0.01,-1.00,0.00"]))
    >>> table = read_pose_table(path)
    >>> table.acc.shape, table.acc_unit
    ((6, 3), 'g')
    >>> table.notes[0]
    "the accelerometer's unit is not given: g, recognised from the poses' norms ..."
    >>> _ = path.write_text("ax,ay" + chr(10) + "1,2" + chr(10))
    >>> read_pose_table(path)
    Traceback (most recent call last):
        ...
    imucalib.io.errors.ReaderError: .../poses.csv: no column named az in the header ...
    """
    path = Path(path)
    lines, header, rows, sep, table = _pose_rows(path)
    ncols = len(table[0])
    text = {j: next((i, c[j]) for i, c in zip(rows, table, strict=True) if _number(c[j]) is None)
            for j in range(ncols) if any(_number(c[j]) is None for c in table)}  # column → its first text
    text_cols = list(text)
    notes: list[str] = []
    units: dict[str, str] = {}
    if header is not None:
        names, units = _named_columns(path, _cells(lines[header], sep), ncols, text, notes)
    else:
        names = _ordered_columns(path, table, ncols, text_cols, notes)
    values = {name: np.array([float(c[j]) for c in table]) for j, name in enumerate(names)
              if name and name != "label"}
    acc, gyro, sigma = _pose_means(values, notes)
    labels = tuple(c[names.index("label")] for c in table) if "label" in names else None
    acc_unit = _unit("accelerometer", acc_unit or units.get("acc") or fallback_acc_unit, acc, notes)
    if gyro is not None:
        gyro_unit = gyro_unit or units.get("gyro") or fallback_gyro_unit
        if gyro_unit is None:
            gyro_unit = "counts"
            notes.append("the gyroscope's unit is not in the header: taken as counts (pass --gyro-unit)")
    source = TableText(lines, header, rows, sep, tuple(names))
    try:
        return PoseTable(acc=acc, acc_unit=acc_unit, gyro=gyro, gyro_unit=gyro_unit if gyro is not None else None,
                         n=values.get("n"), acc_sigma=sigma, labels=labels, notes=tuple(notes), source=source)
    except ValueError as exc:
        raise ReaderError(f"{path}: {exc}") from None


def _pose_rows(path: Path):
    """The file's lines, its header's index (None without one), the poses' line indices, the separator and the
    poses' cells (as many in every row)."""
    try:
        text = read_small_text(path, MAX_TABLE_BYTES, "pose table",
                               "one line per pose: ax ay az [gx gy gz] [n] [σ]")
    except SmallFileError as exc:
        raise ReaderError(f"{path}: {exc}") from None
    lines = tuple(text.splitlines(keepends=True))
    content = [i for i, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith(("#", "%"))]
    if not content:
        raise ReaderError(f"{path}: no pose in the file (one line per pose: ax ay az [gx gy gz] [n] [σ])")
    sep = _separator(lines[content[0]]) if len(content) == 1 else _separator(lines[content[1]])
    first = _cells(lines[content[0]], sep)
    second = _cells(lines[content[1]], sep) if len(content) > 1 else None
    numeric_below = [second is not None and j < len(second) and _number(second[j]) is not None
                     for j in range(len(first))]
    header = content[0] if any(_number(c) is None and (below or second is None)
                               for c, below in zip(first, numeric_below, strict=True)) else None
    rows = tuple(i for i in content if i != header)
    if not rows:
        raise ReaderError(f"{path}: a header and no pose below it")
    table = [_cells(lines[i], sep) for i in rows]
    ncols = len(table[0])
    for i, cells in zip(rows, table, strict=True):
        if len(cells) != ncols:
            raise ReaderError(f"{path}, line {i + 1}: {len(cells)} columns where the first pose has {ncols}: "
                              "every pose needs the same columns")
    return lines, header, rows, sep, table


def _pose_means(values: dict[str, np.ndarray], notes: list[str]):
    """The accelerometer's means (poses × 3), the gyroscope's (or None) and their σ (per axis, per pose, or
    None) from the named columns' values; a note when σ comes without a sample count."""
    acc = np.column_stack([values[f"a{a}"] for a in "xyz"])
    gyro = np.column_stack([values[f"g{a}"] for a in "xyz"]) if all(f"g{a}" in values for a in "xyz") else None
    sigma = None
    if all(f"sigma_{a}" in values for a in "xyz"):
        sigma = np.column_stack([values[f"sigma_{a}"] for a in "xyz"])
    elif "sigma" in values:
        sigma = values["sigma"]
    if sigma is not None and "n" not in values:
        notes.append("the table gives σ but no sample count n: σ is taken as each pose mean's own standard error")
    return acc, gyro, sigma


def _named_columns(path: Path, header: list[str], ncols: int, text: dict[int, tuple[int, str]],
                   notes: list[str]) -> tuple[list[str], dict[str, str]]:
    """Each column's field from the header's names, and the units the names carry (``text``: the columns
    holding text, each with its first such line and cell)."""
    if len(header) != ncols:
        raise ReaderError(f"{path}: the header names {len(header)} columns and the poses have {ncols}")
    names: list[str] = []
    units: dict[str, str] = {}
    unread = []
    for j, cell in enumerate(header):
        kind, unit = _column(cell)
        if j in text and kind in _FIELDS:
            line, cell_text = text[j]
            raise ReaderError(f"{path}, line {line + 1}: the column {cell.strip()!r} holds {cell_text!r}, not a "
                              "number")
        if j in text:
            names.append("label" if "label" not in names else "")
            continue
        if kind is None or kind == "gyro_sigma" or kind in names:
            names.append("")
            if kind != "gyro_sigma":
                unread.append(cell.strip() or f"column {j + 1}")
            continue
        names.append(kind)
        _column_unit(path, cell, kind, unit, units, notes)
    _check_named(path, header, names)
    if unread:
        notes.append(f"column(s) {', '.join(unread)} not read (kept as they are when the table is written again)")
    return names, units


def _column_unit(path: Path, cell: str, kind: str, unit: str | None, units: dict[str, str], notes: list[str]) -> None:
    """The unit a named column ``cell`` (of field ``kind``) carries, into ``units`` by sensor: a note for a unit
    this package does not know, an error for a second unit of the same sensor."""
    sensor = "acc" if kind[0] == "a" or kind.startswith("sigma") else "gyro" if kind[0] == "g" else None
    table = _ACC_UNIT_NAMES if sensor == "acc" else _GYRO_UNIT_NAMES
    if sensor and unit:
        if unit not in table:
            notes.append(f"the unit {unit!r} of column {cell.strip()!r} is not one of "
                         f"{', '.join(ACC_UNITS if sensor == 'acc' else GYRO_UNITS)}: ignored")
        elif units.setdefault(sensor, table[unit]) != table[unit]:
            raise ReaderError(f"{path}: the header gives the {'accelerometer' if sensor == 'acc' else 'gyroscope'}"
                              f" columns two units, {units[sensor]} and {table[unit]}")


def _check_named(path: Path, header: list[str], names: list[str]) -> None:
    """The header names the accelerometer's three axes, the gyroscope's three or none, σ of three axes or one."""
    missing = [f for f in ("ax", "ay", "az") if f not in names]
    if missing:
        raise ReaderError(f"{path}: no column named {' or '.join(missing)} in the header ({', '.join(header)}): name "
                          "the accelerometer's columns ax, ay, az (or acc_x …), with the unit in brackets")
    gyro = [f for f in ("gx", "gy", "gz") if f in names]
    if 0 < len(gyro) < 3:
        raise ReaderError(f"{path}: the header names the gyroscope's {', '.join(gyro)} but not all three axes")
    axes = [f for f in ("sigma_x", "sigma_y", "sigma_z") if f in names]
    if 0 < len(axes) < 3:
        raise ReaderError(f"{path}: the header gives σ of {', '.join(axes)} only: give it for the three axes, or "
                          "one σ column")


def _ordered_columns(path: Path, table: list[list[str]], ncols: int, text_cols: list[int],
                     notes: list[str]) -> list[str]:
    """Each column's field in a table without a header: ``ax ay az [gx gy gz] [n] [σ | σx σy σz]``."""
    numeric = [j for j in range(ncols) if j not in text_cols]
    k = len(numeric)

    def whole(j: int) -> bool:
        v = np.array([float(c[j]) for c in table])
        return bool(np.all((v >= 1) & (v == np.round(v))))

    fields = ["ax", "ay", "az"]
    rest = k - 3
    if rest >= 1 and whole(numeric[3]):
        fields.append("n")
        rest -= 1
    elif rest >= 3:
        fields += ["gx", "gy", "gz"]
        rest -= 3
        if rest >= 1 and whole(numeric[6]):
            fields.append("n")
            rest -= 1
    if rest == 1:
        fields.append("sigma")
    elif rest == 3:
        fields += ["sigma_x", "sigma_y", "sigma_z"]
    elif rest != 0 or k < 3:
        raise ReaderError(f"{path}: {k} numeric columns and no header: without one a pose table is read as "
                          "ax ay az [gx gy gz] [n] [σ or σx σy σz]; add a header line naming the columns")
    names = [""] * ncols
    for j, name in zip(numeric, fields, strict=True):
        names[j] = name
    if text_cols:
        names[text_cols[0]] = "label"
    notes.append(f"no header: the columns were taken as {' '.join(f for f in fields)}")
    return names


def _unit(sensor: str, unit: str | None, acc: np.ndarray, notes: list[str]) -> str:
    """The accelerometer's unit: given, else recognised from the norms (with a note)."""
    if unit is not None:
        if unit not in ACC_UNITS:
            raise ValueError(f"the {sensor} unit must be one of {', '.join(ACC_UNITS)}; got {unit!r}")
        return unit
    guess, norm = guess_acc_unit(acc)
    notes.append(f"the accelerometer's unit is not given: {guess}, recognised from the poses' norms (median "
                 f"|a| = {norm:.4g}); pass --acc-unit to say otherwise")
    return guess


# ------------------------------------------------------------------ writing
def write_pose_table(path: str | Path, table: PoseTable, calibrated_acc: np.ndarray,
                     calibrated_gyro: np.ndarray | None = None) -> None:
    """Write ``table`` with the calibrated columns appended, atomically (:func:`imucalib.io.atomic.atomic_write`).

    The columns added are those :func:`imucalib.io.writers.calibrated_columns` names (``acc_x_cal [m/s^2]`` …,
    ``gyro_x_cal [rad/s]`` …; without the space in a blank-separated table), with 12 significant digits. A
    table read from a file keeps its lines as they were (comments, the separator, the header, each cell's
    text) with the calibrated cells appended to each pose's line, and a header line of its own where it had
    none; a table made in a program is written comma-separated from its values.

    Parameters
    ----------
    path : str or Path
        The file to write (never the table's own file: the command line refuses an output that names an input).
    table : PoseTable
        The averaged poses, as :func:`read_pose_table` read them.
    calibrated_acc : ndarray of shape (M, 3)
        The calibrated accelerometer means [m/s²], one row per pose.
    calibrated_gyro : ndarray of shape (M, 3), optional
        The calibrated gyroscope means [rad/s]; None when the table has no gyroscope columns.

    Returns
    -------
    None
        The file is written.

    Raises
    ------
    ValueError
        A calibrated column with another number of rows than the table has poses.
    OSError
        The file cannot be written (an existing ``path`` is then left as it was).

    Examples
    --------
    A table made in a program, calibrated and written with its calibrated columns:

    >>> import itertools, tempfile
    >>> import numpy as np
    >>> from pathlib import Path
    >>> from imucalib.io import write_pose_table
    >>> from imucalib.io.posetable import PoseTable
    >>> from imucalib.methods._pose_table import apply_to_table, calibrate_pose_table
    >>> corners = np.array(list(itertools.product((-1, 1), repeat=3))) / np.sqrt(3)
    >>> up = np.vstack([np.eye(3), -np.eye(3), corners])  # 14 directions of gravity
    >>> table = PoseTable(acc=1.02 * up + 0.03, acc_unit="g")
    >>> calibrated = apply_to_table(calibrate_pose_table(table, gravity=9.81), table)
    >>> path = Path(tempfile.mkdtemp()) / "calibrated.csv"
    >>> write_pose_table(path, table, calibrated.acc)
    >>> path.read_text().splitlines()[0]
    'ax [g],ay [g],az [g],acc_x_cal [m/s^2],acc_y_cal [m/s^2],acc_z_cal [m/s^2]'
    """
    from .writers import ADDED_FORMAT, calibrated_columns  # imucalib.io.writers costs 82 ms at start-up

    added = calibrated_columns(calibrated_acc, calibrated_gyro)
    for name, v in added.items():
        if len(v) != len(table):
            raise ValueError(f"column {name!r} has {len(v)} rows; the table has {len(table)} poses")
    src = table.source
    sep = "," if src is None else (src.sep or " ")
    names = list(added) if src is None or src.sep is not None else [k.replace(" ", "") for k in added]
    tails = [[ADDED_FORMAT % float(v[k]) for v in added.values()] for k in range(len(table))]
    if src is None:
        out = [sep.join([*_own_header(table), *names]) + "\n"]
        out += [sep.join([*_own_cells(table, k), *tails[k]]) + "\n" for k in range(len(table))]
    else:
        out = list(src.lines)
        if src.header is not None:
            out[src.header] = _append(out[src.header], sep, names)
        for k, i in enumerate(src.rows):
            out[i] = _append(out[i], sep, tails[k])
        if src.header is None:
            own = [_field_header(f, table, j) for j, f in enumerate(src.names)] + names
            out.insert(src.rows[0], sep.join(own if src.sep is not None else [c.replace(" ", "") for c in own])
                       + _ending(out[src.rows[0]]))
    with atomic_write(path, "w", encoding="utf-8", newline="") as fh:
        fh.write("".join(out))


def _ending(line: str) -> str:
    return line[len(line.rstrip("\r\n")):] or "\n"


def _append(line: str, sep: str, cells: list[str]) -> str:
    body = line.rstrip("\r\n")
    return body + "".join(sep + c for c in cells) + _ending(line)


def _field_header(name: str, table: PoseTable, j: int) -> str:
    if not name:
        return f"column {j + 1}"
    if name in ("ax", "ay", "az") or name.startswith("sigma"):
        return f"{name} [{table.acc_unit}]"
    if name in ("gx", "gy", "gz"):
        return f"{name} [{table.gyro_unit}]"
    return name


def _own_header(table: PoseTable) -> list[str]:
    names = [] if table.labels is None else ["label"]
    names += [f"a{a} [{table.acc_unit}]" for a in "xyz"]
    if table.gyro is not None:
        names += [f"g{a} [{table.gyro_unit}]" for a in "xyz"]
    if table.n is not None:
        names.append("n")
    if table.acc_sigma is not None:
        names += [f"sigma_{a} [{table.acc_unit}]" for a in "xyz"]
    return names


def _own_cells(table: PoseTable, k: int) -> list[str]:
    cells = [] if table.labels is None else [table.labels[k]]
    cells += [repr(float(v)) for v in table.acc[k]]
    if table.gyro is not None:
        cells += [repr(float(v)) for v in table.gyro[k]]
    if table.n is not None:
        cells.append(f"{table.n[k]:.0f}")
    if table.acc_sigma is not None:
        cells += [repr(float(v)) for v in table.acc_sigma[k]]
    return cells
