"""The six-position method (Ru 2022, §3.1, eqs. 8–9).

Each accelerometer axis is held along gravity, up and then down; with the raw
readings ``u_up`` and ``u_down`` of that axis::

    b = (u_up + u_down) / 2                          (eq. 8)
    s = (u_up − u_down) / (2 g)   (raw per m/s²)     (eq. 9)

so the canonical scale is ``k1 = 1/s`` and the bias ``b``; the review's method
ignores misalignment (``T_a = I``) and nonlinearity. The six faces are found
automatically among the static poses: after a sphere fit centres the data, the
pose whose direction is closest to ``+x`` (``−x``, …) is that face, and it must
lie within ``max_tilt`` degrees of the axis — otherwise the recording does not
hold that face and the method says which faces are missing. A face a few
degrees off its axis is corrected for its tilt (measured by the
directions the calibration gives, to a fixed point;
:func:`imucalib.fit.accelerometer.six_position`), which eq. 9 as
printed is not; ``fit.poses.faces_tilt_deg`` says by how much. The gyroscope
comes from the static poses and the rotations between them together
(:func:`imucalib.fit.gyroscope.fit_gyroscope`: the poses' means fix the bias,
the rotations' gravity directions the scales and misalignment; the review
calibrates gyroscopes on a rate table, which free-hand data does not have).

The accelerometer's misalignment ``T_a`` (upper triangular) is estimated
where a gyroscope recorded the rotations, and held at the identity otherwise.
Gravity's norm at the six faces does not measure it (its first-order change
``2 a_i a_j T_ij`` is nil with gravity along an axis), nor do the faces'
readings unless they are exact faces of a cube (held by hand they are a
degree or two off, as much as ``T_a`` itself); but a rigid rotation cannot
carry one sheared set of gravity directions into another, so the rotations
between the poses measure it along with the gyroscope
(:func:`imucalib.fit.gyroscope.accelerometer_joint_step`, a zero-mean prior
of the datasheet's cross-axis bound deciding only where they do not). The
faces' tilts and eqs. (8)–(9) are then taken with that ``T_a``. Held at the
identity, ``T_a`` would set the gravity directions the gyroscope is fitted
to wrong by ``T_ij`` (a 90° turn between two faces reads ``90° − T_ij``),
an error of the gyroscope's scales that no residual shows.
"""

from __future__ import annotations

import numpy as np

from ..assembly import POSES_IN_BLOCKS, assemble
from ..calibration import Calibration
from ..fit.accelerometer import accelerometer_covariance as full_covariance
from ..fit.accelerometer import fit_determined, mean_variance, six_position
from ..fit.gyroscope import accelerometer_joint_step, fit_gyroscope, joint_errors_at
from ..fitreport import AccelerometerReport, SegmentationReport, UncertaintyReport
from ..methodinfo import MethodInfo, Option
from ..metrics import interval_means
from ..presets import MIN_HOLD
from ..segment import FACE_NAMES, find_faces, pose_blocks, static_poses, unreliable_transitions

METHOD = MethodInfo(
    name="six_position",
    summary="accelerometer biases and scales from each axis up and down, its misalignment from the rotations "
            "(none without a gyroscope); gyroscope on the poses and rotations",
    needs=("static poses", "six faces", "rotations"),
    models=("linear",),
    options=(
        Option("intervals", None, "samples", "static intervals given instead of found"),
        Option("max_tilt", 15.0, "deg", "largest tilt of a face from its axis"),
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
        Option("min_hold", 1.0, "s", "shortest hold that is a pose (sets the static detector's window)"),
    ),
    paper="ru2022_mems_calibration_review.md (Ru 2022), §3.1, eqs. 8–9",
    accelerometer_only=True,
)

__all__ = ["CROSS_AXIS", "accelerometer_covariance", "calibrate"]

#: the cross-axis sensitivity a consumer MEMS accelerometer's datasheet bounds (MPU-6000/MPU-6050 Product
#: Specification rev. 3.4, §6.2: ±2 %): what the misalignment may be when neither the poses nor the rotations
#: measure it (a uniform prior within ±c, variance c²/3)
CROSS_AXIS = 0.02
#: the accelerometer's misalignment entries (``AccelLayout("upper", 1)`` order) the rotations estimate
MISALIGNMENT = (0, 1, 2)
#: Gauss–Newton steps for the misalignment at most, and the step [rad] below which it has converged
MISALIGNMENT_STEPS, MISALIGNMENT_TOL = 6, 1e-6


def accelerometer_covariance(recording, intervals, faces, acc, gravity: float) -> np.ndarray:
    """Covariance of the six-position accelerometer in ``AccelLayout("upper", 1)`` order, for the gyroscope's errors.

    Where the rotations estimate the misalignment with the gyroscope, its
    entries here are not used (:func:`imucalib.fit.gyroscope.joint_errors`
    takes them from the joint fit). Where they do not, the method holds
    ``T_a`` at the identity; the accelerometer's
    real cross-axis terms set the gravity directions the gyroscope is fitted
    to, so holding them at zero is an error of the gyroscope's parameters
    that its own residuals cannot show: each upper term ``T_ij`` enters with
    the variance ``E[T_ij²]``, the mean squared error of holding it at zero.
    A priori ``T_ij`` is uniform within ±:data:`CROSS_AXIS` (``c²/3``); where
    the poses determine the linear model (:func:`imucalib.fit.accelerometer.fit_determined`,
    nine or more poses in spread directions) its estimate ``T̂_ij ± σ``
    (:func:`imucalib.fit.accelerometer.pose_covariance`) updates that: the
    posterior is the normal ``N(T̂_ij, σ²)`` truncated to ``[−c, c]`` (Bayes'
    rule with a uniform prior), whose second moment is taken. The bias and scale of
    eqs. (8)–(9) carry each face mean's noise (the variance of its mean
    ``v`` by batch means, :func:`~imucalib.fit.accelerometer.mean_variance`):
    ``var b = (v₊ + v₋)/4``, ``var s = (v₊ + v₋)/(2g)²`` and, with
    ``k1 = 1/s``, ``var k1 = k1⁴ var s``.
    """
    v = np.array([mean_variance(recording.acc[intervals[int(i)].slice]) for i in faces])
    axes = np.arange(3)
    pair = v[:3][axes, axes] + v[3:][axes, axes]
    k = np.abs(acc.scale)
    mis = np.full(3, CROSS_AXIS**2 / 3)
    means = interval_means(recording.acc, intervals)
    try:
        full, _, which = fit_determined(means, gravity)
    except ValueError:
        which = None
    if which is not None and which[0] == "linear":
        cov = full_covariance(full, means, gravity)
        sd = np.sqrt(np.diag(cov)[:3])
        if np.all(np.isfinite(sd) & (sd > 0)):
            from scipy.stats import truncnorm  # here: scipy.stats takes a while to import

            t = full.misalignment
            t_hat = np.array([t[0, 1], t[0, 2], t[1, 2]])
            post = truncnorm((-CROSS_AXIS - t_hat) / sd, (CROSS_AXIS - t_hat) / sd, loc=t_hat, scale=sd)
            mis = post.var() + post.mean() ** 2
    return np.diag(np.concatenate([mis, k**4 * pair / (2 * gravity) ** 2, pair / 4]))


def _faces(up, down, means, faces, gravity, misalignment=None):
    """Eqs. (8)–(9) for each axis with its faces' tilts by the calibrated directions, to a fixed point.

    With a misalignment ``T``, an axis reads ``k_i (u_i − b_i) = (T⁻¹ a)_i``: the
    "cosines" of eqs. (8)–(9) are the components of ``T⁻¹ d`` (``d`` the calibrated
    gravity direction). Returns the model and the faces' tilt cosines (of ``d``).
    """
    t = np.eye(3) if misalignment is None else np.asarray(misalignment)
    axes = np.arange(3)
    acc = six_position(up, down, gravity).with_(misalignment=t)  # eqs. (8)-(9)
    for _ in range(5):
        d = acc.forward(means)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        v = np.linalg.solve(t, d.T).T
        acc = six_position(up, down, gravity, cos_up=v[faces[:3], axes],
                           cos_down=-v[faces[3:], axes]).with_(misalignment=t)
    d = acc.forward(means)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return acc, d[faces[:3], axes], -d[faces[3:], axes]


def _with_misalignment(recording, intervals, acc, exclude, up, down, means, faces, gravity):
    """The gyroscope and the accelerometer's misalignment from the rotations together (module docstring).

    The misalignment is iterated to its fixed point with every rotation the
    data leave usable, before any is judged an outlier: held at zero, the
    shear makes the rotations that measure it look like outliers, and leaving
    those out would leave it unmeasured. The outliers of the converged fit
    (:data:`imucalib.fit.gyroscope.OUTLIER_SIGMA`) are then left out and the
    fixed point taken again, at most twice. Returns the accelerometer, the
    gyroscope's fit and whether the misalignment was estimated.
    """
    gyro_fit = fit_gyroscope(recording, intervals, acc, exclude=exclude)
    if gyro_fit.bias_source != "joint" or gyro_fit.rotation_sigma is None:
        return acc, gyro_fit, False
    prior = np.full(len(MISALIGNMENT), CROSS_AXIS**2 / 3)
    left_out = dict(exclude or {})
    for _ in range(2):
        gyro_fit = fit_gyroscope(recording, intervals, acc, exclude=left_out, robust=False)
        t = acc.misalignment.copy()
        for _ in range(MISALIGNMENT_STEPS):
            if gyro_fit.bias_source != "joint":
                return acc, fit_gyroscope(recording, intervals, acc, exclude=exclude), False
            step = accelerometer_joint_step(recording, intervals, acc, gyro_fit.model, gyro_fit.report(),
                                            MISALIGNMENT, prior)
            t[0, 1] += step[0]
            t[0, 2] += step[1]
            t[1, 2] += step[2]
            acc = _faces(up, down, means, faces, gravity, t)[0]
            gyro_fit = fit_gyroscope(recording, intervals, acc, exclude=left_out, robust=False)
            if np.max(np.abs(step)) < MISALIGNMENT_TOL:
                break
        robust = fit_gyroscope(recording, intervals, acc, exclude=left_out)
        if set(robust.left_out) == set(left_out):
            break
        left_out = robust.left_out
    return acc, fit_gyroscope(recording, intervals, acc, exclude=left_out), True


def calibrate(recording, *, gravity: float, intervals=None, max_tilt: float = 15.0,
              init_static: float | None = None, min_hold: float = MIN_HOLD) -> Calibration:
    """Six-position accelerometer calibration (eqs. 8–9) with the gravity-direction gyroscope fit.

    Where the rotations were recorded, the accelerometer's misalignment is estimated with the gyroscope
    (module docstring) and its 1σ is reported with the gyroscope's.

    Parameters
    ----------
    recording : Recording or Session
        The recording: an initial rest, then static poses with rotations between them.
        Six of the poses must be the faces: each axis up and down.
    gravity : float
        Local gravity [m/s²].
    intervals : list of Interval, optional
        The static poses as sample ranges; by default found by the method's detector.
    max_tilt : float
        The largest tilt [deg] of a pose from its face for it to count as that face.
    init_static : float, optional
        Length of the initial rest [s]; by default found automatically.

    Returns
    -------
    Calibration
        The calibration, with its fit figures, 1σ errors and verdict in ``fit``.

    Raises
    ------
    ValueError
        When the poses lack one of the six faces (each axis up and down within ``max_tilt``).

    Examples
    --------
    The six faces of a simulated Ferraris procedure (each axis up, then down, with turns between them):

    >>> from imucalib.methods import six_position
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, procedure="ferraris", rest=5)
    >>> cal = six_position.calibrate(sim.recording, gravity=sim.truth.gravity)
    >>> (cal.accelerometer.scale / sim.truth.accelerometer.scale).round(3)
    array([1., 1., 1.])

    Poses spread over all directions are not the six faces:

    >>> spread = session("handheld", rng=1, rest=10, n_poses=14)
    >>> six_position.calibrate(spread.recording, gravity=spread.truth.gravity)
    Traceback (most recent call last):
        ...
    ValueError: this method needs the six faces, each axis up and down within 15° of gravity; ...
    """
    intervals = static_poses(recording, gravity, intervals, init_static=init_static, min_hold=min_hold)
    means = interval_means(recording.acc, intervals)
    faces = find_faces(means, gravity, max_tilt=max_tilt)
    up, down = means[faces[:3], np.arange(3)], means[faces[3:], np.arange(3)]
    acc, cos_up, cos_down = _faces(up, down, means, faces, gravity)
    blocks = pose_blocks(recording) is not None
    gyro_fit, estimated, exclude = None, False, None
    if recording.gyro is not None and not blocks:  # none without rotations recorded
        exclude = unreliable_transitions(recording, intervals)
        acc, gyro_fit, estimated = _with_misalignment(recording, intervals, acc, exclude, up, down, means, faces,
                                                      gravity)
        if estimated:
            acc, cos_up, cos_down = _faces(up, down, means, faces, gravity, acc.misalignment)
            gyro_fit.errors = joint_errors_at(
                recording, intervals, acc, gyro_fit.model, gyro_fit.report(),
                acc_cov=accelerometer_covariance(recording, intervals, faces, acc, gravity),
                acc_joint=(MISALIGNMENT, np.full(len(MISALIGNMENT), CROSS_AXIS**2 / 3)))
        else:
            gyro_fit = fit_gyroscope(recording, intervals, acc, exclude=exclude,
                                     acc_cov=accelerometer_covariance(recording, intervals, faces, acc, gravity))
    gyro, gyro_errors = (gyro_fit.model, gyro_fit.errors) if gyro_fit is not None else (None, {})
    figures = [
        AccelerometerReport(misalignment="estimated from the rotations with the gyroscope" if estimated else
                            "held at zero (eqs. 8-9): no rotations to measure it"),
        SegmentationReport(faces={name: int(i) for name, i in zip(FACE_NAMES, faces, strict=True)},
                           faces_tilt_deg={name: float(np.degrees(np.arccos(np.clip(c, -1, 1)))) for name, c
                                           in zip(FACE_NAMES, np.concatenate([cos_up, cos_down]), strict=True)}),
        UncertaintyReport(unavailable="accelerometer: the six faces determine its biases and scales exactly "
                                      "(eqs. 8-9), which leaves no residual to estimate the noise from")]
    return assemble("six_position", recording, intervals, acc, gyro, gravity=gravity, uncertainty=gyro_errors,
                    figures=figures if gyro_fit is None else [gyro_fit.report(), *figures],
                    not_calibrated=POSES_IN_BLOCKS if blocks and recording.gyro is not None else None,
                    unreliable=exclude)
