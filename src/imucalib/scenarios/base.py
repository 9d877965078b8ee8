"""What every simulated session shares: the session record, the distortion by a true calibration, pose plans.

Raw readings are made by distorting true signals with a true
:class:`~imucalib.calibration.Calibration` (Zhang 2021, eqs. 31–32: the exact
inverse of the canonical model), then Gaussian noise, quantisation and
saturation. Everything is deterministic for a given seed.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..calibration import Calibration
from ..io.atomic import atomic_write
from ..io.jsontext import dumps
from ..kinematics import integrate, quat_from_rotvec, quat_to_matrix
from ..recording import ImucalibWarning, Interval, Recording

if TYPE_CHECKING:
    from .wang2019 import WangSession

__all__ = ["DEFAULT_NOISE", "Session", "TossSequence", "attitude_with_up", "distort", "noise_levels", "session_files",
           "pose_session", "read_session", "turns_between", "write_session"]

#: default per-sample noise: σ_a [m/s²], σ_g [rad/s] (ICM-42605-like at 100 Hz)
DEFAULT_NOISE = {"accelerometer": 0.005, "gyroscope": 0.0005}


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


# ------------------------------------------------------------ distortion
def noise_levels(noise) -> dict:
    if noise is None:
        return dict(DEFAULT_NOISE)
    if isinstance(noise, int | float):
        return {"accelerometer": float(noise), "gyroscope": float(noise)}
    unknown = set(noise) - {"accelerometer", "gyroscope"}
    if unknown:
        raise ValueError(f"noise keys must be 'accelerometer' and 'gyroscope'; got {sorted(unknown)}")
    out = dict(DEFAULT_NOISE)
    out.update({k: float(v) for k, v in noise.items()})
    if any(v < 0 for v in out.values()):
        raise ValueError(f"noise levels must be ≥ 0; got {out}")
    return out


def distort(truth: Calibration, a: np.ndarray, w: np.ndarray, rng, noise: dict,
             full_scale: dict | None, lsb: dict | None) -> tuple[np.ndarray, np.ndarray]:
    """Raw readings from true specific force and rate (Zhang 2021, eqs. 31–32)."""
    acc = truth.accelerometer.inverse(a)  # eq. (31)
    gyro = truth.gyroscope.inverse(w, a)  # eq. (32): includes G·a
    if noise["accelerometer"]:
        acc = acc + rng.normal(size=acc.shape) * (noise["accelerometer"] / truth.accelerometer.scale)
    if noise["gyroscope"]:
        gyro = gyro + rng.normal(size=gyro.shape) * (noise["gyroscope"] / truth.gyroscope.scale)
    for name, arr in (("accelerometer", acc), ("gyroscope", gyro)):
        if lsb and lsb.get(name):
            arr[:] = np.round(arr / lsb[name]) * lsb[name]
        if full_scale and full_scale.get(name) is not None:
            limit = float(full_scale[name])
            clipped = int(np.count_nonzero(np.abs(arr) > limit))
            if clipped:
                np.clip(arr, -limit, limit, out=arr)
                warnings.warn(f"{clipped} {name} values beyond ±{limit:g} (raw) were clipped, "
                              "as a saturated sensor would report them", ImucalibWarning,
                              stacklevel=3)
    return acc, gyro


# ------------------------------------------------------------------ files
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
    from .wang2019 import WangSession

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
    from .wang2019 import WangSession

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

    A fault in ``session.json`` or a table is a ValueError naming the file and the entry or line
    (:mod:`.sessionfile`).
    """
    from .sessionfile import load_meta, read_recording, read_table, segments

    d = Path(directory)
    meta = load_meta(d)
    meta_path = d / "session.json"
    truth = Calibration.load(d / "truth.json") if (d / "truth.json").is_file() else None
    if meta["scenario"] == "wang2019":  # turntable aggregates, not recordings
        from .wang2019 import WangSession

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


# ------------------------------------------------------- pose/turn sessions
def turns_between(directions: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Body-frame turns (unit axis, angle [rad]) carrying gravity through ``directions``.

    A body turning by ``θ`` about ``n`` sees a fixed vector turn by ``−θ``, so the
    shortest turn from body gravity direction ``a₀`` to ``a₁`` is ``−θ`` about
    ``a₀ × a₁`` (any perpendicular axis for opposite directions).
    """
    d = np.asarray(directions, dtype=float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    out = []
    for a0, a1 in zip(d[:-1], d[1:], strict=True):
        axis = np.cross(a0, a1)
        if np.linalg.norm(axis) < 1e-12:
            axis = np.cross(a0, [1.0, 0, 0] if abs(a0[0]) < 0.9 else [0, 1.0, 0])
        angle = float(np.arctan2(np.linalg.norm(np.cross(a0, a1)), a0 @ a1))
        out.append((-axis / np.linalg.norm(axis), angle))
    return out


def attitude_with_up(direction: np.ndarray) -> np.ndarray:
    """Quaternion of an attitude whose body vector ``direction`` points up (world +z)."""
    d0 = np.asarray(direction, dtype=float)
    d0 = d0 / np.linalg.norm(d0)
    axis = np.cross(d0, [0.0, 0.0, 1.0])
    angle = np.arctan2(np.linalg.norm(axis), d0[2])
    if np.linalg.norm(axis) < 1e-12:
        return quat_from_rotvec(np.array([np.pi if d0[2] < 0 else 0.0, 0.0, 0.0]))
    return quat_from_rotvec(axis / np.linalg.norm(axis) * angle)


def pose_session(truth: Calibration, turns, *, rng=None, up: np.ndarray | None = None,
                 rest: float = 5.0, hold: float = 2.0, move: float = 1.5, rate: float = 100.0,
                 noise=None) -> tuple[Recording, list[Interval]]:
    """A rest, then static holds joined by smooth body-frame turns.

    Each turn ``(axis, angle)`` is a rotation about the body axis with a
    ``sin²`` rate profile over ``move`` seconds; the attitude is the RK4
    integral of the sampled rates, so noise-free gravity directions and gyro
    integration agree exactly. Returns the raw recording and the static
    intervals (the rest first).
    """
    rng = np.random.default_rng(rng)
    noise = noise_levels(noise)
    dt = 1.0 / rate
    n_rest, n_hold, n_move = int(round(rest * rate)), int(round(hold * rate)), int(round(move * rate))
    blocks = [np.zeros((n_rest, 3))]
    intervals = [Interval(0, n_rest, "static")]
    pos = n_rest
    tau = (np.arange(n_move) + 0.5) / n_move
    bump = np.sin(np.pi * tau) ** 2
    for axis, angle in turns:
        axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
        blocks += [np.outer(bump / bump.sum() * angle / dt, axis), np.zeros((n_hold, 3))]
        intervals.append(Interval(pos + n_move, pos + n_move + n_hold, "static"))
        pos += n_move + n_hold
    w = np.concatenate(blocks)
    t = np.arange(w.shape[0]) * dt
    q0 = attitude_with_up(np.array([0.0, 0.0, 1.0]) if up is None else up)
    q = integrate(t, w, q0)
    a = np.einsum("nji,j->ni", quat_to_matrix(q), np.array([0.0, 0.0, truth.gravity]))  # Rᵀ g
    acc, gyro = distort(truth, a, w, rng, noise, None, None)
    units = truth.units
    return Recording(t, acc, gyro, acc_unit=units["accelerometer"]["raw"],
                     gyro_unit=units["gyroscope"]["raw"]), intervals


