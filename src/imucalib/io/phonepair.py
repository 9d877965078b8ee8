"""A phone app's accelerometer and gyroscope files (:mod:`.phone`) read as one recording."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..recording import GYRO_UNITS, ImucalibWarning, Recording
from .errors import ReaderError
from .stamps import TIME_UNITS
from .stamps import check_increasing as _check_time
from .tables import head_names, parse_table, split_table, time_column

if TYPE_CHECKING:
    from .phone import PhoneFile

# the phone apps' layouts (.phone) are imported when two files are met

__all__ = ["phone_specs", "read_phone"]


def phone_specs(paths: Sequence[Path]) -> list[PhoneFile] | None:
    """The phone-app layout of each of two files, or None when either is not a phone app's file.

    Sensor Logger's files share one header; when a file's name does not say which
    sensor it holds, the order decides (accelerometer first, as for imu_tk).
    """
    from .phone import PhoneFile, identify, sensor_logger_header  # imported when a phone file is met: 12 ms at start-up

    specs = []
    for i, path in enumerate(paths):
        names = head_names(path)
        if names is None:
            return None
        spec = identify(path, names)
        if spec is None and sensor_logger_header(names):
            lower = [n.lower() for n in names]
            sensor = "acc" if i == 0 else "gyro"
            spec = PhoneFile("Sensor Logger", sensor, 0, "ns",
                             (lower.index("x"), lower.index("y"), lower.index("z")),
                             "m/s^2" if sensor == "acc" else "rad/s")
        if spec is None:
            return None
        specs.append(spec)
    return specs


def read_phone(paths: Sequence[Path], acc_unit, gyro_unit, time_unit) -> Recording:
    """A phone app's accelerometer and gyroscope files, merged onto the accelerometer's time base."""
    from .phone import check_specific_force  # imported when a phone file is met: 12 ms at start-up

    specs = phone_specs(paths)
    if specs is None:
        raise ReaderError(f"{paths[0]}, {paths[1]}: not a pair of phone-app files (phyphox's or Sensor "
                          "Logger's accelerometer and gyroscope CSV files); see the formats in the docs")
    if specs[0].app != specs[1].app:
        raise ReaderError(f"{paths[0]} is a {specs[0].app} file but {paths[1]} is a {specs[1].app} file; "
                          "their times cannot be matched: pass two files from the same app")
    sensors = sorted(s.sensor for s in specs)
    if sensors != ["acc", "gyro"]:
        what = "accelerometer" if sensors[0] == "acc" else "gyroscope"
        raise ReaderError(f"{paths[0]} and {paths[1]} are both {what} files; pass one accelerometer "
                          "file and one gyroscope file")
    streams = {}
    for path, spec in zip(paths, specs, strict=True):
        table = split_table(path)
        cols = parse_table(path, table, [spec.time, *spec.axes], others=False)
        raw_t, offset = time_column(cols[spec.time])
        _check_time(path, raw_t, table.first_line, table.names[spec.time])
        streams[spec.sensor] = (path, spec, table, raw_t, offset, np.column_stack([cols[j] for j in spec.axes]))
    app = specs[0].app
    unit = time_unit or specs[0].time_unit
    # epoch stamps are kept as exact integers relative to the earliest start
    base = min(offset if offset else float(raw_t[0]) for *_, raw_t, offset, _ in streams.values())
    times = {sensor: (raw_t + (offset - base)) * TIME_UNITS[unit]
             for sensor, (*_, raw_t, offset, _) in streams.items()}
    acc_path, acc_spec, *_, acc = streams["acc"]
    gyro_path, gyro_spec, *_, gyro = streams["gyro"]
    au = check_specific_force(acc_path, acc_spec, acc)
    if acc_unit is not None:
        au = acc_unit
    gu = gyro_unit or gyro_spec.unit
    if gu not in GYRO_UNITS:
        raise ReaderError(f"{gyro_path}: unknown gyroscope unit {gu!r} in the header; pass --gyro-unit")
    orders = {kind: ",".join(streams[sensor][2].names[j] for j in sorted(spec.axes))
              for sensor, kind, spec in (("acc", "accelerometer", acc_spec), ("gyro", "gyroscope", gyro_spec))
              if list(spec.axes) != sorted(spec.axes)}
    if len(orders) == 2 and len(set(orders.values())) == 1:
        reordered = f"; the axes, written in the order {orders['accelerometer']} in both files, were put in x,y,z order"
    elif orders:
        reordered = "; the axes, written in the order " + " and ".join(
            f"{order} ({kind})" for kind, order in orders.items()) + ", were put in x,y,z order"
    else:
        reordered = ""
    warnings.warn(
        f"read {acc_path.name} and {gyro_path.name} as {app}'s accelerometer ({au}) and gyroscope ({gu}) "
        f"files, each with its own time stamps{reordered}", ImucalibWarning, stacklevel=3)
    meta: dict = {"source": [str(acc_path), str(gyro_path)], "app": app, "time_unit": unit,
                  "t0": float(base), "time_relative": bool(base)}
    return Recording.from_streams(times["acc"], acc, times["gyro"], gyro,
                                  acc_unit=au, gyro_unit=gu, metadata=meta)
