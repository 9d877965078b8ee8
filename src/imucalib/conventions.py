"""Exact conversions between each paper's model and the canonical :class:`TriadModel`.

Canonical: ``s = T · (f(u − b − G a) + d)``, ``f(x)_i = k1_i x_i + k2_i x_i² + k3_i x_i³``
(``d`` = ``output_bias``, zero except for Wang 2019).

* **Zhang 2021** (eqs. 1–8): ``s = T f(u + b^Z + G^Z a)`` — the bias and the
  g-dependent bias are *added*: ``b = −b^Z``, ``G = −G^Z``. Its misalignment
  matrices are written with angles: ``T^a = [[1, −α_yz, α_zy], [0, 1, −α_zx],
  [0, 0, 1]]`` (eq. 4) and ``T^g = [[1, −γ_yz, γ_zy], [γ_xz, 1, −γ_zx],
  [−γ_xy, γ_yx, 1]]`` (eq. 8); ``K`` is 3×3 with row ``i`` = ``(k_i1, k_i2, k_i3)``.
* **Qureshi 2017** (eqs. 2–8): ``A^o = K T_s^o (A^s − B)`` with ``K`` diagonal on
  the *left* and ``(T_s^o)⁻¹ = [[1, −θ_yz, θ_zy], [0, 1, −θ_zx], [0, 0, 1]]``
  (eq. 3); the estimated vector is ``X = [b_x, b_y, b_z, k_x, k_y, k_z, k_xy,
  k_xz, k_yz]`` with ``k_xy = θ_yz k_x``, ``k_xz = (θ_yz θ_zx − θ_zy) k_x``,
  ``k_yz = θ_zx k_y`` (eq. 7): the entries of the upper-triangular ``M = K T_s^o``.
  Canonically ``M = T diag(k1)``, so ``k1 = diag(M)`` and ``T = M diag(k1)⁻¹``.
* **Wang 2019** (eqs. 2–8): ``f^p = C (K1 N + K2 N² + K3 N³ + ∇)`` with ``C``
  unit lower-triangular (``E_yx, E_zx, E_zy``) and the bias ``∇`` added after
  the polynomial, in output units: canonical ``shape="lower"``, ``b = 0``,
  ``d = ∇``. The gyroscope (eq. 6) is the same with ``K3 = 0`` and ``∇ = ε``.
"""

from __future__ import annotations

import numpy as np

from .models import TriadModel

__all__ = [
    "from_qureshi",
    "from_wang",
    "from_zhang_accelerometer",
    "from_zhang_gyroscope",
    "qureshi_angles",
    "to_qureshi",
    "to_wang",
    "to_zhang",
]


# -------------------------------------------------------------------- Zhang
def from_zhang_accelerometer(alpha_yz: float, alpha_zy: float, alpha_zx: float, k: np.ndarray,
                             b: np.ndarray) -> TriadModel:
    """Canonical accelerometer from Zhang 2021's ``α``, ``K^a`` (3×3) and ``b^a`` (eqs. 1–4)."""
    k = np.asarray(k, dtype=float).reshape(3, 3)
    t = np.array([[1.0, -alpha_yz, alpha_zy], [0.0, 1.0, -alpha_zx], [0.0, 0.0, 1.0]])  # eq. (4)
    return TriadModel(misalignment=t, scale=k[:, 0], scale_quadratic=k[:, 1], scale_cubic=k[:, 2],
                      bias=-np.asarray(b, dtype=float), shape="upper")


def from_zhang_gyroscope(gamma: dict[str, float], k: np.ndarray, b: np.ndarray,
                         g: np.ndarray) -> TriadModel:
    """Canonical gyroscope from Zhang 2021's ``γ`` (keys yz, zy, xz, zx, xy, yx), ``K^g``, ``b^g``, ``G^g``."""
    k = np.asarray(k, dtype=float).reshape(3, 3)
    t = np.array([[1.0, -gamma["yz"], gamma["zy"]],
                  [gamma["xz"], 1.0, -gamma["zx"]],
                  [-gamma["xy"], gamma["yx"], 1.0]])  # eq. (8)
    return TriadModel(misalignment=t, scale=k[:, 0], scale_quadratic=k[:, 1], scale_cubic=k[:, 2],
                      bias=-np.asarray(b, dtype=float), g_sensitivity=-np.asarray(g, dtype=float),
                      shape="full")


def to_zhang(model: TriadModel) -> dict:
    """Zhang 2021's parameters of a canonical model: angles, ``K`` (3×3), added ``b`` and ``G``."""
    if np.any(model.output_bias):
        raise ValueError("Zhang 2021's model has no output-side bias; this model does")
    t = model.misalignment
    k = np.column_stack([model.scale, model.scale_quadratic, model.scale_cubic])
    out = {"K": k, "b": -model.bias, "G": -model.g_sensitivity}
    if model.shape == "upper":
        out["alpha"] = {"yz": -t[0, 1], "zy": t[0, 2], "zx": -t[1, 2]}
    else:
        out["gamma"] = {"yz": -t[0, 1], "zy": t[0, 2], "xz": t[1, 0], "zx": -t[1, 2],
                        "xy": -t[2, 0], "yx": t[2, 1]}
    return out


# ------------------------------------------------------------------ Qureshi
def from_qureshi(x: np.ndarray) -> TriadModel:
    """Canonical model from Qureshi 2017's ``X = [b, k, k_xy, k_xz, k_yz]`` (eqs. 5–8)."""
    x = np.asarray(x, dtype=float)
    if x.shape != (9,):
        raise ValueError(f"Qureshi's parameter vector has 9 entries; got shape {x.shape}")
    b, k = x[0:3], x[3:6]
    m = np.array([[k[0], x[6], x[7]], [0.0, k[1], x[8]], [0.0, 0.0, k[2]]])  # M = K T_s^o
    t = m / k[None, :]
    return TriadModel(misalignment=np.triu(t, 1) + np.eye(3), scale=k, bias=b, shape="upper")


def to_qureshi(model: TriadModel) -> np.ndarray:
    """Qureshi 2017's ``X`` of a linear upper-triangular canonical model."""
    if model.shape != "upper" or not model.is_linear or np.any(model.output_bias):
        raise ValueError("Qureshi 2017's model is linear with an upper-triangular misalignment")
    m = model.misalignment * model.scale[None, :]
    return np.concatenate([model.bias, np.diag(m), [m[0, 1], m[0, 2], m[1, 2]]])


def qureshi_angles(x: np.ndarray) -> dict[str, float]:
    """``θ_yz, θ_zx, θ_zy`` of Qureshi 2017 from ``X`` (inverting eq. 7's products)."""
    k_x, k_y = x[3], x[4]
    th_yz = x[6] / k_x
    th_zx = x[8] / k_y
    th_zy = th_yz * th_zx - x[7] / k_x
    return {"yz": th_yz, "zx": th_zx, "zy": th_zy}


# --------------------------------------------------------------------- Wang
def from_wang(e: dict[str, float], k1, k2, k3, bias) -> TriadModel:
    """Canonical model from Wang 2019's ``C`` (``E_yx, E_zx, E_zy``), ``K1..K3`` and ``∇`` (eq. 2).

    Units are Wang's: ``N`` in pulses, the output in the unit of ``∇``.
    """
    c = np.array([[1.0, 0.0, 0.0], [e["yx"], 1.0, 0.0], [e["zx"], e["zy"], 1.0]])  # eqs. (5), (8)
    return TriadModel(misalignment=c, scale=k1, scale_quadratic=k2, scale_cubic=k3,
                      bias=np.zeros(3), output_bias=bias, shape="lower")


def to_wang(model: TriadModel) -> dict:
    """Wang 2019's ``E``, ``K1..K3`` and ``∇`` of a lower-triangular canonical model with ``b = 0``."""
    if model.shape != "lower" or np.any(model.bias) or np.any(model.g_sensitivity):
        raise ValueError("Wang 2019's model is lower-triangular with an output-side bias only "
                         "(b = 0, G = 0)")
    c = model.misalignment
    return {"E": {"yx": c[1, 0], "zx": c[2, 0], "zy": c[2, 1]}, "K1": model.scale.copy(),
            "K2": model.scale_quadratic.copy(), "K3": model.scale_cubic.copy(),
            "bias": model.output_bias.copy()}
