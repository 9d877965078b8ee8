"""The six-position method (Ru 2022, §3.1, eqs. 8–9).

Each accelerometer axis is held along gravity, up and then down; with the raw
readings ``u_up`` and ``u_down`` of that axis::

    b = (u_up + u_down) / 2                          (eq. 8)
    s = (u_up − u_down) / (2 g)   (raw per m/s²)     (eq. 9)

so the canonical scale is ``k1 = 1/s`` and the bias ``b``; the method ignores
misalignment (``T_a = I``) and nonlinearity. The six faces are found
automatically among the static poses: after a sphere fit centres the data, the
pose whose direction is closest to ``+x`` (``−x``, …) is that face, and it must
lie within ``max_tilt`` degrees of the axis — otherwise the recording does not
hold that face and the method says which faces are missing. A face a few
degrees off its axis is corrected for its tilt (measured by the
directions the calibration gives, to a fixed point;
:func:`imucalib.fit.accelerometer.six_position`), which eq. 9 as
printed is not; ``fit["faces_tilt_deg"]`` says by how much. The gyroscope
comes from the static poses and the rotations between them together
(:func:`imucalib.fit.gyroscope.fit_gyroscope`: the poses' means fix the bias,
the rotations' gravity directions the scales and misalignment; the review
calibrates gyroscopes on a rate table, which free-hand data does not have).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration, units_of
from ..fit.accelerometer import accelerometer_covariance as full_covariance
from ..fit.accelerometer import fit_determined, six_position
from ..fit.gyroscope import fit_gyroscope
from ..methodinfo import MethodInfo, Option
from ..metrics import fit_summary, interval_means
from ..segment import FACE_NAMES, find_faces, pose_blocks, static_poses, unreliable_transitions

METHOD = MethodInfo(
    name="six_position",
    summary="accelerometer biases and scales from each axis up and down (no misalignment); gyroscope on the "
            "poses and rotations",
    needs=("static poses", "six faces", "rotations"),
    models=("linear",),
    options=(
        Option("intervals", None, "samples", "static intervals given instead of found"),
        Option("max_tilt", 15.0, "deg", "largest tilt of a face from its axis"),
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
    ),
    paper="ru2022_mems_calibration_review.md (Ru 2022), §3.1, eqs. 8–9",
    accelerometer_only=True,
)

__all__ = ["CROSS_AXIS", "accelerometer_covariance", "calibrate"]

#: the cross-axis sensitivity a consumer MEMS accelerometer's datasheet bounds (MPU-6000/MPU-6050 Product
#: Specification rev. 3.4, §6.2: ±2 %): what the misalignment the method holds at zero may be when the poses
#: cannot measure it
CROSS_AXIS = 0.02


def accelerometer_covariance(recording, intervals, faces, acc, gravity: float) -> np.ndarray:
    """Covariance of the six-position accelerometer in ``AccelLayout("upper", 1)`` order, for the gyroscope's errors.

    The method holds the misalignment ``T_a`` at the identity; the accelerometer's
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
    eqs. (8)–(9) carry each face mean's white noise (its samples' variance
    over their number ``v``): ``var b = (v₊ + v₋)/4``, ``var s = (v₊ + v₋)/(2g)²``
    and, with ``k1 = 1/s``, ``var k1 = k1⁴ var s``.
    """
    v = np.array([np.var(recording.acc[intervals[int(i)].slice], axis=0) / max(len(intervals[int(i)]) - 1, 1)
                  for i in faces])
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


def calibrate(recording, *, gravity: float, intervals=None, max_tilt: float = 15.0,
              init_static: float | None = None) -> Calibration:
    """Six-position accelerometer calibration (eqs. 8–9) with the gravity-direction gyroscope fit."""
    intervals = static_poses(recording, gravity, intervals, init_static=init_static)
    means = interval_means(recording.acc, intervals)
    faces = find_faces(means, gravity, max_tilt=max_tilt)
    up, down = means[faces[:3], np.arange(3)], means[faces[3:], np.arange(3)]
    acc = six_position(up, down, gravity)  # eqs. (8)-(9)
    for _ in range(5):  # each face's tilt from its axis by the calibrated direction, then eqs. (8)-(9) for it
        d = acc.forward(means)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        cos_up, cos_down = d[faces[:3], np.arange(3)], -d[faces[3:], np.arange(3)]
        acc = six_position(up, down, gravity, cos_up=cos_up, cos_down=cos_down)
    blocks = pose_blocks(recording) is not None
    gyro_fit = None if recording.gyro is None or blocks else fit_gyroscope(  # none without rotations recorded
        recording, intervals, acc, exclude=unreliable_transitions(recording, intervals),
        acc_cov=accelerometer_covariance(recording, intervals, faces, acc, gravity))
    gyro, gyro_errors = (gyro_fit.model, gyro_fit.errors) if gyro_fit is not None else (None, {})
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="six_position",
                      model="linear", units=units_of(recording))
    fit = fit_summary(cal, recording, intervals, gravity)
    if gyro_fit is not None:
        fit |= gyro_fit.summary()
    if blocks and recording.gyro is not None:
        fit["gyroscope_not_calibrated"] = ("the poses were recorded as separate blocks, with no motion between them: "
                                           "the rotations that calibrate the gyroscope were not recorded")
    fit["faces"] = {name: int(i) for name, i in zip(FACE_NAMES, faces, strict=True)}
    fit["faces_tilt_deg"] = {name: float(np.degrees(np.arccos(np.clip(c, -1, 1))))
                             for name, c in zip(FACE_NAMES, np.concatenate([cos_up, cos_down]), strict=True)}
    fit["uncertainty"] = gyro_errors
    fit["uncertainty_unavailable"] = ("accelerometer: the six faces determine its six parameters exactly "
                                      "(eqs. 8-9), which leaves no residual to estimate the noise from")
    return cal.with_(fit=fit)
