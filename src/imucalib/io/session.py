"""The simulated-session directory format: the session records, writing them, reading them back.

A session (:class:`Session`: raw recordings, the truth and the segment layout; or a
:class:`WangSession` of turntable aggregates) is what a simulator
(:mod:`imucalib.scenarios`) makes and what :func:`imucalib.io.data.read_data` reads back from a
directory, so the format sits below both: reading a session needs no simulator.

``session.json`` is checked entry by entry: every fault is a :class:`SessionFileError` (a ValueError)
naming the file and the entry or line, never a KeyError or numpy's own text.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..calibration import Calibration
from ..constants import G0
from ..recording import ACC_UNITS, GYRO_UNITS, Interval, Recording
from .atomic import atomic_write
from .jsontext import JsonTextError, dumps, loads
from .magnetometer import attach_magnetometer

__all__ = ["Session", "SessionFileError", "TossSequence", "WangSession", "load_meta", "read_recording",
           "read_session", "read_table", "segments", "session_files", "write_session"]


@dataclass
class TossSequence:
    """One RD3 toss: the raw recording and its segments (static, motion, weightless)."""

    recording: Recording
    segments: list[Interval]


@dataclass
class Session:
    """A simulated session: raw recordings, the truth and the segment layout."""

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


class SessionFileError(ValueError):
    """A simulated session directory that cannot be read; the message names the file and entry."""


def _kind(value) -> str:
    if value is None:
        return "null"
    return {dict: "an object", list: "a list", str: "a string", bool: "true/false", int: "a number",
            float: "a number"}.get(type(value), type(value).__name__)


def load_meta(directory: Path) -> dict:
    """``session.json`` of ``directory``, checked: its format, scenario, units and files."""
    path = directory / "session.json"
    if not path.is_file():
        raise SessionFileError(f"{directory}: not a simulated session directory (no session.json)")
    try:
        meta = loads(path.read_bytes().decode("utf-8-sig"))
    except UnicodeDecodeError:
        raise SessionFileError(f"{path}: not a text file") from None
    except json.JSONDecodeError as exc:
        raise SessionFileError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})") \
            from None
    except JsonTextError as exc:
        raise SessionFileError(f"{path}: not a session file: {exc}") from None
    if not isinstance(meta, dict):
        raise SessionFileError(f"{path}: expected a JSON object; got {_kind(meta)}")
    if meta.get("format") != "imucalib.session":
        raise SessionFileError(f"{path}: not an imucalib session file ('format' is "
                               f"{json.dumps(meta.get('format'))}, not \"imucalib.session\")")
    if not isinstance(meta.get("scenario"), str):
        raise SessionFileError(f"{path}: 'scenario': expected a string; got {_kind(meta.get('scenario'))}")
    files = meta.get("files")
    if not isinstance(files, dict):
        raise SessionFileError(f"{path}: 'files': expected an object naming the session's files; "
                               f"got {_kind(files)}")
    for name in files:
        if not (directory / name).is_file():
            raise SessionFileError(f"{path}: 'files' names {name}, which is not in {directory}")
    if meta["scenario"] == "wang2019":
        for name in ("positions.csv", "turns.csv"):
            if name not in files:
                raise SessionFileError(f"{path}: 'files' lacks {name}, which a wang2019 session has")
        return meta
    units = meta.get("units")
    if not isinstance(units, dict):
        raise SessionFileError(f"{path}: 'units': expected an object {{\"accelerometer\": …, \"gyroscope\": …}}; "
                               f"got {_kind(units)}" if units is not None else
                               f"{path}: lacks 'units' (the raw units of the recordings)")
    for sensor, allowed in (("accelerometer", ACC_UNITS), ("gyroscope", GYRO_UNITS)):
        if units.get(sensor) not in allowed:
            raise SessionFileError(f"{path}: 'units.{sensor}': expected one of {', '.join(allowed)}; got "
                                   f"{json.dumps(units.get(sensor))}")
    if "recording.csv" not in files:
        raise SessionFileError(f"{path}: 'files' lacks recording.csv, the session's main recording")
    for name, value in files.items():
        segments(path, name, value)
    return meta


def segments(path: Path, name: str, value) -> list[Interval]:
    """The intervals listed for file ``name`` in ``session.json`` (``path``), checked."""
    where = f"{path}: 'files.{name}'"
    if not isinstance(value, list):
        raise SessionFileError(f"{where}: expected a list of segments; got {_kind(value)}")
    out = []
    for k, s in enumerate(value):
        ok = (isinstance(s, dict) and all(type(s.get(key)) is int for key in ("start", "stop"))
              and isinstance(s.get("kind", "static"), str))
        if not ok or not 0 <= s["start"] < s["stop"]:
            raise SessionFileError(f"{where}, segment {k + 1}: expected {{\"start\": i, \"stop\": j, \"kind\": …}} "
                                   f"with 0 <= i < j; got {json.dumps(s)[:80]}")
        out.append(Interval(s["start"], s["stop"], s.get("kind", "static")))
    return out


def read_table(path: Path, ncols: int) -> np.ndarray:
    """A comma-separated table of ``ncols`` finite numbers a row after one header line."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError:
        raise SessionFileError(f"{path}: not a text file") from None
    rows = []
    for i, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        if len(cells) != ncols:
            raise SessionFileError(f"{path}: line {i}: expected {ncols} values, found {len(cells)}")
        try:
            row = [float(c) for c in cells]
        except ValueError:
            raise SessionFileError(f"{path}: line {i}: a value is not a number") from None
        if not all(np.isfinite(row)):
            raise SessionFileError(f"{path}: line {i}: a value is not finite (NaN or inf)")
        rows.append(row)
    if not rows:
        raise SessionFileError(f"{path}: no rows after the header")
    return np.array(rows, dtype=np.float64)


def read_recording(path: Path, units: dict, intervals: list[Interval]) -> Recording:
    """One recording of the session (``t,ax,ay,az,gx,gy,gz`` in the session's units), its segments checked."""
    from .readers import read  # imucalib.io.readers costs 54 ms at start-up

    rec = read(path, reader="csv", columns=["t", "ax", "ay", "az", "gx", "gy", "gz"],
               acc_unit=units["accelerometer"], gyro_unit=units["gyroscope"], time_unit="s")
    for iv in intervals:
        if iv.stop > len(rec):
            raise SessionFileError(f"{path}: session.json gives it a segment up to sample {iv.stop}, but it has "
                                   f"{len(rec)} samples")
    rec = attach_magnetometer(rec, units.get("magnetometer") if "mx" in rec.extra else None)
    return Recording(rec.t, rec.acc, rec.gyro, acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit,
                     metadata={"source": [str(path)]}, temperature=rec.temperature, mag=rec.mag,
                     mag_unit=rec.mag_unit)


# ------------------------------------------------------------------ writing
def _write_table(path: Path, data: np.ndarray, header: str) -> None:
    """A CSV of numbers at full precision, through a temporary file moved into place."""
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        np.savetxt(fh, data, delimiter=",", fmt="%.17g", header=header, comments="")


def _write_meta(path: Path, meta: dict) -> None:
    """``session.json``, written last: a session is complete when it is there."""
    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write(dumps(meta, indent=1) + "\n")


def _write_rec(path: Path, rec: Recording) -> None:
    cols, names = [rec.t, rec.acc, rec.gyro], "t,ax,ay,az,gx,gy,gz"
    if rec.mag is not None:
        cols.append(rec.mag)
        names += ",mx,my,mz"
    if rec.temperature is not None:
        cols.append(rec.temperature)
        names += ",temperature"
    _write_table(path, np.column_stack(cols), names)


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
    _write_rec(d / "recording.csv", sim.recording)
    for i, w in enumerate(sim.weightless):
        _write_rec(d / f"weightless_{i:03d}.csv", w)
    for i, ts in enumerate(sim.tests):
        _write_rec(d / f"test_{i:02d}.csv", ts.recording)
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
    _write_meta(d / "session.json", meta)
    return d


def _write_turntable_session(sim: WangSession, d: Path) -> None:
    """The files of a wang2019 session (:func:`write_session`)."""
    _write_table(d / "positions.csv", np.column_stack([sim.positions_acc, sim.positions_gyro]),
                 "ax,ay,az,gx,gy,gz")
    _write_table(d / "turns.csv", np.column_stack([sim.turn_sum, sim.turn_sum2, sim.turn_angle]),
                 "sum_x,sum_y,sum_z,sum2_x,sum2_y,sum2_z,angle")
    sim.truth.save(d / "truth.json")
    meta = {"format": "imucalib.session", "format_version": 1, "scenario": sim.scenario,
            "seed": sim.seed, "turntable_error": sim.turntable_error,
            "latitude_deg": sim.latitude_deg, "options": sim.options,
            "files": {"positions.csv": "static position means [pulses/s]",
                      "turns.csv": "clockwise − counter-clockwise turn integrals"}}
    _write_meta(d / "session.json", meta)


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
    >>> from imucalib.io.session import read_session, write_session
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
