"""What ``imucalib calibrate`` reads: a recording from data files, or a simulated session directory.

:func:`read_data` is the one entry point the command line and batch runs
(:mod:`imucalib.batch`) share, so a manifest row is read exactly as the same
files given to ``imucalib calibrate`` are.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

__all__ = ["is_session_directory", "read_data"]


def is_session_directory(paths: Sequence[str | Path], reader: str | None = None) -> bool:
    """True when ``paths`` name a simulated session directory (``imucalib simulate -o DIR``).

    ``reader="session"`` says so; without a reader, one directory that is not a ROS 2 bag is taken
    for a session.
    """
    if reader == "session":
        return True
    if reader is not None or len(paths) != 1 or not Path(paths[0]).is_dir():
        return False
    from .rosbag import is_rosbag  # a directory: perhaps a ROS 2 bag

    return not is_rosbag(Path(paths[0]))


def read_data(
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
    mag_unit: str | None = None,
    mag_topic: str | None = None,
):
    """The data in ``paths``: a :class:`~imucalib.recording.Recording`, or a simulated session.

    This is :func:`imucalib.read`, the one reading the command line, batch runs and a program share.
    ``paths`` is one file, several (two imu_tk files; CSV or MAT files read as blocks of one recording),
    a ROS bag, a pandas DataFrame (read as a CSV file) or a simulated session directory. The other
    parameters are those of :func:`imucalib.io.read`, and ``reader="session"`` for a directory
    written by :func:`imucalib.io.session.write_session` (read by
    :func:`imucalib.io.session.read_session`; found without ``reader`` too). A recording's
    magnetometer columns become its ``mag`` (:func:`imucalib.io.magnetometer.attach_magnetometer`,
    ``mag_unit``), or for a ROS bag the ``sensor_msgs/MagneticField`` topic ``mag_topic``.

    Returns
    -------
    Recording or Session or WangSession
        What :func:`imucalib.methods.calibrate` takes.
    """
    from .readers import is_frame

    if is_frame(paths):
        paths = [paths]  # a pandas DataFrame: read as one CSV file, never a session
    elif isinstance(paths, str | Path):
        paths = [paths]
    paths = list(paths)
    if paths and not is_frame(paths[0]) and is_session_directory(paths, reader):
        from .session import read_session

        return read_session(paths[0])
    from .magnetometer import attach_magnetometer
    from .readers import read

    source = paths[0] if len(paths) == 1 and is_frame(paths[0]) else paths
    rec = read(source, reader=reader, columns=columns, acc_unit=acc_unit, gyro_unit=gyro_unit, rate=rate,
               variable=variable, time_unit=time_unit, topic=topic, progress=progress)
    if mag_topic is not None:
        if rec.metadata.get("reader") != "rosbag":
            raise ValueError("a magnetometer topic (--mag-topic) applies to ROS bags")
        from .rosbag import add_magnetic_field

        return add_magnetic_field(rec, paths[0], mag_topic)
    return attach_magnetometer(rec, mag_unit)
