"""Pose plans for the accelerometer and what each one can determine, before anything is recorded.

A plan is a list of static poses, each given by the direction of the
specific force (gravity, pointing up) in the body frame. For the linear
model ``a = T_a K (u − b)`` (9 parameters: 3 misalignments, 3 scales,
3 biases) the gravity-norm residuals ``‖a_k‖ − g`` (Tedaldi 2014; Ru 2022,
eq. 10) have, at the nominal sensor (``T_a = I``, ``K = I``, ``b = 0``, raw in
m/s²), a Jacobian ``J`` whose Fisher information ``JᵀJ/σ²`` gives the
Cramér–Rao bound of every parameter for a per-pose noise ``σ`` of the
static means; a parameter the plan cannot determine is reported as such.

Plans:

* ``"six"`` — each axis up and down (Ru 2022, eqs. 8–9): enough for biases
  and scales, not for misalignments;
* ``"nine"`` — the six faces and three attitudes with two axes 45° up
  (Ru 2022, Table 3, the approximately optimal nine attitudes): every
  parameter, exactly;
* an integer ``N`` — ``N`` directions spread evenly over the sphere
  (a Fibonacci lattice), as a free-hand Tedaldi/Zhang session roughly does.
"""

from __future__ import annotations

import numpy as np

from .constants import STANDARD_GRAVITY
from .models import TriadModel
from .residuals import AccelLayout, gravity_norm_residuals
from .solve import standard_errors

__all__ = ["plan_directions", "accelerometer_plan"]

_S = np.sqrt(0.5)
#: Ru 2022, Table 3: x up, x down, y up, y down, z up, z down, then (body axes' up components)
#: 7 x east, y north-up 45°, z south-up 45°; 8 y east, z north-up, x south-up; 9 z east, x north-up, y south-up
NINE = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
                 [0, _S, _S], [_S, 0, _S], [_S, _S, 0]], dtype=float)


def plan_directions(plan: str | int) -> np.ndarray:
    """The unit up-directions (body frame) of a named plan or of ``N`` evenly spread poses."""
    if plan == "six":
        return NINE[:6].copy()
    if plan == "nine":
        return NINE.copy()
    try:
        n = int(plan)
    except (TypeError, ValueError):
        raise ValueError(f"plan must be 'six', 'nine' or a number of poses; got {plan!r}") from None
    if n < 1:
        raise ValueError(f"a plan needs at least one pose; got {n}")
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5**0.5) * k  # golden-angle spiral
    r = np.sqrt(1 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def accelerometer_plan(plan: str | int | np.ndarray, *, noise: float = 0.002,
                       gravity: float = STANDARD_GRAVITY) -> dict:
    """Cramér–Rao bounds of the linear accelerometer model's 9 parameters for a pose plan.

    ``noise`` is the standard deviation of one pose's mean [m/s²] (the
    sample noise divided by the square root of the samples held). Returns
    the directions and, per parameter, ``crlb_std`` (NaN where the plan
    cannot determine it) and ``observable``; scales are relative (the
    nominal scale is 1), misalignments in rad, biases in m/s².
    """
    d = plan_directions(plan) if not isinstance(plan, np.ndarray) else np.asarray(plan, dtype=float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    if not (np.isfinite(noise) and noise > 0):
        raise ValueError(f"noise must be a positive number of m/s^2; got {noise!r}")
    layout = AccelLayout("upper", 1)
    theta = layout.pack(TriadModel(shape="upper"))
    _, jac = gravity_norm_residuals(theta, layout, gravity * d, gravity, jacobian=True)
    # the bound for residuals of standard deviation σ: standard_errors with ‖r‖²/dof = σ²
    fake = np.full(jac.shape[0], noise)
    crlb = standard_errors(jac, fake, dof=jac.shape[0])
    names = layout.names("accelerometer")
    return {"directions": d.tolist(), "noise": noise, "poses": int(d.shape[0]),
            "parameters": [{"parameter": n, "crlb_std": float(c), "observable": bool(np.isfinite(c))}
                           for n, c in zip(names, crlb, strict=True)]}
