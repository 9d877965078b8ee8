"""The linear form of a calibration, in the units other tools read, and its factorisations.

Every exported model is linear, so the canonical model (``docs/architecture.rst``) must be
linear too: ``k2 = k3 = 0``. With the output bias ``d`` folded into the input
bias (``T (K (u − b) + d) = T K (u − (b − K⁻¹ d))``) it reads::

    a = A (u_a − b_a),          A = T_a diag(k1_a)
    ω = W (u_g − b_g − G a),    W = T_g diag(k1_g)

Estimators such as OpenVINS and Kalibr take ``sensor_msgs/Imu`` values in
m/s² and rad/s. A raw unit ``u`` reaches them as ``s·u`` with ``s`` the factor
of the unit to SI (1 for m/s² and rad/s, 9.80665 for g, π/180 for deg/s), or,
for counts, the factor the driver multiplies the counts by before publishing
(``raw_scale``: it cannot be read from the calibration). With ``a_m = s_a u_a``
and ``ω_m = s_g u_g``::

    a = (A / s_a) (a_m − s_a b_a),    ω = (W / s_g) (ω_m − s_g b_g − s_g G a)

:func:`rotation_times_triangular` splits a matrix into a proper rotation and a
triangular factor (QR / QL decompositions with the signs fixed), the form
OpenVINS and Kalibr store.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..calibration import Calibration
from ..models import TriadModel
from ..recording import STANDARD_GRAVITY

__all__ = ["ExportError", "LinearForm", "gyroscope_part", "linear_form", "rotation_times_triangular",
           "triangular_times_rotation"]

#: factor of each physical raw unit to SI; ``g`` is the standard gravity g_n (the unit, not the local value)
UNIT_TO_SI = {"m/s^2": 1.0, "g": STANDARD_GRAVITY, "rad/s": 1.0, "deg/s": np.pi / 180}


class ExportError(ValueError):
    """A calibration a target format cannot hold, or export options that do not fit it.

    Examples
    --------
    Raised by the exporters (:func:`to_c`, :func:`to_openvins`, …) with what to change:

    >>> from imucalib.export import ExportError, to_openvins
    >>> from imucalib.scenarios import session
    >>> try:
    ...     to_openvins(session("handheld", rng=1, rest=10, n_poses=14).truth, model="vins")
    ... except ExportError as exc:
    ...     print(exc)
    OpenVINS's IMU model must be one of kalibr, rpng; got 'vins'
    """


@dataclass(frozen=True)
class LinearForm:
    """``a = A (u_a − b_a)``, ``ω = W (u_g − b_g − G a)`` with ``u`` in the units the target reads.

    Attributes
    ----------
    acc_matrix, gyro_matrix : (3, 3) ndarray
        ``A`` [m/s² per unit], ``W`` [rad/s per unit].
    acc_bias, gyro_bias : (3,) ndarray
        ``b_a``, ``b_g`` in the target's units.
    g_sensitivity : (3, 3) ndarray
        ``G`` [target gyroscope unit per m/s²].
    acc_scale, gyro_scale : float
        SI per raw unit used (1.0 when the raw units are kept).
    """

    acc_matrix: np.ndarray
    acc_bias: np.ndarray
    gyro_matrix: np.ndarray
    gyro_bias: np.ndarray
    g_sensitivity: np.ndarray
    acc_scale: float = 1.0
    gyro_scale: float = 1.0


def gyroscope_part(calibration: Calibration, what: str) -> tuple[Calibration, str | None]:
    """``calibration`` with a gyroscope part, which every format has: the identity for an accelerometer-only one.

    A calibration made from an accelerometer-only recording has no gyroscope;
    it is exported with the identity in rad/s (no bias, unit scales, no
    misalignment or g-sensitivity), which passes rates through unchanged.

    Returns
    -------
    (Calibration, str or None)
        The calibration to export and, when the identity was put in, a note saying so (``what`` names the
        format in it).
    """
    if calibration.gyroscope is not None:
        return calibration, None

    identity = calibration.with_(gyroscope=TriadModel(scale=[1.0, 1.0, 1.0], shape="full"),
                                 units={**calibration.units, "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}})
    return identity, (f"the calibration has no gyroscope (it was made from an accelerometer-only recording): the "
                      f"gyroscope part of the {what} is the identity, which passes rates through unchanged")


def _scales(calibration: Calibration, raw_scale: tuple[float, float] | None, target: str) -> tuple[float, float]:
    units = (calibration.units["accelerometer"]["raw"], calibration.units["gyroscope"]["raw"])
    if "counts" in units:
        if raw_scale is None:
            raise ExportError(
                f"{target} reads m/s^2 and rad/s, but this calibration maps raw counts "
                f"(accelerometer {units[0]}, gyroscope {units[1]}): give --raw-scale ACC,GYRO, the factors your "
                "driver multiplies the counts by before publishing (m/s^2 and rad/s per count; 1,1 if it "
                "publishes the counts as they are, and the counts-to-SI scale then lives in the exported matrices)")
        acc, gyro = (float(v) for v in raw_scale)
        if not (np.isfinite(acc) and np.isfinite(gyro) and acc > 0 and gyro > 0):
            raise ExportError(f"--raw-scale must be two positive numbers; got {acc:g},{gyro:g}")
        return (UNIT_TO_SI.get(units[0], acc), UNIT_TO_SI.get(units[1], gyro))
    if raw_scale is not None:
        raise ExportError(f"--raw-scale is for raw counts; this calibration's raw units are {units[0]} and "
                          f"{units[1]}, whose factors to SI are known")
    return UNIT_TO_SI[units[0]], UNIT_TO_SI[units[1]]


def linear_form(calibration: Calibration, target: str, *, physical: bool = False,
                raw_scale: tuple[float, float] | None = None) -> LinearForm:
    """The calibration as ``A``, ``b_a``, ``W``, ``b_g``, ``G`` (module docstring).

    Parameters
    ----------
    calibration : Calibration
    target : str
        The format's name, for messages.
    physical : bool
        Express it for readings in m/s² and rad/s (``a_m = s_a u_a``, ``ω_m = s_g u_g``) rather than
        in the calibration's raw units.
    raw_scale : (float, float), optional
        ``(s_a, s_g)`` for raw counts (``physical`` only).

    Raises
    ------
    ExportError
        When a scale is nonlinear (``k2`` or ``k3`` not zero): no exported model has such terms.
    """
    nonlinear = [name for name, m in (("accelerometer", calibration.accelerometer),
                                      ("gyroscope", calibration.gyroscope)) if not m.is_linear]
    if nonlinear:
        raise ExportError(f"{target} holds a linear model only, and this calibration's {' and '.join(nonlinear)} "
                          f"{'has' if len(nonlinear) == 1 else 'have'} nonlinear scale terms (k2, k3; model "
                          f"{calibration.model}): calibrate with --model linear to export it")
    s_a, s_g = _scales(calibration, raw_scale, target) if physical else (1.0, 1.0)
    out = []
    for m in (calibration.accelerometer, calibration.gyroscope):
        matrix = m.misalignment * m.scale  # T diag(k1)
        bias = m.bias - m.output_bias / m.scale  # T (K (u − b) + d) = T K (u − (b − K⁻¹ d))
        out.append((matrix, bias))
    (a, ba), (w, bg) = out
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        form = LinearForm(acc_matrix=a / s_a, acc_bias=ba * s_a, gyro_matrix=w / s_g, gyro_bias=bg * s_g,
                          g_sensitivity=calibration.gyroscope.g_sensitivity * s_g, acc_scale=s_a, gyro_scale=s_g)
        # what the formats write: the matrices, their inverses and the biases, all finite
        usable = all(np.all(np.isfinite(v)) for v in (form.acc_matrix, form.acc_bias, form.gyro_matrix,
                                                      form.gyro_bias, form.g_sensitivity)) and all(
            np.isfinite(np.linalg.cond(m)) and np.all(np.isfinite(np.linalg.inv(m)))
            for m in (form.acc_matrix, form.gyro_matrix) if np.all(np.isfinite(m)) and np.linalg.det(m) != 0)
        usable = usable and np.linalg.det(form.acc_matrix) != 0 and np.linalg.det(form.gyro_matrix) != 0
    if not usable:
        raise ExportError(f"{target}: with --raw-scale {s_a:g},{s_g:g} the calibration's matrices overflow or "
                          "vanish in double precision; give the factors the driver applies (m/s^2 and rad/s per "
                          "count, e.g. 0.000598,0.000133; 1,1 when it publishes the counts)")
    return form


def _fix_signs(q: np.ndarray, t: np.ndarray, diag_index: int) -> tuple[np.ndarray, np.ndarray]:
    """``q t`` unchanged, ``t``'s diagonal made positive, then ``q`` made proper by flipping ``diag_index``."""
    s = np.where(np.diag(t) < 0, -1.0, 1.0)
    q, t = q * s, s[:, None] * t  # q S · S t
    if np.linalg.det(q) < 0:  # a left-handed sensor (det M < 0): one diagonal entry of t stays negative
        f = np.ones(3)
        f[diag_index] = -1.0
        q, t = q * f, f[:, None] * t
    return q, t


def rotation_times_triangular(m: np.ndarray, *, lower: bool) -> tuple[np.ndarray, np.ndarray]:
    """``m = R · D`` with ``R`` a proper rotation and ``D`` upper (QR) or lower (QL) triangular.

    ``D`` has a positive diagonal when ``det m > 0`` (else its last entry is negative).
    """
    m = np.asarray(m, dtype=float)
    if not lower:
        q, t = np.linalg.qr(m)
        return _fix_signs(q, t, 2)
    j = np.eye(3)[::-1]  # the exchange matrix: J U J is lower triangular for U upper
    q, u = np.linalg.qr(m @ j)  # m J = Q U  →  m = (Q J)(J U J)
    return _fix_signs(q @ j, j @ u @ j, 2)


def triangular_times_rotation(m: np.ndarray, *, lower: bool) -> tuple[np.ndarray, np.ndarray]:
    """``m = D · R`` with ``D`` lower or upper triangular and ``R`` a proper rotation (transpose of the above)."""
    r, d = rotation_times_triangular(np.asarray(m, dtype=float).T, lower=not lower)
    return d.T, r.T
