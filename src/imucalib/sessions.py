"""The simulated sessions: their records, writing them into a directory and reading them back.

A session (:class:`Session`: raw recordings, the truth and the segment layout; or a
:class:`WangSession` of turntable aggregates) is what a simulator
(:mod:`imucalib.scenarios`) makes and what :func:`imucalib.read` reads back from a
directory, so the format sits below both: reading a session needs no simulator. The directory's
index and recordings are read and written by :mod:`imucalib.io.sessionfiles`; the truth is a
calibration file (:class:`~imucalib.calibration.Calibration`).

``session.json`` is checked entry by entry: every fault is a :class:`SessionFileError` (a ValueError)
naming the file and the entry or line, never a KeyError or numpy's own text.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .calibration import Calibration
from .constants import G0
from .io import sessionfiles
from .io.sessionfiles import SessionFileError, load_meta, read_recording, read_table, segments, write_meta, write_table
from .recording import Interval, Recording

__all__ = ["Session", "SessionFileError", "TossSequence", "WangSession", "read_session", "session_files",
           "write_session"]


@dataclass
class TossSequence:
    """One RD3 toss: the raw recording and its segments (static, motion, weightless)."""

    recording: Recording
    segments: list[Interval]


@dataclass
class Session:
    """A simulated session: raw recordings, the truth and the segment layout.

    Examples
    --------
    :func:`imucalib.scenarios.session` makes them; the 10 s rest and 14 poses alternate with 14 rotations:

    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> sim.scenario, sim.seed, len(sim.segments), sim.segments[0]
    ('handheld', 1, 29, Interval(start=0, stop=996, kind='static'))
    >>> sim.truth.method
    'truth'
    """

    scenario: str
    seed: int | None
    recording: Recording
    segments: list[Interval]
    truth: Calibration
    weightless: list[Recording] = field(default_factory=list)
    tests: list[TossSequence] = field(default_factory=list)
    noise: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)

    def method_options(self, method: str) -> dict:
        """The keyword options this session gives ``imucalib.methods.calibrate(..., method=method)``.

        Zhang 2021 gets the weightless spins; a noise-free session hands over its
        static layout (no detector can set a threshold without noise) and
        unweighted residuals.
        """
        if method != "zhang2021":
            return {}
        out: dict = {"weightless": self.weightless}
        levels = self.noise.values() if isinstance(self.noise, dict) else [self.noise]
        if self.segments and not any(float(v) for v in levels):
            out["intervals"] = [s for s in self.segments if s.kind == "static"]
            out["noise_weights"] = False
        return out



@dataclass
class WangSession:
    """Averaged static outputs and integrated turn outputs with the truth."""

    positions_acc: np.ndarray  # (P, 3) mean accelerometer pulses/s per position
    positions_gyro: np.ndarray  # (P, 3) mean gyroscope pulses/s per position
    turn_sum: np.ndarray  # (R, 3) ∫(N⁺ − N⁻) dt, pulses
    turn_sum2: np.ndarray  # (R, 3) ∫(N⁺² − N⁻²) dt, pulses²/s
    turn_angle: np.ndarray  # (R,) the angle θ of each turn [rad]
    truth: Calibration
    latitude_deg: float
    turntable_error: str
    gravity: float = G0
    scenario: str = "wang2019"
    options: dict = field(default_factory=dict)
    seed: int | None = None  # the seed it was simulated with, when given as an int

    @property
    def recording(self):  # the methods registry asks for one; this scenario has none
        return None


def session_files(sim: Session | WangSession) -> list[str]:
    """The names of the files :func:`write_session` writes for ``sim``."""
    if isinstance(sim, WangSession):
        return ["positions.csv", "turns.csv", "truth.json", "session.json"]
    return ["recording.csv", *(f"weightless_{i:03d}.csv" for i in range(len(sim.weightless))),
            *(f"test_{i:02d}.csv" for i in range(len(sim.tests))), "truth.json", "session.json"]


def write_session(sim: Session | WangSession, directory: str | Path, *, overwrite: bool = True) -> Path:
    """Write a simulated session into a directory that :func:`read_session` reads back.

    Parameters
    ----------
    sim : Session or WangSession
        A session of samples (:func:`imucalib.scenarios.session`), written as
        ``recording.csv``, ``weightless_NNN.csv``, ``test_NN.csv``,
        ``truth.json`` and ``session.json``; or a turntable session
        (:func:`imucalib.scenarios.wang2019.session`), written as its
        aggregates: ``positions.csv`` (static position means),
        ``turns.csv`` (clockwise − counter-clockwise turn integrals and
        angles), ``truth.json`` and ``session.json``.
    directory : str or Path
        Created if missing; files already there are overwritten (unless
        ``overwrite`` is false: then :class:`FileExistsError` names them before
        anything is written). Each file is
        written through a temporary file moved into place, and ``session.json``
        (the index :func:`read_session` starts from) is removed first and
        written last, so an interrupted write leaves a directory that does not
        read as a session rather than one mixing two.

    Returns
    -------
    Path
        The directory.

    Raises
    ------
    FileExistsError
        Without ``overwrite``, when the directory holds files of a session already.
    NotADirectoryError
        When ``directory`` is a file.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.sessions import write_session
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> folder = write_session(sim, Path(tempfile.mkdtemp()) / "sim")
    >>> sorted(p.name for p in folder.iterdir())
    ['recording.csv', 'session.json', 'truth.json']
    >>> write_session(sim, folder, overwrite=False)
    Traceback (most recent call last):
        ...
    FileExistsError: /.../sim holds recording.csv, truth.json, session.json, which this ...
    """
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise NotADirectoryError(f"{d}: is a file; a session is written into a folder")
    there = [name for name in session_files(sim) if (d / name).exists() or (d / name).is_symlink()]
    if there and not overwrite:
        raise FileExistsError(f"{d} holds {', '.join(there[:4])}{' …' if len(there) > 4 else ''}, which this session "
                              "would overwrite: give a new folder, or overwrite them (simulate --force)")
    d.mkdir(parents=True, exist_ok=True)
    (d / "session.json").unlink(missing_ok=True)
    if isinstance(sim, WangSession):
        _write_turntable_session(sim, d)
        return d
    sessionfiles.write_recording(d / "recording.csv", sim.recording)
    for i, w in enumerate(sim.weightless):
        sessionfiles.write_recording(d / f"weightless_{i:03d}.csv", w)
    for i, ts in enumerate(sim.tests):
        sessionfiles.write_recording(d / f"test_{i:02d}.csv", ts.recording)
    sim.truth.save(d / "truth.json")
    meta = {
        "format": "imucalib.session", "format_version": 1,
        "scenario": sim.scenario, "seed": sim.seed, "noise": sim.noise, "options": sim.options,
        "units": {"accelerometer": sim.recording.acc_unit, "gyroscope": sim.recording.gyro_unit,
                  **({"magnetometer": sim.recording.mag_unit} if sim.recording.mag is not None else {})},
        "files": {
            "recording.csv": [s.to_dict() for s in sim.segments],
            **{f"weightless_{i:03d}.csv": [{"start": 0, "stop": len(w), "kind": "weightless"}]
               for i, w in enumerate(sim.weightless)},
            **{f"test_{i:02d}.csv": [s.to_dict() for s in ts.segments]
               for i, ts in enumerate(sim.tests)},
        },
    }
    write_meta(d / "session.json", meta)
    return d


def _write_turntable_session(sim: WangSession, d: Path) -> None:
    """The files of a wang2019 session (:func:`write_session`)."""
    write_table(d / "positions.csv", np.column_stack([sim.positions_acc, sim.positions_gyro]),
                 "ax,ay,az,gx,gy,gz")
    write_table(d / "turns.csv", np.column_stack([sim.turn_sum, sim.turn_sum2, sim.turn_angle]),
                 "sum_x,sum_y,sum_z,sum2_x,sum2_y,sum2_z,angle")
    sim.truth.save(d / "truth.json")
    meta = {"format": "imucalib.session", "format_version": 1, "scenario": sim.scenario,
            "seed": sim.seed, "turntable_error": sim.turntable_error,
            "latitude_deg": sim.latitude_deg, "options": sim.options,
            "files": {"positions.csv": "static position means [pulses/s]",
                      "turns.csv": "clockwise − counter-clockwise turn integrals"}}
    write_meta(d / "session.json", meta)


def read_session(directory: str | Path) -> Session | WangSession:
    """Read a directory written by :func:`write_session`: a :class:`Session`, or a ``WangSession``.

    Parameters
    ----------
    directory : str or Path
        The session directory (``session.json``, ``recording.csv``, ``truth.json`` …).

    Returns
    -------
    Session or WangSession
        The recording with its segments, weightless and test segments and truth; for the ``wang2019``
        scenario, the turntable's position and turn aggregates.

    Raises
    ------
    SessionFileError
        A fault in ``session.json`` or a table, naming the file and the entry or line (a :class:`ValueError`).

    Examples
    --------
    >>> import tempfile
    >>> from imucalib.sessions import read_session, write_session
    >>> from imucalib.scenarios import session
    >>> folder = tempfile.mkdtemp()
    >>> _ = write_session(session("handheld", rng=1), folder)
    >>> sim = read_session(folder)
    >>> sim.scenario, sim.truth.method
    ('handheld', 'truth')
    """
    d = Path(directory)
    meta = load_meta(d)
    meta_path = d / "session.json"
    truth = Calibration.load(d / "truth.json") if (d / "truth.json").is_file() else None
    if meta["scenario"] == "wang2019":  # turntable aggregates, not recordings
        pos = read_table(d / "positions.csv", 6)
        turns = read_table(d / "turns.csv", 7)
        return WangSession(positions_acc=pos[:, :3], positions_gyro=pos[:, 3:6], turn_sum=turns[:, :3],
                           turn_sum2=turns[:, 3:6], turn_angle=turns[:, 6], truth=truth,
                           latitude_deg=meta.get("latitude_deg", 0.0),
                           turntable_error=meta.get("turntable_error", ""), options=meta.get("options", {}),
                           seed=meta.get("seed"))
    units, files = meta["units"], meta["files"]

    def rec_and_segments(name):
        ivs = segments(meta_path, name, files[name])
        return read_recording(d / name, units, ivs), ivs

    rec, ivs = rec_and_segments("recording.csv")
    weightless = [rec_and_segments(n)[0] for n in sorted(files) if n.startswith("weightless_")]
    tests = [TossSequence(*rec_and_segments(n)) for n in sorted(files) if n.startswith("test_")]
    return Session(scenario=meta["scenario"], seed=meta.get("seed"), recording=rec,
                   segments=ivs, truth=truth, weightless=weightless,
                   tests=tests, noise=meta.get("noise", {}), options=meta.get("options", {}))
