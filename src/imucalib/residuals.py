"""Residual functions shared by the calibration methods, with analytic Jacobians.

Each residual takes a parameter vector laid out by a :class:`AccelLayout` (or
the gyroscope's own layout) and returns the residual vector and, on request,
its Jacobian. Names of the parameters are those of the calibration file
(``docs/architecture.rst``, *The calibration file*).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .kinematics import IntervalIntegrator, quat_to_matrix, skew
from .models import AXES, TriadModel, misalignment_entries

__all__ = [
    "AccelLayout",
    "GravityNorm",
    "gravity_norm_residuals",
    "GyroLayout",
    "gravity_direction_residuals",
    "gravity_direction_residuals_jac",
    "linear_rate_jacobian",
]


@functools.cache
def _entry_index(shape: str) -> tuple[np.ndarray, np.ndarray]:
    entries = misalignment_entries(shape)
    rows = np.array([i for i, _ in entries], dtype=np.intp)
    cols = np.array([j for _, j in entries], dtype=np.intp)
    rows.flags.writeable = cols.flags.writeable = False
    return rows, cols


#: the 3 × 3 identity, copied where a misalignment is formed
_EYE3 = np.eye(3)
_EYE3.flags.writeable = False


@dataclass(frozen=True)
class AccelLayout:
    """Parameter vector of an accelerometer triad: ``[T entries, k1, (k2), (k3), b]``.

    ``order`` is the polynomial order of the scale factors (1, 2 or 3).
    """

    shape: str = "upper"
    order: int = 1

    def __post_init__(self) -> None:
        if self.order not in (1, 2, 3):
            raise ValueError(f"scale-factor order must be 1, 2 or 3; got {self.order}")

    @property
    def entries(self) -> tuple[tuple[int, int], ...]:
        return misalignment_entries(self.shape)

    @property
    def size(self) -> int:
        return len(self.entries) + 3 * self.order + 3

    @property
    def index(self) -> tuple[np.ndarray, np.ndarray]:
        """The rows and columns of :attr:`entries`, as index arrays."""
        return _entry_index(self.shape)

    def names(self, prefix: str = "accelerometer") -> list[str]:
        out = [f"{prefix}.misalignment.{AXES[i]}{AXES[j]}" for i, j in self.entries]
        for key in ("scale", "scale_quadratic", "scale_cubic")[: self.order]:
            out += [f"{prefix}.{key}.{a}" for a in AXES]
        return out + [f"{prefix}.bias.{a}" for a in AXES]

    def pack(self, model: TriadModel) -> np.ndarray:
        parts = [np.array([model.misalignment[i, j] for i, j in self.entries])]
        parts += [model.scale, model.scale_quadratic, model.scale_cubic][: self.order]
        parts.append(model.bias)
        return np.concatenate(parts)

    def unpack(self, theta: np.ndarray, base: TriadModel | None = None) -> TriadModel:
        n_t = len(self.entries)
        t = _EYE3.copy()
        t[self.index] = theta[:n_t]
        k = theta[n_t : n_t + 3 * self.order].reshape(self.order, 3)
        zeros = np.zeros(3)
        fields = dict(
            misalignment=t,
            shape=self.shape,
            scale=k[0],
            scale_quadratic=k[1] if self.order >= 2 else zeros,
            scale_cubic=k[2] if self.order >= 3 else zeros,
            bias=theta[-3:],
        )
        return TriadModel(**fields) if base is None else base.with_(**fields)


def gravity_norm_residuals(
    theta: np.ndarray,
    layout: AccelLayout,
    raw_means: np.ndarray,
    gravity: float,
    *,
    squared: bool = False,
    jacobian: bool = False,
):
    r"""Gravity-norm residuals of static poses.

    ``r_k = ‖h(u_k, θ)‖ − g`` (Tedaldi 2014), or with ``squared=True``
    ``r_k = ‖h(u_k, θ)‖² − g²`` (Zhang 2021, eq. 10), where
    ``h(u, θ) = T · f(u − b)`` (Zhang 2021, eq. 9, with our bias sign):

    .. math::

        \mathbf h(\mathbf u_k, \boldsymbol\theta) = \mathbf T\, \mathbf f(\mathbf u_k - \mathbf b), \qquad
        r_k = \lVert \mathbf h(\mathbf u_k, \boldsymbol\theta) \rVert - g
        \quad\text{or}\quad
        r_k = \lVert \mathbf h(\mathbf u_k, \boldsymbol\theta) \rVert^2 - g^2

    Parameters
    ----------
    theta : (P,) ndarray
        Parameters laid out by ``layout``.
    raw_means : (M, 3) ndarray
        Raw accelerometer means of the static poses.
    gravity : float
        ``g`` [m/s²].
    jacobian : bool
        Also return the (M, P) Jacobian.

    See Also
    --------
    GravityNorm : the same residuals and Jacobian of fixed poses, for a solver.
    """
    terms = _gravity_norm_terms(theta, layout, raw_means, gravity, squared)
    if not jacobian:
        return terms[0]
    return terms[0], _gravity_norm_jacobian(terms, layout, squared)


def _gravity_norm_terms(theta, layout: AccelLayout, raw_means, gravity: float, squared: bool) -> tuple:
    """``r`` of :func:`gravity_norm_residuals` and the terms of its Jacobian: ``(r, a, f, T, k, powers, ‖a‖)``."""
    rows, cols = layout.index
    n_t = rows.size
    t = _EYE3.copy()
    t[rows, cols] = theta[:n_t]
    k = theta[n_t : n_t + 3 * layout.order].reshape(layout.order, 3)
    b = theta[-3:]
    x = raw_means - b
    powers = [x]
    for _ in range(1, layout.order):
        powers.append(powers[-1] * x)
    f = 0 + k[0] * x  # eq. (2): f = Σₙ kₙ xⁿ, summed from 0 (which turns a −0.0 into +0.0)
    for kk, p in zip(k[1:], powers[1:], strict=True):
        f = f + kk * p
    a = f @ t.T  # eq. (9): h = T f(u − b)
    norm = np.sqrt(np.add.reduce(a * a, axis=1))  # np.linalg.norm(a, axis=1), as numpy forms it
    r = norm**2 - gravity**2 if squared else norm - gravity  # eq. (10) squared, else Tedaldi's ‖h‖ − g
    return r, a, f, t, k, powers, norm


def _gravity_norm_jacobian(terms: tuple, layout: AccelLayout, squared: bool) -> np.ndarray:
    """The (M, P) Jacobian of :func:`gravity_norm_residuals` from :func:`_gravity_norm_terms`."""
    _, a, f, t, k, powers, norm = terms
    rows, cols = layout.index
    n_t = rows.size
    # d r / d a: 2a (squared) or a/‖a‖
    da = 2.0 * a if squared else a / norm[:, None]
    jac = np.empty((a.shape[0], n_t + 3 * len(powers) + 3))  # (M, layout.size)
    np.multiply(da[:, rows], f[:, cols], out=jac[:, :n_t])  # ∂a/∂T_ij = e_i f_j
    nt = da @ t  # (M, 3): (dr/da)·T[:, j] for each column j
    col = n_t
    for p in powers:
        np.multiply(nt, p, out=jac[:, col : col + 3])  # ∂a/∂k_{n,j} = T[:, j] x_j^n
        col += 3
    higher = 0  # Σ_{n≥2} n kₙ xⁿ⁻¹, summed from 0 as the builtin sum does
    for n in range(1, layout.order):
        higher = higher + (n + 1) * k[n] * powers[n - 1]
    dfdx = k[0] + higher
    np.multiply(-nt, dfdx, out=jac[:, col : col + 3])  # ∂a/∂b_j = −T[:, j] f'_j(x_j)
    return jac


class GravityNorm:
    """The residuals and Jacobian of :func:`gravity_norm_residuals` on fixed poses, as functions of ``θ`` alone.

    For a solver that asks for the Jacobian where it last evaluated the
    residuals (Levenberg–Marquardt at an accepted step): that Jacobian is
    formed from the terms of that evaluation, which are the numbers a fresh
    evaluation would compute again.

    Parameters
    ----------
    layout : AccelLayout
    raw_means : (M, 3) ndarray
        Raw accelerometer means of the static poses.
    gravity : float
        ``g`` [m/s²].
    squared : bool
        ``‖h‖² − g²`` (Zhang 2021, eq. 10) instead of ``‖h‖ − g``.
    """

    def __init__(self, layout: AccelLayout, raw_means: np.ndarray, gravity: float, *, squared: bool = False):
        self.layout, self.raw_means, self.gravity, self.squared = layout, raw_means, gravity, squared
        self._key: bytes | None = None
        self._terms: tuple = ()

    def _evaluate(self, theta: np.ndarray) -> tuple:
        theta = np.asarray(theta, dtype=np.float64)
        key = theta.tobytes()
        if key != self._key:  # on a copy: the terms hold views of it
            self._terms = _gravity_norm_terms(theta.copy(), self.layout, self.raw_means, self.gravity, self.squared)
            self._key = key
        return self._terms

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """``r(θ)`` (M,)."""
        return self._evaluate(theta)[0]

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """``∂r/∂θ`` (M, P) at ``θ``."""
        return _gravity_norm_jacobian(self._evaluate(theta), self.layout, self.squared)


@dataclass(frozen=True)
class GyroLayout:
    """Linear gyroscope parameters: the 9 entries of ``M = T_g · diag(k1)``, then ``b`` if estimated.

    With a unit-diagonal ``T_g`` (6 terms, Zhang 2021 eq. 8) the map
    ``(T_g, k1) ↔ M`` is one-to-one: ``k1_j = M_jj`` and ``T_ij = M_ij / M_jj``;
    optimising ``M`` makes the rates linear in the parameters.
    """

    estimate_bias: bool = False

    @property
    def size(self) -> int:
        return 12 if self.estimate_bias else 9

    def pack(self, model: TriadModel) -> np.ndarray:
        m = model.misalignment * model.scale[None, :]
        return np.concatenate([m.ravel(), model.bias]) if self.estimate_bias else m.ravel()

    def unpack(self, theta: np.ndarray, bias: np.ndarray) -> TriadModel:
        m = theta[:9].reshape(3, 3)
        k = np.diag(m).copy()
        t = m / k[None, :]
        np.fill_diagonal(t, 1.0)
        b = theta[9:12] if self.estimate_bias else bias
        return TriadModel(misalignment=t, scale=k, bias=b, shape="full")


def gravity_direction_residuals(
    rates: np.ndarray,
    integrator: IntervalIntegrator,
    gravity_dirs: np.ndarray,
) -> np.ndarray:
    """Gravity-direction residuals between consecutive poses (Zhang 2021, eq. 14).

    ``r_k = g_k − R_{k-1,k}ᵀ g_{k-1}`` with unit gravity directions ``g`` and
    ``R`` the attitude change integrated (RK4) from the calibrated rates.

    Parameters
    ----------
    rates : (N, 3) ndarray
        Calibrated body rates [rad/s] of the whole recording.
    integrator : IntervalIntegrator
        The transitions between poses.
    gravity_dirs : (M, 3) ndarray
        Measured unit gravity directions at the M poses.

    Returns
    -------
    (3·(M−1),) ndarray
    """
    r = quat_to_matrix(integrator(rates))
    predicted = np.einsum("kji,kj->ki", r, gravity_dirs[:-1])
    return (gravity_dirs[1:] - predicted).ravel()


def gravity_direction_residuals_jac(
    rates: np.ndarray,
    rate_jac: np.ndarray,
    integrator: IntervalIntegrator,
    gravity_dirs: np.ndarray,
    steps: np.ndarray | None = None,
    extra_jac=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Residuals of :func:`gravity_direction_residuals` and their Jacobian.

    The attitude change responds to rate perturbations as
    ``δφ = R_endᵀ Σ_j A_j δω_j`` (:meth:`IntervalIntegrator.sensitivity`), and
    ``R'ᵀ g = (I − [δφ]×) Rᵀ g``, so ``∂r_k/∂θ = −[p_k]× R_endᵀ Σ_j A_j ∂ω_j/∂θ``
    with ``p_k = R_endᵀ g_{k-1}``. Gravity directions are held fixed.

    Parameters
    ----------
    rates : (S, 3) ndarray
        Calibrated rates [rad/s] at ``integrator.samples``.
    rate_jac : (S, 3, P) ndarray or callable
        ``∂ω_j/∂θ`` at those samples, or a function of ``(a, b)`` giving those
        of samples ``a … b − 1`` (:meth:`IntervalIntegrator.weighted_sum`;
        e.g. :func:`linear_rate_jacobian`).

    steps : ndarray, optional
        The RK4 factors of ``rates`` when already formed
        (:meth:`IntervalIntegrator.step_factors`).
    extra_jac : (S, 3, Q) ndarray or callable, optional
        ``∂ω_j/∂x`` of other inputs ``x`` of the rates, as ``rate_jac``: their
        Q columns are appended, from the same integration (the first P
        columns are those without them).

    Returns
    -------
    residuals : (3·(M−1),) ndarray
    jacobian : (3·(M−1), P) ndarray
    """
    q_end, weights = integrator.sensitivity(rates, steps)
    r = quat_to_matrix(q_end)
    predicted = np.einsum("kji,kj->ki", r, gravity_dirs[:-1])
    summed = integrator.weighted_sum(weights, rate_jac)  # Σ_j A_j ∂ω_j/∂θ
    turn = -skew(predicted) @ np.swapaxes(r, 1, 2)
    jac = (turn @ summed).reshape(-1, summed.shape[-1])
    if extra_jac is not None:
        more = turn @ integrator.weighted_sum(weights, extra_jac)
        jac = np.hstack([jac, more.reshape(len(more) * 3, -1)])
    return (gravity_dirs[1:] - predicted).ravel(), jac


#: the largest block buffer :func:`linear_rate_jacobian` keeps in its ``workspace``
WORKSPACE_BYTES = 1 << 22


def linear_rate_jacobian(m: np.ndarray, v: np.ndarray, *, bias: bool = True,
                         drift_time: np.ndarray | None = None, workspace: dict | None = None):
    """``∂ω_j/∂θ`` of the rates ``ω_j = M v_j``, ``v_j = u_j − b − τ_j d``, for a block of samples at a time.

    The parameters are ``[M (9, row by row), b (3, when bias), d (3, with
    drift_time τ)]`` (Zhang 2021, eq. 6 with the bias's linear drift):
    ``∂ω_{j,i}/∂M_ik = v_{jk}``, ``∂ω_j/∂b = −M``, ``∂ω_j/∂d = −τ_j M``.
    Returns a function of ``(a, b)`` giving the (b − a, 3, P) Jacobian of the
    samples ``a … b − 1`` of ``v`` (S, 3) for
    :meth:`IntervalIntegrator.weighted_sum`: one buffer as long as the longest
    block asked for is reused, so the per-sample Jacobian (``24 P`` bytes a
    sample) never exists for the whole recording. Its entries are those the
    whole array would hold, so the sums are the same. ``workspace`` (a dict the
    caller keeps, e.g. one per problem) holds that buffer from one Jacobian to
    the next, so a fit's Jacobians do not each allocate and zero it afresh;
    the Jacobian it returns is to be read before the next one is formed.
    """
    size = 9 + (3 if bias else 0) + (3 if drift_time is not None else 0)
    space = {} if workspace is None else workspace
    buf = space.get(size, np.zeros((0, 3, size)))
    minus_m = -m
    filled = 0  # rows of buf whose bias block holds this −M

    def block(a: int, b: int) -> np.ndarray:
        nonlocal buf, filled
        n = b - a
        if n > buf.shape[0]:
            buf = np.zeros((n, 3, size))  # the entries never written stay 0
            filled = 0
            if buf.nbytes <= WORKSPACE_BYTES:  # a long interval's block buffer is not kept between Jacobians
                space[size] = buf
        d = buf[:n]
        if bias and n > filled:  # the same for every sample: written once per row
            buf[filled:n, :, 9:12] = minus_m
            filled = n
        for i in range(3):
            d[:, i, 3 * i : 3 * i + 3] = v[a:b]  # ∂(M v)_i / ∂M_ik = v_k
        if drift_time is not None:  # formed contiguous, then placed (the same products: τ_j (−M))
            d[:, :, 12:15] = np.multiply(drift_time[a:b, None, None], minus_m[None])
        return d

    return block
