"""Calibration methods, one module per published method, behind one entry point.

``calibrate(data, method=NAME, ...)`` runs a method on a :class:`Recording`
and returns a :class:`~imucalib.calibration.Calibration`. ``data`` may also be
a session: an object with a ``recording`` (or turntable aggregates, for
``wang2019``) and ``method_options(method)``, the keyword options it brings
(a simulated session's static layout, Zhang 2021's weightless spins); options
given here take precedence.
"""

from __future__ import annotations

import inspect
import warnings
from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np

from ..calibration import Calibration, with_bias_session
from ..fit.magnetometer import fit_magnetometer
from ..fitreport import MagnetometerReport, UncertaintyReport
from ..io.posetable import PoseTable
from ..methodinfo import DEFAULT_METHOD, MethodInfo
from ..recording import STANDARD_GRAVITY, ImucalibWarning, Interval, Recording
from ..thermal import calibrate_ramp, compensate
from ..upright import inverted_rest_note
from ..verdict import check_rate, with_verdict
from . import ellipsoid, ferraris, qureshi2017, six_position, tedaldi2014, wang2019, zhang2021
from ._pose_table import METHOD_NAME, calibrate_pose_table
from ._pose_table import apply_to_table as _table_apply

__all__ = ["ACCELEROMETER_ONLY", "METHODS", "apply_to_table", "calibrate", "method_names", "six_faces_only",
           "with_magnetometer"]


#: method name → its module (``module.METHOD`` its declaration, ``module.calibrate`` the method itself)
METHODS: dict[str, ModuleType] = {module.METHOD.name: module for module in (
    tedaldi2014, ellipsoid, ferraris, qureshi2017, six_position, wang2019, zhang2021)}


def _run(module: ModuleType, data, *, model: str | None, gravity: float, **options: Any) -> Calibration:
    """``module.calibrate`` on ``data`` (the recording of a session, or its turntable aggregates) with ``options``."""
    info: MethodInfo = module.METHOD
    if len(info.models) == 1 and model not in (None, info.default_model):
        raise ValueError(f"{info.name} fits the {info.default_model} model only; got model={model!r}")
    if "turntable aggregates" in info.needs:
        if not hasattr(data, "positions_acc"):
            raise ValueError(f"{info.name} needs turntable data (static position means and clockwise/"
                             "counter-clockwise turn integrals), as the wang2019 scenario provides; "
                             "it does not run on a free-hand recording")
    else:
        data = _recording_of(data)
    if len(info.models) > 1:
        options = {**options, "model": model or info.default_model}
    return module.calibrate(data, gravity=gravity, **_accepted(module.calibrate, options))


#: the methods that calibrate an accelerometer-only recording (no gyroscope section in the calibration)
ACCELEROMETER_ONLY = tuple(sorted(name for name, module in METHODS.items() if module.METHOD.accelerometer_only))


def method_names() -> list[str]:
    """Names accepted by :func:`calibrate`.

    Returns
    -------
    list of str
        The methods' names, as ``--method`` takes them.

    Examples
    --------
    >>> from imucalib.methods import method_names
    >>> "tedaldi2014" in method_names() and "zhang2021" in method_names()
    True
    """
    return sorted(METHODS)


def _accepted(fn: Callable, options: dict) -> dict:
    """``options`` without ``progress`` when ``fn`` does not report progress."""
    if "progress" in options and "progress" not in inspect.signature(fn).parameters:
        options = {k: v for k, v in options.items() if k != "progress"}
    return options


def _recording_of(data) -> Recording:
    if isinstance(data, Recording):
        return data
    rec = getattr(data, "recording", None)
    if isinstance(rec, Recording):
        return rec
    if hasattr(data, "positions_acc"):
        raise ValueError("this is a turntable session (static position means and turn integrals), not a "
                         "recording of samples: only --method wang2019 calibrates it")
    raise TypeError(f"expected a Recording or a session with a recording; got {type(data).__name__}")


def calibrate(
    data,
    *,
    method: str | None = None,
    model: str | None = None,
    gravity: float = STANDARD_GRAVITY,
    **options: Any,
) -> Calibration:
    """Calibrate with the named method.

    Parameters
    ----------
    data : Recording or session or PoseTable
        Raw readings (a session contributes its ``recording`` and the options
        of its ``method_options(method)``); a table of averaged poses
        (:func:`imucalib.io.read_pose_table`) has its accelerometer calibrated from its pose means
        (:func:`imucalib.methods._pose_table.calibrate_pose_table`, whatever the default method).
    method : str, optional
        One of :func:`method_names`. By default :data:`~imucalib.methodinfo.DEFAULT_METHOD`, as
        ``imucalib calibrate`` without ``--method``; when its calibration is rejected and the static
        poses are only the six faces of a Ferraris procedure (:func:`six_faces_only`: six orientations
        cannot determine the nine accelerometer parameters from the gravity norm alone), ``ferraris``
        is tried on the same recording and its calibration returned when it is not rejected, with an
        :class:`~imucalib.recording.ImucalibWarning` saying so.
    model : str, optional
        Model variant where the method has several (e.g. ``"linear"``, ``"cubic"``).
    gravity : float
        Local gravity [m/s²].
    **options
        Method-specific keyword options (see each method's ``calibrate``), and for a recording
        with a magnetometer: ``magnetometer`` (False: leave it uncalibrated), ``mag_field``
        (local field [µT]) and ``mag_hemisphere`` (``"north"``/``"south"``), see
        :func:`with_magnetometer`; ``temperature_model="linear"`` for a session recorded while the
        temperature changed (biases linear in temperature, :func:`imucalib.thermal.calibrate_ramp`).

    Returns
    -------
    Calibration
        With ``fit.verdict.level`` (``accepted``, ``suspect`` or ``rejected``) and
        ``fit.verdict.reasons`` (:mod:`imucalib.verdict`).

    Raises
    ------
    ValueError
        For an unknown ``method``, a ``model`` the method does not fit, a recording the method cannot
        calibrate (e.g. accelerometer-only for a method that needs a gyroscope, free-hand readings for
        ``wang2019``, poses that miss a face the method needs) or a bad option.
    TypeError
        When ``data`` is neither a recording, a session nor a pose table.

    Examples
    --------
    A short simulated hand-held session, calibrated by the default method and by another one:

    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> cal = calibrate(sim.recording)
    >>> cal.method, cal.fit.verdict.level
    ('tedaldi2014', 'accepted')
    >>> calibrate(sim.recording, method="ellipsoid").fit.verdict.level
    'accepted'
    >>> calibrate(sim.recording, method="no_such_method")
    Traceback (most recent call last):
        ...
    ValueError: unknown method 'no_such_method'; choose one of ellipsoid, ferraris, ...
    """
    cal = _calibrate(data, method=method or DEFAULT_METHOD, model=model, gravity=gravity, **options)
    recording = _recording_or_none(data)
    _note_inverted_rest(cal, recording)
    if (method is None and model is None and cal.fit.verdict.level == "rejected" and recording is not None
            and recording.gyro is not None and six_faces_only(recording, cal.fit.poses.intervals or [])):
        try:
            faces = _calibrate(data, method="ferraris", model=None, gravity=gravity, **options)
        except ValueError:
            return cal
        if faces.fit.verdict.level != "rejected":
            warnings.warn(f"the static poses are only the six faces (the Ferraris procedure): {DEFAULT_METHOD} "
                          "cannot determine the accelerometer's nine parameters from six orientations (its "
                          "calibration was rejected), so it was calibrated with ferraris, which takes the faces' "
                          "directions as known; pass --method to choose", ImucalibWarning, stacklevel=2)
            return faces
    return cal


def _note_inverted_rest(cal: Calibration, recording: Recording | None) -> None:
    """A warning when the calibrated initial rest reads −g on z (:mod:`imucalib.upright`: the sign convention)."""

    intervals = cal.fit.poses.intervals or []
    note = inverted_rest_note(cal, recording, intervals[0]) if recording is not None and intervals else None
    if note is not None:
        warnings.warn(note, ImucalibWarning, stacklevel=3)


def _recording_or_none(data) -> Recording | None:
    rec = data if isinstance(data, Recording) else getattr(data, "recording", None)
    return rec if isinstance(rec, Recording) else None


def six_faces_only(recording: Recording, intervals, *, within_deg: float = 30.0) -> bool:
    """Whether the static poses point gravity along the six axis directions only (and each of them at least once).

    A pose's direction is its mean accelerometer reading's; it counts as a face when within ``within_deg`` of
    ±x, ±y or ±z (raw axes: a MEMS sensor's misalignment and the table's tilt are a few degrees). The initial
    rest is one of the poses.
    """
    if len(intervals) < 6:
        return False
    means = np.array([recording.acc[int(a):int(b)].mean(axis=0) for a, b in intervals])
    u = means / np.linalg.norm(means, axis=1, keepdims=True)
    axis = np.argmax(np.abs(u), axis=1)
    if np.any(np.abs(u[np.arange(len(u)), axis]) < np.cos(np.radians(within_deg))):
        return False
    faces = {(int(k), bool(u[i, k] > 0)) for i, k in enumerate(axis)}
    return len(faces) == 6


def _calibrate(data, *, method: str, model: str | None, gravity: float, **options: Any) -> Calibration:
    """:func:`calibrate` with the method named."""
    if isinstance(data, PoseTable):
        return _calibrate_table(data, method, model, gravity, options)
    try:
        module = METHODS[method]
    except KeyError:
        raise ValueError(
            f"unknown method {method!r}; choose one of {', '.join(method_names())}"
        ) from None
    rec = data if isinstance(data, Recording) else getattr(data, "recording", None)
    if isinstance(rec, Recording) and rec.gyro is None and method not in ACCELEROMETER_ONLY:
        raise ValueError(f"{method} needs a gyroscope and this recording is accelerometer-only; the methods that "
                         f"take it are {', '.join(ACCELEROMETER_ONLY)}")
    session_options = getattr(data, "method_options", None)
    if not isinstance(data, Recording) and callable(session_options):
        options = {**session_options(method), **options}
    mag_options = {k: options.pop(k) for k in ("magnetometer", "mag_field", "mag_hemisphere") if k in options}
    temperature_model = options.pop("temperature_model", None)
    if temperature_model not in (None, "none", "linear"):
        raise ValueError(f"temperature_model must be 'linear' (biases linear in temperature) or None; "
                         f"got {temperature_model!r}")
    recording = data if isinstance(data, Recording) else getattr(data, "recording", None)
    if not isinstance(recording, Recording):
        recording = None
    if recording is not None:
        check_rate(recording)
    raw = recording  # the recording as read: what apply recognises the calibrated session by
    own = temperature_model != "linear"  # the fit's figures are of this calibration on this recording
    if temperature_model == "linear":
        if recording is None:
            raise ValueError("a temperature model is fitted on a recording of samples with a temperature column")
        cal = calibrate_ramp(lambda rec: _run(module, rec, model=model, gravity=gravity, **options), recording)
        recording = compensate(cal, recording)[1]  # the checks below see the recording at the reference temperature
    else:
        cal = _run(module, data, model=model, gravity=gravity, **options)
    if recording is not None and recording.mag is not None and mag_options.get("magnetometer", True):
        cal = with_magnetometer(cal, recording, field=mag_options.get("mag_field"),
                                hemisphere=mag_options.get("mag_hemisphere", "north"))
    if raw is not None:
        cal = with_bias_session(cal, raw)
    # the magnetometer and the bias drift's session leave the accelerometer and gyroscope models as fitted
    return with_verdict(cal, recording, own_figures=own)


def _calibrate_table(table: PoseTable, method: str, model: str | None, gravity: float, options: dict) -> Calibration:
    """:func:`calibrate` of a pose table: its own recipe, which takes no method, model variant or option."""
    if method not in (DEFAULT_METHOD, METHOD_NAME):
        raise ValueError(f"a table of averaged poses is calibrated by the gravity-norm fit of its pose means "
                         f"(method {METHOD_NAME!r}); {method} calibrates a recording of samples")
    if model not in (None, "linear"):
        raise ValueError(f"a table of averaged poses is fitted with the linear model; got model={model!r}")
    unknown = sorted(k for k, v in options.items() if v is not None and k != "progress")
    if unknown:
        raise ValueError(f"a table of averaged poses takes no option {', '.join(unknown)}: they apply to recordings")
    return calibrate_pose_table(table, gravity=gravity)


def apply_to_table(calibration: Calibration, table: PoseTable):
    """A table of averaged poses corrected by ``calibration``: a ``CalibratedTable`` (``acc``, ``gyro``, ``notes``)."""
    return _table_apply(calibration, table)


def with_magnetometer(calibration: Calibration, recording: Recording, *, field: float | None = None,
                      hemisphere: str = "north") -> Calibration:
    """``calibration`` with the magnetometer of ``recording`` calibrated on its static poses.

    Runs :func:`~imucalib.fit.magnetometer.fit_magnetometer` on the poses in
    ``calibration.fit.poses.intervals``. When the magnetometer cannot be
    calibrated (too few poses, readings that do not determine an ellipsoid),
    the calibration is returned without it and ``fit.magnetometer.error``
    says why (the verdict then makes it suspect); a bad option is an error.

    Parameters
    ----------
    calibration : Calibration
        The accelerometer (and gyroscope) calibration of ``recording``.
    recording : Recording
        The recording it was made from, with magnetometer readings (``recording.mag``).
    field : float, optional
        The local field's magnitude [µT], for readings in counts; by default the field is normalised to 1.
    hemisphere : {"north", "south"}
        Where the recording was made (the sign of the field's dip).

    Returns
    -------
    Calibration
        ``calibration`` with its ``magnetometer`` and the ``magnetometer_…`` fit figures.

    Raises
    ------
    ValueError
        For a bad option (``hemisphere``, ``field``).

    Examples
    --------
    A simulated session with a magnetometer, calibrated first without it, then with it:

    >>> from imucalib.methods import calibrate, with_magnetometer
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14, magnetometer=True)
    >>> cal = calibrate(sim.recording, magnetometer=False)
    >>> cal.magnetometer is None
    True
    >>> cal = with_magnetometer(cal, sim.recording)
    >>> cal.magnetometer.unit, round(cal.fit.magnetometer.direction_error_mean_deg, 2)
    ('normalised', 0.05)
    """

    if hemisphere not in ("north", "south"):
        raise ValueError(f"the magnetic hemisphere must be 'north' or 'south'; got {hemisphere!r}")
    if field is not None and not (field > 0 and field < 1000):
        raise ValueError(f"the local field magnitude is a number of µT (25-65 on Earth's surface); got {field!r}")
    fit = calibration.fit
    intervals = [Interval(int(a), int(b)) for a, b in fit.poses.intervals or []]
    if calibration.gyroscope is None or recording.gyro is None:
        why = "its reference directions are carried from pose to pose by the gyroscope, and this calibration has none"
        return calibration.with_(fit=fit.add(MagnetometerReport(error=why)))
    try:
        mag = fit_magnetometer(recording, intervals, calibration, hemisphere=hemisphere, field=field)
    except ValueError as exc:
        return calibration.with_(fit=fit.add(MagnetometerReport(error=str(exc))))
    units = {**calibration.units, "magnetometer": {"raw": recording.mag_unit, "calibrated": mag.model.unit}}
    sigma = UncertaintyReport(sigma={**(fit.uncertainty.sigma or {}), **mag.uncertainty})
    return calibration.with_(magnetometer=mag.model, units=units, fit=fit.add(mag.figures, sigma))
