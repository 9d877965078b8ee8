"""Qureshi & Golnaraghi (IEEE Sensors J. 2017): in-field calibration of a MEMS IMU.

Accelerometer (§III-A): the 9-parameter model ``A^o = K T_s^o (A^s − B)``
(eqs. 2–8; canonically ``T_a diag(k1) = K T_s^o``, see :mod:`imucalib.conventions`)
fitted on interval means (eq. 11)::

    G(X) = Σ_k (‖h(Ā_k, X)‖² − g²)²,   X = [b, k, k_xy, k_xz, k_yz]

by Newton's method with a backtracking line search (eq. 12), from the relaxed
six-position estimate ``k = (a_up − a_down)/(2g)``, ``b = (a_up + a_down)/2``
(eqs. 13–14) with the up/down poses found automatically (:func:`imucalib.segment.find_faces`).

Gyroscope (§III-B), ``ω = K(ω^s − B)`` (eq. 15): rotations about each sensitive
axis between static poses; the angle of each rotation is measured by the
calibrated accelerometer (appendix, eqs. 22–28: the tilt change about a
horizontal axis, computed here as the signed angle between the gravity
directions before and after, about the rotation axis). Then either

* ``"static"`` — ``b`` is the mean of the initial rest and
  ``k_i = Δθ_ik / ((ω̄_ik − b_i) T_k)`` (eq. 18), combined over the rotations
  ``k`` about axis ``i`` by least squares; or
* ``"dynamic"`` — ``[ω̄_ik T_k, −T_k] [k_i, k_i b_i]ᵀ = Δθ_ik`` solved by least
  squares for ``k_i`` and ``b_i`` together (eqs. 19–21).

``fit.uncertainty.sigma``: the accelerometer's 1σ errors from the gravity-norm
residuals' Jacobian at the solution (as :mod:`.tedaldi2014`), the
gyroscope's from each axis's least-squares regression over its turns (NaN
with as many turns as unknowns).

A rotation counts for axis ``i`` when its integrated raw rate lies within 20°
of that axis, the axis is at least 45° from gravity and the turn is below
170° (a half turn's sign is ambiguous); turns whose eq. (18) scale differs
from the axis's median by more than 10 % are left out as not clean (the accelerometer
cannot see rotations about gravity, hence the paper's Fig. 2 sequence that
turns ``z`` horizontal first).
"""

from __future__ import annotations

import numpy as np

from ..assembly import assemble
from ..calibration import Calibration
from ..conventions import from_qureshi, to_qureshi
from ..fit.accelerometer import accelerometer_errors, newton_backtracking, six_position
from ..fit.gyroscope import fit_measured_rotations, rotation_angles
from ..fitreport import GyroscopeReport, MethodReport
from ..methodinfo import MethodInfo, Option
from ..metrics import interval_means
from ..models import TriadModel
from ..presets import MIN_HOLD
from ..segment import find_faces, static_poses

METHOD = MethodInfo(
    name="qureshi2017",
    summary="9-parameter accelerometer by Newton's method on the interval means (18 orientations); "
            "gyroscope bias and scale from turns about each horizontal axis, static-bias or dynamic approach",
    needs=("static poses", "rotations", "gyroscope"),
    models=("linear",),
    options=(
        Option("intervals", None, "samples", "static intervals given instead of found"),
        Option("gyroscope", "static", "", "how the gyroscope's rotations are measured (§III-B)"),
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
        Option("min_hold", 1.0, "s", "shortest hold that is a pose (sets the static detector's window)"),
    ),
    paper="qureshi2017_infield_calibration.md (Qureshi & Golnaraghi, IEEE Sensors J. 2017), §III",
)

__all__ = ["calibrate", "calibrate_accelerometer"]


def calibrate_accelerometer(means: np.ndarray, gravity: float) -> tuple[TriadModel, dict]:
    """The 9-parameter accelerometer of Qureshi 2017 on static means: eqs. (13)-(14), then eqs. (11)-(12)."""
    faces = find_faces(means, gravity, max_tilt=30.0)
    relaxed = six_position(means[faces[:3], np.arange(3)], means[faces[3:], np.arange(3)], gravity)
    # X = [b, k, k_xy, k_xz, k_yz] with k in m/s² per raw unit (eq. 5's K)
    x0 = np.concatenate([relaxed.bias, relaxed.scale, np.zeros(3)])
    if means.shape[0] < 9:
        raise ValueError(f"the 9-parameter model needs at least 9 static poses; got {means.shape[0]}")
    x, iterations = newton_backtracking(x0, means, gravity)
    return from_qureshi(x), {"newton_iterations": iterations, "X": x.tolist(),
                             "X_initial": x0.tolist()}


def calibrate(recording, *, gravity: float, intervals=None, gyroscope: str = "static",
              init_static: float | None = None, min_hold: float = MIN_HOLD) -> Calibration:
    """Qureshi 2017: Newton accelerometer fit, then gyroscope scales from accelerometer-measured turns.

    Parameters
    ----------
    recording : Recording or Session
        The recording: an initial rest, then static poses with rotations between them.
    gravity : float
        Local gravity [m/s²].
    intervals : list of Interval, optional
        The static poses as sample ranges; by default found by the method's detector.
    gyroscope : {"static", "dynamic"}
        The static-bias approach (eq. 18) or the dynamic approach (eqs. 19–21).
    init_static : float, optional
        Length of the initial rest [s]; by default found automatically.

    Returns
    -------
    Calibration
        The calibration, with its fit figures, 1σ errors and verdict in ``fit``.

    Raises
    ------
    ValueError
        When the poses lack one of the six faces (each axis up and down within 30°), or for an unknown
        ``gyroscope``.

    Examples
    --------
    The six faces and the turns between them of a simulated Ferraris procedure:

    >>> from imucalib.methods import qureshi2017
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, procedure="ferraris", rest=5)
    >>> cal = qureshi2017.calibrate(sim.recording, gravity=sim.truth.gravity)
    >>> (cal.accelerometer.scale / sim.truth.accelerometer.scale).round(3)
    array([1., 1., 1.])
    >>> # the gyroscope's, from the turns the accelerometer measures:
    >>> (cal.gyroscope.scale / sim.truth.gyroscope.scale).round(2)
    array([1.  , 0.99, 1.01])
    """
    if gyroscope not in ("static", "dynamic"):
        raise ValueError(f"gyroscope must be 'static' or 'dynamic'; got {gyroscope!r}")
    intervals = static_poses(recording, gravity, intervals, init_static=init_static, min_hold=min_hold)
    means = interval_means(recording.acc, intervals)
    acc, info = calibrate_accelerometer(means, gravity)
    rest_bias = recording.gyro[intervals[0].slice].mean(axis=0)
    rotations = rotation_angles(recording, intervals, acc, rest_bias)
    k, b, gyro_errors, rejected = fit_measured_rotations(rotations, rest_bias, gyroscope)
    gyro = TriadModel(scale=k, bias=b, shape="full")
    figures = [MethodReport(newton_iterations=info["newton_iterations"], qureshi_X=to_qureshi(acc).tolist()),
               GyroscopeReport(approach=gyroscope, rotations_rejected=rejected,
                               rotations_used=[sum(r["axis"] == i for r in rotations) - rejected[i] for i in range(3)])]
    return assemble("qureshi2017", recording, intervals, acc, gyro, gravity=gravity, figures=figures,
                    uncertainty=accelerometer_errors(acc, means, gravity) | gyro_errors)
