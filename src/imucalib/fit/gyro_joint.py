r"""The joint gyroscope fit: the static poses and the rotations between them in one cost (:func:`joint_problem`),
its solve and its error bars (:func:`joint_errors`), and the accelerometer's step of the joint fit.

The rates are Zhang 2021's linear model, eqs. (5)–(6), with this project's bias sign and the bias drifting
linearly in time (``τ = t − t_ref``); the cost joins, as Zhang 2021's global cost (21) joins its (11) and (14),
each kept rotation's gravity-direction error (14) over the rotations' noise ``σ_rot`` and each static pose's
mean reading (11) over its standard error ``se_k`` (:mod:`imucalib.fit.gyro_static`, (S1)):

.. math::

    \boldsymbol\omega = \mathbf M\, (\mathbf u - \mathbf b - \mathbf d\, \tau - \mathbf G\, \mathbf a)
    \quad \text{(5), (6)}

    \mathbf r^\mathrm{rot}_k = \frac{w_k}{\sigma_\mathrm{rot}}
    \bigl(\mathbf d_k - \mathbf R_k^\top \mathbf d_{k-1}\bigr) \quad (14), \qquad
    r^\mathrm{st}_{k,i} = \frac{\bar u_{k,i} - (\mathbf G \mathbf a_k)_i - b_i - d_i\, (t_k - t_\mathrm{ref})}
    {se_{k,i}} \quad (11)

and the rotations' noise is re-estimated from the kept rotations' errors ``e_k = ‖d_k − R_kᵀ d_{k−1}‖``, two
components each, ``p = 9`` parameters of ``M``:

.. math::

    \sigma_\mathrm{rot}^2 = \frac{\sum_k e_k^2}{2 n_\mathrm{kept} - p} \qquad \text{(J1)}
"""

from __future__ import annotations

import numpy as np

from ..fitreport import GyroscopeReport
from ..models import AXES, TriadModel
from ..recording import Interval, Recording
from ..residuals import (
    AccelLayout,
    GyroLayout,
    gravity_direction_residuals,
    gravity_direction_residuals_jac,
    linear_rate_jacobian,
)
from ..solve import levenberg_marquardt, scaled_inverse
from .gyro_direction import READ_CHUNK, Transitions, direction_acc_jacobian, gravity_direction_problem
from .gyro_static import StaticGyro, static_gyro


def joint_problem(recording: Recording, intervals: list[Interval], accelerometer: TriadModel, static: StaticGyro,
                  weights: np.ndarray, sigma_rot: float, transitions: Transitions | None = None):
    """Residuals and Jacobian of the joint gyroscope cost: the rotations and the static poses together.

    Parameters ``θ = [M (9), b (3), d (3, with a drift)]`` with ``M = T_g diag(k1)``;
    the rates are ``ω = M (u − b − d (t − t_ref) − G a)`` (Zhang 2021, eq. 6,
    with ``G`` of the static poses held). The residuals are

    * each kept rotation's gravity-direction error (Zhang 2021, eq. 14) over
      ``sigma_rot``, the rotations' own noise per component [rad];
    * each pose's mean reading against ``b + d (t_k − t_ref) + G a_k``
      (Zhang 2021, eq. 11) over its standard error ``√static.variances``.

    ``jac(θ, with_g=True)`` appends the 9 columns of ``∂r/∂G`` (``G`` row-major,
    held in the fit): ``G`` enters the poses' targets, ``(ū_k − G a_k − …)/se_k``,
    so ``∂r_{k,i}/∂G_ij = −a_{k,j}/se_{k,i}``, and every rotation sample's rate
    ``ω = M (u − b − d τ − G a)``, so ``∂ω/∂G_ij = −M e_i a_j`` with ``a`` the
    sample's calibrated specific force, through the same gravity-direction
    Jacobian as the other parameters (one integration for both).
    ``transitions``: as for :func:`gravity_direction_problem`.

    Returns ``fun``, ``jac``, the pose directions and the number of parameters.
    """
    tr = Transitions(recording, intervals) if transitions is None else transitions
    acc = static.accel if static.accel is not None else accelerometer.forward(tr.acc_means())
    dirs = acc / np.linalg.norm(acc, axis=1, keepdims=True)  # d_k of eq. (14)
    integrator = tr.integrator
    g_sens = static.g_sensitivity
    raw = tr.readings(accelerometer, g_sens)
    tau = recording.t[integrator.samples] - static.t_ref
    with_d = static.drift is not None
    size = 15 if with_d else 12
    w = np.repeat(np.asarray(weights, dtype=float), 3) / sigma_rot  # eq. (14): w_k / σ_rot
    target = static.means - (0.0 if g_sens is None else static.accel @ np.asarray(g_sens).T)  # eq. (11): ū_k − G a_k
    se = np.sqrt(static.variances)
    dt_pose = static.times - static.t_ref

    space: dict = {}  # the rate Jacobian's block buffer, kept from one Jacobian to the next

    def split(th):
        return th[:9].reshape(3, 3), th[9:12], (th[12:15] if with_d else np.zeros(3))

    def key(th):
        return ("joint", id(raw), static.t_ref, with_d, np.asarray(th, dtype=np.float64).tobytes())

    def readings_at(th):  # u − G a − b − d τ
        _, b, dr = split(th)
        v = raw - b
        for a in range(0, len(v), READ_CHUNK):  # τ d: each sample's τ repeated for the three axes, a chunk at a time
            part = v[a : a + READ_CHUNK]
            part -= np.repeat(tau[a : a + READ_CHUNK], 3).reshape(-1, 3) * dr  # eq. (5): − d τ
        return v

    def fun(th):
        m, b, dr = split(th)
        q = tr.attitudes(key(th), lambda: readings_at(th) @ m.T)  # eq. (5): ω = M (u − G a − b − d τ)
        r_rot = gravity_direction_residuals(None, lambda _: q, dirs) * w  # eq. (14)
        r_st = (target - b - dt_pose[:, None] * dr) / se  # eq. (11)
        return np.concatenate([r_rot, r_st.ravel()])

    def jac(th, with_g: bool = False):
        m, b, dr = split(th)
        v = readings_at(th)
        rate_jac = linear_rate_jacobian(m, v, drift_time=tau if with_d else None, workspace=space)
        g_jac = _g_rate_jacobian(m, tr.specific_force(accelerometer)) if with_g else None
        cols = size + 9 if with_g else size
        rates = v @ m.T
        j_rot = gravity_direction_residuals_jac(rates, rate_jac, integrator, dirs,
                                                tr.steps(key(th), rates, keep=False), g_jac)[1] * w[:, None]
        mm = len(static.means)
        j_st = np.zeros((mm, 3, cols))
        for i in range(3):
            j_st[:, i, 9 + i] = -1.0 / se[:, i]
            if with_d:
                j_st[:, i, 12 + i] = -dt_pose / se[:, i]
            if with_g:
                j_st[:, i, size + 3 * i:size + 3 * i + 3] = -static.accel / se[:, i:i + 1]
        return np.vstack([j_rot, j_st.reshape(3 * mm, cols)])

    return fun, jac, dirs, size


#: samples whose specific force :func:`_g_rate_jacobian` tiles at once
TILE_ROWS = 1 << 12


def _g_rate_jacobian(m: np.ndarray, force: np.ndarray):
    """``∂ω/∂G_ij = −M e_i a_j`` (``G`` row-major) of the samples ``a … b − 1`` as a block function (as
    :func:`~imucalib.residuals.linear_rate_jacobian`), ``a`` the calibrated specific force ``force`` (S, 3)."""
    buf = np.zeros((0, 3, 9))
    minus_m = np.repeat(-m.ravel(), 3)  # at 9r + 3i + j: −M_ri

    def block(a: int, b: int) -> np.ndarray:
        nonlocal buf
        if b - a > buf.shape[0]:
            buf = np.empty((b - a, 3, 9))
        out = buf[: b - a]
        # entry (k, r, 3i + j) = a_kj (−M_ri): every entry written, a sample's 27 in one row-wise pass over the
        # force tiled nine times (TILE_ROWS samples at a time: the tiled copy stays small)
        flat = out.reshape(b - a, 27)
        for c in range(a, b, TILE_ROWS):
            d = min(b, c + TILE_ROWS)
            np.multiply(np.tile(force[c:d], (1, 9)), minus_m, out=flat[c - a : d - a])
        return out

    return block


def solve_joint(recording, intervals, accelerometer, static, weights, start: TriadModel,
                 transitions: Transitions | None = None):
    """The joint fit (:func:`joint_problem`), twice: the rotations' noise re-estimated from the first.

    Returns the model, θ, each transition's error norm [rad], ``sigma_rot`` and the final problem.
    """
    tr = Transitions(recording, intervals) if transitions is None else transitions
    n_kept = int(np.count_nonzero(weights))
    e0 = _transition_norms(recording, intervals, accelerometer, start, static, weights, tr)[1]  # its problem freed
    sigma = _rotation_sigma(e0, weights, 9)
    theta = np.concatenate([GyroLayout(False).pack(start), static.bias,
                            static.drift if static.drift is not None else np.zeros(0)])
    for _ in range(2):
        fun, jac, dirs, size = joint_problem(recording, intervals, accelerometer, static, weights, sigma, tr)
        sol = levenberg_marquardt(fun, jac, theta, xtol=1e-12, ftol=1e-12)
        del fun, jac  # with what they hold, before the next problem is formed
        theta = sol.x
        e = np.linalg.norm(sol.fun[: 3 * (len(intervals) - 1)].reshape(-1, 3), axis=1) * sigma
        del sol  # and the problem its Jacobian would be formed from
        sigma = _rotation_sigma(e, weights, 9) if n_kept else sigma
    model = GyroLayout(True).unpack(theta[:12], theta[9:12])
    if static.g_sensitivity is not None:
        model = model.with_(g_sensitivity=static.g_sensitivity)
    fun, jac, _, _ = joint_problem(recording, intervals, accelerometer, static, weights, sigma, tr)
    return model, theta, e, sigma, (fun, jac)


def _rotation_sigma(e: np.ndarray, weights: np.ndarray, p: int) -> float:
    """Per-component noise [rad] of the kept rotations' direction errors ``e``: two components each, ``p`` fitted."""
    kept = np.asarray(weights) > 0
    dof = max(2 * int(np.count_nonzero(kept)) - p, 1)
    s = float(np.sqrt(np.sum(e[kept] ** 2) / dof))  # eq. (J1)
    return s if s > 0 else 1e-12


def _transition_norms(recording, intervals, accelerometer, model, static, weights, transitions=None):
    """Each transition's direction error norm [rad] of ``model`` with the static bias (weights 0 → 0)."""
    fun, _, layout, _, _ = gravity_direction_problem(recording, intervals, accelerometer, model.bias, False,
                                                     None, static.g_sensitivity, transitions)
    e = np.linalg.norm(fun(layout.pack(model)).reshape(-1, 3), axis=1)
    return fun, e * (np.asarray(weights) > 0)


def joint_errors(recording, intervals, accelerometer, model, theta, jac_fun, res, weights, sigma_rot, static, *,
                 acc_cov=None, acc_joint=None, transitions: Transitions | None = None) -> dict[str, float]:
    """1σ errors of the joint fit (:func:`joint_problem`) from its Jacobian, by name.

    ``C = s² (JᵀJ)⁻¹`` with ``s² = ‖r‖²/dof`` (:func:`~imucalib.solve.standard_errors`;
    ``s² ≈ 1`` since each residual is divided by its own noise; ``dof`` counts
    two per kept rotation and three per pose, less the parameters), carried
    to ``T_g`` and ``k1`` by the delta method. The accelerometer's covariance
    ``acc_cov`` enters through the gravity directions to first order
    (``∂θ̂/∂x = −J⁺ ∂r/∂x``, as in :func:`errors_at`); so does the
    g-sensitivity the joint fit holds at the static poses' estimate
    (``static.g_cov``): its error moves the bias the poses show. The bias is the bias
    at ``static.t_ref`` and its 1σ is the error of that: each pose's mean is
    weighted by its white noise plus the scatter between poses
    (``static.variances``, random effects: :func:`_weighted_regression`), so
    tremor and a wandering bias are in it once. Adding the scatter of one pose
    about the fit again (the bias at an arbitrary moment, not at ``t_ref``)
    would count them twice: on the hand-held scenario that made the bias's 1σ
    eight times its error.

    ``acc_joint = (which, prior_var)``: the accelerometer parameters ``which``
    (indices in ``AccelLayout("upper", 1)`` order) were estimated with the
    gyroscope from the same rotations (:func:`accelerometer_joint_step`), each
    with a zero-mean prior of variance ``prior_var``. They are then columns of
    the Jacobian (``∂r/∂x`` of the rotations, one prior row ``x/σ_p`` each),
    so the gyroscope's errors are the marginals of the joint covariance, and
    their own 1σ is returned too; ``acc_cov`` then carries only the others.
    ``jac_fun`` is the problem's Jacobian (``jac`` of :func:`joint_problem`,
    which forms ``∂r/∂G`` in the same pass); ``transitions`` as for
    :func:`gravity_direction_problem`.
    """
    with_g = static.g_cov is not None and np.all(np.isfinite(static.g_cov))
    j = jac_fun(theta, with_g=True) if with_g else jac_fun(theta)
    j_g = None
    if with_g:
        j, j_g = j[:, :-9], j[:, -9:]
    size = j.shape[1]
    n_rot = 3 * (len(intervals) - 1)
    dof = 2 * int(np.count_nonzero(weights)) + 3 * len(static.means) - size
    lay = AccelLayout("upper", 1)
    which = [] if acc_joint is None else [int(i) for i in acc_joint[0]]
    fixed = [i for i in range(lay.size) if i not in which]
    undetermined = acc_cov is not None and not np.all(np.isfinite(np.diag(acc_cov)[fixed]))
    j_acc = None
    if which or (acc_cov is not None and not undetermined):
        j_acc = np.zeros((j.shape[0], lay.size))
        w = np.repeat(np.asarray(weights, dtype=float), 3) / sigma_rot  # eq. (14): w_k / σ_rot
        j_acc[:n_rot] = direction_acc_jacobian(recording, intervals, accelerometer, model, transitions) * w[:, None]
    n_joint = len(which)
    if n_joint:
        j, res, j_acc = _with_accelerometer_columns(j, res, j_acc, accelerometer, which, acc_joint[1])
    extra = _propagated_covariance(j, j_acc, j_g, fixed, None if undetermined else acc_cov, static, n_joint)
    names, a = _joint_transform(theta, size, [lay.names("accelerometer")[i] for i in which])
    if dof <= 0:
        se = np.full(len(names), np.nan)
    else:
        cov, bad = _joint_covariance(j, res, n_rot, weights, leverage=n_joint > 0)
        if extra is not None:
            cov = cov + extra
        bad = np.abs(a) @ bad.astype(float) > 0
        se = np.sqrt(np.clip(np.diag(a @ cov @ a.T), 0.0, None))
        if n_joint:
            se *= _small_sample_factor(j, n_rot, weights, a, 0.0 if extra is None else np.diag(a @ extra @ a.T))
        se[bad] = np.nan
    if undetermined:  # the poses leave the gravity directions themselves undetermined
        se = np.full_like(se, np.nan)
    return {k: float(v) for k, v in zip(names, se, strict=True)}


def _with_accelerometer_columns(j: np.ndarray, res: np.ndarray, j_acc: np.ndarray, accelerometer: TriadModel,
                                which: list[int], prior_var) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The joint fit's Jacobian, residuals and ``∂r/∂x`` with the accelerometer parameters ``which`` as columns,
    each with its zero-mean prior row ``x/σ_p`` (variance ``prior_var``; :func:`joint_errors`)."""
    lay = AccelLayout("upper", 1)
    n_joint, size = len(which), j.shape[1]
    prior_sd = np.sqrt(np.asarray(prior_var, dtype=float))
    j = np.block([[j, j_acc[:, which]], [np.zeros((n_joint, size)), np.diag(1.0 / prior_sd)]])
    res = np.concatenate([res, lay.pack(accelerometer)[which] / prior_sd])
    j_acc = np.vstack([j_acc, np.zeros((n_joint, lay.size))])
    return j, res, j_acc


def _propagated_covariance(j: np.ndarray, j_acc: np.ndarray | None, j_g: np.ndarray | None, fixed: list[int],
                           acc_cov: np.ndarray | None, static: StaticGyro, n_joint: int) -> np.ndarray | None:
    """The covariance the fixed accelerometer parameters (``acc_cov``, None: not carried) and the static poses'
    g-sensitivity (``j_g`` its columns, None: not held) add to the joint fit's, to first order
    (``∂θ̂/∂x = −J⁺ ∂r/∂x``; :func:`joint_errors`); None when neither does."""
    extra = None
    pinv = None
    if acc_cov is not None and fixed:
        pinv = np.linalg.pinv(j)
        sens = -pinv @ j_acc[:, fixed]
        extra = sens @ np.asarray(acc_cov)[np.ix_(fixed, fixed)] @ sens.T
    if j_g is not None:
        sens = -(np.linalg.pinv(j) if pinv is None else pinv) @ np.vstack([j_g, np.zeros((n_joint, 9))])
        c_g = np.zeros((9, 9))
        for i in range(3):  # the rows of G come from independent regressions, one per gyroscope axis
            c_g[3 * i:3 * i + 3, 3 * i:3 * i + 3] = static.g_cov[i]
        extra = (0.0 if extra is None else extra) + sens @ c_g @ sens.T
    return extra


def _joint_transform(theta: np.ndarray, size: int, acc_names: list[str]) -> tuple[list[str], np.ndarray]:
    """The names of the joint fit's reported parameters and the delta method's matrix from ``M = T_g diag(k1)``,
    ``b`` (and the accelerometer parameters named ``acc_names``) to ``T_g``, ``k1``, ``b`` (and those)."""
    n_joint = len(acc_names)
    m = theta[:9].reshape(3, 3)
    off = [(i, k) for i in range(3) for k in range(3) if i != k]
    names = [f"gyroscope.misalignment.{AXES[i]}{AXES[k]}" for i, k in off]
    names += [f"gyroscope.scale.{ax}" for ax in AXES] + [f"gyroscope.bias.{ax}" for ax in AXES]
    names += acc_names
    a = np.zeros((12 + n_joint, size + n_joint))
    for row, (i, k) in enumerate(off):  # T_ik = M_ik / M_kk
        a[row, 3 * i + k] = 1.0 / m[k, k]
        a[row, 4 * k] = -m[i, k] / m[k, k] ** 2
    for k in range(3):  # k1_k = M_kk
        a[6 + k, 4 * k] = 1.0
    a[9:12, 9:12] = np.eye(3)
    a[12:, size:] = np.eye(n_joint)
    return names, a


def _g_sensitivity_jacobian(recording, intervals, accelerometer, static: StaticGyro, weights, sigma_rot,
                            theta) -> np.ndarray:
    """∂r/∂G of the joint residuals (:func:`joint_problem`) at ``theta``, ``G`` row-major, analytic (the last
    columns of its ``jac(θ, with_g=True)``)."""
    _, jac, _, _ = joint_problem(recording, intervals, accelerometer, static, weights, sigma_rot)
    return jac(theta, with_g=True)[:, -9:]


def _inverse_sqrt(a: np.ndarray) -> np.ndarray:
    """``a^(−1/2)`` of a symmetric positive semi-definite matrix; directions with no variance are left as they are."""
    w, v = np.linalg.eigh(a)
    return (v / np.sqrt(np.where(w > 1e-8, w, 1.0))) @ v.T


def _small_sample_factor(j: np.ndarray, n_rot: int, weights: np.ndarray, a: np.ndarray, known,
                         *, rcond: float = 1e-10) -> np.ndarray:
    """Per parameter ``√(ν/(ν − 2))``: the 1σ of a variance estimated from ``ν`` effective degrees of freedom.

    A variance ``V̂`` estimated from few residuals is unbiased, yet the error
    over ``√V̂`` follows Student's t with ``ν`` degrees of freedom, whose
    variance is ``ν/(ν − 2)``, not 1: a 1σ that says how far the estimate
    is from the truth on average is ``√V̂`` times that. For the rotations'
    cluster sandwich with the bias-reduced residuals of
    :func:`_joint_covariance` (``leverage``), ``ν`` is Satterthwaite's for the
    contrast ``c`` (a row of ``a``), as Bell & McCaffrey (2002, §4) give it:
    with every residual of unit variance, ``V̂ = εᵀ Q ε`` with
    ``Q = (I − H) W Wᵀ (I − H)``, ``W``'s columns the rotations' weights
    ``(I − H_kk)^(−1/2) J_k (JᵀJ)⁻¹ c`` on their rows, and
    ``ν = 2 E[V]² / Var[V] = (v₀ + tr Q)² / tr Q²``, where ``v₀`` is the
    part known without residuals (the static poses', the prior's and
    ``known``, the variance the accelerometer's and g-sensitivity's
    covariances add). ``ν`` is held at 3 at least (a factor of √3 at most).
    """
    col, js, inv, _ = scaled_inverse(j, rcond)
    proj = np.eye(js.shape[0]) - js @ inv @ js.T
    kept = np.nonzero(np.asarray(weights) > 0)[0]
    cs = (a / col).T  # contrasts in the scaled parameters, one per column
    u = js @ inv @ cs  # (rows, contrasts)
    j_st = js[n_rot:]
    v0 = np.einsum("pc,pq,qc->c", cs, inv @ j_st.T @ j_st @ inv, cs) + np.asarray(known, dtype=float)
    wmat = np.zeros((js.shape[0], len(kept), cs.shape[1]))
    for col_k, k in enumerate(kept):
        rows = slice(3 * k, 3 * k + 3)
        hk = proj[rows, rows]
        wmat[rows, col_k, :] = _inverse_sqrt(0.5 * (hk + hk.T)) @ u[rows]
    out = np.ones(cs.shape[1])
    for c in range(cs.shape[1]):
        mw = proj @ wmat[:, :, c]
        tr_q = float(np.sum(mw**2))
        tr_q2 = float(np.sum((mw.T @ mw) ** 2))
        if tr_q2 > 0:
            nu = max((v0[c] + tr_q) ** 2 / tr_q2, 3.0)
            out[c] = np.sqrt(nu / (nu - 2.0))
    return out


def _joint_covariance(j: np.ndarray, res: np.ndarray, n_rot: int, weights: np.ndarray, *,
                      rcond: float = 1e-10, leverage: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Covariance of the joint fit's parameters, each rotation's share from its own residual; which are undetermined.

    The sandwich ``(JᵀJ)⁻¹ B (JᵀJ)⁻¹``. The static poses' rows are divided by
    their standard errors (between-pose scatter included), so their part of
    ``B`` is ``J_sᵀ J_s``. A rotation's gravity-direction error is not the
    common white noise ``sigma_rot``: the longer, faster turns carry more of
    the integration's and the hand's errors, and those are the turns that
    pull the bias and the scales most. Its part of ``B`` is
    ``J_kᵀ r_k r_kᵀ J_k`` from its own three residuals, one cluster per
    rotation (the cluster-robust sandwich of Liang & Zeger 1986,
    *Biometrika* 73, 13–22, §2; White 1980 for one residual per cluster),
    times ``n/(n − 9/2)`` for the nine parameters of ``M`` that the ``n``
    rotations' two components each fit. Columns scaled to unit norm and
    unobservable directions dropped as in :func:`imucalib.solve.covariance`.

    ``leverage``: each rotation's residuals are first scaled up for its own
    pull on the fit, ``r̃_k = (I − H_kk)^(−1/2) r_k`` with ``H_kk = J_k (JᵀJ)⁻¹ J_kᵀ``
    its block of the hat matrix (the bias-reduced linearisation of Bell &
    McCaffrey 2002, *Survey Methodology* 28, 169–181, "CR2": unbiased for a
    common variance; the jackknife's ``(I − H_kk)⁻¹`` overstates), instead of the
    ``n/(n − 9/2)`` factor: for a fit whose rotations determine more than
    ``M`` (the accelerometer's misalignment with it, :func:`joint_errors`)
    on a dozen rotations, each rotation's leverage is near one half and the
    plain sandwich would shrink the errors by as much.
    """
    col, js, inv, bad = scaled_inverse(j, rcond)
    j_st = js[n_rot:]
    meat = j_st.T @ j_st
    kept = np.nonzero(np.asarray(weights) > 0)[0]
    if kept.size:
        jk = js[:n_rot].reshape(-1, 3, js.shape[1])[kept]
        rk = res[:n_rot].reshape(-1, 3)[kept]
        if leverage:
            h = np.einsum("kij,jl,kml->kim", jk, inv, jk)
            rk = np.stack([_inverse_sqrt(np.eye(3) - 0.5 * (hk + hk.T)) @ r for hk, r in zip(h, rk, strict=True)])
        g = np.einsum("kij,ki->kj", jk, rk)
        n = kept.size
        meat = meat + (g.T @ g) * (1.0 if leverage else n / max(n - 4.5, 0.5))
    cov = inv @ meat @ inv
    return cov / np.outer(col, col), bad


def _joint_at(recording, intervals, accelerometer, gyroscope, fitted: GyroscopeReport):
    """The joint problem of a fit again, from its report: static poses, weights, σ, θ, residuals, Jacobian."""
    drift = fitted.bias_drift_per_s
    static = static_gyro(recording, intervals, accelerometer, g_sensitivity=bool(np.any(gyroscope.g_sensitivity)),
                         drift=drift is not None)
    weights = np.ones(len(intervals) - 1)
    weights[list(fitted.rotations_left_out or {})] = 0.0
    sigma = float(fitted.rotation_sigma_rad)
    theta = np.concatenate([GyroLayout(True).pack(gyroscope), np.asarray(drift if drift is not None else [])])
    fun, jac, _, _ = joint_problem(recording, intervals, accelerometer, static, weights, sigma)
    return static, weights, sigma, theta, fun, jac


def joint_errors_at(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                    gyroscope: TriadModel, fitted: GyroscopeReport, *, acc_cov: np.ndarray | None = None,
                    acc_joint: tuple | None = None) -> dict[str, float]:
    """The 1σ errors :func:`fit_gyroscope` gave a joint fit, again from its report (:meth:`GyroFit.report`,
    a calibration's ``fit.gyroscope``).

    The static poses' regression is repeated with the choices the fit made
    (g-sensitivity, drift), the rotations left out and their noise
    (``rotation_sigma_rad``) are the fit's. ``acc_joint``: as in
    :func:`joint_errors`.
    """
    static, weights, sigma, theta, fun, jac = _joint_at(recording, intervals, accelerometer, gyroscope, fitted)
    return joint_errors(recording, intervals, accelerometer, gyroscope, theta, jac, fun(theta), weights, sigma,
                        static, acc_cov=acc_cov, acc_joint=acc_joint) | static.errors


def accelerometer_joint_step(recording: Recording, intervals: list[Interval], accelerometer: TriadModel,
                             gyroscope: TriadModel, fitted: GyroscopeReport, which, prior_var) -> np.ndarray:
    """A Gauss–Newton step for accelerometer parameters the rotations determine along with the gyroscope.

    The rotations carry gravity from one pose to the next (Zhang 2021, eq. 14):
    the directions at both ends come from the accelerometer, so its
    parameters enter the residuals ``r`` of the joint problem
    (:func:`joint_problem`) as the gyroscope's do. A rigid rotation cannot
    carry one sheared set of directions into another, and the gyroscope's
    ``M = T_g diag(k1)`` (any linear map of the rates) does not make up for
    it: rotations about axes between the sensor's axes measure the
    accelerometer's misalignment, which gravity's norm at poses near the
    axes does not (its first-order change there, ``2 a_i a_j T_ij``, is
    nil). With the gyroscope's ``θ`` at its optimum for the present
    accelerometer, the step ``δ`` for the parameters ``which`` (indices in
    ``AccelLayout("upper", 1)`` order) solves ``[J_θ J_x; 0 P] [δθ; δ] ≈
    −[r; x/σ_p]`` in least squares, ``P = diag(1/σ_p)`` a zero-mean prior of
    variance ``prior_var`` per parameter (what a datasheet bounds; it
    decides only where the rotations do not). Returns ``δ``.
    """
    static, weights, sigma, theta, fun, jac = _joint_at(recording, intervals, accelerometer, gyroscope, fitted)
    which = [int(i) for i in which]
    j, r = jac(theta), fun(theta)
    n_rot = 3 * (len(intervals) - 1)
    w = np.repeat(weights, 3) / sigma
    j_x = np.zeros((j.shape[0], len(which)))
    j_x[:n_rot] = direction_acc_jacobian(recording, intervals, accelerometer, gyroscope)[:, which] * w[:, None]
    prior_sd = np.sqrt(np.asarray(prior_var, dtype=float))
    x = AccelLayout("upper", 1).pack(accelerometer)[which]
    big = np.block([[j, j_x], [np.zeros((len(which), j.shape[1])), np.diag(1.0 / prior_sd)]])
    col = np.linalg.norm(big, axis=0)
    col = np.where(col > 0, col, 1.0)
    step = -np.linalg.lstsq(big / col, np.concatenate([r, x / prior_sd]), rcond=None)[0] / col
    return step[j.shape[1]:]
