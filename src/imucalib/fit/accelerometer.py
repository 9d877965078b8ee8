"""Accelerometer estimators: building blocks the methods compose.

Every block works on the raw means of static poses (``(M, 3)``, any raw unit)
and returns the canonical model ``a = T_a f(u − b)`` (``docs/architecture.rst``):

* :func:`fit_sphere`, :func:`fit_ellipsoid` — algebraic, no initial guess
  (Ru 2022, §3.2, the ellipsoid/norm methods);
* :func:`fit_gravity_norm` — ``‖a_k‖ = g`` by Levenberg–Marquardt (Tedaldi 2014;
  Zhang 2021, eq. 10), linear or polynomial, with :func:`accelerometer_errors`;
* :func:`fit_determined` — the same residuals for the richest linear model the
  poses determine (few poses: scale and bias per axis, or a sphere);
* :func:`six_position` — each axis up and down (Ru 2022, eqs. 8–9);
* :func:`faces_full` — the six faces with full misalignment (Ferraris 1995);
* :func:`qureshi_cost`, :func:`newton_backtracking` — Qureshi 2017, eqs. 11–12.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fitreport import AccelerometerReport, FitReport, UncertaintyReport
from ..models import TriadModel
from ..residuals import AccelLayout, GravityNorm, gravity_norm_residuals
from ..solve import cholesky, errors_from_covariance, levenberg_marquardt, lstsq, scaled_inverse, solve

__all__ = ["REDUCED_MODELS", "GravityNormFit", "accelerometer_covariance", "accelerometer_errors",
           "accelerometer_figures", "determined_figures", "faces_full", "fit_determined", "fit_ellipsoid",
           "fit_gravity_norm", "fit_sphere", "full_from_sensitivity", "gravity_norm_fit", "newton_backtracking",
           "mean_variance", "pose_covariance", "qureshi_cost", "reduced_expansion", "six_position"]


def fit_sphere(raw: np.ndarray, gravity: float) -> TriadModel:
    r"""Centre and one common scale from a sphere fit (≥ 4 well-spread poses).

    The norm equation of the static accelerometer (Ru 2022, eq. 10,
    ``‖a‖² = g²``) with ``a = k (u − b)``, one scale ``k`` for the three axes:

    .. math::

        \lVert \mathbf u_k - \mathbf b \rVert^2 = \rho^2
        \iff 2\, \mathbf u_k^\top \mathbf b + (\rho^2 - \lVert \mathbf b \rVert^2) = \lVert \mathbf u_k \rVert^2,
        \qquad k = g / \rho

    ``‖u − b‖² = ρ²`` is linear in ``(b, ρ² − ‖b‖²)``; the scale is ``g / ρ``.
    """
    raw = np.asarray(raw, dtype=np.float64)
    if raw.shape[0] < 4:
        raise ValueError(f"a sphere fit needs at least 4 static poses; got {raw.shape[0]}")
    mu = raw.mean(axis=0)
    s = np.abs(raw - mu).max() or 1.0
    z = (raw - mu) / s
    design = np.column_stack([2 * z, np.ones(len(z))])  # Ru 2022, eq. (10) as a sphere, linear in (b, ρ² − ‖b‖²)
    sol = lstsq(design, np.sum(z * z, axis=1))
    c = sol[:3]
    rho2 = sol[3] + c @ c
    if not rho2 > 0:
        raise ValueError("the static poses do not determine a sphere (too few directions)")
    k = gravity / (np.sqrt(rho2) * s)  # k = g / ρ
    return TriadModel(scale=np.full(3, k), bias=mu + s * c, shape="upper")


def fit_ellipsoid(raw: np.ndarray, gravity: float) -> TriadModel:
    """Linear accelerometer model from static means by an algebraic ellipsoid fit.

    Parameters
    ----------
    raw : (M, 3) array_like
        Raw accelerometer means of M ≥ 9 static poses, spread over directions.
    gravity : float
        ``g`` [m/s²].

    Returns
    -------
    TriadModel
        ``T`` unit upper-triangular, ``k1`` (SI per raw unit), ``b`` (raw units).

    Raises
    ------
    ValueError
        Too few poses, or poses that do not determine an ellipsoid (e.g. all
        about one axis): the quadric is then not positive definite.
    """
    t, k, bias = _ellipsoid(raw, gravity)
    return TriadModel(misalignment=t, scale=k, bias=bias, shape="upper")


def _ellipsoid(raw: np.ndarray, gravity: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""``T`` (3, 3), ``k1`` and ``b`` of :func:`fit_ellipsoid` (which see), not yet checked as a model.

    The norm equation of the static accelerometer (Ru 2022, eq. 10, ``‖a‖² =
    g²``) with the linear model ``a = T K (u − b)`` is a quadric in the raw
    readings (``K = diag(k1)``); fitted algebraically as a general quadric in
    the centred, scaled readings ``z``, then factored (the ellipsoid methods
    of Ru 2022, §3.2.2 (2)):

    .. math::

        (\mathbf u - \mathbf b)^\top \mathbf Q\, (\mathbf u - \mathbf b) = g^2, \qquad
        \mathbf Q = (\mathbf T \mathbf K)^\top (\mathbf T \mathbf K) \qquad \text{(E1)}

        \mathbf z^\top \mathbf A\, \mathbf z + 2\, \mathbf v^\top \mathbf z = 1, \qquad
        \mathbf c = -\mathbf A^{-1} \mathbf v, \qquad
        \mathbf Q = \frac{g^2}{(1 + \mathbf c^\top \mathbf A\, \mathbf c)\, s^2}\, \mathbf A \qquad \text{(E2)}

    with ``b = μ + s c`` (``μ`` the readings' mean, ``s`` their largest
    deviation from it), and ``T K`` the upper-triangular Cholesky factor of ``Q``.
    """
    raw = np.asarray(raw, dtype=np.float64)
    if raw.ndim != 2 or raw.shape[1] != 3:
        raise ValueError(f"raw must have shape (M, 3); got {raw.shape}")
    if raw.shape[0] < 9:
        raise ValueError(
            f"an ellipsoid fit needs at least 9 static poses in different directions; "
            f"got {raw.shape[0]}"
        )
    mu = np.add.reduce(raw, axis=0) / raw.shape[0]  # raw.mean(axis=0), as numpy forms it
    d = raw - mu
    s = np.maximum.reduce(np.abs(d), axis=None) or 1.0  # np.abs(d).max()
    z = d / s  # conditioning: centred, unit range
    x, y, w = z[:, 0], z[:, 1], z[:, 2]
    # the design (x², y², w², 2xy, 2xw, 2yw, 2x, 2y, 2w), a column to a row
    design = np.empty((9, len(z)))
    x2, y2 = np.multiply(2, x, out=design[6]), np.multiply(2, y, out=design[7])
    np.multiply(2, w, out=design[8])
    np.multiply(x, x, out=design[0])
    np.multiply(y, y, out=design[1])
    np.multiply(w, w, out=design[2])
    np.multiply(x2, y, out=design[3])
    np.multiply(x2, w, out=design[4])
    np.multiply(y2, w, out=design[5])
    p = lstsq(design.T, np.ones(len(z)))  # eq. (E2): zᵀ A z + 2 vᵀ z = 1
    a = np.array([[p[0], p[3], p[4]], [p[3], p[1], p[5]], [p[4], p[5], p[2]]])
    v = p[6:9]
    try:
        c = -solve(a, v)  # eq. (E2): the centre
    except np.linalg.LinAlgError:
        raise ValueError("the static poses do not determine an ellipsoid (singular quadric)") from None
    kappa = 1.0 + c @ a @ c
    q = a * (gravity**2 / kappa) / s**2  # eq. (E2): (u − b)ᵀ Q (u − b) = g² in raw units
    try:
        lower = cholesky(q)
    except np.linalg.LinAlgError:
        raise ValueError(
            "the static poses do not determine an ellipsoid (the fitted quadric is not "
            "positive definite): record poses spread over all directions"
        ) from None
    tk = lower.T  # eq. (E1): upper triangular, (T K)ᵀ (T K) = Q
    k = tk.diagonal().copy()
    t = _EYE3.copy()  # the strict upper triangle of T K / k (each + 0.0, as np.triu(·, 1) + I forms it), unit diagonal
    t[_UPPER] += (tk / k[None, :])[_UPPER]
    bias = mu + s * c  # eq. (E2): b = μ + s c
    if not (_ALL(np.isfinite(t), axis=None) and _ALL(np.isfinite(k)) and _ALL(np.isfinite(bias))):
        raise ValueError("the static poses do not determine an ellipsoid (not finite)")
    return t, k, bias


#: the strict upper triangle of a 3 × 3 matrix
_UPPER = (np.array([0, 0, 1]), np.array([1, 2, 2]))
_EYE3 = np.eye(3)
_EYE3.flags.writeable = False
_ALL = np.logical_and.reduce


@dataclass(frozen=True)
class GravityNormFit:
    """The outcome of :func:`gravity_norm_fit`: the model, its residuals and how the solver ended."""

    model: TriadModel
    residuals: np.ndarray  # ‖a_k‖ − g [m/s²]
    jacobian: np.ndarray  # (M, P) at the solution, in ``AccelLayout("upper", order)`` order
    converged: bool
    iterations: int

    def errors(self, order: int) -> dict[str, float]:
        """1σ errors of the parameters by name, each pose's scatter from its own residual (:func:`pose_covariance`)."""
        names = AccelLayout("upper", order).names("accelerometer")
        se = errors_from_covariance(*pose_covariance(self.jacobian, self.residuals))
        return {k: float(v) for k, v in zip(names, se, strict=True)}


def gravity_norm_fit(raw_means: np.ndarray, gravity: float, *, order: int = 1, initial: TriadModel | None = None,
                     max_iter: int = 200) -> GravityNormFit:
    r"""Fit ``a = T_a f(u − b)`` to ``‖a_k‖ = g`` on static means (Tedaldi 2014; Zhang 2021, eq. 10).

    .. math::

        \hat{\boldsymbol\theta} = \arg\min_{\boldsymbol\theta} \sum_{k=1}^{M}
        \bigl(\lVert \mathbf T_a\, \mathbf f(\mathbf u_k - \mathbf b) \rVert - g\bigr)^2

    Levenberg–Marquardt with the analytic Jacobian from ``initial`` (default:
    the algebraic ellipsoid fit, or the sphere fit where the poses do not
    determine an ellipsoid); ``order`` 2 or 3 adds the polynomial scale
    factors of Zhang 2021, eq. (2), started at zero.
    """
    model, sol = _gravity_norm_solve(raw_means, gravity, order, initial, max_iter)
    return GravityNormFit(model, sol.fun, sol.jac, sol.success, sol.njev)


def _gravity_norm_solve(raw_means: np.ndarray, gravity: float, order: int, initial: TriadModel | None,
                        max_iter: int = 200):
    """The model of :func:`gravity_norm_fit` and the solver's result (its Jacobian formed only when read)."""
    layout = AccelLayout("upper", order)
    if initial is None:
        try:  # the ellipsoid's parameters, packed as ``layout.pack(fit_ellipsoid(...))`` would
            t, k, bias = _ellipsoid(raw_means, gravity)
            theta0 = np.concatenate([t[layout.index], k, *([np.zeros(3)] * (order - 1)), bias])
        except ValueError:
            initial = fit_sphere(raw_means, gravity)
    if initial is not None:
        theta0 = layout.pack(initial)
    if raw_means.shape[0] < layout.size:
        raise ValueError(
            f"the accelerometer model has {layout.size} parameters but only "
            f"{raw_means.shape[0]} static poses were found: record more poses"
        )
    problem = GravityNorm(layout, raw_means, gravity)
    sol = levenberg_marquardt(problem.residuals, problem.jacobian, theta0, xtol=1e-14, ftol=1e-14,
                              max_iter=max_iter)
    return layout.unpack(sol.x, initial), sol


def fit_gravity_norm(
    raw_means: np.ndarray, gravity: float, *, order: int = 1, initial: TriadModel | None = None
) -> tuple[TriadModel, np.ndarray]:
    """Fit ``a = T_a f(u − b)`` to ``‖a‖ = g`` on static means (Tedaldi 2014).

    Returns the model and the final residuals ``‖a_k‖ − g`` [m/s²] (:func:`gravity_norm_fit`).
    """
    model, sol = _gravity_norm_solve(raw_means, gravity, order, initial)
    return model, sol.fun


#: the linear accelerometer models from the richest down: (name, misalignment shape or None for one common scale,
#: parameters, what it leaves out)
REDUCED_MODELS = (
    ("linear", "upper", 9, ""),
    ("scale and bias per axis", "diagonal", 6, "the misalignment (taken as none)"),
    ("sphere", None, 4, "the misalignment and the differences between the axes' scale factors (one common scale)"),
)
#: a model is determined when its column-normalised Jacobian's smallest singular value is at least this × the largest
DETERMINED = 1e-6


def fit_determined(raw_means: np.ndarray, gravity: float, *, weights: np.ndarray | None = None,
                   richest: str | None = None) -> tuple[TriadModel, np.ndarray, tuple[str, int, str]]:
    """The richest linear model of :data:`REDUCED_MODELS` the poses determine, fitted to ``‖a_k‖ = g``.

    ``richest`` names the richest model tried (default the first, the full linear model).

    The gravity-norm residuals ``r_k = ‖T_a K (u_k − b)‖ − g`` (Tedaldi 2014;
    Zhang 2021, eq. 10), each multiplied by ``weights[k]`` (``1/σ_k``, the
    pose's scatter; all 1 by default), are minimised by Levenberg–Marquardt for
    the full linear model (9 parameters, upper-triangular ``T_a``), else for a
    scale and a bias per axis (6, ``T_a = I``), else for a sphere (4: one
    scale and the bias, :func:`fit_sphere` refined). A model is taken when
    there are at least as many poses as parameters and the Jacobian at the
    solution, its columns normalised, has a smallest singular value of at least
    :data:`DETERMINED` × its largest (the poses' directions determine every
    parameter).

    Returns
    -------
    model : TriadModel
    residuals : (M,) ndarray
        ``‖a_k‖ − g`` [m/s²], unweighted.
    which : (name, parameters, left out)
        The row of :data:`REDUCED_MODELS` used.

    Raises
    ------
    ValueError
        When not even the sphere is determined (fewer than 4 poses, or poses in too few directions).
    """
    raw_means = np.asarray(raw_means, dtype=np.float64)
    m = raw_means.shape[0]
    w = np.ones(m) if weights is None else np.asarray(weights, dtype=np.float64)
    try:
        start = fit_sphere(raw_means, gravity)
    except ValueError:
        start = None
    layout = AccelLayout("upper", 1)  # θ = (T_xy, T_xz, T_yz, k, b); a reduced model is θ = E·φ
    problem = GravityNorm(layout, raw_means, gravity)
    first = 0 if richest is None else [row[0] for row in REDUCED_MODELS].index(richest)
    for row in REDUCED_MODELS[first:]:
        name, shape, p, _ = row
        if m < p or start is None:
            continue
        expand = _expand(shape)

        def fun(phi, expand=expand):
            return w * problem.residuals(expand @ phi)

        def jac(phi, expand=expand):
            return w[:, None] * problem.jacobian(expand @ phi) @ expand

        phi0 = lstsq(expand, layout.pack(start))  # the sphere's: T = I, one scale
        sol = levenberg_marquardt(fun, jac, phi0, xtol=1e-14, ftol=1e-14)
        j = sol.jac  # jac(sol.x), formed in the iterations or now
        norms = np.linalg.norm(j, axis=0)
        if np.any(norms == 0) or not np.all(np.isfinite(j)):
            continue
        sv = np.linalg.svd(j / norms, compute_uv=False)
        if sv[-1] < DETERMINED * sv[0]:
            continue
        model = layout.unpack(expand @ sol.x, start)
        return model, np.linalg.norm(model.forward(raw_means), axis=1) - gravity, (name, p, row[3])
    raise ValueError(f"no accelerometer model is determined by these {m} static poses: at least 4 poses in "
                     "directions spread over the sphere are needed (six faces determine a scale and a bias per axis, "
                     "nine spread poses the misalignment too)")


def reduced_expansion(name: str) -> np.ndarray:
    """E (9, P) of the model named ``name`` in :data:`REDUCED_MODELS`: its parameters ``φ`` as ``θ = E φ`` in
    ``AccelLayout("upper", 1)`` order (what :func:`fit_determined` fits)."""
    return _expand(next(row[1] for row in REDUCED_MODELS if row[0] == name))


def _expand(shape: str | None) -> np.ndarray:
    """E (9, P): the parameters ``θ = (T_xy, T_xz, T_yz, k, b)`` of the upper layout from a reduced model's ``φ``."""
    if shape == "upper":
        return np.eye(9)
    if shape == "diagonal":  # no misalignment: φ = (k, b)
        expand = np.zeros((9, 6))
        expand[3:, :] = np.eye(6)
        return expand
    expand = np.zeros((9, 4))  # one common scale: φ = (k, b)
    expand[3:6, 0] = 1.0
    expand[6:, 1:] = np.eye(3)
    return expand


def accelerometer_figures(acc: TriadModel, means: np.ndarray, gravity: float,
                          which: tuple[str, int, str] | None) -> FitReport:
    """The accelerometer's part of the fit report: its 1σ errors (:func:`accelerometer_errors`), or for a model
    from :func:`fit_determined` (``which`` not None) :func:`determined_figures`."""
    if which is None:
        return FitReport.of(UncertaintyReport(sigma=accelerometer_errors(acc, means, gravity)))
    return determined_figures(acc, means, gravity, which)


def determined_figures(acc: TriadModel, means: np.ndarray, gravity: float, which: tuple[str, int, str], *,
                       weights: np.ndarray | None = None) -> FitReport:
    """The fit report's part of a model from :func:`fit_determined`: which model, what it leaves out, its 1σ errors.

    ``accelerometer.model`` names the model; for a reduced one ``accelerometer.model_reduced`` says what the
    poses do not determine. ``uncertainty.sigma`` holds the 1σ errors of the parameters fitted (the delta method
    through ``E`` of :func:`pose_covariance`, each pose's own scatter), or, when the poses determine them exactly,
    ``uncertainty.unavailable`` says so.
    """
    name, p, left = which
    m = means.shape[0]
    row = next(r for r in REDUCED_MODELS if r[0] == name)
    figures = AccelerometerReport(model=name)
    if name != "linear":
        figures = figures.with_(model_reduced=f"{m} static poses determine {p} accelerometer parameters: the model "
                                              f"is reduced to {name}, leaving out {left}")
    if m <= p:
        return FitReport.of(figures, UncertaintyReport(
            unavailable=f"accelerometer: the {m} poses determine its {p} parameters exactly, which leaves no "
                        "residual to estimate the noise from", sigma={}))
    lay = AccelLayout("upper", 1)
    expand = _expand(row[1])
    w = np.ones(m) if weights is None else np.asarray(weights, dtype=np.float64)
    r, j = gravity_norm_residuals(lay.pack(acc), lay, means, gravity, jacobian=True)
    se = errors_from_covariance(*pose_covariance(w[:, None] * j @ expand, w * r), transform=expand)
    fitted = np.any(expand != 0, axis=1)
    sigma = {k: float(v) for k, v, f in zip(lay.names("accelerometer"), se, fitted, strict=True) if f}
    return FitReport.of(figures, UncertaintyReport(sigma=sigma))


def accelerometer_covariance(acc: TriadModel, means: np.ndarray, gravity: float, *,
                             which: tuple[str, int, str] | None = None) -> np.ndarray:
    """Covariance of a linear upper-triangular accelerometer model's parameters (``AccelLayout("upper", 1)`` order).

    Infinite on the diagonal of a parameter the poses do not determine. For a reduced model of
    :func:`fit_determined` (``which``), ``E C_φ Eᵀ``: the parameters it holds fixed have none.
    """
    lay = AccelLayout("upper", 1)
    r, j = gravity_norm_residuals(lay.pack(acc), lay, means, gravity, jacobian=True)
    if which is None:
        cov, bad = pose_covariance(j, r)
        cov[bad, bad] = np.inf
        return cov
    expand = _expand(next(row[1] for row in REDUCED_MODELS if row[0] == which[0]))
    cov, bad = pose_covariance(j @ expand, r)
    cov[bad, :] = 0.0
    cov[:, bad] = 0.0
    out = expand @ cov @ expand.T
    undetermined = np.any(expand[:, bad] != 0, axis=1)
    out[undetermined, undetermined] = np.inf
    return out


def accelerometer_errors(acc: TriadModel, means: np.ndarray, gravity: float) -> dict[str, float]:
    """1σ errors of a linear upper-triangular accelerometer model from the gravity-norm fit at ``acc``.

    The square roots of the diagonal of :func:`pose_covariance` (each pose's own scatter), NaN where the poses
    do not determine a parameter.
    """
    lay = AccelLayout("upper", 1)
    r, j = gravity_norm_residuals(lay.pack(acc), lay, means, gravity, jacobian=True)
    se = errors_from_covariance(*pose_covariance(j, r))
    return {k: float(v) for k, v in zip(lay.names("accelerometer"), se, strict=True)}


#: the sandwich of :func:`pose_covariance` needs at least this many poses per parameter (mean leverage ≤ 1/2)
SANDWICH_POSES_PER_PARAMETER = 2
#: a pose whose leverage is within this of 1 determines a direction alone: its residual says nothing of its noise
LEVERAGE_ONE = 1e-6


def pose_covariance(jac: np.ndarray, residuals: np.ndarray, *, rcond: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    """Covariance of a least-squares fit over static poses whose scatter differs from pose to pose, and which
    parameters the poses do not determine.

    The gravity-norm residual of a pose holds more than its samples' white
    noise: tremor, a hand creeping into the pose, a transition's tail; and
    how much more differs from pose to pose. ``σ² (JᵀJ)⁻¹`` with one common
    ``σ²`` then misstates the errors (too small where the poses that scatter
    most have the most leverage). The heteroskedasticity-consistent "sandwich"
    ``(JᵀJ)⁻¹ Jᵀ diag(ω_k) J (JᵀJ)⁻¹`` takes each pose's variance from its own
    residual; ``ω_k = r_k² / (1 − h_k)²`` with the leverage
    ``h_k = [J (JᵀJ)⁻¹ Jᵀ]_kk`` is the HC3 estimator (MacKinnon & White 1985,
    *J. Econometrics* 29, 305–325; recommended for small samples by
    Long & Ervin 2000, *Am. Stat.* 54, 217–224), the jackknife's
    variance to first order: a residual shrunk by a pose's own pull on the
    fit is inflated back. A pose with leverage 1 (it alone determines a
    direction, ``r_k = 0``) takes the common ``σ² = ‖r‖²/(M − P)`` instead.
    With fewer than :data:`SANDWICH_POSES_PER_PARAMETER` poses per parameter
    the mean leverage ``P/M`` exceeds 1/2 and the ``(1 − h_k)⁻²`` factors make
    the sandwich noisier than what it corrects: the covariance is then
    ``σ² (JᵀJ)⁻¹`` with that common ``σ²`` (the residuals' reduced χ²).
    The columns are scaled to unit norm and unobservable directions dropped
    as in :func:`imucalib.solve.covariance`; zero when ``M ≤ P`` (no residual
    to take a scatter from: the callers say the errors are unavailable).
    """
    m, p = jac.shape
    col, js, inv, bad = scaled_inverse(jac, rcond)
    if m <= p:  # the poses determine the parameters exactly: no residual to take a scatter from
        return np.zeros((p, p)), bad
    s2 = float(residuals @ residuals) / (m - p)
    if m < SANDWICH_POSES_PER_PARAMETER * p:  # leverages near 1: each pose's own variance is not measurable
        return s2 * inv / np.outer(col, col), bad
    h = np.einsum("ij,jk,ik->i", js, inv, js)
    omega = np.where(h < 1 - LEVERAGE_ONE, residuals**2 / np.maximum(1 - h, LEVERAGE_ONE) ** 2, s2)
    cov_s = inv @ (js.T * omega) @ js @ inv
    return cov_s / np.outer(col, col), bad




#: batches a pose's samples are cut into for the variance of its mean
BATCHES = 10


def mean_variance(x: np.ndarray) -> np.ndarray:
    """Variance of the mean of a pose's samples (per column) by batch means, which hand tremor's correlation keeps.

    The samples of a hand-held pose are not independent (the postural sway of 0.5–2 Hz moves the sensor for
    many samples at a time), so ``var/n`` understates the variance of their mean. Cut into ``B`` = :data:`BATCHES`
    consecutive batches, the batch means are nearly independent and their variance over ``B`` is that of the
    mean (the method of batch means; with white noise it is ``var/n`` again). A pose too short for batches
    takes ``var/(n − 1)``.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    size = n // BATCHES
    if size < 2:
        return np.var(x, axis=0) / max(n - 1, 1)
    means = x[: size * BATCHES].reshape(BATCHES, size, *x.shape[1:]).mean(axis=1)
    return np.var(means, axis=0, ddof=1) / BATCHES


def six_position(up: np.ndarray, down: np.ndarray, gravity: float, *, cos_up: np.ndarray | float = 1.0,
                 cos_down: np.ndarray | float = 1.0) -> TriadModel:
    r"""Bias and scale from each axis's raw reading up and down (Ru 2022, eqs. 8–9).

    .. math::

        b = \frac{u_\mathrm{up} + u_\mathrm{down}}{2} \quad (8), \qquad
        s = \frac{u_\mathrm{up} - u_\mathrm{down}}{2 g} \quad (9)

    ``b = (u_up + u_down)/2`` (eq. 8), ``s = (u_up − u_down)/(2g)`` raw per m/s²
    (eq. 9), so ``k1 = 1/s``; ``T_a = I``. A face held ``δ`` off its axis reads
    ``g cos δ``, not ``g``: with the cosines of the two faces' tilts given,
    ``s = (u_up − u_down)/(g (cos δ_up + cos δ_down))`` and
    ``b = (u_up cos δ_down + u_down cos δ_up)/(cos δ_up + cos δ_down)``, exact for
    any tilt (eq. 9 as printed assumes ``δ = 0``, and a 15° tilt makes ``s``
    1/cos 15° − 1 = 3.5 % wrong).
    """
    cu, cd = np.asarray(cos_up, dtype=float), np.asarray(cos_down, dtype=float)
    b = (up * cd + down * cu) / (cu + cd)  # eq. (8), generalised to tilted faces
    s = (up - down) / (gravity * (cu + cd))  # eq. (9), raw per m/s²
    return TriadModel(scale=1.0 / s, bias=b, shape="upper")


def faces_full(faces: np.ndarray, gravity: float, *, bias: str = "axis") -> TriadModel:
    r"""Ferraris 1995: ``S_a e_i = (ū₊ᵢ − ū₋ᵢ)/(2g)`` and the bias from the faces.

    The six-face method of Ferraris et al. 1995 with the sensitivity model
    ``u = S_a a + b``, written here in this module's symbols (the paper's
    equations are not in the project's paper set, so they go unnumbered):

    .. math::

        \mathbf S_a \mathbf e_i = \frac{\bar{\mathbf u}_{+i} - \bar{\mathbf u}_{-i}}{2 g}, \qquad
        b_i = \frac{\bar u_{+i,i} + \bar u_{-i,i}}{2}, \qquad
        \mathbf T_a\, \mathrm{diag}(\mathbf k) = \mathbf S_a^{-1}

    ``faces`` holds the raw means of +x, +y, +z, −x, −y, −z. The cube's faces
    define the frame, so the misalignment is full: ``T_a diag(k) = S_a⁻¹``.
    ``bias="axis"``: ``b_i = (ū₊ᵢ,ᵢ + ū₋ᵢ,ᵢ)/2``, each axis from its own pair, where
    a face's tilt enters to second order; ``"mean"``: the mean of the six faces
    (what ``imucal`` does), where it enters to first order.
    """
    s_a = (faces[:3] - faces[3:]).T / (2 * gravity)  # Ferraris 1995: columns S_a e_i
    if bias == "axis":
        b = (faces[np.arange(3), np.arange(3)] + faces[3 + np.arange(3), np.arange(3)]) / 2  # Ferraris 1995: b_i
    elif bias == "mean":
        b = faces.mean(axis=0)
    else:
        raise ValueError(f"bias must be 'axis' or 'mean'; got {bias!r}")
    return full_from_sensitivity(s_a, b)


def full_from_sensitivity(s: np.ndarray, bias: np.ndarray, **extra) -> TriadModel:
    """``u = S x + b`` as the canonical ``x = T diag(k) (u − b)``: ``T diag(k) = S⁻¹``, ``T_ii = 1``."""
    m = np.linalg.inv(s)  # Ferraris 1995: T_a diag(k) = S_a⁻¹
    k = np.diag(m).copy()
    t = m / k[None, :]
    np.fill_diagonal(t, 1.0)  # m_ii / m_ii, exactly one
    return TriadModel(misalignment=t, scale=k, bias=bias, shape="full", **extra)


def qureshi_cost(x: np.ndarray, means: np.ndarray, gravity: float):
    r"""G(X) (eq. 11), its gradient and its Hessian (exact, analytic).

    Qureshi 2017, eqs. (7), (8) and (11), with ``X = (b, k, k_xy, k_xz, k_yz)``
    and ``M = K T`` upper triangular (diagonal ``k``, then ``k_xy``, ``k_xz``,
    ``k_yz`` above it), over the ``N`` poses' means ``Ā_k``:

    .. math::

        h(\bar A_k, X) = \mathbf M\, (\bar A_k - B) \quad (8), \qquad
        G(X) = \sum_{k=1}^{N} \bigl( \lVert h(\bar A_k, X) \rVert^2 - \lVert g \rVert^2 \bigr)^2 \quad (11)
    """
    b, k, kxy, kxz, kyz = x[:3], x[3:6], x[6], x[7], x[8]
    m = np.array([[k[0], kxy, kxz], [0.0, k[1], kyz], [0.0, 0.0, k[2]]])  # eq. (7): K T from X
    d = means - b  # (N, 3)
    h = d @ m.T  # eq. (8)
    r = np.sum(h * h, axis=1) - gravity**2  # eq. (11): ‖h‖² − ‖g‖², each pose
    # ∂h/∂X for each sample: (N, 3, 9)
    n = means.shape[0]
    dh = np.zeros((n, 3, 9))
    dh[:, :, 0:3] = -m[None, :, :]  # ∂h/∂b = −M
    dh[:, 0, 3] = d[:, 0]
    dh[:, 1, 4] = d[:, 1]
    dh[:, 2, 5] = d[:, 2]
    dh[:, 0, 6] = d[:, 1]
    dh[:, 0, 7] = d[:, 2]
    dh[:, 1, 8] = d[:, 2]
    dr = 2 * np.einsum("ni,nip->np", h, dh)  # ∂r/∂X
    # ∂²r/∂X² = 2 (∂h)ᵀ(∂h) + 2 Σ_i h_i ∂²h_i ; h is bilinear in (b, M): ∂²h_i/∂b_j∂M_il = −δ
    d2r = 2 * np.einsum("nip,niq->npq", dh, dh)
    m_index = {(0, 0): 3, (1, 1): 4, (2, 2): 5, (0, 1): 6, (0, 2): 7, (1, 2): 8}
    for (i, j), p in m_index.items():
        # h_i = Σ_j M_ij (u_j − b_j): ∂²h_i/∂M_ij∂b_j = −1
        d2r[:, p, j] += -2 * h[:, i]
        d2r[:, j, p] += -2 * h[:, i]
    value = float(r @ r)  # eq. (11)
    grad = 2 * dr.T @ r
    hess = 2 * (dr.T @ dr + np.einsum("n,npq->pq", r, d2r))
    return value, grad, hess


def newton_backtracking(x0: np.ndarray, means: np.ndarray, gravity: float, *, max_iter: int = 100,
                        tol: float = 1e-14) -> tuple[np.ndarray, int]:
    r"""Minimise eq. (11) by Newton's method with an Armijo backtracking line search (eq. 12).

    Qureshi 2017, eqs. (10) and (12), the step length ``t`` halved until the
    Armijo condition holds (the line search the paper leaves to its ref. [15]):

    .. math::

        \hat X = \arg\min_X G(X) \quad (10), \qquad
        X_k = X_{k-1} - t\, \bigl(\nabla^2 G(X)\bigr)^{-1} \nabla G(X) \quad (12)

    Where the Hessian is not positive definite the step falls back to steepest
    descent. Returns the minimiser and the number of iterations.
    """
    x = np.array(x0, dtype=float)
    scale = np.maximum(np.abs(x), 1e-3)  # work in relative units for conditioning
    for it in range(1, max_iter + 1):
        value, grad, hess = qureshi_cost(x, means, gravity)
        gs, hs = grad * scale, hess * scale[:, None] * scale[None, :]
        try:
            c = np.linalg.cholesky(hs)
            step = -np.linalg.solve(c.T, np.linalg.solve(c, gs))  # eq. (12): −(∇²G)⁻¹ ∇G
        except np.linalg.LinAlgError:
            step = -gs
        t = 1.0
        while True:  # backtracking: sufficient decrease (Armijo, c = 1e-4), halving t
            trial = x + t * step * scale  # eq. (12)
            if qureshi_cost(trial, means, gravity)[0] <= value + 1e-4 * t * (gs @ step) or t < 1e-12:
                break
            t *= 0.5
        x = trial
        if np.max(np.abs(t * step)) < tol or value == 0.0:
            return x, it
    return x, max_iter
