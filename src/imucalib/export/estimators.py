"""A calibration for visual-inertial estimators: OpenVINS's ``kalibr_imu_chain.yaml`` and Kalibr's IMU yaml.

**OpenVINS** (``ov_msckf``; docs "Analytical Propagation: IMU Intrinsic Models",
``VioManagerOptions.h`` and ``Propagator.cpp`` of v2.7) reads, under ``imu0``,
``Tw``, ``Ta`` (3×3), ``R_IMUtoGYRO``, ``R_IMUtoACC`` (rotations), ``Tg`` and
``model``, forms ``D = T⁻¹`` and keeps its lower triangle (``model: kalibr``,
the default) or its upper triangle (``model: rpng``), then corrects each
reading ``a_m``, ``ω_m`` [m/s², rad/s] with the biases it estimates online::

    a_I = R_IMUtoACCᵀ · Da · (a_m − b_a)
    ω_I = R_IMUtoGYROᵀ · Dw · (ω_m − b_g − Tg · a_I)

With the linear form of :mod:`.linear` in physical units (``a = A (a_m − b_a)``,
``ω = W (ω_m − b_g − G a)``) the frame ``I`` is imucalib's and

* ``A = R_IMUtoACCᵀ Da`` and ``W = R_IMUtoGYROᵀ Dw`` are QR (``rpng``: ``Da``,
  ``Dw`` upper triangular) or QL (``kalibr``: lower) decompositions with proper
  rotations; for ``rpng`` and the canonical upper-triangular ``T_a``, ``A`` is
  upper triangular already and ``R_IMUtoACC = I``; ``Ta = Da⁻¹``, ``Tw = Dw⁻¹``
  (triangular as ``D``);
* ``Tg = s_g G`` (OpenVINS's ``Tg`` multiplies ``a_I``, ours ``a``: the same vector);
* the biases ``s_a b_a``, ``s_g b_g`` have no entry: OpenVINS estimates them
  online; the file names them in a comment as the values at calibration time.

**Kalibr** (``IccSensors.py``, ``IccScaledMisalignedImu``: Rehder et al. 2017)
models the raw readings from the true specific force ``a_i`` and rate ``ω_i``
in its IMU frame ``i`` (the accelerometer's, made orthogonal)::

    α_m = M_a a_i + b_a,    ω_m = M_g C_gyro_i ω_i + A C_gyro_i a_i + b_g

with ``M_a``, ``M_g`` lower triangular. Its input ``imu.yaml`` (``--imu``)
holds only the four noise entries, ``rostopic`` and ``update_rate``: Kalibr
estimates the intrinsics itself from identity and reads none. They have a place
only in its imu-camera result (the ``imu0`` entry of ``…-imu.yaml`` with
``model: scale-misalignment``), the form written here. imucalib makes the
accelerometer frame orthogonal with an upper-triangular ``T_a``, Kalibr with a
lower-triangular ``M_a``: the two frames differ by a small rotation ``R``,
``a_i = R a``, ``ω_i = R ω``, found by ``s_a A⁻¹ = M_a R`` (an LQ
decomposition); then ``s_g W⁻¹ = M_g C_gyro_i R`` and ``A = s_g G Rᵀ C_gyro_iᵀ``.
The file gives ``R`` in a comment.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from ..calibration import MAX_FILE_BYTES, Calibration
from ..io.jsontext import SmallFileError, loads, read_small_text
from ..noise import BOUND_MARK, kalibr_noise
from .linear import (
    ExportError,
    LinearForm,
    gyroscope_part,
    linear_form,
    rotation_times_triangular,
    triangular_times_rotation,
)
from .text import comment_text, yaml_scalar

__all__ = ["NOISE_KEYS", "OPENVINS_MODELS", "read_noise", "to_kalibr", "to_openvins"]

#: the noise entries of Kalibr's and OpenVINS's IMU files [SI units, per √Hz]
NOISE_KEYS = ("accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
              "gyroscope_random_walk")

#: a ROS graph resource name (wiki.ros.org/Names): a topic
_ROS_NAME = re.compile(r"[~/]?[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*")

#: OpenVINS's IMU models and whether their D matrices are lower triangular
OPENVINS_MODELS = {"kalibr": True, "rpng": False}


def _num(x: float) -> str:
    """Shortest text that reads back as the same double (full precision), a float to YAML 1.1 too.

    PyYAML (Kalibr's reader) takes ``4e-05`` for a string: the mantissa gets a point (``4.0e-05``).
    """
    if not np.isfinite(x):  # an overflow (--raw-scale 1e308,1e308) or an undefined value: never written
        raise ExportError(f"a value to write is {float(x)!r}, not a finite number: the calibration or the options "
                          "(--raw-scale, the --noise file) hold numbers too large or undefined; check them")
    text = repr(float(x) + 0.0)  # + 0.0: no "-0.0"
    mantissa, e, exponent = text.partition("e")
    return f"{mantissa}.0e{exponent}" if e and "." not in mantissa else text


def _matrix(name: str, m: np.ndarray, indent: str = "  ") -> list[str]:
    return [f"{indent}{name}:"] + [f"{indent}  - [{', '.join(_num(v) for v in row)}]" for row in np.asarray(m)]


def _vector(v) -> str:
    return "[" + ", ".join(f"{x:.10g}" for x in v) + "]"


# ----------------------------------------------------------------------- noise
def read_noise(path: str | Path) -> tuple[dict, list[str]]:
    """The noise entries (and ``rostopic``, ``update_rate`` where given) of an IMU noise file.

    Parameters
    ----------
    path : str or Path
        Kalibr's/OpenVINS's ``imu.yaml`` (flat, or one ``imu0`` entry) or the JSON of ``imucalib noise --json``
        made in SI units (``--calibration``).

    Returns
    -------
    entries : dict
        ``accelerometer_noise_density`` [m/s²/√Hz], ``accelerometer_random_walk`` [m/s³/√Hz],
        ``gyroscope_noise_density`` [rad/s/√Hz], ``gyroscope_random_walk`` [rad/s²/√Hz], and where given
        ``update_rate`` [Hz] and ``rostopic``; ``bounded`` lists those the file marks as upper bounds rather
        than measured values.
    notes : list of str
        What the reader should know about the file.

    Raises
    ------
    ExportError
        A file that is too large or not text, an entry missing, given twice (a file of several IMUs), not a
        number or not positive, or a JSON not in m/s² and rad/s.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.export import read_noise
    >>> path = Path(tempfile.mkdtemp()) / "imu.yaml"
    >>> _ = path.write_text(chr(10).join([
    ...     "accelerometer_noise_density: 2.0e-3", "accelerometer_random_walk: 3.0e-3",
    ...     "gyroscope_noise_density: 1.7e-4", "gyroscope_random_walk: 2.0e-5",
    ...     "rostopic: /imu0", "update_rate: 200"]))
    >>> entries, notes = read_noise(path)
    >>> entries["gyroscope_noise_density"], entries["update_rate"], entries["rostopic"]
    (0.00017, 200.0, '/imu0')
    """
    path = Path(path)
    try:
        text = read_small_text(path, MAX_FILE_BYTES, "noise file",
                               "one is a few lines: Kalibr's imu.yaml, or the JSON of imucalib noise --json")
    except SmallFileError as exc:
        raise ExportError(f"--noise {path}: {exc}") from None
    if text.lstrip().startswith("{"):
        return _noise_from_json(path, text)
    found: dict[str, list[str]] = {}
    bounded = []
    for line in text.splitlines():
        m = re.match(r"\s*([A-Za-z_]+)\s*:\s*([^#]*?)\s*(#.*)?$", line)
        if m and m.group(1) in (*NOISE_KEYS, "rostopic", "update_rate") and m.group(2):
            found.setdefault(m.group(1), []).append(m.group(2).strip("'\""))
            if BOUND_MARK in (m.group(3) or ""):
                bounded.append(m.group(1))
    twice = [k for k, v in found.items() if len(v) > 1]
    if twice:
        raise ExportError(f"--noise {path}: {', '.join(twice)} given more than once (a file of several IMUs?); "
                          "give a file with one IMU")
    missing = [k for k in NOISE_KEYS if k not in found]
    if missing:
        raise ExportError(f"--noise {path}: no {', '.join(missing)}; expected Kalibr's imu.yaml (imucalib noise "
                          "--kalibr writes one) or the JSON of imucalib noise --json")
    out: dict = {}
    for key in (*NOISE_KEYS, "update_rate"):
        if key in found:
            try:
                out[key] = float(found[key][0])
            except ValueError:
                raise ExportError(f"--noise {path}: {key} is {found[key][0]!r}, not a number") from None
            if not (np.isfinite(out[key]) and out[key] > 0):
                raise ExportError(f"--noise {path}: {key} must be a positive number; got {found[key][0]}")
    if "rostopic" in found:
        out["rostopic"] = found["rostopic"][0]
    out["bounded"] = bounded
    return out, [f"--noise {path}: {k} is an upper bound, not a measured value (a longer rest measures it)"
                 for k in bounded]


def _noise_from_json(path: Path, text: str) -> tuple[dict, list[str]]:
    try:
        doc = loads(text)
        acc, gyro, rate = doc["accelerometer"], doc["gyroscope"], doc["rate_hz"]
        units = (acc.get("unit"), gyro.get("unit"))
    except (ValueError, KeyError, TypeError, AttributeError):  # not JSON, nested without end, not this JSON
        raise ExportError(f"--noise {path}: not the JSON of imucalib noise --json (it needs accelerometer, "
                          "gyroscope and rate_hz)") from None
    if units != ("m/s^2", "rad/s"):
        raise ExportError(f"--noise {path}: the noise is in {units[0]} and {units[1]}; the file needs m/s^2 and "
                          "rad/s: run imucalib noise with --calibration CALIBRATION.json")
    try:
        values, notes = kalibr_noise(acc, gyro)
        rate = float(rate)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:  # entries missing or of the wrong kind
        what = f"no {exc.args[0]!r} entry" if isinstance(exc, KeyError) else str(exc)
        raise ExportError(f"--noise {path}: {what}; the file needs the accelerometer's and gyroscope's "
                          "white_noise_density and random_walk (per axis) and rate_hz, as imucalib noise --json "
                          "writes them") from None
    for key, value in (*values.items(), ("rate_hz", rate)):
        if key != "bounded" and not (np.isfinite(value) and value > 0):
            raise ExportError(f"--noise {path}: {key} must be a positive number; got {value!r}")
    return {**values, "update_rate": rate}, notes


def _noise_lines(noise: dict | None, rostopic: str | None, indent: str, notes: list[str],
                 what: str) -> list[str]:
    lines = []
    if noise:
        units = {"accelerometer_noise_density": "m/s^2/sqrt(Hz)", "accelerometer_random_walk": "m/s^3/sqrt(Hz)",
                 "gyroscope_noise_density": "rad/s/sqrt(Hz)", "gyroscope_random_walk": "rad/s^2/sqrt(Hz)"}
        bounded = noise.get("bounded", ())
        lines += [f"{indent}{k}: {_num(noise[k])}  # [{units[k]}]{f' {BOUND_MARK}' if k in bounded else ''}"
                  for k in NOISE_KEYS]
    else:
        notes.append(f"no --noise file: the noise entries ({', '.join(NOISE_KEYS)}) are left out; {what} needs "
                     "them (imucalib noise DATA --calibration CAL.json --kalibr imu.yaml measures them)")
    topic = rostopic or (noise or {}).get("rostopic")
    if topic and not _ROS_NAME.fullmatch(topic):
        raise ExportError(f"the topic {json.dumps(topic)[:80]} is not a ROS name (letters, digits, _ and /, not "
                          "starting with a digit)")
    if topic:
        lines.append(f"{indent}rostopic: {yaml_scalar(topic)}")
    else:
        notes.append("no topic given (--rostopic, or a --noise file with one): rostopic is left out")
    if (noise or {}).get("update_rate"):
        lines.append(f"{indent}update_rate: {_num(noise['update_rate'])}  # [Hz]")
    else:
        notes.append("no update_rate (a --noise file gives it): left out")
    return lines


def _published_scale_note(cal: Calibration, form: LinearForm, noise: dict | None, notes: list[str]) -> None:
    """Note when noise measured in SI meets readings published in other units (counts with a rough --raw-scale)."""
    if not noise or "counts" not in (cal.units["accelerometer"]["raw"], cal.units["gyroscope"]["raw"]):
        return
    for name, matrix in (("accelerometer", form.acc_matrix), ("gyroscope", form.gyro_matrix)):
        ratio = float(np.median(np.abs(np.diag(matrix))))  # calibrated SI per published unit
        if abs(ratio - 1) > 0.1:
            notes.append(f"the {name}'s published readings are {ratio:.4g}× off SI with this --raw-scale, but the "
                         "noise entries are in SI: scale them by 1/that factor, or give --raw-scale near the "
                         "sensor's true scale")


def _bias_note(form: LinearForm, target: str, notes: list[str]) -> None:
    """Note biases too large for an estimator that starts its online bias estimate from zero."""
    a, g = float(np.max(np.abs(form.acc_bias))), float(np.max(np.abs(form.gyro_bias)))
    if a > 0.5 or g > 0.05:  # m/s², rad/s: far beyond a MEMS sensor's residual bias after its own trimming
        notes.append(f"the biases are large ({a:.3g} m/s^2, {g:.3g} rad/s at most, e.g. an offset-binary zero "
                     f"of raw counts): {target} estimates them online starting from zero; subtract them before "
                     "publishing (the file's comment gives them)")


def _header(cal: Calibration, form: LinearForm, target: str) -> list[str]:
    u = cal.units
    lines = [f"# imucalib calibration as {target}: method {comment_text(cal.method)}, model "
             f"{comment_text(cal.model)}, created {comment_text(cal.created or '-')}"]
    if u["accelerometer"]["raw"] == "counts" or u["gyroscope"]["raw"] == "counts":
        lines.append(f"# raw counts read as published: {form.acc_scale!r} m/s^2 and {form.gyro_scale!r} rad/s "
                     "per count (--raw-scale); the matrices below take the published values")
    else:
        lines.append(f"# raw units {comment_text(u['accelerometer']['raw'])}, {comment_text(u['gyroscope']['raw'])} "
                     "read as m/s^2, rad/s")
    lines.append(f"# calibrated with gravity {cal.gravity:.6g} m/s^2")
    lines.append(f"# biases at calibration time (estimated online, no entry): accelerometer "
                 f"{_vector(form.acc_bias)} m/s^2, gyroscope {_vector(form.gyro_bias)} rad/s")
    return lines


# --------------------------------------------------------------------- OpenVINS
def to_openvins(calibration: Calibration, *, model: str = "kalibr", raw_scale: tuple[float, float] | None = None,
                noise: dict | None = None, rostopic: str | None = None) -> tuple[str, list[str]]:
    """The ``imu0`` entry of OpenVINS's ``kalibr_imu_chain.yaml`` (module docstring); the text and notes.

    An accelerometer-only calibration gets the identity as its gyroscope part
    (:func:`.linear.gyroscope_part`), and a note saying so.

    Parameters
    ----------
    calibration : Calibration
        A linear calibration (no ``k2``, ``k3`` scale terms).
    model : {"kalibr", "rpng"}
        OpenVINS's IMU model: ``D = T⁻¹`` lower (kalibr) or upper (rpng) triangular.
    raw_scale : (float, float), optional
        For a calibration of raw counts: the factors [m/s² and rad/s per count] the driver multiplies the
        counts by before publishing them (``1, 1`` when it publishes the counts).
    noise : dict, optional
        The noise entries (and ``rostopic``, ``update_rate``) :func:`read_noise` reads; without them the
        entries are left out, with a note.
    rostopic : str, optional
        The IMU's ROS topic (overrides the one in ``noise``).

    Returns
    -------
    text : str
        The YAML text.
    notes : list of str
        What the reader should know: what was left out, the biases OpenVINS estimates online, the scales.

    Raises
    ------
    ExportError
        An unknown ``model``; a calibration with nonlinear scale terms; raw counts without ``raw_scale`` (or
        ``raw_scale`` for readings in physical units); matrices that overflow or vanish; a topic that is not a
        ROS name.

    Examples
    --------
    A calibration of readings already in m/s² and rad/s (a simulated session calibrated by its truth, then
    calibrated again), as OpenVINS reads it:

    >>> from imucalib.export import to_openvins
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> cal = calibrate(sim.truth.apply(sim.recording))
    >>> text, notes = to_openvins(cal, rostopic="/imu0")
    >>> [line for line in text.splitlines() if not line.startswith("#")][1:4]
    ['imu0:', '  rostopic: /imu0', '  model: kalibr']
    >>> notes[0]
    'no --noise file: the noise entries (accelerometer_noise_density, ...) are left out; ...'

    A calibration of raw counts needs the factors the driver publishes them with:

    >>> to_openvins(sim.truth)
    Traceback (most recent call last):
        ...
    imucalib.export.linear.ExportError: OpenVINS reads m/s^2 and rad/s, but this calibration ...
    """
    if model not in OPENVINS_MODELS:
        raise ExportError(f"OpenVINS's IMU model must be one of {', '.join(OPENVINS_MODELS)}; got {model!r}")
    lower = OPENVINS_MODELS[model]
    calibration, note = gyroscope_part(calibration, "OpenVINS imu0 intrinsics (kalibr_imu_chain.yaml)")
    form = linear_form(calibration, "OpenVINS", physical=True, raw_scale=raw_scale)
    # T_a upper triangular (the canonical shape) gives R_IMUtoACC = I exactly for rpng
    r_acc, da = rotation_times_triangular(form.acc_matrix, lower=lower)
    r_gyro, dw = rotation_times_triangular(form.gyro_matrix, lower=lower)
    tri = np.tril if lower else np.triu
    ta, tw = tri(np.linalg.inv(da)), tri(np.linalg.inv(dw))  # the inverse of a triangular matrix is triangular
    notes: list[str] = [note] if note else []
    _published_scale_note(calibration, form, noise, notes)
    _bias_note(form, "OpenVINS", notes)
    lines = ["%YAML:1.0", *_header(calibration, form, f"the imu0 intrinsics of OpenVINS (model {model})"),
             f"# OpenVINS: D = T^-1 ({'lower' if lower else 'upper'} triangle); "
             "a_I = R_IMUtoACC^T Da (a_m - b_a); w_I = R_IMUtoGYRO^T Dw (w_m - b_g - Tg a_I)",
             "imu0:", *_noise_lines(noise, rostopic, "  ", notes, "OpenVINS"),
             f"  model: {model}",
             *_matrix("Tw", tw), *_matrix("R_IMUtoGYRO", r_gyro.T), *_matrix("Ta", ta),
             *_matrix("R_IMUtoACC", r_acc.T), *_matrix("Tg", form.g_sensitivity), ""]
    return "\n".join(lines), notes


# ----------------------------------------------------------------------- Kalibr
def to_kalibr(calibration: Calibration, *, raw_scale: tuple[float, float] | None = None,
              noise: dict | None = None, rostopic: str | None = None) -> tuple[str, list[str]]:
    """Kalibr's ``imu0`` result entry for the scale-misalignment model (module docstring); the text and notes.

    An accelerometer-only calibration gets the identity as its gyroscope part
    (:func:`.linear.gyroscope_part`), and a note saying so.

    Parameters
    ----------
    calibration : Calibration
        A linear calibration (no ``k2``, ``k3`` scale terms).
    raw_scale : (float, float), optional
        For a calibration of raw counts: the factors [m/s² and rad/s per count] the driver multiplies the
        counts by before publishing them (``1, 1`` when it publishes the counts).
    noise : dict, optional
        The noise entries (and ``rostopic``, ``update_rate``) :func:`read_noise` reads; without them the
        entries are left out, with a note.
    rostopic : str, optional
        The IMU's ROS topic (overrides the one in ``noise``).

    Returns
    -------
    text : str
        The YAML text (``M``, ``A``, ``C_gyro_i``; the rotation between Kalibr's IMU frame and imucalib's
        in a comment).
    notes : list of str
        What the reader should know: that rotation's angle, what was left out, the biases.

    Raises
    ------
    ExportError
        A calibration with nonlinear scale terms; raw counts without ``raw_scale`` (or ``raw_scale`` for
        readings in physical units); matrices that overflow or vanish; a topic that is not a ROS name.

    Examples
    --------
    A calibration of readings already in m/s² and rad/s (a simulated session calibrated by its truth, then
    calibrated again), as Kalibr writes its result:

    >>> from imucalib.export import to_kalibr
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> cal = calibrate(sim.truth.apply(sim.recording))
    >>> text, notes = to_kalibr(cal, rostopic="/imu0")
    >>> "C_gyro_i:" in text, "rostopic: /imu0" in text
    (True, True)
    >>> notes[0]
    "Kalibr's IMU frame i is the accelerometer frame made orthogonal with a lower-triangular ..."
    """
    calibration, note = gyroscope_part(calibration, "Kalibr imu0 entry (scale-misalignment)")
    form = linear_form(calibration, "Kalibr", physical=True, raw_scale=raw_scale)
    m_acc, r = triangular_times_rotation(np.linalg.inv(form.acc_matrix), lower=True)  # s_a A⁻¹ = M_a R
    m_gyro, c_gyro_b = triangular_times_rotation(np.linalg.inv(form.gyro_matrix), lower=True)
    c_gyro_i = c_gyro_b @ r.T  # M_g C_gyro_i R = s_g W⁻¹
    a_sens = form.g_sensitivity @ c_gyro_b.T  # A C_gyro_i R = s_g G
    angle = np.degrees(np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1)))
    notes = [note] if note else []
    notes.append(f"Kalibr's IMU frame i is the accelerometer frame made orthogonal with a lower-triangular M_a, "
                 f"imucalib's with an upper-triangular T_a: they differ by a rotation of {angle:.4g} deg (in the "
                 "file's comments); Kalibr's --imu input reads only the noise, rostopic and update_rate")
    _published_scale_note(calibration, form, noise, notes)
    _bias_note(form, "Kalibr", notes)
    lines = [*_header(calibration, form, "Kalibr's imu0 result (model scale-misalignment)"),
             "# Kalibr: alpha_m = M_a a_i + b_a;  w_m = M_g C_gyro_i w_i + A C_gyro_i a_i + b_g (IccSensors.py)",
             "# Kalibr's --imu input file reads only the noise entries, rostopic and update_rate; the",
             "# intrinsics have a place only in its imu-camera result, this form",
             "# frame: a_i = R a, w_i = R w with a, w imucalib's calibrated output and R =",
             *[f"#   [{', '.join(_num(v) for v in row)}]" for row in r],
             "imu0:", *_matrix("T_i_b", np.eye(4)), *_noise_lines(noise, rostopic, "  ", notes, "Kalibr"),
             "  model: scale-misalignment", "  time_offset: 0.0",
             "  accelerometers:", *_matrix("M", m_acc, "    "),
             "  gyroscopes:", *_matrix("A", a_sens, "    "), *_matrix("C_gyro_i", c_gyro_i, "    "),
             *_matrix("M", m_gyro, "    "), ""]
    return "\n".join(lines), notes
