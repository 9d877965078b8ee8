r"""The gyroscope's bias at rest from the static poses (:func:`static_gyro`): the poses' mean rates by a
random-effects regression, with the bias's drift and the g-sensitivity.

At rest the gyroscope reads its bias and the g-sensitivity's share (Zhang 2021, eq. 11, with this project's
bias sign), here with the bias drifting linearly in time; with ``ū_k`` pose ``k``'s mean reading, ``a_k`` its
calibrated specific force, ``t_k`` its mean time, ``s_k²`` its samples' variance and ``n_k`` their number, one
axis at a time (the regressor row ``x_k`` holds 1, ``t_k − t_ref`` and ``a_k`` as chosen):

.. math::

    \bar u_k = b + d\, (t_k - t_\mathrm{ref}) + \mathbf G_{i\cdot}\, \mathbf a_k + e_k, \qquad
    e_k \sim \mathcal N\bigl(0,\; v_k + \tau^2\bigr), \quad v_k = \frac{s_k^2}{n_k - 1}
    \qquad \text{(S1)}

    \hat{\mathbf c} = (\mathbf X^\top \mathbf W \mathbf X)^{+} \mathbf X^\top \mathbf W \bar{\mathbf u},
    \quad \mathbf W = \mathrm{diag}\Bigl(\frac{1}{v_k + \tau^2}\Bigr), \qquad
    \sum_k \frac{(\bar u_k - \mathbf x_k \hat{\mathbf c})^2}{v_k + \tau^2} = M - p
    \qquad \text{(S2)}

(``τ² = 0`` when the left side is already below ``M − p`` at zero; Paule & Mandel 1982), and of the fits with
and without ``G`` and ``d`` the one of the least Bayesian information criterion over the three axes
(``n = 3M``, ``p`` counting 3 per coefficient and the 3 ``τ²``):

.. math::

    \mathrm{BIC} = -2 \ln L + p \ln n, \qquad
    \ln L = -\frac12 \sum_k \Bigl( \ln\bigl(2\pi (v_k + \tau^2)\bigr)
    + \frac{(\bar u_k - \mathbf x_k \hat{\mathbf c})^2}{v_k + \tau^2} \Bigr) \qquad \text{(S3)}
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..metrics import interval_means
from ..models import AXES, TriadModel
from ..recording import Interval, Recording


@dataclass(frozen=True)
class StaticGyro:
    """The gyroscope at rest over the static poses: ``ū_k = b + d (t_k − t_ref) + G a_k`` (Zhang 2021, eq. 11).

    ``variances`` (M, 3) are each pose mean's variance as the fit weights it:
    the white noise of its samples over their number plus the scatter
    between poses the noise does not explain (tremor, a random walk of the
    bias).
    """

    bias: np.ndarray
    bias_cov: np.ndarray  # of the estimate: what it carries into the other parameters
    g_sensitivity: np.ndarray | None  # None when the poses do not support it
    errors: dict[str, float]
    spread: np.ndarray  # per axis, the scatter of one pose's mean about the fit: drift and turn-on changes
    drift: np.ndarray | None = None  # the bias's linear drift [raw per s], None when the poses show none
    t_ref: float = 0.0  # the time [s] at which ``bias`` holds: the mean of the poses' times
    times: np.ndarray | None = None  # (M,) each pose's mean time [s]
    means: np.ndarray | None = None  # (M, 3) each pose's mean reading [raw]
    accel: np.ndarray | None = None  # (M, 3) each pose's calibrated specific force [m/s²]
    variances: np.ndarray | None = None  # (M, 3) each pose mean's variance [raw²], scatter included
    drift_se: np.ndarray | None = None  # (3,) 1σ of ``drift``
    g_cov: np.ndarray | None = None  # (3, 3, 3) per gyroscope axis, the covariance of its row of ``g_sensitivity``


def _regression_solve(x: np.ndarray, u: np.ndarray, v: np.ndarray, tau2: float):
    """One axis's weighted least squares of ``u ≈ x c`` with weights ``1/(v + τ²)``: ``c``, its covariance, χ², the
    residuals.

    The covariance is the pseudo-inverse of ``xᵀ W x`` (``np.linalg.pinv``, relative cut-off 1e-15).
    """
    w = 1.0 / (v + tau2)  # eq. (S2): W
    xw = x * w[:, None]
    cov = np.linalg.pinv(x.T @ xw)
    c = cov @ (xw.T @ u)  # eq. (S2)
    r = u - x @ c
    return c, cov, float(np.add.reduce(w * r * r)), r  # eq. (S2): χ²


def _weighted_regressions(problems: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> list[tuple]:
    """:func:`_weighted_regression` of each ``(x, u, v)``, the searches for ``τ²`` run side by side.

    Each search is the bisection :func:`_weighted_regression` describes, with
    the same brackets, midpoints and stopping test; only the χ² that decides
    each step is formed for all of them at once (one stacked pseudo-inverse,
    the regressors padded with zero columns, which leave the fit as it is).
    The χ² at ``τ² = 0`` that decides whether to search, and every returned
    fit, are computed one by one as in the single case, so a search can only
    end elsewhere if a step's χ² lies within rounding of the degrees of
    freedom.
    """
    first = [_regression_solve(x, u, v, 0.0) for x, u, v in problems]
    dofs = [max(x.shape[0] - x.shape[1], 1) for x, _, _ in problems]
    tau2 = [0.0] * len(problems)
    todo = [k for k, (f, dof) in enumerate(zip(first, dofs, strict=True)) if f[2] > dof]
    if todo:
        width = max(problems[k][0].shape[1] for k in todo)
        m = problems[todo[0]][0].shape[0]
        x = np.zeros((len(todo), m, width))
        for i, k in enumerate(todo):
            x[i, :, : problems[k][0].shape[1]] = problems[k][0]
        u = np.array([problems[k][1] for k in todo])
        v = np.array([problems[k][2] for k in todo])
        dof = np.array([dofs[k] for k in todo], dtype=float)
        lo = np.zeros(len(todo))
        hi = np.array([float(np.max(first[k][3] * first[k][3])) * 10 + 1e-300 for k in todo])
        active = np.ones(len(todo), bool)
        xt, uc = np.swapaxes(x, 1, 2), u[:, :, None]
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            w = 1.0 / (v + mid[:, None])
            xw = x * w[:, :, None]
            c = np.linalg.pinv(xt @ xw) @ (np.swapaxes(xw, 1, 2) @ uc)  # eq. (S2)
            r = u - (x @ c)[:, :, 0]
            above = np.add.reduce(w * r * r, axis=1) > dof  # eq. (S2): χ² against M − p
            lo = np.where(active & above, mid, lo)
            hi = np.where(active & ~above, mid, hi)
            active &= ~(hi - lo <= 1e-10 * hi)
            if not active.any():
                break
        for i, k in enumerate(todo):
            tau2[k] = float(hi[i])
    out = []
    for (x, u, v), f, t in zip(problems, first, tau2, strict=True):
        c, cov, _, r = f if t == 0.0 else _regression_solve(x, u, v, t)
        var = v + t
        loglik = -0.5 * float(np.sum(np.log(2 * np.pi * var) + r * r / var))  # eq. (S3): ln L
        out.append((c, cov, t, np.array([loglik])))
    return out


def _weighted_regression(x: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, float,
                                                                                 np.ndarray]:
    """One axis: least squares of ``u ≈ x c`` weighted by ``1/(v + τ²)``, ``τ²`` by Paule & Mandel.

    ``τ²`` ≥ 0 is the between-pose variance that makes the weighted residuals'
    χ² equal their degrees of freedom (Paule & Mandel 1982, the random-effects
    estimator of meta-analysis); 0 when the white noise ``v`` already explains
    the scatter. It is found by bisection on ``[0, 10 max r²]`` (χ² decreases
    with ``τ²``) to a relative 1e-10. Returns the coefficients, their
    covariance, ``τ²`` and the log-likelihood of the pose means.
    """
    return _weighted_regressions([(x, u, v)])[0]


def _pose_statistics(recording: Recording, intervals: list[Interval], accelerometer: TriadModel) -> tuple:
    """The poses' mean rates ``u`` (M, 3), calibrated specific forces ``a`` (M, 3), mean times and their mean
    ``t_ref``, and the variance ``σ_k²/n_k`` of each pose's mean rate (M, 3), for :func:`static_gyro`."""
    u = interval_means(recording.gyro, intervals)
    a = accelerometer.forward(interval_means(recording.acc, intervals))
    times = np.array([float(np.mean(recording.t[iv.slice])) for iv in intervals])
    t_ref = float(np.mean(times))
    # each pose's variance over its samples' count less one
    v = np.array([np.var(recording.gyro[iv.slice], axis=0) / max(len(iv) - 1, 1) for iv in intervals])  # eq. (S1): v_k
    v = np.maximum(v, 1e-300)  # a quantised constant reading: no noise at all
    return u, a, times, t_ref, v


def _candidate_fits(u: np.ndarray, a: np.ndarray, times: np.ndarray, t_ref: float, v: np.ndarray,
                    g_sensitivity: bool | str, drift: bool | str) -> dict:
    """The regressions :func:`static_gyro` chooses among: ``(with_g, with_d)`` → (Bayesian information
    criterion, design matrix, each axis's :func:`_weighted_regression`)."""
    m = len(u)
    opts_g = [False, True] if g_sensitivity == "auto" else [bool(g_sensitivity)]
    opts_d = [False, True] if drift == "auto" else [bool(drift)]
    fits = {}
    for with_g in opts_g:
        if with_g and m <= 8:
            continue
        for with_d in opts_d:
            if with_d and m <= 5:
                continue
            cols = [np.ones(m)] + ([times - t_ref] if with_d else []) + ([*a.T] if with_g else [])  # eq. (S1): x_k
            fits[with_g, with_d] = np.column_stack(cols)
    regressions = _weighted_regressions([(x, u[:, j], v[:, j]) for x in fits.values() for j in range(3)])
    for i, (key, x) in enumerate(list(fits.items())):
        per_axis = regressions[3 * i : 3 * i + 3]
        loglik = sum(float(f[3][0]) for f in per_axis)
        n, p = 3 * m, 3 * x.shape[1] + 3
        fits[key] = (-2 * loglik + p * np.log(n), x, per_axis)  # eq. (S3)
    if not fits:  # too few poses for what was asked: the plain mean
        x = np.ones((m, 1))
        fits[False, False] = (0.0, x, [_weighted_regression(x, u[:, j], v[:, j]) for j in range(3)])
    return fits


def static_gyro(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, *,
                g_sensitivity: bool | str = "auto", drift: bool | str = "auto") -> StaticGyro:
    """Bias, drift and g-sensitivity of the gyroscope from its means at the static poses.

    At rest the gyroscope reads ``ū_k = b + G a_k`` (Zhang 2021, eq. 11, with
    the canonical sign), with the bias free to drift linearly in time,
    ``b + d (t_k − t_ref)`` (``t_k`` the pose's mean time, ``t_ref`` the mean of
    them, so ``b`` is the bias the poses show on average): a linear regression
    over the poses with the calibrated specific force ``a_k``, each pose
    weighted by the variance of its mean, ``σ_k²/n_k + τ²`` (``σ_k²`` its
    samples' variance, ``τ²`` the scatter between poses beyond that noise:
    tremor, a random walk; :func:`_weighted_regression`).

    ``g_sensitivity`` and ``drift`` ``"auto"``: each is kept when it lowers
    the Bayesian information criterion ``−2 ln L + p ln n`` of the pose means
    (``n = 3M``; ``p`` counts 3 per coefficient and the 3 ``τ²``); a turn-on
    change or random walk scatters the means without a pattern in ``a`` or
    ``t`` and makes neither appear. ``G`` needs more than 8 poses and the drift
    more than 5. The bias (at ``t_ref``) has the regression's covariance,
    which holds the scatter between poses through ``τ²``; ``spread`` (the
    scatter of one pose's mean about the fit) is reported beside it, not
    added to it.
    """
    u, a, times, t_ref, v = _pose_statistics(recording, intervals, accelerometer)
    fits = _candidate_fits(u, a, times, t_ref, v, g_sensitivity, drift)
    with_g, with_d = min(fits, key=lambda k: fits[k][0])  # eq. (S3): the least BIC
    _, x, per_axis = fits[with_g, with_d]
    coef = np.column_stack([f[0] for f in per_axis])  # (p, 3)
    covs = [f[1] for f in per_axis]
    tau2 = np.array([f[2] for f in per_axis])
    res = u - x @ coef
    dof = max(len(u) - x.shape[1], 1)
    spread = np.sqrt(np.sum(res**2, axis=0) / dof)
    bias = coef[0]
    bias_cov = np.diag([c[0, 0] for c in covs])
    errors: dict[str, float] = {}
    g = d = d_se = g_cov = None
    first_g = 2 if with_d else 1
    if with_d:
        d = coef[1].copy()
        d_se = np.sqrt([c[1, 1] for c in covs])
    if with_g:
        g = coef[first_g:].T  # row: gyroscope axis, column: accelerometer axis
        g_cov = np.array([c[first_g:, first_g:] for c in covs])
        se = np.sqrt(np.array([np.diag(c) for c in g_cov]))
        errors = {f"gyroscope.g_sensitivity.{AXES[i]}{AXES[j]}": float(se[i, j]) for i in range(3) for j in range(3)}
    return StaticGyro(bias, bias_cov, g, errors, spread, d, t_ref, times, u, a, v + tau2[None, :], d_se, g_cov)
