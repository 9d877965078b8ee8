r"""Quaternions, rotations and the integration of angular-rate sequences.

Conventions
-----------
Quaternions are Hamilton quaternions stored **scalar first**, ``q = [w, x, y, z]``,
as float64 arrays of shape (..., 4). A unit quaternion ``q`` rotates a vector
from the body frame to the reference frame, ``v_ref = R(q) · v_body``; the
attitude of a body turning with body-frame rate ``ω`` obeys the quaternion
kinematics (Zhang 2021, Sec. IV-B, whose eq. (23) is their exact one-step
solution for a constant rate), with ``R(q)`` the matrix of Zhang 2021, eq. (13):

.. math::

    \dot{\mathbf q} = \tfrac12\, \mathbf q \otimes \begin{bmatrix} 0 \\ \boldsymbol\omega \end{bmatrix}
    \qquad \text{(Q1)}

    \mathbf R(\mathbf q) = \begin{bmatrix}
    1 - 2q_2^2 - 2q_3^2 & 2(q_1q_2 - q_0q_3) & 2(q_0q_2 + q_1q_3) \\
    2(q_1q_2 + q_0q_3) & 1 - 2q_1^2 - 2q_3^2 & 2(q_2q_3 - q_0q_1) \\
    2(q_1q_3 - q_0q_2) & 2(q_2q_3 + q_0q_1) & 1 - 2q_1^2 - 2q_2^2
    \end{bmatrix} \qquad \text{(Zhang 2021, eq. 13)}

:func:`to_scipy` and
:func:`from_scipy` convert to and from :class:`scipy.spatial.transform.Rotation`
(which stores scalar last).

Integration
-----------
Between samples ``k`` and ``k+1`` the rate is taken as linear in time, so the
classic fourth-order Runge–Kutta step uses ``ω_k`` at the start, the mid-step
rate ``(ω_k + ω_{k+1}) / 2`` and ``ω_{k+1}`` at the end (Zhang 2021, eq. 23 is
the first-order special case). Because the equation is linear in ``q`` and every
stage multiplies ``q`` on the right, one RK4 step of (Q1) is ``q_{k+1} = q_k ⊗ S_k``
with ``h`` the step length and ``ω_m = (ω_k + ω_{k+1}) / 2`` (the classic
RK4 stages, derived here; quaternions ``[s, v]`` written as scalar and vector):

.. math::

    K_1 = \tfrac12 \boldsymbol\omega_k, \quad
    K_2 = (1 + \tfrac h2 K_1) \otimes \tfrac12 \boldsymbol\omega_m, \quad
    K_3 = (1 + \tfrac h2 K_2) \otimes \tfrac12 \boldsymbol\omega_m, \quad
    K_4 = (1 + h K_3) \otimes \tfrac12 \boldsymbol\omega_{k+1} \qquad \text{(Q2)}

    S_k = 1 + \tfrac h6 (K_1 + 2 K_2 + 2 K_3 + K_4), \qquad
    \mathbf q_{k+1} = \mathbf q_k \otimes S_k \qquad \text{(Q3)}

So the attitude change over an interval is the ordered product ``S_0 ⊗ … ⊗ S_{n-1}``
(normalised once: scaling commutes with the product, so this equals normalising
after every step). The step factors are computed for all samples at once and the
products are formed by pairwise (tree) reduction, which vectorises the
integration over time steps and over many intervals together.
"""

from __future__ import annotations

from .derivatives import five_point_derivative, segmented_five_point
from .integrator import IntervalIntegrator
from .products import integrate, integrate_intervals, rk4_step_factors
from .quaternions import (
    angle_between,
    from_scipy,
    matrix_to_quat,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    quat_normalize,
    quat_to_matrix,
    quat_to_rotvec,
    skew,
    to_scipy,
)

__all__ = [
    "quat_multiply",
    "quat_conjugate",
    "quat_normalize",
    "quat_to_matrix",
    "matrix_to_quat",
    "quat_from_rotvec",
    "quat_to_rotvec",
    "rk4_step_factors",
    "integrate",
    "integrate_intervals",
    "IntervalIntegrator",
    "to_scipy",
    "from_scipy",
    "skew",
    "angle_between",
    "five_point_derivative",
    "segmented_five_point",
]
