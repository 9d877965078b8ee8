"""Magnetometer columns of a table: found by name among the columns a reader kept, with their unit.

Readers keep every column they do not use as an ``extra`` column named as in
the file's header; :func:`attach_magnetometer` finds three of them that name a
magnetometer's axes and makes them the recording's ``mag``:

* ``mx my mz``, ``mag_x mag_y mag_z``, ``magx …``, ``magnetometer_x …``,
  ``magneticField_x …``, ``m_x …``, and the same with a unit in brackets
  (``mag_x [uT]``, ``mx (gauss)``);
* the unit from ``--mag-unit`` (``counts``, ``uT``, ``gauss``), else from the
  header's brackets (``uT``, ``µT``, ``microtesla``, ``G``, ``gauss``, ``mG``
  as gauss/1000 is refused: scale it first), else counts.

The columns stay in ``extra`` as well, so that a writer copies them as they
were (``imucalib apply`` adds ``mag_x_cal`` … beside them).
"""

from __future__ import annotations

import re

import numpy as np

from ..recording import Recording

__all__ = ["MAG_NAME", "attach_magnetometer", "magnetometer_columns"]

#: a magnetometer axis column: the prefix, the axis, an optional unit in brackets
MAG_NAME = re.compile(r"^\s*(?:m|mag|magnetometer|magneticfield|magnetic_field|magn)[\s_.-]?([xyz])\s*"
                      r"(?:[\[(]\s*([^\])]*)\s*[\])])?\s*$", re.I)
_UNITS = {"ut": "uT", "µt": "uT", "microtesla": "uT", "micro tesla": "uT", "g": "gauss", "gs": "gauss",
          "gauss": "gauss", "counts": "counts", "lsb": "counts", "raw": "counts"}


def magnetometer_columns(names) -> tuple[list[str], str | None] | None:
    """The names of the x, y, z magnetometer columns among ``names`` and the unit their header gives."""
    found: dict[str, tuple[str, str | None]] = {}
    for name in names:
        m = MAG_NAME.match(str(name))
        if m and m.group(1).lower() not in found:
            found[m.group(1).lower()] = (str(name), m.group(2))
    if set(found) != {"x", "y", "z"}:
        return None
    cols = [found[a][0] for a in "xyz"]
    units = {found[a][1].strip().lower() for a in "xyz" if found[a][1]}
    if len(units) > 1:
        raise ValueError(f"the magnetometer columns {', '.join(cols)} give different units")
    unit = None
    if units:
        text = units.pop()
        if text not in _UNITS:
            raise ValueError(f"the magnetometer column {cols[0]} is in {text!r}, which imucalib does not know: "
                             "give --mag-unit counts, uT or gauss (and scale the data to one of them)")
        unit = _UNITS[text]
    return cols, unit


def attach_magnetometer(recording: Recording, mag_unit: str | None = None) -> Recording:
    """``recording`` with its magnetometer columns (found in ``extra`` by name) as ``mag``.

    ``mag_unit`` overrides the header's unit; given when the header writes another, it is an error
    (like the accelerometer's and gyroscope's unit options). A recording that already has ``mag``,
    or has no such columns, is returned as it is (``mag_unit`` then is an error: nothing to apply it to).
    """
    if recording.mag is not None:
        return recording
    found = magnetometer_columns(recording.extra)
    if found is None:
        if mag_unit is not None:
            raise ValueError("--mag-unit was given, but the data have no magnetometer columns (mx, my, mz or "
                             "mag_x, mag_y, mag_z)")
        return recording
    cols, header_unit = found
    if mag_unit is not None and header_unit is not None and mag_unit != header_unit:
        raise ValueError(f"--mag-unit {mag_unit} contradicts the header, which writes {cols[0]} in {header_unit}")
    values = []
    for c in cols:
        try:
            v = np.asarray(recording.extra[c], dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"the magnetometer column {c} holds values that are not numbers") from None
        values.append(v)
    mag = np.column_stack(values)
    bad = ~np.all(np.isfinite(mag), axis=1)
    if np.any(bad):
        raise ValueError(f"the magnetometer column(s) have {int(bad.sum())} rows without a number (first at row "
                         f"{int(np.nonzero(bad)[0][0])}): a magnetometer logged at a lower rate must be "
                         "interpolated onto the other sensors' time stamps first")
    return Recording(t=recording.t, acc=recording.acc, gyro=recording.gyro, acc_unit=recording.acc_unit,
                     gyro_unit=recording.gyro_unit, temperature=recording.temperature, extra=dict(recording.extra),
                     metadata={**recording.metadata, "magnetometer_columns": cols}, mag=mag,
                     mag_unit=mag_unit or header_unit or "counts")
