"""The fit report: what a calibration's fit found, stage by stage, as typed records.

:attr:`imucalib.calibration.Calibration.fit` is a :class:`FitReport`: one frozen record per stage — the
segmentation's poses (:class:`SegmentationReport`), the accelerometer's, gyroscope's and magnetometer's fits,
the method's own figures, the temperature model, the parameters' 1σ errors and the verdict — each field
declared once here with its unit and meaning (the field's ``metadata``), and the key it has in a calibration
file's ``fit`` object. The methods and the shared stages build the records; the command line, the report,
validation and batch runs read their attributes (``cal.fit.verdict.level``, ``cal.fit.accelerometer.residual_rms``).

A record holds only the fields given to it: a field not given reads as None and is not written, while one given
as None is written as ``null`` (``magnetometer_field_error``: a uniform field), so that a file's ``fit`` object
is exactly the flat one of :meth:`FitReport.to_flat`, read back by :meth:`FitReport.from_flat`. A key no record
declares (a file from another version) is kept as read in :attr:`FitReport.extra` and written back. Read as a
mapping, a report is that flat object (``report["verdict"]``), for scripts written against the flat layout.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

__all__ = ["GROUPS", "AccelerometerReport", "FitReport", "GyroscopeReport", "MagnetometerReport", "MethodReport",
           "SegmentationReport", "ThermalReport", "UncertaintyReport", "VerdictReport", "declarations"]


class _Unset:
    """The default of a field not given (read as None, not written)."""

    __slots__ = ()

    def __repr__(self) -> str:
        return "<unset>"


_UNSET: Any = _Unset()


def _f(key: str, unit: str, meaning: str, *, by_index: bool = False) -> Any:
    """A report field: its key in the file's ``fit`` object, its unit (``""``: a count, a ratio, a name or
    text; for a list or mapping, its entries' unit) and what it holds, in one sentence. ``by_index``: a
    mapping by integer index in the record, by the index's text in the file (JSON's keys are texts)."""
    return field(default=_UNSET, metadata={"key": key, "unit": unit, "meaning": meaning, "by_index": by_index})


def _encoded(f, value: Any) -> Any:
    """A field's value as the file's ``fit`` object holds it."""
    if f.metadata["by_index"] and isinstance(value, Mapping):
        return {str(k): v for k, v in value.items()}
    return value


def _decoded(f, value: Any) -> Any:
    """A field's value from the file's ``fit`` object, as the record holds it."""
    if f.metadata["by_index"] and isinstance(value, Mapping):
        return {int(k): v for k, v in value.items()}
    return value


@functools.cache
def _declared_fields(record: type) -> tuple:
    """The fields of a record class that the file declares (those with a key), in their order."""
    return tuple(f for f in fields(record) if "key" in f.metadata)


@functools.cache
def _names(record: type) -> frozenset:
    """The names of a record class's declared fields."""
    return frozenset(f.name for f in _declared_fields(record))


@functools.cache
def _nothing_given(record: type) -> dict[str, None]:
    """Each declared field of a record class as None (its value when not given)."""
    return dict.fromkeys(f.name for f in _declared_fields(record))


@dataclass(frozen=True, init=False, repr=False, eq=False)
class _Group:
    """A stage's record: the fields given, each None when not given.

    ``given`` names the fields given (those written to the file). A copy with changes is :meth:`with_`
    (``dataclasses.replace`` would give every field, the ones not given as ``null``). The records share this
    ``__init__``, which takes the fields by name and notes which were given, and its ``__eq__`` and ``__repr__``.
    """

    given: frozenset = field(default=frozenset(), init=False, repr=False)

    def __init__(self, **values: Any) -> None:
        cls = type(self)
        if not values.keys() <= _names(cls):
            raise TypeError(f"{cls.__name__} has no field {', '.join(sorted(values.keys() - _names(cls)))}")
        given = frozenset(name for name, value in values.items() if value is not _UNSET)
        state = self.__dict__  # as dataclass's own __init__ of a frozen class sets them, past __setattr__
        state.update(_nothing_given(cls))
        state.update((name, values[name]) for name in given)
        state["given"] = given

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self.given == other.given and all(getattr(self, f.name) == getattr(other, f.name)
                                                 for f in self._declared())

    __hash__ = None  # type: ignore[assignment]  # records hold lists and mappings

    def __repr__(self) -> str:
        fields_ = ", ".join(f"{f.name}={getattr(self, f.name)!r}" for f in self._declared())
        return f"{type(self).__qualname__}({fields_})"

    @classmethod
    def _declared(cls) -> tuple:
        return _declared_fields(cls)

    def __bool__(self) -> bool:
        return bool(self.given)

    def with_(self, **changes: Any) -> _Group:
        """A copy with ``changes`` given (an attribute given as None is written as ``null``)."""
        return type(self)(**{**{n: getattr(self, n) for n in self.given}, **changes})

    def merged(self, other: _Group) -> _Group:
        """This record with the fields ``other`` gives replaced by ``other``'s."""
        return self.with_(**{n: getattr(other, n) for n in other.given})

    def flat(self) -> dict[str, Any]:
        """The given fields by their keys in the file, in their declared order."""
        return {f.metadata["key"]: _encoded(f, getattr(self, f.name)) for f in self._declared() if f.name in self.given}


@dataclass(frozen=True, init=False, repr=False, eq=False)
class SegmentationReport(_Group):
    """The static poses the fit used and how they cover the directions (the segmentation).

    Examples
    --------
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> cal = calibrate(session("handheld", rng=1, rest=10, n_poses=14).recording)
    >>> cal.fit.poses.static_intervals, cal.fit.poses.intervals[:2], cal.fit.poses.threshold_multiplier
    (15, [[0, 948], [1476, 1802]], 7.0)
    """

    intervals: list | None = _f("intervals", "samples",
            "the static intervals used, [start, stop) sample indices")
    static_intervals: int | None = _f("static_intervals", "",
            "the number of static intervals used")
    pose_coverage: dict | None = _f("pose_coverage", "",
            "per body axis, the least and largest gravity component over the poses (unit vector)")
    quality_flags: list | None = _f("quality_flags", "",
            "warnings on the poses' coverage and spread, in words")
    initial_rest_seconds: float | None = _f("initial_rest_seconds", "s",
            "length of the initial rest used for the noise")
    threshold_multiplier: float | None = _f("threshold_multiplier", "",
            "the static detector's threshold, in multiples of the rest's variance (tedaldi2014's choice)")
    faces: dict | None = _f("faces", "",
            "the static pose taken for each face (+x, −x, …): index into the intervals")
    faces_tilt_deg: dict | None = _f("faces_tilt_deg", "deg",
            "each face's tilt from its axis")
    sections: str | None = _f("sections", "samples",
            "ferraris: the named sample ranges used")


@dataclass(frozen=True, init=False, repr=False, eq=False)
class AccelerometerReport(_Group):
    """The accelerometer's fit figures.

    Examples
    --------
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> cal = calibrate(session("handheld", rng=1, rest=10, n_poses=14).recording)
    >>> fit = cal.fit.accelerometer
    >>> round(fit.residual_rms, 4), fit.residual_to_noise < 1  # [m/s²]; under the white-noise floor
    (0.0005, True)
    """

    residual_rms: float | None = _f("accelerometer_residual_rms", "m/s^2",
            "RMS of |a| − g over the static poses")
    residual_rms_raw: float | None = _f("accelerometer_residual_rms_raw", "m/s^2",
            "RMS of |a| − g over the same poses for the raw readings (the identity calibration: no bias, the "
            "unit's nominal scale, no misalignment; physical units only)")
    noise_floor: float | None = _f("accelerometer_noise_floor", "m/s^2",
            "the residual RMS the white noise alone leaves")
    residual_to_noise: float | None = _f("accelerometer_residual_to_noise", "",
            "accelerometer_residual_rms over accelerometer_noise_floor")
    unvisited_sigma_to_noise: float | None = _f("accelerometer_unvisited_sigma_to_noise", "",
            "the largest 1σ of the calibrated |a| over the directions no pose visited, over "
            "accelerometer_noise_floor (0: every axis visited up and down; null: not determined)")
    model: Any = _f("accelerometer_model", "",
            "the accelerometer model fitted (the full one or a reduced one)")
    weights: Any = _f("accelerometer_weights", "",
            "pose_table: how the table's poses were weighted, in words")
    reduced_chi2: Any = _f("accelerometer_reduced_chi2", "",
            "pose_table: Σ (r_k/σ_r,k)² / (M − P) of the fit weighted by the table's σ/√n")
    model_reduced: Any = _f("accelerometer_model_reduced", "",
            "why the poses determine a reduced accelerometer model, in words")
    misalignment: str | None = _f("accelerometer_misalignment", "",
            "six_position: whether the accelerometer's misalignment was estimated (from the rotations) or held at "
            "zero, in words")


@dataclass(frozen=True, init=False, repr=False, eq=False)
class GyroscopeReport(_Group):
    """The gyroscope's fit figures.

    Examples
    --------
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> cal = calibrate(session("handheld", rng=1, rest=10, n_poses=14).recording)
    >>> fit = cal.fit.gyroscope
    >>> round(fit.angle_error_mean_deg, 3), fit.bias_source, fit.g_sensitivity
    (0.034, 'joint', 'estimated')
    """

    angle_error_mean_deg: float | None = _f("gyroscope_angle_error_mean_deg", "deg",
            "mean gravity-direction error after integrating each rotation, over every rotation between the poses "
            "(those left out of the fit included)")
    angle_error_mean_deg_raw: Any = _f("gyroscope_angle_error_mean_deg_raw", "deg",
            "gyroscope_angle_error_mean_deg for the raw readings (the identity calibration of both sensors; "
            "physical units only)")
    angle_error_max_deg: float | None = _f("gyroscope_angle_error_max_deg", "deg",
            "largest gravity-direction error after a rotation")
    angle_errors_deg: list | None = _f("gyroscope_angle_errors_deg", "deg",
            "each rotation's gravity-direction error, in order (the rotation from pose k + 1 to k + 2 at k)")
    angle_error_kept_mean_deg: float | None = _f("gyroscope_angle_error_kept_mean_deg", "deg",
            "mean gravity-direction error over the rotations kept")
    angle_error_reliable_mean_deg: float | None = _f("gyroscope_angle_error_reliable_mean_deg", "deg",
            "mean gravity-direction error over the rotations without saturated samples, spikes or gaps (the ones "
            "the verdict's noise check judges), when some have them")
    angle_error_predicted_deg: float | None = _f("gyroscope_angle_error_predicted_deg", "deg",
            "the mean gravity-direction error the noise alone predicts")
    error_to_noise: float | None = _f("gyroscope_error_to_noise", "",
            "the mean gravity-direction error over the predicted, over the rotations without saturated samples, "
            "spikes or gaps")
    rest_rate_deg_s: list | None = _f("gyroscope_rest_rate_deg_s", "deg/s",
            "the calibrated rate at rest, per axis (mean over the poses)")
    rest_rate_to_scatter: float | None = _f("gyroscope_rest_rate_to_scatter", "",
            "the largest rest rate over its scatter between poses")
    bias_source: str | None = _f("gyroscope_bias_source", "",
            "where the gyroscope bias comes from (the rests or the rotations)")
    bias_drift_per_s: list | None = _f("gyroscope_bias_drift_per_s", "raw/s",
            "the gyroscope bias's linear drift, per axis")
    bias_drift_se_per_s: list | None = _f("gyroscope_bias_drift_se_per_s", "raw/s",
            "1σ error of the bias drift, per axis")
    bias_time_s: float | None = _f("gyroscope_bias_time_s", "s",
            "the time at which the drifting bias is the bias stated")
    bias_session_s: list | None = _f("gyroscope_bias_session_s", "s",
            "the first and last time of the recording the bias drift was fitted on, in its time base")
    bias_session_check: list | None = _f("gyroscope_bias_session_check", "",
            "a few samples of that recording ([time s, raw gyroscope x, y, z]) that apply recognises it by")
    bias_drift_over_session_deg_s: list | None = _f("gyroscope_bias_drift_over_session_deg_s", "deg/s",
            "the calibrated rate at rest the bias drift adds to the stored bias's at the session's start and end "
            "(two rows, per axis)")
    g_sensitivity: str | None = _f("gyroscope_g_sensitivity", "",
            "whether the g-sensitivity was estimated ('estimated' or 'none')")
    rotation_sigma_rad: float | None = _f("gyroscope_rotation_sigma_rad", "rad",
            "the rotations' residual scatter the gyroscope fit weighs by")
    not_calibrated: Any = _f("gyroscope_not_calibrated", "",
            "why the gyroscope was left uncalibrated, in words")
    rest_mean: Any = _f("gyroscope_rest_mean", "raw",
            "pose_table: the mean of the poses' gyroscope means, per axis (the bias where the sensor was still)")
    rest_mean_sigma: Any = _f("gyroscope_rest_mean_sigma", "raw",
            "pose_table: the standard error of gyroscope_rest_mean over the poses")
    rest_mean_unit: Any = _f("gyroscope_rest_mean_unit", "",
            "pose_table: the raw unit of gyroscope_rest_mean")
    approach: str | None = _f("gyroscope_approach", "",
            "qureshi2017's gyroscope approach (static bias or dynamic)")
    rotations_left_out: dict[int, str] | None = _f("rotations_left_out", "",
            "the rotations left out of the gyroscope fit and why, by index", by_index=True)
    rotations_unreliable: dict[int, str] | None = _f("rotations_unreliable", "",
            "the rotations between poses whose integration the data do not allow (saturated samples, spikes, "
            "sampling gaps, unsteady poses) and why, by index: left out of the fit and of the verdict's judgement",
            by_index=True)
    rotations_used: list | None = _f("rotations_used", "",
            "qureshi2017: turns used about each axis")
    rotations_rejected: list | None = _f("rotations_rejected", "",
            "qureshi2017: turns rejected about each axis")
    turns: dict | None = _f("turns", "",
            "ferraris: the turn found about each axis: index into the motions")
    turn_sections: list | None = _f("turn_sections", "samples",
            "ferraris: each turn's sample range")
    turn_angle_deg: float | None = _f("turn_angle_deg", "deg",
            "ferraris: the known angle of each turn, and the angles measured")


@dataclass(frozen=True, init=False, repr=False, eq=False)
class MagnetometerReport(_Group):
    """The magnetometer's fit figures.

    Examples
    --------
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> cal = calibrate(session("handheld", rng=1, rest=10, n_poses=14, magnetometer=True).recording)
    >>> fit = cal.fit.magnetometer
    >>> fit.poses, round(fit.dip_spread_deg, 3), fit.field_uniform
    (15, 0.026, True)
    """

    poses: Any = _f("magnetometer_poses", "",
            "static poses the magnetometer fit used")
    axes: Any = _f("magnetometer_axes", "",
            "the magnetometer's axes named in the accelerometer's frame")
    rotations_left_out: Any = _f("magnetometer_rotations_left_out", "",
            "rotations left out of the magnetometer's alignment")
    alignment_rotation_deg: Any = _f("magnetometer_alignment_rotation_deg", "deg",
            "angle of the magnetometer-to-body rotation")
    hemisphere: Any = _f("magnetometer_hemisphere", "",
            "the field points below (north) or above (south) the horizontal")
    dip_deg: Any = _f("magnetometer_dip_deg", "deg",
            "the fitted dip angle of the field")
    dips_deg: Any = _f("magnetometer_dips_deg", "deg",
            "the dip angle at each pose")
    dip_spread_deg: Any = _f("magnetometer_dip_spread_deg", "deg",
            "the dip angles' standard deviation over the poses")
    field_norms: Any = _f("magnetometer_field_norms", "calibrated",
            "the calibrated field's magnitude at each pose")
    norm_spread: Any = _f("magnetometer_norm_spread", "",
            "the calibrated magnitudes' relative standard deviation")
    direction_error_mean_deg: Any = _f("magnetometer_direction_error_mean_deg", "deg",
            "mean error of the field's direction over the poses")
    direction_error_max_deg: Any = _f("magnetometer_direction_error_max_deg", "deg",
            "largest error of the field's direction")
    hard_iron_drift_per_min: Any = _f("magnetometer_hard_iron_drift_per_min", "raw/min",
            "the hard iron's drift, per axis (None: not fitted)")
    hard_iron_drift_sigma_per_min: Any = _f("magnetometer_hard_iron_drift_sigma_per_min", "raw/min",
            "1σ error of the hard-iron drift")
    hard_iron_drift_over_session: Any = _f("magnetometer_hard_iron_drift_over_session", "calibrated",
            "how far the hard-iron drift moves the calibrated field over the session")
    field_uniform: Any = _f("magnetometer_field_uniform", "",
            "whether the field was the same at every pose (else the fit held it to each pose's vertical component "
            "and horizontal magnitude)")
    field_scatter_chi2: Any = _f("magnetometer_field_scatter_chi2", "",
            "the poses' field norms' scatter per degree of freedom against their noise")
    field_error: Any = _f("magnetometer_field_error", "calibrated",
            "the field's error at a pose where the field is not uniform, 1σ (None: uniform)")
    accelerometer_shift_sigma: Any = _f("magnetometer_accelerometer_shift_sigma", "",
            "how far the joint fit moved the accelerometer's parameters, in their 1σ (None: uniform field)")
    error: Any = _f("magnetometer_error", "",
            "why the magnetometer was left uncalibrated, in words")


@dataclass(frozen=True, init=False, repr=False, eq=False)
class MethodReport(_Group):
    """Figures a particular method reports about its own fit.

    Examples
    --------
    >>> from imucalib.fitreport import MethodReport
    >>> MethodReport(converged=True, iterations=12).flat()  # the file's keys of the given fields
    {'converged': True, 'iterations': 12}
    """

    converged: bool | None = _f("converged", "",
            "whether the method's iterative solver converged")
    iterations: int | None = _f("iterations", "",
            "zhang2021: Levenberg–Marquardt iterations")
    cost: float | None = _f("cost", "",
            "zhang2021: the final cost of eq. (21), weighted")
    weights: dict | None = _f("weights", "",
            "zhang2021: the mean weight of each residual kind")
    weightless_segments: int | None = _f("weightless_segments", "",
            "zhang2021: weightless (tossed) segments used")
    weightless_residual_rms: float | None = _f("weightless_residual_rms", "m/s^2",
            "zhang2021: RMS of the eq. (19) loss over the weightless segments")
    model_selection: dict | None = _f("model_selection", "",
            "zhang2021: the model variants tried, their criteria and the one chosen")
    newton_iterations: int | None = _f("newton_iterations", "",
            "qureshi2017: Newton iterations of eq. (12)")
    qureshi_X: list | None = _f("qureshi_X", "",
            "qureshi2017: the parameter vector X of eq. (11) (b, k, k_xy, k_xz, k_yz)")
    positions: Any = _f("positions", "",
            "wang2019: turntable positions used")
    turn_pairs: Any = _f("turn_pairs", "",
            "wang2019: clockwise/counter-clockwise turn pairs used")
    accelerometer_cost: Any = _f("accelerometer_cost", "",
            "wang2019: the final cost of eq. (18)")
    gyroscope_cost: Any = _f("gyroscope_cost", "",
            "wang2019: the final cost of eq. (30)")
    bias_cost: Any = _f("bias_cost", "",
            "wang2019: the final cost of eq. (35)")


@dataclass(frozen=True, init=False, repr=False, eq=False)
class ThermalReport(_Group):
    """The temperature model.

    Examples
    --------
    >>> from imucalib.fitreport import ThermalReport
    >>> ThermalReport().flat(), ThermalReport(temperature_c=25.0).flat()  # nothing given, nothing written
    ({}, {'temperature_c': 25.0})
    """

    model: Any = _f("temperature_model", "",
            "the temperature model ('linear': biases linear in temperature)")
    temperature_c: Any = _f("temperature_c", "°C",
            "the lowest, reference and highest temperature of the calibrations combined")
    decisions: Any = _f("thermal_decisions", "",
            "per parameter, the order of its temperature model and why")
    slopes_left_out: Any = _f("thermal_slopes_left_out", "",
            "the temperature slopes the data do not support, left out")
    combined_from: Any = _f("combined_from", "",
            "the number of calibrations a thermal model combines")


@dataclass(frozen=True, init=False, repr=False, eq=False)
class UncertaintyReport(_Group):
    """1σ errors of the parameters.

    Examples
    --------
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> cal = calibrate(session("handheld", rng=1, rest=10, n_poses=14).recording)
    >>> round(cal.fit.uncertainty.sigma["accelerometer.bias.x"], 2)  # 1σ [counts]
    0.8
    """

    sigma: dict | None = _f("uncertainty", "the parameter's",
            "1σ error of each named parameter (accelerometer.bias.x, …)")
    unavailable: str | None = _f("uncertainty_unavailable", "",
            "why some parameters have no 1σ error, in words")


@dataclass(frozen=True, init=False, repr=False, eq=False)
class VerdictReport(_Group):
    """The verdict on the calibration and what to do next.

    Examples
    --------
    >>> from imucalib.fitreport import VerdictReport
    >>> verdict = VerdictReport(level="accepted").with_(notes=["the initial rest is 10 s long"])
    >>> verdict.level, verdict.flat()
    ('accepted', {'verdict': 'accepted', 'verdict_notes': ['the initial rest is 10 s long']})
    """

    level: str | None = _f("verdict", "",
            "accepted, suspect or rejected")
    reasons: list | None = _f("verdict_reasons", "",
            "the reasons for a verdict other than accepted, in words")
    notes: list | None = _f("verdict_notes", "",
            "notes that do not change the verdict, in words")
    next_poses: list | None = _f("next_poses", "",
            "the up-directions of the poses to record next (unit vectors in the body frame)")


#: the fit report's records: attribute of :class:`FitReport` → (record, what it covers)
GROUPS: dict[str, str] = {
    "poses": "the static poses the fit used and how they cover the directions",
    "accelerometer": "the accelerometer's fit figures",
    "gyroscope": "the gyroscope's fit figures",
    "magnetometer": "the magnetometer's fit figures",
    "method": "figures a particular method reports about its own fit",
    "thermal": "the temperature model",
    "uncertainty": "1σ errors of the parameters",
    "verdict": "the verdict on the calibration and what to do next",
}

_RECORDS: dict[str, type[_Group]] = {
    "poses": SegmentationReport, "accelerometer": AccelerometerReport, "gyroscope": GyroscopeReport,
    "magnetometer": MagnetometerReport, "method": MethodReport, "thermal": ThermalReport,
    "uncertainty": UncertaintyReport, "verdict": VerdictReport,
}
#: a file key → (record's attribute in FitReport, field's attribute in the record)
_KEYS: dict[str, tuple[str, str]] = {f.metadata["key"]: (g, f.name) for g, r in _RECORDS.items()
                                     for f in r._declared()}
_FIELDS = {f.metadata["key"]: f for r in _RECORDS.values() for f in r._declared()}


def declarations() -> Iterator[tuple[str, str, str, str]]:
    """Every declared field as ``(key in the file, unit, meaning, record)``, records in :data:`GROUPS`' order."""
    for g, record in _RECORDS.items():
        for f in record._declared():
            yield f.metadata["key"], f.metadata["unit"], f.metadata["meaning"], g


@dataclass(frozen=True, eq=False)
class FitReport(Mapping):
    """What a calibration's fit found: one record per stage, and the keys of a file no record declares.

    Read as a mapping it is the file's flat ``fit`` object (:meth:`to_flat`); two reports are equal when
    those are.

    Attributes
    ----------
    poses : SegmentationReport
    accelerometer : AccelerometerReport
    gyroscope : GyroscopeReport
    magnetometer : MagnetometerReport
    method : MethodReport
    thermal : ThermalReport
    uncertainty : UncertaintyReport
    verdict : VerdictReport
    extra : Mapping
        Keys of a file's ``fit`` that no record declares (a file from another version), kept as read.

    Examples
    --------
    A calibration's report, read by record and, as the file has it, by key:

    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> cal = calibrate(session("handheld", rng=1, rest=10, n_poses=14).recording)
    >>> cal.fit.verdict.level, cal.fit.poses.static_intervals
    ('accepted', 15)
    >>> cal.fit["verdict"], cal.fit["static_intervals"]
    ('accepted', 15)
    >>> from imucalib.fitreport import FitReport, VerdictReport
    >>> report = FitReport().add(VerdictReport(level="suspect", reasons=["record more poses"]))
    >>> report.to_flat()
    {'verdict': 'suspect', 'verdict_reasons': ['record more poses']}
    >>> FitReport.from_flat(report.to_flat()) == report
    True
    """

    poses: SegmentationReport = field(default_factory=SegmentationReport)
    accelerometer: AccelerometerReport = field(default_factory=AccelerometerReport)
    gyroscope: GyroscopeReport = field(default_factory=GyroscopeReport)
    magnetometer: MagnetometerReport = field(default_factory=MagnetometerReport)
    method: MethodReport = field(default_factory=MethodReport)
    thermal: ThermalReport = field(default_factory=ThermalReport)
    uncertainty: UncertaintyReport = field(default_factory=UncertaintyReport)
    verdict: VerdictReport = field(default_factory=VerdictReport)
    extra: Mapping[str, Any] = field(default_factory=dict)

    RECORDS: ClassVar[dict[str, type[_Group]]] = _RECORDS

    # --------------------------------------------------------- building
    def add(self, *records: _Group | FitReport) -> FitReport:
        """This report with each record's given fields replaced by ``records``' (a whole report merges each of
        its records, and its extra keys)."""
        out = {g: getattr(self, g) for g in _RECORDS}
        extra = dict(self.extra)
        for r in records:
            if isinstance(r, FitReport):
                out = {g: out[g].merged(getattr(r, g)) for g in _RECORDS}
                extra.update(r.extra)
                continue
            g = _GROUP_OF[type(r)]
            out[g] = out[g].merged(r)
        return FitReport(**out, extra=extra)

    @classmethod
    def of(cls, *records: _Group | FitReport) -> FitReport:
        """A report of ``records`` (see :meth:`add`)."""
        return cls().add(*records)

    # ------------------------------------------------- the flat form
    def to_flat(self) -> dict[str, Any]:
        """The file's ``fit`` object: every given field by its key (records in order), then :attr:`extra`."""
        out: dict[str, Any] = {}
        for g in _RECORDS:
            out.update(getattr(self, g).flat())
        out.update(self.extra)
        return out

    @classmethod
    def from_flat(cls, flat: Mapping[str, Any]) -> FitReport:
        """Inverse of :meth:`to_flat`: each declared key into its record, the others into :attr:`extra`."""
        if isinstance(flat, FitReport):
            return flat
        given: dict[str, dict[str, Any]] = {g: {} for g in _RECORDS}
        extra = {}
        for key, value in flat.items():
            if key in _KEYS:
                g, name = _KEYS[key]
                given[g][name] = _decoded(_FIELDS[key], value)
            else:
                extra[key] = value
        return cls(**{g: r(**given[g]) for g, r in _RECORDS.items()}, extra=extra)

    @staticmethod
    def undeclared(flat: Mapping[str, Any]) -> list[str]:
        """The keys of a flat ``fit`` object no record declares, in their order."""
        return [k for k in flat if k not in _KEYS]

    # ------------------------------------------------ mapping (flat)
    def __getitem__(self, key: str) -> Any:
        if key in _KEYS:
            g, name = _KEYS[key]
            record = getattr(self, g)
            if name in record.given:
                return _encoded(_FIELDS[key], getattr(record, name))
        elif key in self.extra:
            return self.extra[key]
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return iter(self.to_flat())

    def __len__(self) -> int:
        return sum(len(getattr(self, g).given) for g in _RECORDS) + len(self.extra)

    def __repr__(self) -> str:
        parts = [f"{g}={getattr(self, g)!r}" for g in _RECORDS if getattr(self, g)]
        if self.extra:
            parts.append(f"extra={dict(self.extra)!r}")
        return f"FitReport({', '.join(parts)})"


_GROUP_OF: dict[type, str] = {r: g for g, r in _RECORDS.items()}
