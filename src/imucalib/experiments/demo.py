"""``imucalib demo``: the main job on a simulated sensor whose truth is known, start to finish.

A hand-held session of an MPU-6050-like IMU in raw counts (:mod:`imucalib.scenarios.handheld`) is written to
a folder as a recording would be, calibrated with the default method, written as ``calib.json`` and an HTML
report, applied to its own recording, and the corrected readings compared with the true ones: the
story a user follows with a real recording (``imucalib calibrate``, ``imucalib apply``), with the truth to
check it against.

"Before" is what one gets without a calibration: the readings converted by the datasheet's nominal factors
(MPU-6050 Product Specification rev. 3.4, §6.1 and §6.2: 16384 counts/g, 131 counts/(°/s), no bias), the
:data:`~imucalib.scenarios.handheld.ACC_COUNTS_PER_G` and
:data:`~imucalib.scenarios.handheld.GYRO_COUNTS_PER_DPS` the simulator draws its sensor around.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..calibration import Calibration
from ..metrics import gravity_direction_errors
from ..models import TriadModel
from ..recording import Interval

__all__ = ["DemoErrors", "DemoResult", "demo_files", "run_demo"]

#: the files the demo writes into its folder, besides the session folder
DEMO_FILES = ("calib.json", "calibrated.csv", "report.html")


@dataclass(frozen=True)
class DemoErrors:
    """Errors against the truth of one way of reading the sensor (the datasheet's factors, or a calibration).

    Attributes
    ----------
    accelerometer_mg : float
        The largest error of a static pose's mean specific force, ``max ‖a − a_true‖`` over the poses [mg].
    gyroscope_dps : float
        The largest error of the angular rate at rest, ``max ‖ω − ω_true‖`` over the poses' means [°/s].
    angle_deg : float or None
        The mean gravity-direction error after each rotation between poses (the gyroscope's integrated
        attitude against the accelerometer's gravity, :func:`imucalib.metrics.gravity_direction_errors`)
        [deg]; None without rotations.
    """

    accelerometer_mg: float
    gyroscope_dps: float
    angle_deg: float | None


@dataclass(frozen=True)
class DemoResult:
    """What :func:`run_demo` did and found.

    Attributes
    ----------
    seed : int
        The simulated session's seed.
    folder : Path
        Where the files were written.
    files : tuple of Path
        The session folder, the calibration file, the calibrated CSV and the report.
    duration_s, rate_hz : float
        The recording's length [s] and sampling rate [Hz].
    poses : int
        Static poses the calibration found.
    method : str
        The calibration's method (the command line's default).
    verdict : str
        ``accepted``, ``suspect`` or ``rejected``.
    reasons : list of str
        The verdict's reasons.
    residual_rms, noise_floor : float or None
        ``|a| − g`` RMS over the poses after calibration and its white-noise floor [m/s²].
    before, after, truth : DemoErrors
        The datasheet's factors, the calibration, and the true parameters themselves (whose angle error is
        the floor the noise leaves).
    seconds : float
        Wall time of the whole run [s].
    """

    seed: int
    folder: Path
    files: tuple[Path, ...]
    duration_s: float
    rate_hz: float
    poses: int
    method: str
    verdict: str
    reasons: list[str]
    residual_rms: float | None
    noise_floor: float | None
    before: DemoErrors
    after: DemoErrors
    truth: DemoErrors
    seconds: float

    def to_dict(self) -> dict:
        """The result as plain JSON types."""
        out = {k: getattr(self, k) for k in self.__dataclass_fields__}
        out["folder"] = str(self.folder)
        out["files"] = [str(f) for f in self.files]
        for k in ("before", "after", "truth"):
            out[k] = dict(vars(out[k]))
        return out


def demo_files(folder: str | Path) -> list[Path]:
    """The paths :func:`run_demo` writes into ``folder`` that exist already (the session's and its own)."""
    d = Path(folder)
    return [d / name for name in (*DEMO_FILES, "session") if (d / name).exists()]


def _nominal(truth: Calibration) -> Calibration:
    """The datasheet's reading of the sensor: nominal scale factors, no bias, no misalignment."""
    # imucalib.scenarios.handheld costs 26 ms at start-up
    from ..scenarios.handheld import ACC_COUNTS_PER_G, GYRO_COUNTS_PER_DPS

    acc = TriadModel(scale=np.full(3, truth.gravity / ACC_COUNTS_PER_G))
    gyro = TriadModel(scale=np.full(3, math.radians(1.0 / GYRO_COUNTS_PER_DPS)))
    return truth.with_(accelerometer=acc, gyroscope=gyro, lever_arm=None)


def _errors(cal: Calibration, truth: Calibration, rec, intervals: list[Interval]) -> DemoErrors:
    """:class:`DemoErrors` of ``cal`` against ``truth`` on the poses ``intervals`` of ``rec``."""
    acc_mean = np.array([rec.acc[iv.slice].mean(axis=0) for iv in intervals])
    gyro_mean = np.array([rec.gyro[iv.slice].mean(axis=0) for iv in intervals])
    da = cal.accelerometer_si(acc_mean) - truth.accelerometer_si(acc_mean)
    dg = cal.gyroscope_si(gyro_mean, acc_mean) - truth.gyroscope_si(gyro_mean, acc_mean)
    angles = gravity_direction_errors(cal, rec, intervals) if len(intervals) > 1 else np.array([])
    return DemoErrors(accelerometer_mg=float(np.max(np.linalg.norm(da, axis=1)) / truth.gravity * 1e3),
                      gyroscope_dps=float(np.degrees(np.max(np.linalg.norm(dg, axis=1)))),
                      angle_deg=float(np.degrees(np.mean(angles))) if angles.size else None)


def run_demo(folder: str | Path = "imucalib-demo", seed: int = 0, *, overwrite: bool = False,
             progress: Callable[[str], None] | None = None) -> DemoResult:
    """Simulate a hand-held session, calibrate it, apply the calibration and compare both with the truth.

    Parameters
    ----------
    folder : str or Path
        Where to write ``session/`` (the simulated recording, :func:`imucalib.scenarios.write_session`),
        ``calib.json``, ``calibrated.csv`` (the recording with the calibrated columns appended, as
        ``imucalib apply`` writes it) and ``report.html``; created if missing.
    seed : int
        Seed of the simulated sensor and session.
    overwrite : bool
        Replace those files when the folder holds them already; by default they are refused.
    progress : callable, optional
        Called with a short message before each stage.

    Returns
    -------
    DemoResult
        The files written, the calibration's verdict and the errors against the truth before and after.

    Raises
    ------
    FileExistsError
        If ``folder`` holds files the demo writes and ``overwrite`` is false.

    Examples
    --------
    >>> import tempfile
    >>> from imucalib.experiments.demo import run_demo
    >>> result = run_demo(tempfile.mkdtemp(), seed=0)  # doctest: +SKIP
    >>> result.verdict, result.after.accelerometer_mg < result.before.accelerometer_mg  # doctest: +SKIP
    ('accepted', True)
    """
    from ..io import write_csv  # imucalib.io costs 38 ms at start-up
    from ..methods import calibrate  # imucalib.methods costs 114 ms at start-up
    from ..report import html_report  # imucalib.report costs 24 ms at start-up
    from ..scenarios import read_session, session, write_session  # imucalib.scenarios costs 31 ms at start-up

    say = progress or (lambda msg: None)
    t0 = time.perf_counter()
    out = Path(folder)
    there = demo_files(out)
    if there and not overwrite:
        raise FileExistsError(f"{out} holds {', '.join(p.name for p in there)}, which the demo writes: give another "
                              "folder with -o, or replace them with --force")
    say("simulating a hand-held session")
    sim = session("handheld", rng=seed)
    write_session(sim, out / "session", overwrite=True)
    rec = read_session(out / "session").recording
    truth = sim.truth
    say("calibrating")
    cal = calibrate(rec)
    cal.save(out / "calib.json")
    intervals = [Interval(a, b) for a, b in cal.fit.poses.intervals]
    say("writing the report")
    html_report(cal, out / "report.html", recording=rec, intervals=intervals,
                title=f"imucalib demo: the simulated session of seed {seed}")
    say("applying the calibration")
    applied = cal.apply(rec)
    write_csv(out / "calibrated.csv", rec, calibrated_acc=applied.acc, calibrated_gyro=applied.gyro)
    fit = cal.fit
    return DemoResult(
        seed=seed, folder=out, files=(out / "session", *(out / name for name in DEMO_FILES)),
        duration_s=float(rec.duration), rate_hz=float(rec.rate), poses=len(intervals), method=cal.method,
        verdict=str(fit.verdict.level), reasons=list(fit.verdict.reasons or []),
        residual_rms=fit.accelerometer.residual_rms, noise_floor=fit.accelerometer.noise_floor,
        before=_errors(_nominal(truth), truth, rec, intervals), after=_errors(cal, truth, rec, intervals),
        truth=_errors(truth, truth, rec, intervals), seconds=time.perf_counter() - t0)
