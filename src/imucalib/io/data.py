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
    from .rosbag import is_rosbag  # a directory: perhaps a ROS 2 bag (imucalib.io.rosbag costs 71 ms at start-up)

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
    poses: bool = False,
):
    """The data in ``paths``: a :class:`~imucalib.recording.Recording`, or a simulated session.

    This is :func:`imucalib.read`, the one reading the command line, batch runs and a program share.
    A recording's magnetometer columns become its ``mag``
    (:func:`imucalib.io.magnetometer.attach_magnetometer`, ``mag_unit``), or for a ROS bag the
    ``sensor_msgs/MagneticField`` topic ``mag_topic``.

    Parameters
    ----------
    paths : str, Path, sequence of them, or pandas.DataFrame
        One file, several (two imu_tk files; CSV or MAT files read as blocks of one recording), a ROS bag,
        a pandas DataFrame (read as a CSV file) or a simulated session directory (written by
        :func:`imucalib.io.session.write_session`, read by :func:`imucalib.io.session.read_session`; found
        without ``reader`` too).
    reader : {"csv", "imutk", "mat", "phone", "rosbag", "session"}, optional
        The format; guessed from the file(s) when omitted (:func:`imucalib.io.guess_reader`).
    columns, acc_unit, gyro_unit, rate, variable, time_unit, topic, progress
        As for :func:`imucalib.io.read`: the columns in the order ``t, ax, ay, az, gx, gy, gz``, the
        accelerometer's unit (counts, g, m/s^2) and the gyroscope's (counts, deg/s, rad/s), the sampling
        rate [Hz] of a file without a time column, a MATLAB matrix's name, the time column's unit, a ROS
        bag's ``sensor_msgs/Imu`` topic, and ``progress(done, total)``.
    mag_unit : str, optional
        The magnetometer columns' unit (``"uT"``, ``"counts"`` …), when the header does not write it; an error
        when it contradicts the header or there are no magnetometer columns.
    mag_topic : str, optional
        ROS bags only: the ``sensor_msgs/MagneticField`` topic.
    poses : bool
        ``paths`` is one table of averaged poses, one row per orientation
        (:func:`imucalib.io.posetable.read_pose_table`, with ``acc_unit`` and ``gyro_unit``).

    Returns
    -------
    Recording or Session or WangSession or PoseTable
        What :func:`imucalib.methods.calibrate` takes.

    Raises
    ------
    ReaderError
        A file that cannot be read as the reader has it, saying what is wrong and which option fixes it.
    SessionFileError
        A session directory whose ``session.json`` or tables are faulty.
    ValueError
        Options that do not go together (``mag_topic`` for a file that is not a ROS bag, ``poses=True``
        with several files or a reader other than CSV, ``mag_unit`` without magnetometer columns).

    Examples
    --------
    A simulated session directory reads as the session, with its truth:

    >>> import tempfile, imucalib
    >>> from imucalib.io.session import write_session
    >>> from imucalib.scenarios import session
    >>> folder = tempfile.mkdtemp()
    >>> _ = write_session(session("handheld", rng=1), folder)
    >>> data = imucalib.read(folder)
    >>> data.recording.acc.shape[1], data.truth.method
    (3, 'truth')
    """
    if poses:
        return _pose_table(paths, reader, acc_unit, gyro_unit)
    from .readers import is_frame  # imucalib.io.readers costs 174 ms at start-up

    if is_frame(paths):
        paths = [paths]  # a pandas DataFrame: read as one CSV file, never a session
    elif isinstance(paths, str | Path):
        paths = [paths]
    paths = list(paths)
    if paths and not is_frame(paths[0]) and is_session_directory(paths, reader):
        from .session import read_session  # imucalib.io.session costs 152 ms at start-up

        return read_session(paths[0])
    from .magnetometer import attach_magnetometer  # imucalib.io.magnetometer costs 108 ms at start-up
    from .readers import read  # imucalib.io.readers costs 174 ms at start-up

    source = paths[0] if len(paths) == 1 and is_frame(paths[0]) else paths
    rec = read(source, reader=reader, columns=columns, acc_unit=acc_unit, gyro_unit=gyro_unit, rate=rate,
               variable=variable, time_unit=time_unit, topic=topic, progress=progress)
    if mag_topic is not None:
        if rec.metadata.get("reader") != "rosbag":
            raise ValueError("a magnetometer topic (--mag-topic) applies to ROS bags")
        from .rosbag import add_magnetic_field  # imucalib.io.rosbag costs 71 ms at start-up

        return add_magnetic_field(rec, paths[0], mag_topic)
    return attach_magnetometer(rec, mag_unit)


def _pose_table(paths, reader: str | None, acc_unit: str | None, gyro_unit: str | None):
    """:func:`read_data` of a table of averaged poses: one text file."""
    from .posetable import read_pose_table  # imucalib.io.posetable costs 126 ms at start-up

    paths = [paths] if isinstance(paths, str | Path) else list(paths)
    if len(paths) != 1 or not isinstance(paths[0], str | Path):
        raise ValueError(f"a table of averaged poses is one text file; got {len(paths)} inputs")
    if reader not in (None, "csv"):
        raise ValueError(f"a table of averaged poses is a text table: the reader {reader!r} does not apply")
    return read_pose_table(paths[0], acc_unit=acc_unit, gyro_unit=gyro_unit)
