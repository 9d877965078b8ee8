"""Levenberg–Marquardt for tall least-squares problems, and the standard errors of its estimates.

The calibration problems have tens of parameters and up to ~10⁵ residuals.
MINPACK (``scipy.optimize.least_squares(method="lm")``) factorises the whole
Jacobian with unblocked Householder QR at every iteration; here the step is
solved from the normal equations ``(JᵀJ + λ D²) δ = −Jᵀr`` (one BLAS product,
then a Cholesky factorisation of a P×P matrix), with Marquardt's scaling
``D² = diag(JᵀJ)`` and Nielsen's update of the damping ``λ``. The Jacobian is
evaluated only at accepted points.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

__all__ = ["LMResult", "ScaledInverse", "cholesky", "errors_from_covariance", "levenberg_marquardt", "lstsq",
           "scaled_inverse", "solve", "standard_errors"]


@dataclass
class LMResult:
    """Outcome of :func:`levenberg_marquardt` (fields as in scipy's ``OptimizeResult``).

    ``jac`` is the Jacobian at ``x``. Where the last accepted step ended the
    iterations, it is evaluated when first read (most callers read only ``x``
    and ``fun``); ``njev`` counts it either way.
    """

    x: np.ndarray
    cost: float  # ½‖r‖²
    fun: np.ndarray
    _jac: np.ndarray | Callable[[], np.ndarray]
    nfev: int
    njev: int
    status: int
    message: str

    @property
    def jac(self) -> np.ndarray:
        if callable(self._jac):
            self._jac = np.asarray(self._jac(), dtype=np.float64)
        return self._jac

    @property
    def success(self) -> bool:
        return self.status > 0


def _initial_residuals(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray) -> np.ndarray:
    """``fun(x)`` as float64, refused when not finite (:func:`levenberg_marquardt`)."""
    r = np.asarray(fun(x), dtype=np.float64)
    rr = float(r @ r)  # not finite where any residual is not
    if not rr < math.inf:
        if not np.isfinite(r).all():
            raise ValueError("Residuals are not finite in the initial point.")
    return r


def _scaled_normal_equations(jac: Callable[[np.ndarray], np.ndarray], x: np.ndarray, r: np.ndarray, cost: float,
                             gtol: float) -> tuple:
    """The Jacobian at ``x`` and the scaled system ``Â = D⁻¹ A D⁻¹``, ``ĝ = D⁻¹ g`` (``A = JᵀJ``, ``g = Jᵀr``,
    ``D² = diag A``), with ``D⁻¹``, and whether the gradient is zero to ``gtol`` (:func:`levenberg_marquardt`)."""
    j = np.asarray(jac(x), dtype=np.float64)
    a = j.T @ j
    g = j.T @ r
    d2 = np.maximum(a.diagonal(), _TINY)
    dinv = 1.0 / np.sqrt(d2)
    if _MAX(np.abs(g) * dinv, axis=None) <= gtol * max(math.sqrt(2 * cost), _TINY):
        # |Jᵢᵀr| / (‖Jᵢ‖‖r‖): the residual is orthogonal to the Jacobian
        return j, None, None, dinv, True
    # scaled system: (Â + λ I) δ̂ = −ĝ with Â = D⁻¹ A D⁻¹ (the same until the next Jacobian)
    a_s = a * dinv[:, None] * dinv[None, :]
    g_s = g * dinv
    return j, a_s, g_s, dinv, False


def _trial_step(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray, a_s: np.ndarray, g_s: np.ndarray,
                dinv: np.ndarray, lam: float, cost: float) -> tuple:
    """The damped step at ``λ`` (scaled), the point it reaches, its residuals and cost, and the ratio ``ρ`` of
    the actual to the predicted cost reduction (−1 where none is predicted; :func:`levenberg_marquardt`)."""
    step_s = _solve_damped(a_s, g_s, lam)
    step = step_s * dinv
    x_new = x + step
    r_new = np.asarray(fun(x_new), dtype=np.float64)
    rr = float(r_new @ r_new)  # not finite where any residual is not
    cost_new = 0.5 * rr if rr < math.inf else math.inf
    predicted = -(g_s @ step_s) - 0.5 * step_s @ (a_s @ step_s)
    rho = (cost - cost_new) / predicted if predicted > 0 else -1.0
    return step_s, x_new, r_new, cost_new, rho


def _converged(reduction: float, cost: float, step_s: np.ndarray, x: np.ndarray, dinv: np.ndarray, ftol: float,
               xtol: float) -> tuple[int, str] | None:
    """``(status, message)`` when an accepted step ends the iterations by ``ftol`` or ``xtol``, else None
    (:func:`levenberg_marquardt`)."""
    if reduction <= ftol * max(cost + reduction, _TINY):
        return 2, "the relative cost reduction is below ftol"
    if _norm(step_s) <= xtol * (_norm(x / dinv) + xtol):
        return 3, "the relative step is below xtol"
    return None


def levenberg_marquardt(fun: Callable[[np.ndarray], np.ndarray], jac: Callable[[np.ndarray], np.ndarray],
                        x0: np.ndarray, *, ftol: float = 1e-12, xtol: float = 1e-12, gtol: float = 1e-8,
                        max_iter: int = 200, lambda0: float = 1e-3, stol: float = 0.0) -> LMResult:
    """Minimise ``½‖fun(x)‖²`` by Levenberg–Marquardt.

    Parameters
    ----------
    fun : callable
        Residuals ``r(x)`` (M,).
    jac : callable
        Jacobian ``∂r/∂x`` (M, P).
    x0 : (P,) array_like
        Initial point.
    ftol, xtol, gtol : float
        Stop when the relative cost reduction of an accepted step is below
        ``ftol`` (status 2), the scaled step is below ``xtol`` times the scaled
        ``x`` (status 3), or the cosine between the residual vector and every
        Jacobian column is below ``gtol`` (status 1, MINPACK's test).
    max_iter : int
        Most iterations (status 0 when reached).
    stol : float
        Also stop (status 4) when an accepted step lowers the cost by less
        than ``stol`` times the residual variance ``‖r‖²/(M − P)``: the fit
        moved by ``√(2·stol)`` standard errors at most, far below what the
        noise can resolve, and Gauss–Newton's quadratic convergence makes the
        rest smaller still. The result's ``jac`` is then the one of the
        previous iterate (the point differs by that step), which saves a
        Jacobian evaluation. 0 (default) disables the test, as noise-free
        data need.
    """
    x = np.array(x0, dtype=np.float64)
    r = _initial_residuals(fun, x)
    cost = 0.5 * float(r @ r)
    nfev, njev = 1, 0
    lam = None
    nu = 2.0
    status, message = 0, "the maximum number of iterations was reached"
    j = None
    for _ in range(max_iter):
        if j is None:
            j, a_s, g_s, dinv, flat = _scaled_normal_equations(jac, x, r, cost, gtol)
            njev += 1
            if flat:
                status, message = 1, "the gradient is zero to tolerance"
                break
            if lam is None:
                lam = lambda0
        step_s, x_new, r_new, cost_new, rho = _trial_step(fun, x, a_s, g_s, dinv, lam, cost)
        nfev += 1
        if rho > 0:
            reduction = cost - cost_new
            x, r, cost = x_new, r_new, cost_new
            dof = max(r.size - x.size, 1)
            if stol > 0 and reduction <= stol * 2.0 * cost / dof:
                status, message = 4, "the last step is negligible against the noise (stol)"
                break
            j = None
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            stop = _converged(reduction, cost, step_s, x, dinv, ftol, xtol)
            if stop is not None:
                status, message = stop
                break
        else:
            lam *= nu
            nu *= 2.0
            if lam > 1e16:
                status, message = 3, "no further decrease is possible (damping saturated)"
                break
    if j is None:  # the Jacobian at the last accepted point, formed only if read
        j = functools.partial(jac, x)
        njev += 1
    return LMResult(x=x, cost=cost, fun=r, _jac=j, nfev=nfev, njev=njev, status=status,
                    message=message)


#: the smallest positive normal double (``np.finfo(float).tiny``)
_TINY = np.finfo(float).tiny

_MAX = np.maximum.reduce


def lstsq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.lstsq(a, b, rcond=None)[0]``: the least-squares solution of a float64 ``a`` (M, N) and ``b`` (M,)
    (LAPACK ``gelsd``, ``rcond`` = ``eps · max(M, N)``); ``LinAlgError`` where the SVD does not converge."""
    return np.linalg.lstsq(a, b, rcond=None)[0]


def _norm(v: np.ndarray) -> float:
    """``np.linalg.norm`` of a 1-D float64 array: the same ``sqrt(v·v)`` numpy forms for it."""
    return np.sqrt(v.dot(v))


@functools.lru_cache(maxsize=16)
def _eye(n: int) -> np.ndarray:
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


def cholesky(m: np.ndarray) -> np.ndarray:
    """``np.linalg.cholesky(m)`` of a float64 (P, P) ``m``; ``LinAlgError`` where ``m`` is not positive definite."""
    return np.linalg.cholesky(m)


def solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.solve(a, b)`` of a float64 (P, P) ``a`` and a (P,) ``b`` (LAPACK ``gesv``); ``LinAlgError``
    where ``a`` is singular."""
    return np.linalg.solve(a, b)


def _solve_damped(a: np.ndarray, g: np.ndarray, lam: float) -> np.ndarray:
    """``(A + λI) δ = −g`` by Cholesky, ``A + λI = C Cᵀ``: ``δ = C⁻ᵀ (C⁻¹ (−g))``; least squares where it fails.

    The triangular systems are solved by LAPACK's general solver (``np.linalg.solve``).
    """
    m = a + lam * _eye(a.shape[0])
    try:
        c = np.linalg.cholesky(m)
        return np.linalg.solve(c.T, np.linalg.solve(c, -g))
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(m, -g, rcond=None)[0]


def standard_errors(jac: np.ndarray, residuals: np.ndarray, *, dof: float | None = None,
                    transform: np.ndarray | None = None, rcond: float = 1e-10,
                    extra_cov: np.ndarray | None = None) -> np.ndarray:
    """1σ standard errors of least-squares estimates, NaN where the data do not determine them.

    The covariance of a least-squares fit at its minimum is ``σ² (JᵀJ)⁻¹``
    with ``σ² = ‖r‖² / dof`` (Gauss–Newton approximation; e.g. Nocedal &
    Wright, *Numerical Optimization*, §10.3), ``dof`` the residuals' degrees
    of freedom minus the parameters (default ``M − P``). ``transform`` (Q, P)
    maps the fitted parameters to reported ones to first order (delta method:
    ``A C Aᵀ``). The columns are scaled to unit norm before inverting, so
    parameters spanning many orders of magnitude keep their accuracy; an
    eigen-direction of the scaled ``JᵀJ`` below ``rcond`` times the largest is
    unobservable, and every parameter with a visible share of it gets NaN
    rather than a falsely small error. Returns NaN everywhere when there are
    no degrees of freedom left to estimate ``σ²``. ``extra_cov`` (P, P) is added
    to the fitted parameters' covariance before ``transform``: what an input
    held fixed in the fit (a bias taken from the rest) contributes.
    """
    m, p = jac.shape
    dof = m - p if dof is None else dof
    if dof <= 0:
        return np.full(p if transform is None else transform.shape[0], np.nan)
    cov, bad = covariance(jac, residuals, dof=dof, rcond=rcond)
    if extra_cov is not None:
        cov = cov + extra_cov
    return errors_from_covariance(cov, bad, transform=transform)


def errors_from_covariance(cov: np.ndarray, bad: np.ndarray, *, transform: np.ndarray | None = None) -> np.ndarray:
    """1σ errors from a covariance (``transform``: the delta method, ``A C Aᵀ``), NaN where ``bad`` (undetermined,
    as :func:`covariance` marks them) or where a reported parameter draws on one."""
    if transform is not None:
        bad = np.abs(transform) @ bad.astype(float) > 0
        cov = transform @ cov @ transform.T
    out = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    out[bad] = np.nan
    return out


class ScaledInverse(NamedTuple):
    """``(JᵀJ)⁻¹`` in unit-norm columns (:func:`scaled_inverse`)."""

    col: np.ndarray  # (P,) the columns' norms (1 where a column is zero)
    js: np.ndarray  # (M, P) the Jacobian with its columns scaled to unit norm
    inv: np.ndarray  # (P, P) the pseudo-inverse of ``jsᵀ js`` over its observable directions
    bad: np.ndarray  # (P,) bool: a parameter with a visible share of an unobservable direction


def scaled_inverse(jac: np.ndarray, rcond: float = 1e-10) -> ScaledInverse:
    """The inverse of the normal matrix of ``jac`` with its columns scaled to unit norm.

    Parameters spanning many orders of magnitude keep their accuracy; an
    eigen-direction of the scaled ``JᵀJ`` below ``rcond`` times the largest
    is unobservable: dropped from the inverse, and every parameter loaded on
    it (a component above 1e-3) flagged ``bad``. The parameters' covariance
    is ``σ² inv / outer(col, col)``.
    """
    col = np.linalg.norm(jac, axis=0)
    col = np.where(col > 0, col, 1.0)
    js = jac / col
    w, v = np.linalg.eigh(js.T @ js)
    good = w > rcond * max(w[-1], np.finfo(float).tiny)
    bad = np.any(np.abs(v[:, ~good]) > 1e-3, axis=1)
    inv = (v[:, good] / w[good]) @ v[:, good].T
    return ScaledInverse(col, js, inv, bad)


def covariance(jac: np.ndarray, residuals: np.ndarray, *, dof: float | None = None,
               rcond: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    """``σ² (JᵀJ)⁻¹`` of a least-squares fit at its minimum, and which parameters it does not determine.

    As in :func:`standard_errors` (scaled columns, unobservable directions
    dropped); the second result flags the parameters loaded on one of them.
    """
    m, p = jac.shape
    dof = m - p if dof is None else dof
    s2 = float(residuals @ residuals) / max(dof, 1)
    si = scaled_inverse(jac, rcond)
    return s2 * si.inv / np.outer(si.col, si.col), si.bad
