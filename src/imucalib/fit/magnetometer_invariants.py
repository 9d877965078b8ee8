r"""The magnetometer where the field is not the same at every pose: its two invariants, with the accelerometer.

:func:`~imucalib.fit.magnetometer.fit_magnetometer` holds the field to three
sets of equations (M2)–(M4): its norm, its dip and its rotation with the
gyroscope. They are independent evidence only while the field is one uniform
field and each pose's reading differs from it by the readings' noise. Hand-held
near a desk, a computer or the holder's body, the field changes from place to
place by far more: then every pose's calibrated field carries an error ``e_i``
of its own, the same for all the equations of that pose, and

* the samples read while moving (the norm equations of (M2) beyond the poses)
  carry the same error, strongly correlated along each transition: counted as
  independent they outweigh the poses many times over;
* the rotation equations (M4) compare the field's direction at two poses with
  the gyroscope's rotation: each difference holds two poses' errors and the
  chain of them ties the headings, which a local field error turns freely.

What stays is the two quantities of each pose that do not depend on its
heading: the field's component along gravity and its horizontal magnitude. These
are the invariants of the dip-angle methods — the calibrated field's norm and
its dot product with the calibrated gravity are the same at every pose — as
Papafotis & Sotiriadis fit them jointly for the accelerometer and the
magnetometer ("Accelerometer and Magnetometer Joint Calibration and Axes
Alignment", Technologies 8(1), 11, 2020), and as the dot-product-invariant
methods reviewed in Ru 2022, §4 and Table 4, use them between two sensors. The
equations below are not those papers' (whose equation numbers are not quoted
here): they are the maximum-likelihood form of the same invariants under an
isotropic field error, derived as follows.

Pose ``i`` (of ``M``) reads the field ``m_i = O S (u_i − b)`` (the model
(M1), ``F = 1``) in a frame whose up direction is ``d_i``, the calibrated
accelerometer's unit specific force. The true field there is ``h_i = R_iᵀ h``
with ``h = (cos δ, 0, −sin δ)`` in a level frame whose x axis is magnetic
north, and ``R_i`` is known but for the heading ``ψ_i``. With an isotropic
error ``m_i = h_i + e_i``, ``e_i ~ N(0, σ² I)``, the heading that fits ``m_i``
best points ``h_i``'s horizontal part along ``m_i``'s, and what remains are two
residuals, each with variance ``σ²`` — the vertical component (I1) and the
horizontal magnitude (I2):

.. math::

    r_{z,i} = \mathbf d_i^\top \mathbf m_i + \sin\delta \qquad \text{(I1)}

    r_{h,i} = \lVert \mathbf m_i - (\mathbf d_i^\top \mathbf m_i)\, \mathbf d_i \rVert - \cos\delta
    \qquad \text{(I2)}

(the third, along the horizontal perpendicular to ``m_i``, is taken up by
``ψ_i``). The accelerometer's parameters ``a`` enter through ``d_i``; they
are fitted jointly, with the accelerometer's own estimate ``â`` and its 1σ
``σ_a`` (``fit.uncertainty.sigma``) as their prior — the accelerometer's
equations, linearised, summarised by their solution and spread (their
correlations are not kept in the calibration and are left out):

.. math::

    r_{a,j} = (a_j - \hat a_j) / \sigma_{a,j} \qquad \text{(I3)}

Minimising ``Σ (r_z² + r_h²) / σ² + Σ r_a²`` over ``b``, ``S``, ``O``, ``δ``
(and the hard iron's drift, (M5)) and ``a``; ``σ`` is the residuals' own
spread, re-estimated twice with the degrees of freedom the magnetometer's
parameters take:

.. math::

    \sigma^2 = \sum_i \bigl(r_{z,i}^2 + r_{h,i}^2\bigr) / (2 M - p) \qquad \text{(I4)}

The covariance of all parameters is ``(JᵀJ)⁻¹`` at the solution (``J`` the
Jacobian of the weighted residuals): it holds the accelerometer's uncertainty
as it reaches the magnetometer through ``d_i``. The calibration keeps the
accelerometer the method fitted: the joint fit moves it by a small fraction of
its 1σ (reported), well inside its own errors.

The two invariants get one weight, as the isotropic error has it. Where the
field differs from pose to pose the fit leaves both scattering by about the
same amount (the norm's relative spread and the dip's spread in radians): a
larger weight on either trades the other's scatter for its own rather than
lowering both (on the MPU-9250 session of 40 poses, 1.15 × on the norm takes
its spread from 1.52 % to 1.47 % and the dip's from 0.935° to 0.965°; left
out in turn, each pose is predicted to 1.8 % and 1.16°, the size of the
field's own differences).

Which case a session is in is read from the poses' field norms under the first
fit: the norm of each pose's mean against the noise of that mean (its samples'
scatter over their count). Their χ² per degree of freedom is near 1 for a
uniform field; beyond :data:`FIELD_DISTURBED_CHI2` — the poses' norms scatter
more than three times what their noise explains — the field is taken as not
uniform and this fit replaces the first.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["FIELD_DISTURBED_CHI2", "InvariantFit", "central_jacobian", "field_scatter", "fit_invariants"]

#: the poses' field norms scattering more than this χ² per degree of freedom (3² = 9, rounded up: beyond three
#: times the noise of the pose means) mark a field that is not the same at every pose
FIELD_DISTURBED_CHI2 = 10.0
#: the ellipsoid's 9 parameters take that many degrees of freedom from the poses' norms
_ELLIPSOID_DOF = 9


@dataclass(frozen=True)
class InvariantFit:
    """The invariants' fit: the magnetometer's parameters as ``fit_magnetometer`` lays them out, and more.

    ``theta`` is ``b (3), S (6), φ (3), δ`` and, with a drift, ``ḃ (3)``; ``covariance`` is its covariance
    with the accelerometer's uncertainty carried in; ``field_error`` is ``σ`` of (I4) in units of the field;
    ``accelerometer_shift_sigma`` the largest ``|a_j − â_j| / σ_a,j``.
    """

    theta: np.ndarray
    covariance: np.ndarray
    field_error: float
    accelerometer_shift_sigma: float
    drift_chi2: float


def field_scatter(mag: np.ndarray, intervals, bias: np.ndarray, soft_iron: np.ndarray) -> tuple[float, float]:
    """χ² per degree of freedom of the poses' field norms against the noise of the pose means, and that noise.

    Each pose's norm is the mean of ``‖S (u − b)‖`` over its samples; its variance is the samples' variance
    over their count. The norms' weighted scatter about their weighted mean, over ``M − 9`` degrees of
    freedom (the ellipsoid's parameters), is near 1 when the field is uniform. The noise returned is the
    pose means' RMS 1σ (units of the field).
    """
    norms, var = [], []
    for iv in intervals:
        v = np.linalg.norm((mag[iv.start:iv.stop] - bias) @ soft_iron, axis=1)
        norms.append(float(v.mean()))
        var.append(float(v.var(ddof=1)) / v.size if v.size > 1 else np.inf)
    norms, var = np.array(norms), np.maximum(np.array(var), 1e-300)
    w = 1.0 / var
    mean = float(np.sum(w * norms) / np.sum(w))
    dof = max(norms.size - _ELLIPSOID_DOF, 1)
    return float(np.sum(w * (norms - mean) ** 2) / dof), float(np.sqrt(np.mean(var)) / mean)


def fit_invariants(mag_means: np.ndarray, acc_means: np.ndarray, accelerometer, acc_sigma: dict[str, float],
                   theta0: np.ndarray, scale: np.ndarray, unpack: Callable, min_pose: np.ndarray,
                   drift_chi2_limit: float) -> InvariantFit:
    """Fit (I1)–(I3) to the poses (module docstring).

    Parameters
    ----------
    mag_means, acc_means : (M, 3) ndarray
        The poses' raw magnetometer and accelerometer means.
    accelerometer : TriadModel
        The accelerometer as the method fitted it (``â``).
    acc_sigma : dict
        1σ of the accelerometer's parameters by name (``accelerometer.bias.x`` …); those with a finite,
        positive 1σ are fitted jointly, the others held.
    theta0 : ndarray
        Start: ``b, S (6), φ, δ`` as ``fit_magnetometer`` lays them out (13 values).
    scale : ndarray
        Typical sizes of those 13 parameters (steps of the Jacobian).
    unpack : callable
        ``theta → (b, S, O, δ, ḃ)``, as in ``fit_magnetometer``.
    min_pose : (M,) ndarray
        The poses' times [min] from their mean: the hard iron's drift (M5) is tried, and kept where its χ²
        exceeds ``drift_chi2_limit``.
    """
    from scipy.optimize import least_squares  # scipy.optimize costs 422 ms at start-up

    values = accelerometer.parameters("accelerometer")
    names = [n for n, sd in acc_sigma.items() if n in values and sd is not None and np.isfinite(sd) and sd > 0]
    a_hat = np.array([values[n] for n in names])
    a_sd = np.array([float(acc_sigma[n]) for n in names])
    m = mag_means.shape[0]

    def residuals(th: np.ndarray, n_mag: int, sigma: float) -> np.ndarray:
        b, s, o, dip, drift = unpack(th[:n_mag])
        a = th[n_mag:]
        acc = accelerometer.with_parameters("accelerometer", dict(zip(names, a, strict=True))) if names \
            else accelerometer
        up = acc.forward(acc_means)
        up /= np.linalg.norm(up, axis=1, keepdims=True)
        field = (mag_means - b - np.outer(min_pose, drift)) @ s @ o.T
        z = np.einsum("ij,ij->i", up, field)
        h = np.sqrt(np.maximum(np.einsum("ij,ij->i", field, field) - z**2, 0.0))
        return np.concatenate([(z + np.sin(dip)) / sigma,  # (I1)
                               (h - np.cos(dip)) / sigma,  # (I2)
                               (a - a_hat) / a_sd])  # (I3)

    def solve(theta: np.ndarray, step: np.ndarray, n_mag: int) -> tuple[np.ndarray, float]:
        sigma = 1e-2
        for _ in range(3):  # (I4): σ from the residuals' own spread, refitted
            sol = least_squares(residuals, theta, args=(n_mag, sigma), x_scale=step, method="lm",
                                xtol=1e-14, ftol=1e-14, max_nfev=4000)
            theta = sol.x
            r = sol.fun[:2 * m] * sigma
            sigma = max(float(np.sqrt(np.sum(r**2) / max(2 * m - n_mag, 1))), 1e-12)  # (I4)
        return theta, sigma

    def covariance(theta: np.ndarray, step: np.ndarray, n_mag: int, sigma: float) -> np.ndarray:
        jac = central_jacobian(lambda th: residuals(th, n_mag, sigma), theta, step)
        try:
            return np.linalg.inv(jac.T @ jac)
        except np.linalg.LinAlgError:
            return np.full((theta.size, theta.size), np.nan)

    n0 = theta0.size
    step = np.concatenate([scale, a_sd])
    theta, sigma = solve(np.concatenate([theta0, a_hat]), step, n0)
    cov = covariance(theta, step, n0, sigma)
    # (M5): the hard iron drifting in time, kept where the poses show it
    step_d = np.concatenate([scale, np.full(3, scale[0]), a_sd])
    th_d, sig_d = solve(np.concatenate([theta[:n0], np.zeros(3), theta[n0:]]), step_d, n0 + 3)
    cov_d = covariance(th_d, step_d, n0 + 3, sig_d)
    block = cov_d[n0:n0 + 3, n0:n0 + 3]
    drift_chi2 = float(th_d[n0:n0 + 3] @ np.linalg.solve(block, th_d[n0:n0 + 3])) \
        if np.all(np.isfinite(block)) else 0.0
    n_mag = n0
    if drift_chi2 > drift_chi2_limit:
        theta, sigma, cov, n_mag = th_d, sig_d, cov_d, n0 + 3
    shift = float(np.max(np.abs(theta[n_mag:] - a_hat) / a_sd)) if names else 0.0
    return InvariantFit(theta=theta[:n_mag], covariance=cov[:n_mag, :n_mag], field_error=sigma,
                        accelerometer_shift_sigma=shift, drift_chi2=drift_chi2)


def central_jacobian(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """∂fun/∂x by central differences with steps proportional to ``scale``."""
    f0 = fun(x)
    jac = np.empty((f0.size, x.size))
    for i in range(x.size):
        h = 1e-6 * scale[i]
        e = np.zeros_like(x)
        e[i] = h
        jac[:, i] = (fun(x + e) - fun(x - e)) / (2 * h)
    return jac
