"""Qureshi & Golnaraghi (IEEE Sensors J. 2017): in-field calibration of a MEMS IMU.

Accelerometer (§III-A): the 9-parameter model ``A^o = K T_s^o (A^s − B)``
(eqs. 2–8; canonically ``T_a diag(k1) = K T_s^o``, see :mod:`imucalib.conventions`)
fitted on interval means (eq. 11)::

    G(X) = Σ_k (‖h(Ā_k, X)‖² − g²)²,   X = [b, k, k_xy, k_xz, k_yz]

by Newton's method with a backtracking line search (eq. 12), from the relaxed
six-position estimate ``k = (a_up − a_down)/(2g)``, ``b = (a_up + a_down)/2``
(eqs. 13–14) with the up/down poses found automatically (:mod:`.six_position`).

Gyroscope (§III-B), ``ω = K(ω^s − B)`` (eq. 15): rotations about each sensitive
axis between static poses; the angle of each rotation is measured by the
calibrated accelerometer (appendix, eqs. 22–28: the tilt change about a
horizontal axis, computed here as the signed angle between the gravity
directions before and after, about the rotation axis). Then either

* ``"static"`` — ``b`` is the mean of the initial rest and
  ``k_i = Δθ_ik / ((ω̄_ik − b_i) T_k)`` (eq. 18), combined over the rotations
  ``k`` about axis ``i`` by least squares; or
* ``"dynamic"`` — ``[ω̄_ik T_k, −T_k] [k_i, k_i b_i]ᵀ = Δθ_ik`` solved by least
  squares for ``k_i`` and ``b_i`` together (eqs. 19–21).

``fit["uncertainty"]``: the accelerometer's 1σ errors from the gravity-norm
residuals' Jacobian at the solution (as :mod:`.tedaldi2014`), the
gyroscope's from each axis's least-squares regression over its turns (NaN
with as many turns as unknowns).

A rotation counts for axis ``i`` when its integrated raw rate lies within 20°
of that axis, the axis is at least 45° from gravity and the turn is below
170° (a half turn's sign is ambiguous); turns whose eq. (18) scale differs
from the axis's median by more than 10 % are left out as not clean (the accelerometer
cannot see rotations about gravity, hence the paper's Fig. 2 sequence that
turns ``z`` horizontal first).
"""

from __future__ import annotations

import numpy as np

from ..calibration import Calibration
from ..conventions import from_qureshi, to_qureshi
from ..metrics import fit_summary, interval_means, transition_bounds
from ..models import TriadModel
from ..solve import standard_errors
from .six_position import find_faces
from .tedaldi2014 import accelerometer_errors, detect_intervals

__all__ = ["calibrate", "calibrate_accelerometer", "montecarlo", "newton_backtracking", "rotation_angles"]


def _g_and_derivatives(x: np.ndarray, means: np.ndarray, gravity: float):
    """G(X) (eq. 11), its gradient and its Hessian (exact, analytic)."""
    b, k, kxy, kxz, kyz = x[:3], x[3:6], x[6], x[7], x[8]
    m = np.array([[k[0], kxy, kxz], [0.0, k[1], kyz], [0.0, 0.0, k[2]]])
    d = means - b  # (N, 3)
    h = d @ m.T  # eq. (8)
    r = np.sum(h * h, axis=1) - gravity**2
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
    value = float(r @ r)
    grad = 2 * dr.T @ r
    hess = 2 * (dr.T @ dr + np.einsum("n,npq->pq", r, d2r))
    return value, grad, hess


def newton_backtracking(x0: np.ndarray, means: np.ndarray, gravity: float, *, max_iter: int = 100,
                        tol: float = 1e-14) -> tuple[np.ndarray, int]:
    """Minimise eq. (11) by Newton's method with an Armijo backtracking line search (eq. 12).

    Where the Hessian is not positive definite the step falls back to steepest
    descent. Returns the minimiser and the number of iterations.
    """
    x = np.array(x0, dtype=float)
    scale = np.maximum(np.abs(x), 1e-3)  # work in relative units for conditioning
    for it in range(1, max_iter + 1):
        value, grad, hess = _g_and_derivatives(x, means, gravity)
        gs, hs = grad * scale, hess * scale[:, None] * scale[None, :]
        try:
            c = np.linalg.cholesky(hs)
            step = -np.linalg.solve(c.T, np.linalg.solve(c, gs))
        except np.linalg.LinAlgError:
            step = -gs
        t = 1.0
        while True:  # backtracking: sufficient decrease (Armijo, c = 1e-4), halving t
            trial = x + t * step * scale
            if _g_and_derivatives(trial, means, gravity)[0] <= value + 1e-4 * t * (gs @ step) or t < 1e-12:
                break
            t *= 0.5
        x = trial
        if np.max(np.abs(t * step)) < tol or value == 0.0:
            return x, it
    return x, max_iter


def calibrate_accelerometer(means: np.ndarray, gravity: float) -> tuple[TriadModel, dict]:
    """The 9-parameter accelerometer of Qureshi 2017 on static means."""
    faces = find_faces(means, gravity, max_tilt=30.0)
    up = means[faces[:3], np.arange(3)]
    down = means[faces[3:], np.arange(3)]
    k0 = (up - down) / (2 * gravity)  # eq. (13): raw per m/s²
    b0 = (up + down) / 2  # eq. (14)
    x0 = np.concatenate([b0, 1.0 / k0, np.zeros(3)])  # X uses k in m/s² per raw (eq. 5's K)
    if means.shape[0] < 9:
        raise ValueError(f"the 9-parameter model needs at least 9 static poses; got {means.shape[0]}")
    x, iterations = newton_backtracking(x0, means, gravity)
    return from_qureshi(x), {"newton_iterations": iterations, "X": x.tolist(),
                             "X_initial": x0.tolist()}


def rotation_angles(recording, intervals, acc_model: TriadModel, bias: np.ndarray, *,
                    axis_tolerance: float = 20.0, min_tilt: float = 45.0,
                    max_angle: float = 170.0) -> list[dict]:
    """Rotations between consecutive static poses: axis, accelerometer angle, mean raw rate, duration."""
    a = acc_model.forward(interval_means(recording.acc, intervals))
    u = a / np.linalg.norm(a, axis=1, keepdims=True)
    starts, stops = transition_bounds(intervals)
    out = []
    for k, (s0, s1) in enumerate(zip(starts, stops, strict=True)):
        raw = recording.gyro[s0 : s1 + 1]
        t = recording.t[s0 : s1 + 1]
        total = np.trapezoid(raw - bias, t, axis=0)
        i = int(np.argmax(np.abs(total)))
        e = np.zeros(3)
        e[i] = 1.0
        off_axis = np.degrees(np.arccos(np.clip(abs(total[i]) / np.linalg.norm(total), 0, 1)))
        tilt = np.degrees(np.arccos(np.clip(abs(u[k] @ e), 0, 1)))
        if off_axis > axis_tolerance or tilt < min_tilt:
            continue
        # body turns by +θ about e ⇒ gravity turns by −θ: θ = −atan2((g₀ × g₁)·e, g₀·g₁)
        # (the tilt change of eqs. 23–28 about a horizontal axis)
        theta = -np.arctan2(np.cross(u[k], u[k + 1]) @ e, u[k] @ u[k + 1])
        if abs(theta) > np.radians(max_angle):  # ±180° is ambiguous: the sign flips with noise
            continue
        duration = float(t[-1] - t[0])
        out.append({"axis": i, "angle": float(theta), "mean_rate": float(np.mean(raw[:, i])),
                    "duration": duration,
                    "mean_rate_trapezoid": float(np.trapezoid(raw[:, i], t) / duration)})
    return out


def calibrate(recording, *, gravity: float, intervals=None, gyroscope: str = "static",
              init_static: float | None = None) -> Calibration:
    """Qureshi 2017: Newton accelerometer fit, then gyroscope scales from accelerometer-measured turns.

    Parameters
    ----------
    gyroscope : {"static", "dynamic"}
        The static-bias approach (eq. 18) or the dynamic approach (eqs. 19–21).
    """
    if gyroscope not in ("static", "dynamic"):
        raise ValueError(f"gyroscope must be 'static' or 'dynamic'; got {gyroscope!r}")
    if intervals is None:
        intervals = detect_intervals(recording, gravity, init_static=init_static)[0]
    intervals = [iv for iv in intervals if iv.kind == "static"]
    means = interval_means(recording.acc, intervals)
    acc, info = calibrate_accelerometer(means, gravity)
    rest_bias = recording.gyro[intervals[0].slice].mean(axis=0)
    rotations = rotation_angles(recording, intervals, acc, rest_bias)
    k = np.empty(3)
    b = rest_bias.copy()
    rejected = [0, 0, 0]
    errors = accelerometer_errors(acc, means, gravity)
    for i in range(3):
        rows = [r for r in rotations if r["axis"] == i]
        need = 1 if gyroscope == "static" else 2
        if len(rows) < need:
            raise ValueError(
                f"no usable rotation about the {'xyz'[i]} axis ({len(rows)} found, {need} needed): "
                "rotate about each axis while it is horizontal (at least 45° from gravity), "
                "as in the paper's Fig. 2"
            )
        theta = np.array([r["angle"] for r in rows])
        tk = np.array([r["duration"] for r in rows])
        wbar = np.array([r["mean_rate_trapezoid"] for r in rows])
        # consensus: a turn whose eq. (18) scale disagrees with the median by > 10 % was not a
        # clean turn about the axis (or crossed ±180°); it is left out
        k_each = theta / ((wbar - rest_bias[i]) * tk)
        good = np.abs(k_each / np.median(k_each) - 1) < 0.1
        if np.count_nonzero(good) < need:
            raise ValueError(f"the turns about the {'xyz'[i]} axis disagree (eq. 18 scales "
                             f"{np.round(k_each, 9).tolist()}): turn about one axis at a time")
        theta, tk, wbar = theta[good], tk[good], wbar[good]
        rejected[i] = int(np.count_nonzero(~good))
        if gyroscope == "static":
            # eq. (18) for each rotation, combined by least squares over k
            x = (wbar - rest_bias[i]) * tk
            k[i] = float(x @ theta / (x @ x))
            errors[f"gyroscope.scale.{'xyz'[i]}"] = float(standard_errors(x[:, None], k[i] * x - theta)[0])
        else:
            a_mat = np.column_stack([wbar * tk, -tk])  # eq. (19)
            sol = np.linalg.solve(a_mat.T @ a_mat, a_mat.T @ theta)  # eq. (21)
            k[i], b[i] = sol[0], sol[1] / sol[0]
            to_kb = np.array([[1.0, 0.0], [-sol[1] / sol[0] ** 2, 1.0 / sol[0]]])  # (k, k·b) → (k, b)
            se = standard_errors(a_mat, a_mat @ sol - theta, transform=to_kb)
            errors[f"gyroscope.scale.{'xyz'[i]}"], errors[f"gyroscope.bias.{'xyz'[i]}"] = map(float, se)
    gyro = TriadModel(scale=k, bias=b, shape="full")
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="qureshi2017",
                      model="linear",
                      units={"accelerometer": {"raw": recording.acc_unit, "calibrated": "m/s^2"},
                             "gyroscope": {"raw": recording.gyro_unit, "calibrated": "rad/s"}})
    fit = fit_summary(cal, recording, intervals, gravity)
    fit.update(newton_iterations=info["newton_iterations"], gyroscope_approach=gyroscope,
               rotations_used=[sum(r["axis"] == i for r in rotations) - rejected[i] for i in range(3)],
               rotations_rejected=rejected,
               qureshi_X=to_qureshi(acc).tolist(), uncertainty=errors)
    return cal.with_(fit=fit)


def _mc_run(seed: int) -> dict:
    from ..simulate import qureshi_session, qureshi_validation

    rec, iv, truth = qureshi_session(seed)
    v = qureshi_validation(truth, seed + 1_000_003)  # 92 fresh orientations, raw in g
    out = {"seed": seed, "raw_rms_g": float(np.sqrt(np.mean((np.linalg.norm(v, axis=1) - 1.0) ** 2)))}
    for approach in ("static", "dynamic"):
        cal = calibrate(rec, gravity=truth.gravity, intervals=iv, gyroscope=approach)
        rel = cal.gyroscope.scale / truth.gyroscope.scale - 1
        out[f"gyro_scale_rel_error_{approach}"] = rel.tolist()
    a = cal.accelerometer.forward(v) / truth.gravity
    out["calibrated_rms_g"] = float(np.sqrt(np.mean((np.linalg.norm(a, axis=1) - 1.0) ** 2)))
    return out


def montecarlo(runs: int = 20, *, seed: int = 0, workers: int = 1) -> dict:
    """Qureshi 2017, §IV on simulation: the 18-orientation session with Table II-like truth, ``runs`` times.

    Per run, RMS(‖a‖ − g) over 92 fresh orientations raw and calibrated [g]
    (the paper: 0.0129 g → 0.0014 g) and the gyroscope scales' relative
    errors with the static-bias and the dynamic approach (the paper's
    agreement with a rate table: within 0.41 %). Returns the means, the
    worst run and the per-run figures.
    """
    if runs < 1:
        raise ValueError(f"runs must be at least 1; got {runs}")
    seeds = [seed + i for i in range(runs)]
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as ex:
            results = list(ex.map(_mc_run, seeds))
    else:
        results = [_mc_run(s) for s in seeds]
    fold = [r["raw_rms_g"] / r["calibrated_rms_g"] for r in results]
    worst = {a: float(max(np.max(np.abs(r[f"gyro_scale_rel_error_{a}"])) for r in results))
             for a in ("static", "dynamic")}
    return {"scenario": "qureshi2017", "method": "qureshi2017", "runs": runs,
            "raw_rms_g_mean": float(np.mean([r["raw_rms_g"] for r in results])),
            "calibrated_rms_g_mean": float(np.mean([r["calibrated_rms_g"] for r in results])),
            "reduction_fold_min": float(min(fold)), "reduction_fold_mean": float(np.mean(fold)),
            "gyro_scale_rel_error_max": worst, "per_run": results}
