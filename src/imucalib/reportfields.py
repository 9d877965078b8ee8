"""The fit report: every field a calibration's ``fit`` may hold, with its unit, meaning and group.

:attr:`imucalib.calibration.Calibration.fit` is a dictionary that the methods, the shared stages, the verdict
and the thermal model fill, and that the command line, the report, validation and batch runs read. Its fields
are declared here, once: a field is written and read by the name declared, and a test scans the package's
source for every ``fit["…"]``, ``fit.get("…")``, ``fit.update(…)``, ``fit={…}`` and ``fit |= {…}`` and fails
on a name not in :data:`FIELDS`; another calibrates with every method and checks the fields it finds.

A calibration file's ``fit`` is written as it is (the layout of the file is unchanged: format version 1).
Reading a file with a field not declared here (a file from an older or newer version) keeps the field as it
was read and warns once, naming it (:func:`undeclared`).
"""

from __future__ import annotations

from collections import namedtuple

__all__ = ["FIELDS", "GROUPS", "FieldInfo", "field", "undeclared"]


class FieldInfo(namedtuple("FieldInfo", "name unit meaning group")):
    """One field of the fit report.

    Attributes
    ----------
    name : str
        The key in ``Calibration.fit`` and in the file's ``fit`` object.
    unit : str
        Its unit (``""``: a count, a ratio, a name or text; for a list or mapping, its entries' unit).
    meaning : str
        What it holds, in one sentence.
    group : str
        The group it belongs to (a key of :data:`GROUPS`).
    """

    __slots__ = ()


#: the groups of fields and what each covers
GROUPS = {
    "poses": "the static poses the fit used and how they cover the directions",
    "accelerometer": "the accelerometer's fit figures",
    "gyroscope": "the gyroscope's fit figures",
    "magnetometer": "the magnetometer's fit figures",
    "method": "figures a particular method reports about its own fit",
    "thermal": "the temperature model",
    "uncertainty": "1σ errors of the parameters",
    "verdict": "the verdict on the calibration and what to do next",
}

_F = FieldInfo
#: every declared field, grouped
FIELDS: tuple[FieldInfo, ...] = (
    # poses
    _F("intervals", "samples", "the static intervals used, [start, stop) sample indices", "poses"),
    _F("static_intervals", "", "the number of static intervals used", "poses"),
    _F("pose_coverage", "", "per body axis, the least and largest gravity component over the poses (unit vector)",
       "poses"),
    _F("quality_flags", "", "warnings on the poses' coverage and spread, in words", "poses"),
    _F("initial_rest_seconds", "s", "length of the initial rest used for the noise", "poses"),
    _F("threshold_multiplier", "", "the static detector's threshold, in multiples of the rest's variance "
       "(tedaldi2014's choice)", "poses"),
    _F("faces", "", "the static pose taken for each face (+x, −x, …): index into the intervals", "poses"),
    _F("faces_tilt_deg", "deg", "each face's tilt from its axis", "poses"),
    # accelerometer
    _F("accelerometer_residual_rms", "m/s^2", "RMS of |a| − g over the static poses", "accelerometer"),
    _F("accelerometer_residual_rms_raw", "m/s^2", "RMS of |a| − g over the same poses for the raw readings (the "
       "identity calibration: no bias, the unit's nominal scale, no misalignment; physical units only)",
       "accelerometer"),
    _F("accelerometer_noise_floor", "m/s^2", "the residual RMS the white noise alone leaves", "accelerometer"),
    _F("accelerometer_residual_to_noise", "", "accelerometer_residual_rms over accelerometer_noise_floor",
       "accelerometer"),
    _F("accelerometer_unvisited_sigma_to_noise", "", "the largest 1σ of the calibrated |a| over the directions no "
       "pose visited, over accelerometer_noise_floor (0: every axis visited up and down; null: not determined)",
       "accelerometer"),
    _F("accelerometer_model", "", "the accelerometer model fitted (the full one or a reduced one)", "accelerometer"),
    _F("accelerometer_weights", "", "pose_table: how the table's poses were weighted, in words", "accelerometer"),
    _F("accelerometer_reduced_chi2", "", "pose_table: Σ (r_k/σ_r,k)² / (M − P) of the fit weighted by the table's "
       "σ/√n", "accelerometer"),
    _F("accelerometer_model_reduced", "", "why the poses determine a reduced accelerometer model, in words",
       "accelerometer"),
    _F("accelerometer_misalignment", "", "six_position: whether the accelerometer's misalignment was estimated "
       "(from the rotations) or held at zero, in words", "accelerometer"),
    # gyroscope
    _F("gyroscope_angle_error_mean_deg", "deg", "mean gravity-direction error after integrating each rotation, over "
       "every rotation between the poses (those left out of the fit included)", "gyroscope"),
    _F("gyroscope_angle_error_mean_deg_raw", "deg", "gyroscope_angle_error_mean_deg for the raw readings (the "
       "identity calibration of both sensors; physical units only)", "gyroscope"),
    _F("gyroscope_angle_error_max_deg", "deg", "largest gravity-direction error after a rotation", "gyroscope"),
    _F("gyroscope_angle_error_kept_mean_deg", "deg", "mean gravity-direction error over the rotations kept",
       "gyroscope"),
    _F("gyroscope_angle_error_reliable_mean_deg", "deg", "mean gravity-direction error over the rotations without "
       "saturated samples, spikes or gaps (the ones the verdict's noise check judges), when some have them",
       "gyroscope"),
    _F("gyroscope_angle_error_predicted_deg", "deg", "the mean gravity-direction error the noise alone predicts",
       "gyroscope"),
    _F("gyroscope_error_to_noise", "", "the mean gravity-direction error over the predicted, over the rotations "
       "without saturated samples, spikes or gaps", "gyroscope"),
    _F("gyroscope_rest_rate_deg_s", "deg/s", "the calibrated rate at rest, per axis (mean over the poses)",
       "gyroscope"),
    _F("gyroscope_rest_rate_to_scatter", "", "the largest rest rate over its scatter between poses", "gyroscope"),
    _F("gyroscope_bias_source", "", "where the gyroscope bias comes from (the rests or the rotations)",
       "gyroscope"),
    _F("gyroscope_bias_drift_per_s", "raw/s", "the gyroscope bias's linear drift, per axis", "gyroscope"),
    _F("gyroscope_bias_drift_se_per_s", "raw/s", "1σ error of the bias drift, per axis", "gyroscope"),
    _F("gyroscope_bias_time_s", "s", "the time at which the drifting bias is the bias stated", "gyroscope"),
    _F("gyroscope_bias_session_s", "s", "the first and last time of the recording the bias drift was fitted on, "
       "in its time base", "gyroscope"),
    _F("gyroscope_bias_session_check", "", "a few samples of that recording ([time s, raw gyroscope x, y, z]) that "
       "apply recognises it by", "gyroscope"),
    _F("gyroscope_bias_drift_over_session_deg_s", "deg/s", "the calibrated rate at rest the bias drift adds to the "
       "stored bias's at the session's start and end (two rows, per axis)", "gyroscope"),
    _F("gyroscope_g_sensitivity", "", "whether the g-sensitivity was estimated ('estimated' or 'none')",
       "gyroscope"),
    _F("gyroscope_rotation_sigma_rad", "rad", "the rotations' residual scatter the gyroscope fit weighs by",
       "gyroscope"),
    _F("gyroscope_not_calibrated", "", "why the gyroscope was left uncalibrated, in words", "gyroscope"),
    _F("gyroscope_rest_mean", "raw", "pose_table: the mean of the poses' gyroscope means, per axis (the bias where "
       "the sensor was still)", "gyroscope"),
    _F("gyroscope_rest_mean_sigma", "raw", "pose_table: the standard error of gyroscope_rest_mean over the poses",
       "gyroscope"),
    _F("gyroscope_rest_mean_unit", "", "pose_table: the raw unit of gyroscope_rest_mean", "gyroscope"),
    _F("gyroscope_approach", "", "qureshi2017's gyroscope approach (static bias or dynamic)", "gyroscope"),
    _F("rotations_left_out", "", "the rotations left out of the gyroscope fit and why, by index", "gyroscope"),
    _F("rotations_used", "", "qureshi2017: turns used about each axis", "gyroscope"),
    _F("rotations_rejected", "", "qureshi2017: turns rejected about each axis", "gyroscope"),
    _F("turns", "", "ferraris: the turn found about each axis: index into the motions", "gyroscope"),
    _F("turn_sections", "samples", "ferraris: each turn's sample range", "gyroscope"),
    _F("turn_angle_deg", "deg", "ferraris: the known angle of each turn, and the angles measured", "gyroscope"),
    _F("sections", "samples", "ferraris: the named sample ranges used", "poses"),
    # magnetometer
    _F("magnetometer_poses", "", "static poses the magnetometer fit used", "magnetometer"),
    _F("magnetometer_axes", "", "the magnetometer's axes named in the accelerometer's frame", "magnetometer"),
    _F("magnetometer_rotations_left_out", "", "rotations left out of the magnetometer's alignment", "magnetometer"),
    _F("magnetometer_alignment_rotation_deg", "deg", "angle of the magnetometer-to-body rotation", "magnetometer"),
    _F("magnetometer_hemisphere", "", "the field points below (north) or above (south) the horizontal",
       "magnetometer"),
    _F("magnetometer_dip_deg", "deg", "the fitted dip angle of the field", "magnetometer"),
    _F("magnetometer_dips_deg", "deg", "the dip angle at each pose", "magnetometer"),
    _F("magnetometer_dip_spread_deg", "deg", "the dip angles' standard deviation over the poses", "magnetometer"),
    _F("magnetometer_field_norms", "calibrated", "the calibrated field's magnitude at each pose", "magnetometer"),
    _F("magnetometer_norm_spread", "", "the calibrated magnitudes' relative standard deviation", "magnetometer"),
    _F("magnetometer_direction_error_mean_deg", "deg", "mean error of the field's direction over the poses",
       "magnetometer"),
    _F("magnetometer_direction_error_max_deg", "deg", "largest error of the field's direction", "magnetometer"),
    _F("magnetometer_hard_iron_drift_per_min", "raw/min", "the hard iron's drift, per axis (None: not fitted)",
       "magnetometer"),
    _F("magnetometer_hard_iron_drift_sigma_per_min", "raw/min", "1σ error of the hard-iron drift", "magnetometer"),
    _F("magnetometer_hard_iron_drift_over_session", "calibrated", "how far the hard-iron drift moves the "
       "calibrated field over the session", "magnetometer"),
    _F("magnetometer_field_uniform", "", "whether the field was the same at every pose (else the fit held it "
       "to each pose's vertical component and horizontal magnitude)", "magnetometer"),
    _F("magnetometer_field_scatter_chi2", "", "the poses' field norms' scatter per degree of freedom against "
       "their noise", "magnetometer"),
    _F("magnetometer_field_error", "calibrated", "the field's error at a pose where the field is not uniform, "
       "1σ (None: uniform)", "magnetometer"),
    _F("magnetometer_accelerometer_shift_sigma", "", "how far the joint fit moved the accelerometer's parameters, "
       "in their 1σ (None: uniform field)", "magnetometer"),
    _F("magnetometer_error", "", "why the magnetometer was left uncalibrated, in words", "magnetometer"),
    # method
    _F("converged", "", "whether the method's iterative solver converged", "method"),
    _F("iterations", "", "zhang2021: Levenberg–Marquardt iterations", "method"),
    _F("cost", "", "zhang2021: the final cost of eq. (21), weighted", "method"),
    _F("weights", "", "zhang2021: the mean weight of each residual kind", "method"),
    _F("weightless_segments", "", "zhang2021: weightless (tossed) segments used", "method"),
    _F("weightless_residual_rms", "m/s^2", "zhang2021: RMS of the eq. (19) loss over the weightless segments",
       "method"),
    _F("model_selection", "", "zhang2021: the model variants tried, their criteria and the one chosen", "method"),
    _F("newton_iterations", "", "qureshi2017: Newton iterations of eq. (12)", "method"),
    _F("qureshi_X", "", "qureshi2017: the parameter vector X of eq. (11) (b, k, k_xy, k_xz, k_yz)", "method"),
    _F("positions", "", "wang2019: turntable positions used", "method"),
    _F("turn_pairs", "", "wang2019: clockwise/counter-clockwise turn pairs used", "method"),
    _F("accelerometer_cost", "", "wang2019: the final cost of eq. (18)", "method"),
    _F("gyroscope_cost", "", "wang2019: the final cost of eq. (30)", "method"),
    _F("bias_cost", "", "wang2019: the final cost of eq. (35)", "method"),
    # thermal
    _F("temperature_model", "", "the temperature model ('linear': biases linear in temperature)", "thermal"),
    _F("temperature_c", "°C", "the lowest, reference and highest temperature of the calibrations combined",
       "thermal"),
    _F("thermal_decisions", "", "per parameter, the order of its temperature model and why", "thermal"),
    _F("thermal_slopes_left_out", "", "the temperature slopes the data do not support, left out", "thermal"),
    _F("combined_from", "", "the number of calibrations a thermal model combines", "thermal"),
    # uncertainty
    _F("uncertainty", "the parameter's", "1σ error of each named parameter (accelerometer.bias.x, …)",
       "uncertainty"),
    _F("uncertainty_unavailable", "", "why some parameters have no 1σ error, in words", "uncertainty"),
    # verdict
    _F("verdict", "", "accepted, suspect or rejected", "verdict"),
    _F("verdict_reasons", "", "the reasons for a verdict other than accepted, in words", "verdict"),
    _F("verdict_notes", "", "notes that do not change the verdict, in words", "verdict"),
    _F("next_poses", "", "the up-directions of the poses to record next (unit vectors in the body frame)",
       "verdict"),
)
del _F

_BY_NAME = {f.name: f for f in FIELDS}


def field(name: str) -> FieldInfo:
    """The declaration of the field ``name``; a KeyError naming the field when it is not declared."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise KeyError(f"{name!r} is not a declared field of the fit report (imucalib.reportfields.FIELDS)") from None


def undeclared(fit: dict) -> list[str]:
    """The keys of ``fit`` that are not declared fields, in their order."""
    return [k for k in fit if k not in _BY_NAME]
