r"""Magnetometer: hard and soft iron, and the field expressed in the accelerometer's frame.

The magnetometer is calibrated after the accelerometer and the gyroscope, from
the same static poses and the rotations between them, with the model of
:class:`~imucalib.models.MagnetometerModel`:

.. math::

    \mathbf m = F\, \mathbf O\, \mathbf S\, (\mathbf u - \mathbf b) \qquad \text{(M1)}

The Earth's field ``h`` is constant in the world frame while the sensor is
turned by hand, so three sets of equations hold (the multi-position approach of
Särkkä et al. 2017 and the magnetometer-aided calibration reviewed in Ru 2022,
§4.2 (3), written here for this model):

* **norm** — for every pose ``i`` (and every sample while moving) hard and soft
  iron make the readings an ellipsoid, ``S`` and ``b`` map it onto the unit
  sphere:

  .. math::

      \lVert \mathbf S\, (\mathbf u_i - \mathbf b) \rVert = 1 \qquad \text{(M2)}

* **dip** — the angle between field and gravity does not change from pose to
  pose, with ``d_i`` the calibrated gravity direction (the accelerometer's unit
  specific force at rest, pointing up) and ``δ`` the field's dip below the
  horizontal:

  .. math::

      \mathbf d_i^\top \mathbf n_i = -\sin\delta, \qquad
      \mathbf n_i = \frac{\mathbf O\, \mathbf S\, (\mathbf u_i - \mathbf b)}
      {\lVert \mathbf S\, (\mathbf u_i - \mathbf b) \rVert} \qquad \text{(M3)}

* **rotation** — with ``R_k`` the attitude change from pose ``k`` to ``k+1``
  integrated from the calibrated gyroscope, exactly as the gravity direction is
  carried in Zhang 2021, eq. (14):

  .. math::

      \mathbf n_{k+1} = \mathbf R_k^\top \mathbf n_k \qquad \text{(M4)}

The hard iron of a real die may drift while the session lasts (the die warms
up; currents on the board change). Unmodelled, a drift of 3 µT over a few
minutes in a 48 µT field spreads the calibrated field's norm by 1 % and its dip
by 0.7° over the poses. The joint fit adds ``ḃ`` and keeps it only where the
poses show it (its χ² against its own covariance beyond the 99.9 % point of
χ²(3)); ``b`` is then the hard iron at ``t̄``, the poses' mean time:

.. math::

    \mathbf b(t) = \mathbf b + \dot{\mathbf b}\, (t - \bar t) \qquad \text{(M5)}

All of (M2)–(M5) assume one uniform field, each pose's reading differing from
it by the readings' noise. Where the poses' field norms scatter far beyond that
noise (a desk, a computer or the holder's body nearby), every pose carries a
field error of its own, the same in all its equations; then the fit keeps,
of each pose, only what does not depend on its heading — the field's vertical
component and its horizontal magnitude — and fits them jointly with the
accelerometer (:mod:`imucalib.fit.magnetometer_invariants`, (I1)–(I4)).  (I)

(M2) alone is the usual ellipsoid fit: it leaves ``O`` free, so a magnetometer
die whose axes are permuted and reflected relative to the accelerometer's (the
MPU-9250's magnetometer has x and y swapped and z reversed) keeps a wandering
angle to gravity. (M3) and (M4) fix ``O``: first by a linear solve — (M4) and
(M3) are linear and homogeneous in the nine entries of ``L = O`` and in
``κ = −sin δ``, so the smallest right singular vector of the stacked equations
gives ``L`` up to scale, and the nearest orthogonal matrix (polar
decomposition, determinant +1 or −1) is ``O``; then all of ``b``, ``S``, ``O``,
``δ`` (and ``ḃ``, M5) together by Gauss–Newton (Levenberg–Marquardt) on
(M2)–(M4), each group weighted by its own residual spread (re-estimated three
times, with the degrees of freedom the parameters take): the noise each
group's equations have once the model fits. This also gives the 1σ of every
parameter.

The data cannot tell ``O`` from ``−O`` (a field reversed everywhere rotates the
same way): the sign is chosen so that the field points below the horizontal in
the northern magnetic hemisphere (``hemisphere="north"``, dip > 0) and above it
in the southern one. Near the magnetic equator (``|δ| < 5°``) the choice is
weak, and the fit says so.

The calibrated unit: with raw readings in µT (or gauss), ``F`` is the
geometric-mean radius of the fitted ellipsoid, ``det(S)^(−1/3)``, in µT (no
external reference fixes the field's magnitude better); with raw counts the
field is normalised (``F = 1``) unless the local field magnitude is given
(e.g. from a geomagnetic model), in µT.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..calibration import Calibration
from ..fitreport import MagnetometerReport
from ..kinematics import IntervalIntegrator, quat_from_rotvec, quat_to_matrix
from ..metrics import interval_means, transition_bounds
from ..models import AXES, MagnetometerModel
from ..recording import Interval, Recording
from .accelerometer import fit_ellipsoid
from .magnetometer_invariants import FIELD_DISTURBED_CHI2, central_jacobian, field_scatter, fit_invariants

__all__ = ["MIN_MAG_POSES", "MagnetometerFit", "alignment_from_rotations", "fit_magnetometer", "pose_figures",
           "pose_references", "soft_iron_from_ellipsoid"]

#: the fewest static poses the magnetometer fit takes
MIN_MAG_POSES = 6
#: below this |dip| [deg] the field's sign (hence det O) is weakly determined
WEAK_DIP_DEG = 5.0
#: the hard iron's drift (M5) is fitted only when its χ² exceeds this, the 99.9 % point of χ² with 3 degrees
DRIFT_CHI2 = 16.27
_SYM = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


@dataclass(frozen=True)
class MagnetometerFit:
    """A fitted magnetometer: the model, its record of the fit report and the 1σ errors by name."""

    model: MagnetometerModel
    figures: MagnetometerReport
    uncertainty: dict
    covariance: np.ndarray


def _sym(v: np.ndarray) -> np.ndarray:
    s = np.empty((3, 3))
    for k, (i, j) in enumerate(_SYM):
        s[i, j] = s[j, i] = v[k]
    return s


def soft_iron_from_ellipsoid(raw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hard iron ``b`` and symmetric ``S`` with ``‖S (u − b)‖ ≈ 1`` from an algebraic ellipsoid fit (M2).

    ``raw`` (N, 3) are readings spread over directions (N ≥ 9). ``S`` is the
    symmetric square root of the fitted quadric ``(u − b)ᵀ Q (u − b) = 1``.
    """
    tri = fit_ellipsoid(raw, 1.0)  # eq. (M2): (u − b)ᵀ (T K)ᵀ (T K) (u − b) = 1
    tk = tri.misalignment @ np.diag(tri.scale)
    q = tk.T @ tk
    w, v = np.linalg.eigh(q)
    return tri.bias, (v * np.sqrt(w)) @ v.T


def alignment_from_rotations(s: np.ndarray, up: np.ndarray, rot: np.ndarray, use: np.ndarray,
                             hemisphere: str) -> np.ndarray:
    """The orthogonal ``O`` from the linear equations (M3), (M4) (see the module docstring).

    ``s`` (M, 3) are the poses' sphere-mapped fields ``S (u − b)``, ``up`` (M, 3) the unit gravity
    directions, ``rot`` (M−1, 3, 3) the attitude changes between consecutive poses, ``use`` (M−1,)
    which transitions to use.
    """
    rows = []
    eye = np.eye(3)
    for k in np.nonzero(use)[0]:  # eq. (M4): (L s_{k+1})_a − (R_kᵀ L s_k)_a = 0
        rows.append(np.hstack([np.kron(eye, s[k + 1][None, :]) - np.kron(rot[k].T, s[k][None, :]), np.zeros((3, 1))]))
    for i in range(s.shape[0]):  # eq. (M3): d_iᵀ L s_i − κ = 0
        rows.append(np.hstack([np.kron(up[i][None, :], s[i][None, :]), [[-1.0]]]))
    a = np.vstack(rows)
    x = np.linalg.svd(a)[2][-1]
    u, _, vt = np.linalg.svd(x[:9].reshape(3, 3))
    o = u @ vt
    down = float(np.mean(np.einsum("ij,ij->i", up, s @ o.T)))  # < 0: the field points below the horizontal
    if (down > 0) == (hemisphere == "north"):
        o = -o
    return o


def _rotvec_matrix(v: np.ndarray) -> np.ndarray:
    return quat_to_matrix(quat_from_rotvec(v))


def pose_references(calibration: Calibration, recording: Recording,
                    intervals: list[Interval]) -> tuple[np.ndarray, np.ndarray]:
    """Unit gravity directions at the poses (M, 3) and attitude changes between them (M−1, 3, 3) by ``calibration``.

    The references (M3) and (M4) hold the field to: ``v_{k+1} = R_kᵀ v_k``.
    """
    starts, stops = transition_bounds(intervals)
    integ = IntervalIntegrator(recording.t, starts, stops)
    idx = integ.samples
    return _references(calibration, interval_means(recording.acc, intervals), recording.gyro[idx],
                       recording.acc[idx], integ)


def _references(calibration: Calibration, acc_means, raw_gyro, raw_acc, integrator) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pose_references` from the poses' raw accelerometer means and the integrated samples."""
    acc = calibration.accelerometer.forward(acc_means)
    rates = calibration.gyroscope.forward(raw_gyro, calibration.accelerometer.forward(raw_acc))
    return acc / np.linalg.norm(acc, axis=1, keepdims=True), quat_to_matrix(integrator.from_samples(rates))


def pose_figures(model: MagnetometerModel, mag_means: np.ndarray, up: np.ndarray, rot: np.ndarray) -> dict:
    """Field-norm spread, dip and its spread, direction errors between poses, for ``model``."""
    m = model.forward(mag_means)
    norm = np.linalg.norm(m, axis=1)
    n = m / norm[:, None]
    dip = np.degrees(np.arcsin(np.clip(-np.einsum("ij,ij->i", up, n), -1.0, 1.0)))  # eq. (M3)
    pred = np.einsum("kji,kj->ki", rot, n[:-1])  # eq. (M4)
    err = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", pred, n[1:]), -1.0, 1.0)))
    return {"norm_spread": float(np.std(norm) / np.mean(norm)), "dip_deg": float(np.mean(dip)),
            "dip_spread_deg": float(np.std(dip)), "direction_errors_deg": err,
            "norms": norm, "dips_deg": dip}


def fit_magnetometer(recording: Recording, intervals: list[Interval], calibration: Calibration, *,
                     hemisphere: str = "north", field: float | None = None,
                     motion_samples: int = 1000) -> MagnetometerFit:
    """Calibrate the magnetometer of ``recording`` after its accelerometer and gyroscope (``calibration``).

    Parameters
    ----------
    recording : Recording
        Raw readings with ``mag``.
    intervals : list of Interval
        The static poses the accelerometer and gyroscope were calibrated on, in time order.
    calibration : Calibration
        The accelerometer and gyroscope calibration (the gravity directions and the rotations).
    hemisphere : {"north", "south"}
        Magnetic hemisphere: the field points below (north) or above (south) the horizontal.
    field : float, optional
        Local field magnitude [µT]: the calibrated field is then in µT whatever the raw unit.
    motion_samples : int
        Readings taken while moving (decimated to at most this many) also enter the norm equations (M2).

    Returns
    -------
    MagnetometerFit
        The magnetometer model (hard and soft iron, the alignment into the accelerometer's frame, the field)
        and its fit figures (``magnetometer_…`` entries of a calibration's ``fit``).

    Raises
    ------
    ValueError
        No magnetometer in the recording, too few poses, poses that do not determine the
        ellipsoid, or a bad option.

    Examples
    --------
    A simulated session with a magnetometer: its hard-iron bias [counts] beside the truth's:

    >>> from imucalib import Interval
    >>> from imucalib.fit.magnetometer import fit_magnetometer
    >>> from imucalib.methods import calibrate
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14, magnetometer=True)
    >>> cal = calibrate(sim.recording, magnetometer=False)
    >>> intervals = [Interval(a, b) for a, b in cal.fit.poses.intervals]
    >>> found = fit_magnetometer(sim.recording, intervals, cal)
    >>> found.model.bias.round(1), sim.truth.magnetometer.bias.round(1)
    (array([-86.6, -85.6, 107.3]), array([-86.6, -85.5, 107.4]))
    """
    _check_options(recording, intervals, hemisphere, field)
    mag_means = interval_means(recording.mag, intervals)
    acc_means = interval_means(recording.acc, intervals)
    starts, stops = transition_bounds(intervals)
    integrator = IntervalIntegrator(recording.t, starts, stops)
    idx = integrator.samples
    raw_gyro, raw_acc = recording.gyro[idx], recording.acc[idx]

    def references(cal: Calibration):
        """Gravity directions at the poses and attitude changes between them, by ``cal``."""
        return _references(cal, acc_means, raw_gyro, raw_acc, integrator)

    up, rot = references(calibration)  # v_{k+1} = R_kᵀ v_k
    mov = _motion_samples(recording, intervals, motion_samples)
    mag_moving = recording.mag[mov]
    b0, s0, use, gyro_ok, o0, dip0 = _starting_point(mag_means, mag_moving, up, rot, calibration, hemisphere)

    # pose and motion-sample times [min] from the poses' mean time: the hard iron may drift (M5)
    t_pose = np.array([float(np.mean(recording.t[iv.start:iv.stop])) for iv in intervals])
    t_ref = float(np.mean(t_pose))
    min_pose, min_move = (t_pose - t_ref) / 60.0, (recording.t[mov] - t_ref) / 60.0
    eq = _PoseEquations(mag_means, mag_moving, up, rot, o0, min_pose, min_move, use)
    theta, sigma, cov, scale = _fit_drift_if_shown(eq, b0, s0, dip0, calibration, references)

    # (I): a field that is not the same at every pose (the poses' norms scatter far beyond their noise) leaves
    # the rotation and motion-sample equations out: the two invariants of each pose, with the accelerometer
    b, s, _, _, drift = eq.unpack(theta)
    field_chi2, _ = field_scatter(recording.mag - np.outer((recording.t - t_ref) / 60.0, drift), intervals, b, s)
    uniform = field_chi2 <= FIELD_DISTURBED_CHI2
    invariants = None
    if not uniform:
        invariants = fit_invariants(mag_means, acc_means, calibration.accelerometer,
                                    calibration.fit.uncertainty.sigma or {}, theta[:13], scale[:13],
                                    eq.unpack, min_pose, DRIFT_CHI2)
        theta, cov = invariants.theta, invariants.covariance
        use[:] = gyro_ok  # no rotation equations in this fit: every rotation the gyroscope kept is scored
    model, o, dip, drift = _model(eq.unpack(theta), recording.mag_unit, field)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    figures = _figures(model, eq, theta, sd, dip, drift, hemisphere)
    figures = figures.with_(
        # (I): whether the field was uniform over the poses, and what the fit held it to
        field_uniform=bool(uniform),
        field_scatter_chi2=field_chi2,
        field_error=None if invariants is None else invariants.field_error,
        accelerometer_shift_sigma=None if invariants is None else invariants.accelerometer_shift_sigma,
    )
    return MagnetometerFit(model=model, figures=figures, uncertainty=_named_errors(cov, sd, o), covariance=cov)


def _check_options(recording: Recording, intervals: list[Interval], hemisphere: str, field: float | None) -> None:
    """The errors :func:`fit_magnetometer` raises before fitting: no magnetometer, a bad option, too few poses."""
    if recording.mag is None:
        raise ValueError("the recording has no magnetometer columns (mx, my, mz) to calibrate")
    if hemisphere not in ("north", "south"):
        raise ValueError(f"hemisphere must be 'north' or 'south'; got {hemisphere!r}")
    if field is not None and not (np.isfinite(field) and field > 0):
        raise ValueError(f"the local field magnitude must be a positive number of µT; got {field!r}")
    if len(intervals) < MIN_MAG_POSES:
        raise ValueError(f"the magnetometer fit needs at least {MIN_MAG_POSES} static poses; got {len(intervals)}")


def _motion_samples(recording: Recording, intervals: list[Interval], motion_samples: int) -> np.ndarray:
    """The indices of the samples outside the static poses, decimated to at most ``motion_samples``."""
    moving = np.ones(len(recording), bool)
    for iv in intervals:
        moving[iv.start:iv.stop] = False
    mov = np.nonzero(moving)[0]
    if mov.size > motion_samples:
        mov = mov[np.linspace(0, mov.size - 1, motion_samples).round().astype(int)]
    return mov


def _starting_point(mag_means: np.ndarray, mag_moving: np.ndarray, up: np.ndarray, rot: np.ndarray,
                    calibration: Calibration, hemisphere: str) -> tuple:
    """The fit's start: hard and soft iron from the ellipsoid (M2), then the linear solve of (M3)-(M4) for
    ``O`` and the dip it gives; with the rotations (M4) uses (``use``, and ``gyro_ok``: those the gyroscope's
    fit kept)."""
    spread = np.vstack([mag_means, mag_moving])
    try:
        b0, s0 = soft_iron_from_ellipsoid(spread)
    except ValueError as exc:
        raise ValueError(f"the magnetometer readings do not determine hard and soft iron: {exc}") from None
    use = np.ones(len(mag_means) - 1, bool)
    # the rotations the gyroscope's fit left out (a spike, a bump) are wrong here too: not in (M4)
    left_out = list(calibration.fit.gyroscope.rotations_left_out or {})
    use[[k for k in left_out if 0 <= k < use.size]] = False
    gyro_ok = use.copy()
    o0 = alignment_from_rotations((mag_means - b0) @ s0, up, rot, use, hemisphere)
    n0 = (mag_means - b0) @ s0 @ o0.T  # eq. (M1), F = 1
    n0 /= np.linalg.norm(n0, axis=1, keepdims=True)
    dip0 = float(np.arcsin(np.clip(-np.mean(np.einsum("ij,ij->i", up, n0)), -1, 1)))  # eq. (M3)
    return b0, s0, use, gyro_ok, o0, dip0


class _PoseEquations:
    """The residual groups of the fit, (M2) norms of the poses and of the motion samples, (M3) dips, (M4)
    rotations, with the hard iron's drift (M5) when ``theta`` holds it; ``use``: the rotations (M4) takes
    (changed in place as the fit leaves some out)."""

    def __init__(self, mag_means, mag_moving, up, rot, o0, min_pose, min_move, use) -> None:
        self.mag_means, self.mag_moving, self.up, self.rot, self.o0 = mag_means, mag_moving, up, rot, o0
        self.min_pose, self.min_move, self.use = min_pose, min_move, use

    def unpack(self, th):
        """``b``, ``S``, ``O``, the dip and the drift (zero without) from the parameters ``th``."""
        drift = th[13:16] if th.size > 13 else np.zeros(3)
        return th[:3], _sym(th[3:9]), self.o0 @ _rotvec_matrix(th[9:12]), th[12], drift

    def groups(self, th, up=None, rot=None):
        """The four residual groups at ``th``, against the references ``up``, ``rot`` (default the fit's)."""
        up = self.up if up is None else up
        rot = self.rot if rot is None else rot
        b, s, o, dip, drift = self.unpack(th)
        v = (self.mag_means - b - np.outer(self.min_pose, drift)) @ s  # eq. (M5), (M1): S (u − b(t))
        norm = np.linalg.norm(v, axis=1)
        n = v @ o.T / norm[:, None]  # eq. (M3): n_i
        r_norm = norm - 1.0  # eq. (M2)
        # eq. (M2), (M5)
        r_move = np.linalg.norm((self.mag_moving - b - np.outer(self.min_move, drift)) @ s, axis=1) - 1.0
        r_dip = np.einsum("ij,ij->i", up, n) + np.sin(dip)  # eq. (M3)
        r_rot = (n[1:] - np.einsum("kji,kj->ki", rot, n[:-1]))[self.use].ravel()  # eq. (M4)
        return r_norm, r_move, r_dip, r_rot

    def solve(self, theta, scale, sigma):
        """Levenberg–Marquardt on the weighted groups, the weights from each group's own residual spread,
        refitted; a rotation the gyroscope got wrong is left out of ``use`` once. ``(theta, sigma)``."""
        from scipy.optimize import least_squares  # here: importing scipy.optimize takes ~0.3 s

        use = self.use
        p = theta.size
        for _ in range(3):  # weights from each group's own residual spread, refitted
            def fun(th, sig=sigma):
                return np.concatenate([g / s for g, s in zip(self.groups(th), sig, strict=True)])

            sol = least_squares(fun, theta, x_scale=scale, method="lm", xtol=1e-14, ftol=1e-14, max_nfev=2000)
            theta = sol.x
            res = self.groups(theta)
            dof = np.array([r.size for r in res], dtype=float)
            dof[3] *= 2.0 / 3.0  # a unit-vector difference has two degrees of freedom, not three
            total = dof.sum()
            sigma = np.array([np.sqrt(np.sum(r**2) / max(d * (1 - p / total), 1.0)) if r.size else 1.0
                              for r, d in zip(res, dof, strict=True)])
            sigma = np.maximum(sigma, 1e-12)
            # a transition the gyroscope got wrong (a bump, a missed pose) is left out once: > 5σ and > 3°
            err = np.linalg.norm(res[3].reshape(-1, 3), axis=1)
            bad = np.zeros_like(use)
            bad[np.nonzero(use)[0]] = (err > 5 * sigma[3]) & (err > np.radians(3.0))
            if np.any(bad) and np.count_nonzero(use & ~bad) >= max(3, use.sum() * 4 // 5):
                use[:] = use & ~bad
        return theta, sigma

    def covariance(self, theta, sigma, scale, calibration: Calibration, references):
        """The parameters' covariance from the weighted groups' Jacobian, with what the calibration's own
        errors carry into the references (:func:`_carried_covariance`)."""
        def fun_final(th):
            return np.concatenate([g / s for g, s in zip(self.groups(th), sigma, strict=True)])

        jac = central_jacobian(fun_final, theta, scale)
        try:
            cov = np.linalg.inv(jac.T @ jac)
        except np.linalg.LinAlgError:
            return np.full((theta.size, theta.size), np.nan)
        return cov + _carried_covariance(calibration, references, self.groups, theta, sigma, jac, cov)


def _fit_drift_if_shown(eq: _PoseEquations, b0, s0, dip0, calibration: Calibration, references) -> tuple:
    """The fit from the start ``b0``, ``s0``, ``dip0``, with the hard iron's drift (M5) where the poses show it:
    ``(theta, sigma, cov, scale)``."""
    use = eq.use
    theta = np.concatenate([b0, [s0[i, j] for i, j in _SYM], np.zeros(3), [dip0]])
    scale = np.concatenate([np.full(3, 1.0 / np.abs(s0).max()), np.full(6, np.abs(s0).max()), np.ones(4)])
    sigma = np.array([1e-3, 1e-2, 1e-2, 1e-2])
    theta, sigma = eq.solve(theta, scale, sigma)

    # (M5): the hard iron drifting linearly in time (a die warming up, currents nearby), kept only where the
    # poses show it: the drift's χ² against its own covariance beyond the 99.9 % point of χ²(3)
    use_static = use.copy()
    th_d, sig_d = eq.solve(np.concatenate([theta, np.zeros(3)]), np.concatenate([scale, np.full(3, scale[0])]),
                           sigma)
    scale_d = np.concatenate([scale, np.full(3, scale[0])])
    cov_d = eq.covariance(th_d, sig_d, scale_d, calibration, references)
    drift_chi2 = float(th_d[13:] @ np.linalg.solve(cov_d[13:, 13:], th_d[13:])) if np.all(np.isfinite(cov_d)) \
        else 0.0
    if drift_chi2 > DRIFT_CHI2:
        theta, sigma, cov, scale = th_d, sig_d, cov_d, scale_d
    else:
        use[:] = use_static
        cov = eq.covariance(theta, sigma, scale, calibration, references)
    return theta, sigma, cov, scale


def _model(unpacked: tuple, unit_raw: str, field: float | None) -> tuple:
    """The magnetometer model of the fitted parameters (``unpacked``: :meth:`_PoseEquations.unpack`'s), with
    its alignment, dip and drift."""
    b, s, o, dip, drift = unpacked
    if np.linalg.det(s) <= 0 or np.any(np.linalg.eigvalsh(s) <= 0):
        raise ValueError("the magnetometer fit did not give a positive definite soft-iron matrix: the poses "
                         "do not spread the field over enough directions")
    f_norm, unit = _field_norm(unit_raw, field, s)
    return MagnetometerModel(bias=b, soft_iron=s, alignment=o, field_norm=f_norm, unit=unit), o, dip, drift


def _field_norm(unit_raw: str, field: float | None, s: np.ndarray) -> tuple[float, str]:
    """The calibrated field's magnitude ``F`` and unit (the module docstring's calibrated unit)."""
    if field is not None:
        f_norm, unit = float(field), "uT"
    elif unit_raw in ("uT", "gauss"):
        f_norm, unit = float(np.linalg.det(s) ** (-1.0 / 3.0)) * (100.0 if unit_raw == "gauss" else 1.0), "uT"
    else:
        f_norm, unit = 1.0, "normalised"
    return f_norm, unit


def _named_errors(cov: np.ndarray, sd: np.ndarray, o: np.ndarray) -> dict:
    """1σ by name (``sd`` the square roots of ``cov``'s diagonal)."""
    # the alignment as a small rotation about the accelerometer's axes: O Exp(φ) Oᵀ is the
    # rotation det(O)·O φ, so ψ = det(O) O φ and cov_ψ = O cov_φ Oᵀ
    unc = {f"magnetometer.bias.{a}": float(sd[i]) for i, a in enumerate(AXES)}
    for k, (i, j) in enumerate(_SYM):
        unc[f"magnetometer.soft_iron.{AXES[i]}{AXES[j]}"] = float(sd[3 + k])
    cov_psi = o @ cov[9:12, 9:12] @ o.T
    for i, a in enumerate(AXES):
        unc[f"magnetometer.alignment_angle.{a}"] = float(np.sqrt(max(cov_psi[i, i], 0.0)))
    unc["magnetometer.dip"] = float(sd[12])
    return unc


def _figures(model: MagnetometerModel, eq: _PoseEquations, theta: np.ndarray, sd: np.ndarray, dip, drift,
             hemisphere: str) -> MagnetometerReport:
    """The magnetometer's record of the fit report: the poses, the rotations and the drift (M5)."""
    p = theta.size
    s, use, min_pose = model.soft_iron, eq.use, eq.min_pose
    fig = pose_figures(model, eq.mag_means - np.outer(min_pose, drift), eq.up, eq.rot)  # eq. (M5)
    err = fig["direction_errors_deg"][use]
    names, angle = model.axes()
    return MagnetometerReport(
        poses=len(eq.mag_means),
        norm_spread=fig["norm_spread"],
        dip_deg=float(np.degrees(dip)),
        dip_spread_deg=fig["dip_spread_deg"],
        direction_error_mean_deg=float(err.mean()) if err.size else None,
        direction_error_max_deg=float(err.max()) if err.size else None,
        rotations_left_out=int(np.count_nonzero(~use)),
        axes=names,
        alignment_rotation_deg=angle if np.isfinite(angle) else None,
        hemisphere=hemisphere,
        field_norms=fig["norms"].tolist(),
        dips_deg=fig["dips_deg"].tolist(),
        # (M5): raw units per minute, None when the poses show no drift; the bias is the one at the poses' mean time
        hard_iron_drift_per_min=drift.tolist() if p > 13 else None,
        hard_iron_drift_sigma_per_min=sd[13:16].tolist() if p > 13 else None,
        hard_iron_drift_over_session=float(np.linalg.norm(s @ drift) * np.ptp(min_pose)) if p > 13 else None,
    )


def _carried_covariance(calibration: Calibration, references, groups, theta, sigma, jac, cov) -> np.ndarray:
    """The accelerometer's and gyroscope's own 1σ carried into the magnetometer's parameters.

    The gravity directions and the rotations are inputs the fit holds fixed; to first order
    ``∂θ̂/∂x = −(JᵀJ)⁻¹ Jᵀ ∂r/∂x``, so each parameter ``x`` of the calibration with a 1σ in
    ``fit.uncertainty.sigma`` adds ``σ_x² (∂θ̂/∂x)(∂θ̂/∂x)ᵀ`` (their correlations are not kept in the
    calibration file and are left out).
    """
    unc = calibration.fit.uncertainty.sigma or {}
    values = calibration.parameters()
    extra = np.zeros_like(cov)
    base = np.concatenate([g / s for g, s in zip(groups(theta), sigma, strict=True)])
    pinv = cov @ jac.T
    for name, sd in unc.items():
        if not name.startswith(("accelerometer.", "gyroscope.")) or name not in values:
            continue
        if sd is None or not np.isfinite(sd) or sd <= 0:
            continue
        h = sd * 1e-2
        try:
            up, rot = references(calibration.with_parameters({name: values[name] + h}))
        except ValueError:
            continue
        moved = np.concatenate([g / s for g, s in zip(groups(theta, up, rot), sigma, strict=True)])
        sens = -pinv @ ((moved - base) / h)
        extra += np.outer(sens, sens) * sd**2
    return extra
