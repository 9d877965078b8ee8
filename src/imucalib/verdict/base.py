"""The verdict's foundations: its levels and limits, a finding, and the static poses' figures its checks share.

:class:`Poses` computes each figure of the static poses (their raw and calibrated means, the white noise of the
calibrated readings, the gyroscope's rate at rest) once per assessment, for every check that reads it; the
noise (:func:`rest_noise`) and the gravity-direction error the noise alone predicts
(:func:`predicted_direction_error`) come from them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..calibration import Calibration
from ..metrics import (
    COVERAGE_CONE_DEG,
    gravity_direction_errors,
    gravity_noise_floor,
    interval_means,
    transition_bounds,
)
from ..recording import Interval, Recording
from ..segment import unreliable_transitions

__all__ = ["CALIBRATE_ROWS", "GYRO_ROTATION_PARAMETERS", "LEVELS", "NOMINAL", "POSE_BYTES", "THRESHOLDS", "Check",
           "Poses", "grade", "predicted_direction_error", "predicted_error_of", "rest_noise", "rest_noise_of",
           "rest_rates", "rest_rates_of", "white_noise_variance"]

LEVELS = ("accepted", "suspect", "rejected")

#: (suspect, rejected) limits of each figure; see the module docstring for where they come from
THRESHOLDS = {
    # sampling rate [Hz] outside which no IMU records
    "rate_hz": (5.0, 50_000.0),
    # median angular speed the accelerometer sees between poses [deg/s]: a hand turns at 2-1500 deg/s
    "turn_speed_deg_s": (2.0, 1500.0),
    # |a| at rest against the declared gravity with physical units: relative difference
    "rest_norm_rel": (0.05, 0.15),
    # calibrated scale against the declared unit's nominal factor: relative difference
    "nominal_scale_rel": (0.15, 0.5),
    # accelerometer cross-axis (misalignment) terms [deg]: one die's own axes
    "cross_axis_deg": (3.0, 15.0),
    # gyroscope cross-axis terms [deg]: T_g also holds the rotation between the gyroscope's and the
    # accelerometer's frames (two dies, or a package mounted askew); the Xsens MTi of ../shared/data has a
    # 3.1° term (imu_tk finds the same), so 3° would call a real, good sensor suspect
    "gyro_cross_axis_deg": (6.0, 15.0),
    # static poses per estimated accelerometer parameter (the over-fit check below judges the fit itself;
    # this one says the poses are few before the residual can)
    "poses_per_parameter": (1.5, 1.0),
    # gravity-norm residual / white-noise floor, too high
    "residual_to_noise_high": (8.0, 40.0),
    # the same, normalised by sqrt((M - p) / M), too low: an over-fit
    "residual_to_noise_low": 0.4,
    # gyroscope gravity-direction error / noise prediction (means over the rotations)
    "gyro_error_to_noise": (10.0, 40.0),
    # the mean gravity-direction error [deg] below which the gyroscope check does not make a calibration
    # suspect, and below which it does not reject one: a model that leaves a fraction of a degree between
    # poses is worse than it could be, not wrong
    "gyro_error_floor_deg": (0.25, 2.0),
    # calibrated gyroscope at rest: |mean rate over the poses| / its standard error from the poses' scatter,
    # and the rate [deg/s] below which that is not a reason (0.02 deg/s: 1.2 deg of heading a minute)
    "rest_rate_to_scatter": (6.0, 20.0),
    "rest_rate_floor_deg_s": (0.02, 0.1),
    # rotations kept in the gyroscope fit: direction components (two per rotation) per scale and
    # misalignment parameter (nine)
    "rotations_per_parameter": (2.0, 1.0),
    # known-angle turns: relative error of the angle (re-integrated with the calibration; measured with the
    # poses' rough gyroscope scale, good to a few per cent, only the rejecting limit applies)
    "turn_angle_rel": (0.03, 0.2),
    # 1 sigma of a scale factor, relative; of a misalignment term [deg]
    "scale_sigma_rel": 0.02,
    "misalignment_sigma_deg": 1.0,
    # an accelerometer parameter whose 1σ moves the output at 1 g by more than this fraction of g, and by more
    # than holding it at its nominal value would, makes the calibration worse than the nominal one: rejected
    # (2 % of g: the scale limit above, in the output's terms, for every kind of parameter)
    "parameter_effect_g": 0.02,
    # a pose visits the gravity directions within this angle [deg] of its own (metrics.pose_coverage's cone: an
    # axis never within it of up or down leaves that side to the other side alone, Ru 2022 §3.1); over the
    # directions outside every pose's cone, the 1σ of the calibrated |a| the fit's covariance predicts is set
    # against residual_to_noise_high, the limits validate judges a new recording by (unvisited_sigma)
    "coverage_cone_deg": COVERAGE_CONE_DEG,
    # magnetometer: relative spread of the calibrated field's norm over the poses; spread of its dip [deg];
    # mean error of the field direction carried by the gyroscope from pose to pose [deg]. A good calibration
    # in a uniform field leaves ~0.1 % and ~0.05° (noise and the gyroscope's own error); a plain ellipsoid
    # fit of a die whose axes are permuted leaves tens of degrees; iron nearby (a desk, a laptop) leaves a
    # field that is not uniform, which no calibration can fix
    "mag_norm_spread": (0.02, 0.05),
    "mag_dip_spread_deg": (2.0, 5.0),
    "mag_direction_error_deg": (3.0, 10.0),
}

#: the gyroscope parameters the rotations between poses determine: three scales, six misalignment terms
GYRO_ROTATION_PARAMETERS = 9

#: bytes of calibrated pose samples an assessment holds at once (its poses are calibrated a group at a time)
POSE_BYTES = 1 << 23

#: samples of consecutive poses the verdict calibrates in one call (:meth:`Poses.poses`)
CALIBRATE_ROWS = 1 << 12

#: raw-unit factors to SI of the physical units (``"g"`` uses the calibration's gravity)
NOMINAL = {"m/s^2": 1.0, "rad/s": 1.0, "deg/s": np.pi / 180}


@dataclass(frozen=True)
class Check:
    """One finding: ``level`` 1 makes the calibration suspect, 2 rejects it; 0 is a note.

    Examples
    --------
    The verdict's checks (:func:`plausibility`, :func:`assess`) give their findings as checks:

    >>> from imucalib.verdict import Check
    >>> finding = Check(1, "the gravity-norm residual is 9× the white-noise floor")
    >>> finding.level, finding.text
    (1, 'the gravity-norm residual is 9× the white-noise floor')
    """

    level: int
    text: str


def white_noise_variance(x: np.ndarray, order: int = 4) -> np.ndarray:
    """Per-column variance of the white noise in ``x`` (N, K), blind to slow disturbances.

    The ``order``-th difference of white noise of variance ``σ²`` has the
    variance ``C(2·order, order) σ²``, while a disturbance at frequency ``f``
    is scaled by ``(2 sin(π f Δt))^order``: a 5 Hz shake sampled at 100 Hz by
    ``0.31⁴ ≈ 0.01``, hand sway and drift by far less. So the noise of a
    sensor on a vibrating table, or held by a hand, is its own.
    """
    x = np.asarray(x, dtype=float)
    if x.shape[0] <= order + 1:
        return np.var(x, axis=0)
    return _from_squares(np.add.reduce(_squared_differences(x, order), axis=0), x.shape[0], order)


def _squared_differences(x: np.ndarray, order: int) -> np.ndarray:
    """The squared ``order``-th differences of ``x`` (N, K) over its rows, as ``np.diff(x, n=order, axis=0)**2``."""
    d = x
    for _ in range(order):
        d = d[1:] - d[:-1]
    return d * d


def _from_squares(total: np.ndarray, n: int, order: int) -> np.ndarray:
    """:func:`white_noise_variance` from the column sums of :func:`_squared_differences` of ``n`` rows (``np.mean``'s
    division, then the binomial factor)."""
    return total / (n - order) / math.comb(2 * order, order)


def rest_noise(calibration: Calibration, recording: Recording, intervals: list[Interval],
               rest: Interval | None = None) -> tuple[float, float]:
    """Per-sample white-noise variances (accelerometer [m²/s⁴], gyroscope [rad²/s²]) of the sensor at rest.

    From the initial rest (``rest``, default the first interval), or the
    static poses' median when that is lower (a rest that was disturbed), each
    by :func:`white_noise_variance` of the calibrated readings, the mean over
    the three axes: what the sensor's own noise is, not what a vibration or
    a hand added to the poses.
    """
    return rest_noise_of(Poses(calibration, recording, intervals), rest)


def rest_noise_of(found: Poses, rest: Interval | None) -> tuple[float, float]:
    """:func:`rest_noise` from the poses' figures of one assessment."""
    rest = rest or found.intervals[0]
    (s_a2, s_g2, _), *poses = found.poses([rest] + [iv for iv in found.intervals if iv is not rest and len(iv) > 20])
    if poses:
        s_a2 = min(s_a2, float(np.median([p[0] for p in poses])))
        s_g2 = min(s_g2, float(np.median([p[1] for p in poses])))
    return s_a2, s_g2


def predicted_direction_error(calibration: Calibration, recording: Recording, intervals: list[Interval],
                              rest: Interval | None = None) -> np.ndarray:
    """The mean gravity-direction error [rad] each rotation would show from sensor noise alone.

    Per rotation ``k`` (pose ``k`` to ``k+1``, duration ``T_k``), the error has
    two components perpendicular to gravity, each of variance

    ``σ_g² T_k Δt`` (the gyroscope's white noise integrated: angle random walk)
    ``+ σ_b² T_k²`` (the bias's error over the turn) ``+ (σ_a/g)² (1/n_k + 1/n_{k+1})``
    (the two poses' mean directions),

    with ``σ_g``, ``σ_a`` the calibrated per-sample white noise of the sensor at
    rest (:func:`rest_noise`: a vibration or tremor the poses carry is a
    disturbance the calibration has to survive, not noise that excuses its
    error), ``Δt`` the sampling interval and ``σ_b² = σ_g²/n_rest`` the noise
    of the rest's mean; a 2-D Gaussian error of that variance has the mean
    norm ``√(π v / 2)``.

    Parameters
    ----------
    calibration : Calibration
        The calibration whose gyroscope and accelerometer give the noise in SI units.
    recording : Recording
        The recording.
    intervals : list of Interval
        Its static poses, in time order.
    rest : Interval, optional
        The initial rest the noise is measured on; by default the first pose.

    Returns
    -------
    numpy.ndarray
        One mean error [rad] per rotation (``len(intervals) - 1``).

    Examples
    --------
    The 14 rotations of a short simulated session: the noise alone would tilt gravity by about 0.02°:

    >>> import numpy as np
    >>> from imucalib.scenarios import session
    >>> from imucalib.segment import detect_intervals
    >>> from imucalib.verdict import predicted_direction_error
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> intervals, *_ = detect_intervals(sim.recording, sim.truth.gravity)
    >>> error = predicted_direction_error(sim.truth, sim.recording, intervals)
    >>> len(error), round(float(np.degrees(error).mean()), 2)
    (14, 0.02)
    """
    return predicted_error_of(Poses(calibration, recording, intervals), rest)


def predicted_error_of(found: Poses, rest: Interval | None) -> np.ndarray:
    """:func:`predicted_direction_error` from the poses' figures of one assessment."""
    calibration, recording, intervals = found.calibration, found.recording, found.intervals
    rest = rest or intervals[0]
    s_a2, s_g2 = rest_noise_of(found, rest)
    s_b2 = s_g2 / max(len(rest), 1)  # the rest's mean: noise only, whatever the fit made of the bias
    starts, stops = transition_bounds(intervals)
    t = recording.t
    dur = t[stops] - t[starts]
    dt = recording.step
    n = np.array([len(iv) for iv in intervals], dtype=float)
    g = calibration.gravity
    v = s_g2 * dur * dt + s_b2 * dur**2 + s_a2 / g**2 * (1 / n[:-1] + 1 / n[1:])
    return np.sqrt(np.pi * v / 2)


def rest_rates(calibration: Calibration, recording: Recording, intervals: list[Interval]) -> np.ndarray:
    """The calibrated gyroscope's mean rate [rad/s] over each static pose (M, 3)."""
    return rest_rates_of(Poses(calibration, recording, intervals))


def rest_rates_of(found: Poses) -> np.ndarray:
    """:func:`rest_rates` from the poses' figures of one assessment."""
    return np.array([rate for _, _, rate in found.poses(found.intervals, noise=False)])


class Poses:
    """Figures of the static poses that several checks read, each computed once per assessment.

    Each figure is computed when first asked for, by the same operations in the same order as the check
    that reads it would compute it alone, so every figure is the same to the last bit. With ``own_figures``
    (the fit report was made with this calibration's models on this recording, as ``calibrate``'s is, before
    anything changed them), the noise floor, the unreliable rotations and the rotations' gravity-direction
    errors are read from the report where it holds them for these poses (:func:`imucalib.metrics.fit_summary`,
    :func:`imucalib.assembly.assemble`; the errors in degrees, the same to a part in 10¹⁵). Per pose only its
    figures are kept; its calibrated samples only while its group is summed (:meth:`poses`), so memory
    follows :data:`POSE_BYTES` or the longest pose, not the recording. Shared arrays are read-only, so no
    check can change them for another.
    """

    def __init__(self, calibration: Calibration, recording: Recording, intervals: list[Interval], *,
                 own_figures: bool = False) -> None:
        self.calibration, self.recording, self.intervals = calibration, recording, intervals
        # the fit report's figures are this calibration's on these poses: said so, and the report's poses are these
        self._report_is_of_these = own_figures and calibration.fit.poses.intervals == [[iv.start, iv.stop]
                                                                                          for iv in intervals]
        self._means: np.ndarray | None = None
        self._up: np.ndarray | None = None
        self._errors: np.ndarray | None = None
        self._pose: dict[tuple[int, int], tuple[float, float, np.ndarray]] = {}

    @property
    def means(self) -> np.ndarray:
        """The raw accelerometer's mean over each pose (M, 3) (:func:`imucalib.metrics.interval_means`)."""
        if self._means is None:
            self._means = interval_means(self.recording.acc, self.intervals)
            self._means.flags.writeable = False
        return self._means

    @property
    def floor(self) -> float:
        """The gravity-norm residual's white-noise floor [m/s²] (:func:`imucalib.metrics.gravity_noise_floor`)."""
        floor = self.calibration.fit.accelerometer.noise_floor
        if floor is not None and self._report_is_of_these:
            return floor
        return gravity_noise_floor(self.calibration, self.recording, self.intervals)

    @property
    def unreliable(self) -> dict[int, str]:
        """The rotations between the poses whose integration the data do not allow, by index: why
        (:func:`imucalib.segment.unreliable_transitions`)."""
        found = self.calibration.fit.gyroscope.rotations_unreliable
        if found is not None and self._report_is_of_these:
            return found
        return unreliable_transitions(self.recording, self.intervals)

    @property
    def up(self) -> np.ndarray:
        """The calibrated specific force of each pose (M, 3) [m/s²] (:func:`imucalib.metrics.pose_specific_force`)."""
        if self._up is None:
            self._up = self.calibration.accelerometer_si(self.means)
            self._up.flags.writeable = False
        return self._up

    @property
    def direction_errors(self) -> np.ndarray:
        """The calibrated gravity-direction error [rad] of every rotation between consecutive poses (M − 1,)
        (:func:`imucalib.metrics.gravity_direction_errors`), those the fit left out included."""
        if self._errors is None:
            found = self.calibration.fit.gyroscope.angle_errors_deg
            if found is not None and self._report_is_of_these:
                self._errors = np.radians(found)
            else:
                self._errors = gravity_direction_errors(self.calibration, self.recording, self.intervals, up=self.up)
            self._errors.flags.writeable = False
        return self._errors

    def poses(self, intervals: list[Interval], noise: bool = True) -> list[tuple[float | None, float | None,
                                                                                np.ndarray]]:
        """Per interval: the calibrated accelerometer's and gyroscope's white-noise variances (the means over
        the axes of :func:`white_noise_variance`; None unless ``noise``) and the gyroscope's mean rate (3,)
        [rad/s].

        The calibrated readings are those of ``Calibration.accelerometer_si`` and ``gyroscope_si``; the
        g-sensitivity term reads the calibrated accelerometer already computed for the variance. The poses are
        calibrated a group at a time (about :data:`POSE_BYTES` of samples).
        """
        todo, group, size = {}, [], 0
        for iv in intervals:
            key = (iv.start, iv.stop)
            if key not in todo and (key not in self._pose or (noise and self._pose[key][0] is None)):
                todo[key] = iv
        for iv in todo.values():
            if group and size + len(iv) > POSE_BYTES // 72:  # held a sample: the rates, six squared differences
                self._calibrate(group, noise)
                group, size = [], 0
            group.append(iv)
            size += len(iv)
        if group:
            self._calibrate(group, noise)
        return [self._pose[(iv.start, iv.stop)] for iv in intervals]

    def _calibrated(self, group: list[Interval], with_acc: bool, g_sensitive: bool):
        """Per pose of ``group``: its calibrated accelerometer (None unless ``with_acc``) and gyroscope samples.

        Consecutive poses are calibrated together, up to :data:`CALIBRATE_ROWS` samples at a time (each row on
        its own: the numbers of pose by pose, with a few calls instead of two per pose, and arrays small enough
        to be reused rather than mapped afresh).
        """
        cal, rec = self.calibration, self.recording
        k = 0
        while k < len(group):
            batch, rows = [group[k]], len(group[k])
            k += 1
            while k < len(group) and rows + len(group[k]) <= CALIBRATE_ROWS:
                batch.append(group[k])
                rows += len(group[k])
                k += 1
            cuts = np.cumsum([len(iv) for iv in batch])[:-1]
            acc = cal.accelerometer_si(np.concatenate([rec.acc[iv.slice] for iv in batch])) if with_acc else None
            raw_gyro = np.concatenate([rec.gyro[iv.slice] for iv in batch])
            gyro = cal.gyroscope.forward(raw_gyro, acc) if g_sensitive else cal.gyroscope_si(raw_gyro)
            accs = np.split(acc, cuts) if acc is not None else [None] * len(batch)
            yield from zip(accs, np.split(gyro, cuts), strict=True)

    def _calibrate(self, group: list[Interval], noise: bool) -> None:
        """Calibrate the poses ``group`` and keep their figures (:meth:`poses`)."""
        cal, order = self.calibration, 4
        g_sensitive = cal.gyroscope is not None and np.any(cal.gyroscope.g_sensitivity)
        gyros, squares, short = [], [], {}
        for acc, gyro in self._calibrated(group, noise or g_sensitive, g_sensitive):
            gyros.append(gyro)
            if noise:  # both sensors side by side: each column's differences and sums are as on its own
                both = np.concatenate((acc, gyro), axis=1)
                if both.shape[0] <= order + 1:
                    short[len(gyros) - 1] = white_noise_variance(both, order)
                else:
                    squares.append(_squared_differences(both, order))
        rates = [np.add.reduce(g, axis=0) for g in gyros]
        square_sums = iter([np.add.reduce(s, axis=0) for s in squares])
        add = np.add.reduce  # np.mean's sum, without its per-call overhead
        for k, (iv, gyro) in enumerate(zip(group, gyros, strict=True)):
            s_a2 = s_g2 = None
            if noise:
                v = short[k] if k in short else _from_squares(next(square_sums), len(iv), order)
                v_a, v_g = v[:3], v[3:]
                s_a2, s_g2 = float(add(v_a) / v_a.size), float(add(v_g) / v_g.size)
            self._pose[(iv.start, iv.stop)] = (s_a2, s_g2, rates[k] / gyro.shape[0])


def grade(value: float, limits: tuple[float, float]) -> int:
    """The level a figure earns against its (suspect, rejected) limits: 0, 1 or 2 (above each limit)."""
    return 2 if value > limits[1] else 1 if value > limits[0] else 0
