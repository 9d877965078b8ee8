"""What ``imucalib calibrate`` reads: a recording from data files, a table of averaged poses, or a simulated
session directory.

:func:`read` is :func:`imucalib.read`, the one entry point the command line and batch runs
(:mod:`imucalib.batch`) share, so a manifest row is read exactly as the same
files given to ``imucalib calibrate`` are. The files' columns are read by :func:`imucalib.io.read`;
this adds the magnetometer, tables of poses and session directories (whose truth is a calibration,
:mod:`imucalib.sessions`).
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from pathlib import Path

from .io.sessionfiles import is_session_directory

__all__ = ["read"]


def read(
    paths: str | Path | Sequence[str | Path],
    *,
    reader: str | None = None,
    mag_unit: str | None = None,
    mag_topic: str | None = None,
    poses: bool = False,
    **options,
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
        :func:`imucalib.sessions.write_session`, read by :func:`imucalib.sessions.read_session`; found
        without ``reader`` too).
    reader : {"csv", "imutk", "mat", "phone", "rosbag", "session"}, optional
        The format; guessed from the file(s) when omitted (:func:`imucalib.io.guess_reader`).
    mag_unit : str, optional
        The magnetometer columns' unit (``"uT"``, ``"counts"`` …), when the header does not write it; an error
        when it contradicts the header or there are no magnetometer columns.
    mag_topic : str, optional
        ROS bags only: the ``sensor_msgs/MagneticField`` topic.
    poses : bool
        ``paths`` is one table of averaged poses, one row per orientation
        (:func:`imucalib.io.posetable.read_pose_table`, with ``acc_unit`` and ``gyro_unit``).
    **options
        The options of :func:`imucalib.io.read`, which reads the files (documented there): ``columns``
        (in the order ``t, ax, ay, az, gx, gy, gz``), ``acc_unit`` (counts, g, m/s^2), ``gyro_unit``
        (counts, deg/s, rad/s), ``rate`` [Hz] of a file without a time column, ``variable`` (a MATLAB
        matrix's name), ``time_unit``, ``topic`` (a ROS bag's ``sensor_msgs/Imu`` topic) and
        ``progress(done, total)``.

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
    >>> from imucalib.sessions import write_session
    >>> from imucalib.scenarios import session
    >>> folder = tempfile.mkdtemp()
    >>> _ = write_session(session("handheld", rng=1), folder)
    >>> data = imucalib.read(folder)
    >>> data.recording.acc.shape[1], data.truth.method
    (3, 'truth')
    """
    if poses:
        return _pose_table(paths, reader, options)
    from .io.readers import is_frame  # imucalib.io.readers costs 174 ms at start-up
    from .io.readers import read as read_files  # imucalib.io.readers costs 174 ms at start-up

    paths = [paths] if is_frame(paths) or isinstance(paths, str | Path) else list(paths)  # a DataFrame: one table
    if paths and not is_frame(paths[0]) and is_session_directory(paths, reader):  # never a DataFrame
        from .sessions import read_session  # imucalib.sessions costs 152 ms at start-up

        return read_session(paths[0])
    rec = read_files(paths[0] if len(paths) == 1 and is_frame(paths[0]) else paths, reader=reader, **options)
    return _with_magnetometer(rec, paths, mag_unit, mag_topic)


def _with_magnetometer(rec, paths: list, mag_unit: str | None, mag_topic: str | None):
    """The recording :func:`read` read, its magnetometer attached: its columns', or a ROS bag's topic's."""
    from .io.magnetometer import attach_magnetometer  # imucalib.io.magnetometer costs 108 ms at start-up

    if mag_topic is not None:
        if rec.metadata.get("reader") != "rosbag":
            raise ValueError("a magnetometer topic (--mag-topic) applies to ROS bags")
        from .io.rosbag import add_magnetic_field  # imucalib.io.rosbag costs 71 ms at start-up

        return add_magnetic_field(rec, paths[0], mag_topic)
    return attach_magnetometer(rec, mag_unit)


def _pose_table(paths, reader: str | None, options: dict):
    """:func:`read` of a table of averaged poses: one text file."""

    from .io.posetable import read_pose_table  # imucalib.io.posetable costs 126 ms at start-up
    from .io.readers import read as read_files  # imucalib.io.readers costs 174 ms at start-up

    known = set(inspect.signature(read_files).parameters) - {"paths", "reader"}
    for name in options:
        if name not in known:
            raise TypeError(f"read() got an unexpected keyword argument {name!r}")
    paths = [paths] if isinstance(paths, str | Path) else list(paths)
    if len(paths) != 1 or not isinstance(paths[0], str | Path):
        raise ValueError(f"a table of averaged poses is one text file; got {len(paths)} inputs")
    if reader not in (None, "csv"):
        raise ValueError(f"a table of averaged poses is a text table: the reader {reader!r} does not apply")
    return read_pose_table(paths[0], acc_unit=options.get("acc_unit"), gyro_unit=options.get("gyro_unit"))
