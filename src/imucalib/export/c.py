"""A calibration as C source, to correct readings on the device itself.

The generated header holds the canonical model's constants and one function,
``static inline void <prefix>_apply(const double acc_raw[3], const double gyro_raw[3], double acc[3], double gyro[3])``,
that evaluates exactly what :meth:`imucalib.calibration.Calibration.apply` does:

* ``a = T_a · (f_a(u_a − b_a) + d_a)``  [m/s²]
* ``ω = T_g · (f_g(u_g − b_g − G·a) + d_g)``  [rad/s]
* ``f(x)_i = k1_i x_i + k2_i x_i² + k3_i x_i³`` (Horner's rule)

Constants are printed with 17 significant digits (double round-trip); use
``float`` on a small microcontroller by passing ``ctype="float"``.

A calibration that follows temperature (:mod:`imucalib.thermal`) gets
``<prefix>_apply(acc_raw, gyro_raw, temperature_c, acc, gyro)``: every bias,
linear scale factor and misalignment term is first evaluated at the sample's
temperature as ``c₀ + c₁ ΔT + c₂ ΔT²`` (``ΔT = T − T₀``, thermal.py eq. T1;
the ``_C1``/``_C2`` arrays, zero where a term does not follow temperature).
A calibrated magnetometer gets ``<prefix>_apply_mag(mag_raw, mag)``:
``m = M (u − b)`` with ``M = F O S`` (models.py).

The calibration's text (method, model, creation time, units) appears only
inside the header's comments, escaped (:func:`.text.c_comment`): whatever a
calibration file holds, the code is the same.
"""

from __future__ import annotations

import re
import warnings

import numpy as np

from ..calibration import Calibration
from ..recording import ImucalibWarning
from .linear import ExportError, gyroscope_part
from .text import c_comment

__all__ = ["to_c"]

#: single precision's range: a constant beyond it does not compile (-Werror), one below it is zero
_FLOAT = np.finfo(np.float32)


def _array(values, fmt) -> str:
    v = np.asarray(values, dtype=float)
    if v.ndim == 1:
        return "{" + ", ".join(fmt(x) for x in v) + "}"
    return "{" + ", ".join(_array(row, fmt) for row in v) + "}"


def to_c(calibration: Calibration, *, prefix: str = "imucalib", ctype: str = "double") -> str:
    """C99 header text with the calibration's constants and ``<prefix>_apply``.

    An accelerometer-only calibration gets the identity as its gyroscope part
    (:func:`.linear.gyroscope_part`), with an :class:`~imucalib.recording.ImucalibWarning` saying so.

    Parameters
    ----------
    calibration : Calibration
        The calibration (any model: the polynomial scales, g-sensitivity and a thermal model are written too).
    prefix : str
        The C identifier the header's names start with (``<PREFIX>_ACC_T``, ``<prefix>_apply`` …).
    ctype : {"double", "float"}
        The constants' C type; ``"float"`` writes single-precision literals.

    Returns
    -------
    str
        The header's text, with an include guard; ``<prefix>_apply`` takes the raw readings (and the
        temperature [°C] for a thermal calibration) and writes m/s² and rad/s.

    Raises
    ------
    ValueError
        ``prefix`` not a C identifier, or ``ctype`` neither ``"double"`` nor ``"float"``.
    ExportError
        With ``ctype="float"``, a constant beyond single precision's range.

    Examples
    --------
    >>> import numpy as np
    >>> from imucalib.scenarios import session
    >>> truth = session("handheld", rng=1).truth
    >>> cal = truth.with_(gyroscope=truth.gyroscope.with_(g_sensitivity=np.zeros((3, 3))))
    >>> from imucalib.export import to_c
    >>> header = to_c(truth, prefix="imu")
    >>> header.splitlines()[4:6]
    ['#ifndef IMU_CALIBRATION_H', '#define IMU_CALIBRATION_H']
    >>> "void imu_apply(" in header
    True
    """
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise ValueError(f"prefix must be a C identifier; got {prefix!r}")
    if ctype not in ("double", "float"):
        raise ValueError(f"ctype must be 'double' or 'float'; got {ctype!r}")
    suffix = "f" if ctype == "float" else ""

    num, tiny = _number_writer(ctype, suffix)
    up = prefix.upper()
    cal, note = gyroscope_part(calibration, "C99 header")
    if note:
        warnings.warn(note, ImucalibWarning, stacklevel=2)
    lines = _constant_lines(cal, prefix, up, ctype, num)
    thermal = cal.thermal
    lines += _apply_thermal(prefix, up, ctype) if thermal is not None else _apply_plain(prefix, up, ctype)
    if cal.magnetometer is not None:
        lines += _magnetometer_lines(cal, prefix, up, ctype, num)
    lines += [f"#endif /* {up}_CALIBRATION_H */", ""]
    if tiny:
        warnings.warn(f"{len(tiny)} constant(s) below float's range (e.g. {tiny[0]:.3g}, under "
                      f"{float(_FLOAT.smallest_subnormal):.3g}) are written as 0, the value float holds; export "
                      "without --float (double) to keep them", ImucalibWarning, stacklevel=2)
    return "\n".join(lines)


def _number_writer(ctype: str, suffix: str) -> tuple:
    """``num(x)``, a constant as a C literal of ``ctype``, and the list of the constants too small for float
    that it wrote as 0 (:func:`to_c` warns of them)."""
    tiny: list[float] = []

    def num(x: float) -> str:
        if ctype == "float":  # what float holds: past its largest, refused; below its smallest, the zero it is
            if abs(x) > _FLOAT.max:
                raise ExportError(f"the constant {x:g} is beyond float's range (±{_FLOAT.max:.4g}); export it "
                                  "without --float (double)")
            if x != 0 and np.float32(x) == 0:
                tiny.append(x)
                x = 0.0
        text = f"{x:.17g}"
        if not re.search(r"[.eEn]", text):
            text += ".0"
        return text + suffix

    return num, tiny


def _constant_lines(cal: Calibration, prefix: str, up: str, ctype: str, num) -> list[str]:
    """The header's opening comment, include guard and constants, and ``<prefix>_triad`` (:func:`to_c`)."""
    units = cal.units
    thermal = cal.thermal
    lines = [
        f"/* imucalib calibration: method {c_comment(cal.method)}, model {c_comment(cal.model)}, created "
        f"{c_comment(cal.created or '-')}",
        f" * raw units: accelerometer {c_comment(units['accelerometer']['raw'])}, gyroscope "
        f"{c_comment(units['gyroscope']['raw'])}",
        " * a = T_a (f_a(u_a - b_a) + d_a) [m/s^2];  w = T_g (f_g(u_g - b_g - G a) + d_g) [rad/s]",
        " * f(x)_i = k1_i x_i + k2_i x_i^2 + k3_i x_i^3 */",
        f"#ifndef {up}_CALIBRATION_H",
        f"#define {up}_CALIBRATION_H",
        "",
    ]
    for name, m in (("ACC", cal.accelerometer), ("GYRO", cal.gyroscope)):
        k = np.vstack([m.scale, m.scale_quadratic, m.scale_cubic])
        lines += [
            f"static const {ctype} {up}_{name}_T[3][3] = {_array(m.misalignment, num)};",
            f"static const {ctype} {up}_{name}_K[3][3] = {_array(k, num)}; /* rows: k1, k2, k3 */",
            f"static const {ctype} {up}_{name}_B[3] = {_array(m.bias, num)};",
            f"static const {ctype} {up}_{name}_D[3] = {_array(m.output_bias, num)};",
        ]
        if thermal is not None:
            sensor = "accelerometer" if name == "ACC" else "gyroscope"
            for order in (1, 2):
                coeffs = _thermal_arrays(thermal, sensor, order)
                lines += [f"static const {ctype} {up}_{name}_{key}_C{order}{shape} = {_array(coeffs[key], num)};"
                          for key, shape in (("T", "[3][3]"), ("K1", "[3]"), ("B", "[3]"))]
    if thermal is not None:
        lines.insert(3, f" * temperature: c0 + c1 dT + c2 dT^2 with dT = T - {thermal.reference_c:g} degC, calibrated "
                        f"over {thermal.range_c[0]:.1f}..{thermal.range_c[1]:.1f} degC")
        lines.append(f"static const {ctype} {up}_REFERENCE_C = {num(thermal.reference_c)};")
    lines += [
        f"static const {ctype} {up}_GYRO_G[3][3] = {_array(cal.gyroscope.g_sensitivity, num)};",
        "",
        f"static inline void {prefix}_triad(const {ctype} t[3][3], const {ctype} k[3][3], const {ctype} d[3],",
        f"                           const {ctype} x[3], {ctype} out[3])",
        "{",
        f"    {ctype} f[3];",
        "    for (int i = 0; i < 3; ++i)",
        "        f[i] = x[i] * (k[0][i] + x[i] * (k[1][i] + x[i] * k[2][i])) + d[i];",
        "    for (int i = 0; i < 3; ++i)",
        "        out[i] = t[i][0] * f[0] + t[i][1] * f[1] + t[i][2] * f[2];",
        "}",
        "",
    ]
    return lines


def _magnetometer_lines(cal: Calibration, prefix: str, up: str, ctype: str, num) -> list[str]:
    """The magnetometer's constants and ``<prefix>_apply_mag`` (:func:`to_c`)."""
    mag = cal.magnetometer
    units = cal.units
    return [
        f"/* magnetometer: m = M (u - b), raw {c_comment(units.get('magnetometer', {}).get('raw', 'counts'))}, "
        f"calibrated {c_comment(mag.unit)}, in the accelerometer's frame */",
        f"static const {ctype} {up}_MAG_M[3][3] = {_array(mag.matrix, num)};",
        f"static const {ctype} {up}_MAG_B[3] = {_array(mag.bias, num)};",
        "",
        f"static inline void {prefix}_apply_mag(const {ctype} mag_raw[3], {ctype} mag[3])",
        "{",
        "    for (int i = 0; i < 3; ++i)",
        f"        mag[i] = {up}_MAG_M[i][0] * (mag_raw[0] - {up}_MAG_B[0]) + {up}_MAG_M[i][1] * (mag_raw[1] - "
        f"{up}_MAG_B[1]) + {up}_MAG_M[i][2] * (mag_raw[2] - {up}_MAG_B[2]);",
        "}",
        "",
    ]


def _thermal_arrays(thermal, sensor: str, order: int) -> dict:
    """The ``c_order`` coefficients of ``sensor``'s misalignment, k1 and bias (zeros where constant)."""
    out = {"T": np.zeros((3, 3)), "K1": np.zeros(3), "B": np.zeros(3)}
    axes = "xyz"
    for name, c in thermal.coefficients.items():
        s, key, comp = name.split(".")
        if s != sensor:
            continue
        v = c[order - 1]
        if key == "bias":
            out["B"][axes.index(comp)] = v
        elif key == "scale":
            out["K1"][axes.index(comp)] = v
        else:
            out["T"][axes.index(comp[0]), axes.index(comp[1])] = v
    return out


def _gyro_input(up: str, b: str) -> str:
    return (f"        x[i] = gyro_raw[i] - {b}[i] - ({up}_GYRO_G[i][0] * acc[0] + {up}_GYRO_G[i][1] * acc[1]"
            f" + {up}_GYRO_G[i][2] * acc[2]);")


def _apply_plain(prefix: str, up: str, ctype: str) -> list[str]:
    return [
        f"static inline void {prefix}_apply(const {ctype} acc_raw[3], const {ctype} gyro_raw[3],",
        f"                           {ctype} acc[3], {ctype} gyro[3])",
        "{",
        f"    {ctype} x[3];",
        "    for (int i = 0; i < 3; ++i)",
        f"        x[i] = acc_raw[i] - {up}_ACC_B[i];",
        f"    {prefix}_triad({up}_ACC_T, {up}_ACC_K, {up}_ACC_D, x, acc);",
        "    for (int i = 0; i < 3; ++i)",
        _gyro_input(up, f"{up}_GYRO_B"),
        f"    {prefix}_triad({up}_GYRO_T, {up}_GYRO_K, {up}_GYRO_D, x, gyro);",
        "}",
        "",
    ]


def _apply_thermal(prefix: str, up: str, ctype: str) -> list[str]:
    lines = [
        f"/* the constants of one sensor at temperature dt = T - {up}_REFERENCE_C */",
        f"static inline void {prefix}_at(const {ctype} t0[3][3], const {ctype} t1[3][3], const {ctype} t2[3][3],",
        f"                        const {ctype} k0[3][3], const {ctype} k1[3], const {ctype} k2[3],",
        f"                        const {ctype} b0[3], const {ctype} b1[3], const {ctype} b2[3], {ctype} dt,",
        f"                        {ctype} t[3][3], {ctype} k[3][3], {ctype} b[3])",
        "{",
        "    for (int i = 0; i < 3; ++i) {",
        "        for (int j = 0; j < 3; ++j) {",
        "            t[i][j] = t0[i][j] + dt * (t1[i][j] + dt * t2[i][j]);",
        "            k[i][j] = k0[i][j];",
        "        }",
        "        k[0][i] += dt * (k1[i] + dt * k2[i]);",
        "        b[i] = b0[i] + dt * (b1[i] + dt * b2[i]);",
        "    }",
        "}",
        "",
        f"static inline void {prefix}_apply(const {ctype} acc_raw[3], const {ctype} gyro_raw[3],",
        f"                                  {ctype} temperature_c, {ctype} acc[3], {ctype} gyro[3])",
        "{",
        f"    {ctype} x[3], t[3][3], k[3][3], b[3];",
        f"    const {ctype} dt = temperature_c - {up}_REFERENCE_C;",
    ]
    for name, out in (("ACC", "acc"), ("GYRO", "gyro")):
        lines += [
            f"    {prefix}_at({up}_{name}_T, {up}_{name}_T_C1, {up}_{name}_T_C2, {up}_{name}_K, {up}_{name}_K1_C1, "
            f"{up}_{name}_K1_C2,",
            f"        {up}_{name}_B, {up}_{name}_B_C1, {up}_{name}_B_C2, dt, t, k, b);",
            "    for (int i = 0; i < 3; ++i)",
            "        x[i] = acc_raw[i] - b[i];" if name == "ACC" else _gyro_input(up, "b"),
            f"    {prefix}_triad((const {ctype} (*)[3])t, (const {ctype} (*)[3])k, {up}_{name}_D, x, {out});",
        ]
    return lines + ["}", ""]
