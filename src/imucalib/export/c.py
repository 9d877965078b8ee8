"""A calibration as C source, to correct readings on the device itself.

The generated header holds the canonical model's constants and one function,
``<prefix>_apply(const double acc_raw[3], const double gyro_raw[3], double acc[3], double gyro[3])``,
that evaluates exactly what :meth:`imucalib.calibration.Calibration.apply` does:

* ``a = T_a · (f_a(u_a − b_a) + d_a)``  [m/s²]
* ``ω = T_g · (f_g(u_g − b_g − G·a) + d_g)``  [rad/s]
* ``f(x)_i = k1_i x_i + k2_i x_i² + k3_i x_i³`` (Horner's rule)

Constants are printed with 17 significant digits (double round-trip); use
``float`` on a small microcontroller by passing ``ctype="float"``.
"""

from __future__ import annotations

import re

import numpy as np

from ..calibration import Calibration

__all__ = ["to_c"]


def _array(values, fmt) -> str:
    v = np.asarray(values, dtype=float)
    if v.ndim == 1:
        return "{" + ", ".join(fmt(x) for x in v) + "}"
    return "{" + ", ".join(_array(row, fmt) for row in v) + "}"


def to_c(calibration: Calibration, *, prefix: str = "imucalib", ctype: str = "double") -> str:
    """C99 header text with the calibration's constants and ``<prefix>_apply``."""
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", prefix):
        raise ValueError(f"prefix must be a C identifier; got {prefix!r}")
    if ctype not in ("double", "float"):
        raise ValueError(f"ctype must be 'double' or 'float'; got {ctype!r}")
    suffix = "f" if ctype == "float" else ""

    def num(x: float) -> str:
        text = f"{x:.17g}"
        if not re.search(r"[.eEn]", text):
            text += ".0"
        return text + suffix

    up = prefix.upper()
    cal = calibration
    units = cal.units
    lines = [
        f"/* imucalib calibration: method {cal.method}, model {cal.model}, created {cal.created or '-'}",
        f" * raw units: accelerometer {units['accelerometer']['raw']}, gyroscope {units['gyroscope']['raw']}",
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
    lines += [
        f"static const {ctype} {up}_GYRO_G[3][3] = {_array(cal.gyroscope.g_sensitivity, num)};",
        "",
        f"static void {prefix}_triad(const {ctype} t[3][3], const {ctype} k[3][3], const {ctype} d[3],",
        f"                           const {ctype} x[3], {ctype} out[3])",
        "{",
        f"    {ctype} f[3];",
        "    for (int i = 0; i < 3; ++i)",
        "        f[i] = x[i] * (k[0][i] + x[i] * (k[1][i] + x[i] * k[2][i])) + d[i];",
        "    for (int i = 0; i < 3; ++i)",
        "        out[i] = t[i][0] * f[0] + t[i][1] * f[1] + t[i][2] * f[2];",
        "}",
        "",
        f"static void {prefix}_apply(const {ctype} acc_raw[3], const {ctype} gyro_raw[3],",
        f"                           {ctype} acc[3], {ctype} gyro[3])",
        "{",
        f"    {ctype} x[3];",
        "    for (int i = 0; i < 3; ++i)",
        f"        x[i] = acc_raw[i] - {up}_ACC_B[i];",
        f"    {prefix}_triad({up}_ACC_T, {up}_ACC_K, {up}_ACC_D, x, acc);",
        "    for (int i = 0; i < 3; ++i)",
        f"        x[i] = gyro_raw[i] - {up}_GYRO_B[i] - ({up}_GYRO_G[i][0] * acc[0] + {up}_GYRO_G[i][1] * acc[1]"
        f" + {up}_GYRO_G[i][2] * acc[2]);",
        f"    {prefix}_triad({up}_GYRO_T, {up}_GYRO_K, {up}_GYRO_D, x, gyro);",
        "}",
        "",
        f"#endif /* {up}_CALIBRATION_H */",
        "",
    ]
    return "\n".join(lines)
