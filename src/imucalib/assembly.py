"""A method's calibration put together: the record, the fit report every method gives, the method's own figures.

Every method of :mod:`imucalib.methods` ends the same way: the calibration record of its models (with the
recording's units), the figures every calibration carries (:func:`imucalib.metrics.fit_summary`: the poses,
the residual and its noise floor, the gyroscope's angle errors, what to record next), its own records of the
fit report (:mod:`imucalib.fitreport`) and its parameters' 1σ errors, and, when the gyroscope was left
uncalibrated, why. :func:`assemble` does that once for all of them; the verdict is added after the stages
that follow every method (the magnetometer, the bias drift's session), by :func:`imucalib.verdict.with_verdict`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from .calibration import Calibration, units_of
from .fitreport import GyroscopeReport, SegmentationReport, UncertaintyReport
from .kinematics import IntervalIntegrator
from .metrics import fit_summary
from .models import TriadModel
from .recording import Interval, Recording

__all__ = ["POSES_IN_BLOCKS", "assemble", "rest_seconds"]

#: why the gyroscope of a recording whose poses are separate blocks (no motion between them) is not calibrated
POSES_IN_BLOCKS = ("the poses were recorded as separate blocks, with no motion between them: the rotations that "
                   "calibrate the gyroscope were not recorded")


def rest_seconds(recording: Recording, rest: Interval) -> SegmentationReport:
    """The length of the initial rest used for the noise, as the fit report holds it."""
    return SegmentationReport(initial_rest_seconds=float(recording.t[rest.stop - 1] - recording.t[rest.start]))


def assemble(method: str, recording: Recording, intervals: Sequence[Interval], accelerometer: TriadModel,
             gyroscope: TriadModel | None, *, gravity: float, model: str = "linear",
             lever_arm: np.ndarray | None = None, figures: Iterable = (), uncertainty: Mapping | None = None,
             not_calibrated: str | None = None, left_out: Mapping[int, str] | None = None,
             unreliable: Mapping[int, str] | None = None, integrator: IntervalIntegrator | None = None
             ) -> Calibration:
    """The calibration a method returns, with its fit report.

    Parameters
    ----------
    method, model : str
        The method's name and its model variant.
    recording : Recording
        The recording calibrated (its units are the calibration's raw units).
    intervals : sequence of Interval
        The static poses the method used.
    accelerometer, gyroscope : TriadModel
        The fitted models (``gyroscope`` None: not calibrated, ``not_calibrated`` says why).
    gravity : float
        Local gravity [m/s²].
    lever_arm : (3,) ndarray, optional
        The accelerometer's lever arm, when the method fits one.
    figures : iterable of records or FitReport
        The method's own records of the fit report (:mod:`imucalib.fitreport`), added in order after the
        figures every method gives.
    uncertainty : mapping, optional
        1σ errors by parameter name, added to those the figures hold.
    not_calibrated : str, optional
        Why the gyroscope was left uncalibrated (e.g. :data:`POSES_IN_BLOCKS`); ``left_out``: the rotations
        left out as unreliable, by index, and why.
    unreliable : mapping, optional
        The rotations whose integration the data do not allow, by index, and why
        (:func:`imucalib.segment.unreliable_transitions`), when the method found them: the verdict judges
        the gyroscope on the others without finding them again.
    integrator : IntervalIntegrator, optional
        The integrator of the rotations between the poses, when the gyroscope's fit has one.

    Returns
    -------
    Calibration
        With ``fit`` holding the figures every method gives, then ``figures``, the 1σ errors and why the
        gyroscope was not calibrated.

    Examples
    --------
    A method's ending, here with the simulation's true models in place of fitted ones (no verdict yet: the
    registry judges the calibration after the magnetometer):

    >>> from imucalib.assembly import assemble
    >>> from imucalib.fitreport import MethodReport
    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> cal = assemble("tedaldi2014", sim.recording, intervals, sim.truth.accelerometer, sim.truth.gyroscope,
    ...                gravity=sim.truth.gravity, figures=[MethodReport(converged=True)])
    >>> cal.fit.poses.static_intervals, cal.fit.method.converged, cal.fit.verdict.level
    (15, True, None)
    """
    cal = Calibration(accelerometer=accelerometer, gyroscope=gyroscope, lever_arm=lever_arm, gravity=gravity,
                      method=method, model=model, units=units_of(recording))
    fit = fit_summary(cal, recording, intervals, gravity, integrator=integrator)
    if unreliable is not None and gyroscope is not None:
        fit = fit.add(GyroscopeReport(rotations_unreliable=dict(sorted(unreliable.items()))))
    if not_calibrated:
        fit = fit.add(GyroscopeReport(not_calibrated=not_calibrated))
        if left_out:
            fit = fit.add(GyroscopeReport(rotations_left_out=dict(sorted(left_out.items()))))
    fit = fit.add(*figures)
    if uncertainty is not None:
        fit = fit.add(UncertaintyReport(sigma={**(fit.uncertainty.sigma or {}), **uncertainty}))
    return cal.with_(fit=fit)
