"""The ``wang2019`` scenario: a navigation-grade IMU on a low-precision turntable (Wang 2019, §5.1).

Model (Wang 2019, eqs. 2 and 6), outputs ``N`` in pulses per second::

    f = C_a (K_a1 N + K_a2 N² + K_a3 N³ + ∇)     C_a unit lower-triangular (eq. 5)
    ω = C_g (K_g1 N + K_g2 N² + ε)                C_g unit lower-triangular (eq. 8)

held canonically as ``TriadModel(shape="lower", output_bias=∇)`` in SI units
(:mod:`imucalib.conventions`). Truth drawn as §5.1 states: biases
U(−10⁴, 10⁴) µg, ``K1`` U(1, 5) µg/pulse,
``K2`` U(−5, 5) fg/pulse², ``K3`` U(−5, 5) zg/pulse³, misalignments
U(−5·10⁻⁴, 5·10⁻⁴); gyroscope (Table 3's distributions) bias U(−5, 5)·10⁻⁶ °/s,
``K1`` U(1, 5)·10⁻⁷ °/s/pulse, ``K2`` U(−5, 5)·10⁻¹⁷ °/s/pulse².

The plan (Figures 2 and 3 are missing from the text; derived from the
sensitivity analysis, eqs. 20–25 and 31–34):

* **15 positions** — the scale factors and the bias of axis ``i`` are most
  sensitive with axis ``i`` along gravity (eqs. 20–24): the six faces ±x, ±y,
  ±z; the misalignment ``E_ij`` with gravity in the ``i–j`` plane at 45° or
  135° to the axes (eq. 25): three directions in each of the x–y, x–z and y–z
  planes (45°, 135°, 225°), nine in all.
* **12 rotation pairs** — a clockwise and a counter-clockwise 360° turn at
  10 °/s about: each axis and its opposite (eqs. 32–33: the scale factors are
  most sensitive with the axis along the rotation vector; six) and, for
  ``E_gij`` (eq. 34), an axis in each of the three planes at 45° and at 135°
  to the plane's axes (six) — 12 pairs for the 9 parameters of eq. (30).

Turntable angle errors (3″, 3′ or 3°, 1σ) tilt every position and every
rotation axis away from the plan; the rotation angle itself (a full turn) is
exact, as a turntable's stop is.

Noise. §5.1 states one noise figure per sensor, the "random bias" of 100 µg
and 0.01 °/h (1σ). They are read here as the white noise of every output
sample, the usual convention of INS simulations, at 100 Hz. The paper states
neither its sample rate nor how long a position is held; the session holds
each position ``dwell_s`` = 300 s, a common hold for a navigation-grade unit
whose gyroscope bias is measured against the Earth rate, and turns at
10 °/s. One noise model then serves both parts: a position's mean carries
``σ/√(dwell·rate)`` (0.58 µg and 5.8·10⁻⁵ °/h), a turn's integrals
``∫N dt`` and ``∫N² dt`` come from its noisy 100 Hz samples. The dwell sets
the gyroscope bias error (eq. 35 against the 15 °/h Earth rate; the method
reaches the Cramér–Rao bound): with 100 s the largest axis's RMS is
1.7·10⁻⁸ °/s, 7 % above Table 3's largest; the paper's 2·10⁻⁹ °/s on y and z
would take one to two hours per position. (Drawing the 100 µg as a constant
offset per run instead changes nothing the method sees: the bias
distribution U(−10⁴, 10⁴) µg already covers it, and a constant gyroscope
offset cancels between a clockwise and a counter-clockwise turn.) Outputs
are what the method uses: position means and turn integrals, not a time
series.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..calibration import Calibration
from ..constants import DEG, DEG_PER_HOUR, EARTH_RATE, G0, MICRO_G
from ..kinematics import quat_from_rotvec, quat_to_matrix
from ..methods.wang2019 import _poly_norm_residuals, calibrate
from ..models import TriadModel

__all__ = ["EARTH_RATE", "G0", "NOISE", "PAPER_RMS", "TURNTABLE_ERRORS", "WangSession", "montecarlo",
           "parameter_errors_wang_units", "plan", "plan_report", "session"]

#: §5.1's "random bias" (1σ), applied as white noise per sample (module docstring)
NOISE = {"accelerometer": 100.0 * MICRO_G, "gyroscope": 0.01 * DEG_PER_HOUR}
TURNTABLE_ERRORS = {"3arcsec": 3 / 3600 * DEG, "3arcmin": 3 / 60 * DEG, "3deg": 3 * DEG}


@dataclass
class WangSession:
    """Averaged static outputs and integrated turn outputs with the truth."""

    positions_acc: np.ndarray  # (P, 3) mean accelerometer pulses/s per position
    positions_gyro: np.ndarray  # (P, 3) mean gyroscope pulses/s per position
    turn_sum: np.ndarray  # (R, 3) ∫(N⁺ − N⁻) dt, pulses
    turn_sum2: np.ndarray  # (R, 3) ∫(N⁺² − N⁻²) dt, pulses²/s
    turn_angle: np.ndarray  # (R,) the angle θ of each turn [rad]
    truth: Calibration
    latitude_deg: float
    turntable_error: str
    gravity: float = G0
    scenario: str = "wang2019"
    options: dict = field(default_factory=dict)
    seed: int | None = None  # the seed it was simulated with, when given as an int

    @property
    def recording(self):  # the methods registry asks for one; this scenario has none
        return None


def plan() -> tuple[np.ndarray, np.ndarray]:
    """The 15 gravity directions (body frame) and 12 rotation axes (body frame)."""
    s = np.sqrt(0.5)
    faces = np.vstack([np.eye(3), -np.eye(3)])
    planes = []
    for i, j in ((0, 1), (0, 2), (1, 2)):
        for a in (45, 135, 225):
            v = np.zeros(3)
            v[i], v[j] = np.cos(np.radians(a)), np.sin(np.radians(a))
            planes.append(v)
    positions = np.vstack([faces, planes])
    axes = []
    for i, j in ((0, 1), (0, 2), (1, 2)):
        for sign in (1, -1):
            v = np.zeros(3)
            v[i], v[j] = s, sign * s
            axes.append(v)
    axes = np.vstack([np.eye(3), -np.eye(3), axes])
    return positions, axes


def _frame_with_up(up: np.ndarray) -> np.ndarray:
    """A rotation matrix body→navigation (ENU) that puts the body vector ``up`` on +U."""
    up = up / np.linalg.norm(up)
    helper = np.array([1.0, 0, 0]) if abs(up[0]) < 0.9 else np.array([0, 1.0, 0])
    east = np.cross(helper, up)
    east /= np.linalg.norm(east)
    north = np.cross(up, east)
    return np.vstack([east, north, up])  # rows: nav axes in body coordinates → R_nb


def random_truth(rng) -> Calibration:
    """Truth drawn from §5.1's distributions, canonical SI units (raw = pulses/s)."""
    u = rng.uniform
    acc = TriadModel(
        misalignment=np.array([[1, 0, 0], [u(-5e-4, 5e-4), 1, 0], [u(-5e-4, 5e-4), u(-5e-4, 5e-4), 1]]),
        scale=u(1, 5, 3) * MICRO_G, scale_quadratic=u(-5, 5, 3) * 1e-15 * G0,
        scale_cubic=u(-5, 5, 3) * 1e-21 * G0,
        output_bias=u(-1e4, 1e4, 3) * MICRO_G, shape="lower")
    gyro = TriadModel(
        misalignment=np.array([[1, 0, 0], [u(-5e-4, 5e-4), 1, 0], [u(-5e-4, 5e-4), u(-5e-4, 5e-4), 1]]),
        scale=u(1, 5, 3) * 1e-7 * DEG, scale_quadratic=u(-5, 5, 3) * 1e-17 * DEG,
        output_bias=u(-5, 5, 3) * 1e-6 * DEG, shape="lower")
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=G0, method="truth", model="wang2019",
                       units={"accelerometer": {"raw": "counts", "calibrated": "m/s^2"},
                              "gyroscope": {"raw": "counts", "calibrated": "rad/s"}})


def session(rng=None, *, turntable_error: str = "3arcsec", latitude_deg: float = 32.0,
            noise: dict | None = None, truth: Calibration | None = None,
            rate_deg_s: float = 10.0, sample_rate: float = 100.0, dwell_s: float = 300.0) -> WangSession:
    """Simulate one calibration (positions and CW/CCW turn pairs) with a drawn truth.

    ``noise`` overrides the white noise per sample, ``{"accelerometer": m/s²,
    "gyroscope": rad/s}`` (defaults: §5.1's 100 µg and 0.01 °/h); 0 gives
    noise-free outputs. The latitude (default 32°, Nanjing, where the paper's
    authors work) sets the Earth rate's direction, not its magnitude.
    """
    seed = int(rng) if isinstance(rng, int | np.integer) else None
    rng = np.random.default_rng(rng)
    if turntable_error not in TURNTABLE_ERRORS:
        raise ValueError(f"turntable_error must be one of {', '.join(TURNTABLE_ERRORS)}; "
                         f"got {turntable_error!r}")
    unknown = set(noise or {}) - set(NOISE)
    if unknown:
        raise ValueError(f"unknown noise key(s) {', '.join(sorted(unknown))}; use {', '.join(NOISE)}")
    if any(not np.isfinite(v) or v < 0 for v in (noise or {}).values()):
        raise ValueError(f"noise levels must be finite and non-negative; got {noise}")
    if dwell_s <= 0 or sample_rate <= 0 or rate_deg_s <= 0:
        raise ValueError("dwell_s, sample_rate and rate_deg_s must be positive")
    sigma_tt = TURNTABLE_ERRORS[turntable_error]
    noise = {**NOISE, **(noise or {})}
    mean_factor = 1.0 / np.sqrt(dwell_s * sample_rate)  # white noise averaged over a position
    truth = truth or random_truth(rng)
    lat = np.radians(latitude_deg)
    w_ie_n = EARTH_RATE * np.array([0.0, np.cos(lat), np.sin(lat)])
    g_n = np.array([0.0, 0.0, G0])
    positions, axes = plan()
    acc_means, gyro_means = [], []
    for up in positions:
        tilt = quat_to_matrix(quat_from_rotvec(rng.normal(0, sigma_tt, 3)))
        r_nb = tilt @ _frame_with_up(up)  # body → nav, with the turntable's error
        f_b = r_nb.T @ g_n
        w_b = r_nb.T @ w_ie_n
        n_a = truth.accelerometer.inverse(f_b[None])[0]
        n_a = n_a + rng.normal(0, noise["accelerometer"] * mean_factor, 3) / truth.accelerometer.scale
        n_g = truth.gyroscope.inverse(w_b[None])[0]
        n_g = n_g + rng.normal(0, noise["gyroscope"] * mean_factor, 3) / truth.gyroscope.scale
        acc_means.append(n_a)
        gyro_means.append(n_g)
    # turns: the body axis `a` is put vertical (with a tilt error) and turned a full circle
    rate = np.radians(rate_deg_s)
    duration = 2 * np.pi / rate
    t = np.arange(int(round(duration * sample_rate)) + 1) / sample_rate
    dt = np.diff(t)
    sums, sums2 = [], []
    for a in axes:
        r0 = quat_to_matrix(quat_from_rotvec(rng.normal(0, sigma_tt, 3))) @ _frame_with_up(a)  # body→nav rows
        out = []
        for sign in (1.0, -1.0):
            # attitude: body turns about its own axis `a` at sign·rate; in nav the same vertical turn
            ang = sign * rate * t
            turn = quat_to_matrix(quat_from_rotvec(np.outer(ang, [0.0, 0.0, 1.0])))  # nav rotation
            r_bn = np.einsum("ij,njk->nik", r0.T, turn.transpose(0, 2, 1))  # body←nav at each t
            w_b = np.einsum("nij,j->ni", r_bn, w_ie_n) + sign * rate * (r0.T @ [0.0, 0.0, 1.0])
            n_g = truth.gyroscope.inverse(w_b)
            n_g = n_g + rng.normal(0, noise["gyroscope"], n_g.shape) / truth.gyroscope.scale
            mid, mid2 = 0.5 * (n_g[1:] + n_g[:-1]), 0.5 * (n_g[1:] ** 2 + n_g[:-1] ** 2)
            out.append((mid.T @ dt, mid2.T @ dt))  # trapezoidal ∫N dt, ∫N² dt
        sums.append(out[0][0] - out[1][0])
        sums2.append(out[0][1] - out[1][1])
    return WangSession(
        positions_acc=np.array(acc_means), positions_gyro=np.array(gyro_means),
        turn_sum=np.array(sums), turn_sum2=np.array(sums2), turn_angle=np.full(len(axes), 2 * np.pi),
        truth=truth, latitude_deg=latitude_deg, turntable_error=turntable_error,
        options={"noise": noise, "rate_deg_s": rate_deg_s, "sample_rate": sample_rate, "dwell_s": dwell_s},
        seed=seed,
    )


# ------------------------------------------------------- the §5.1 experiment
def parameter_errors_wang_units(estimate: Calibration, truth: Calibration) -> dict[str, np.ndarray]:
    """Errors in the units of Wang 2019, Tables 2–3 (µg, µg/pulse, fg/pulse², zg/pulse³, 1e-4…)."""
    a, ta = estimate.accelerometer, truth.accelerometer
    g, tg = estimate.gyroscope, truth.gyroscope
    low = [(1, 0), (2, 0), (2, 1)]
    return {
        "acc_bias_ug": (a.output_bias - ta.output_bias) / MICRO_G,
        "acc_k1_ug_per_pulse": (a.scale - ta.scale) / MICRO_G,
        "acc_k2_fg_per_pulse2": (a.scale_quadratic - ta.scale_quadratic) / (1e-15 * G0),
        "acc_k3_zg_per_pulse3": (a.scale_cubic - ta.scale_cubic) / (1e-21 * G0),
        "acc_misalignment_1e-4": np.array([a.misalignment[i] - ta.misalignment[i] for i in low]) / 1e-4,
        "gyro_bias_1e-6_deg_s": (g.output_bias - tg.output_bias) / (1e-6 * DEG),
        "gyro_k1_1e-7_deg_s_pulse": (g.scale - tg.scale) / (1e-7 * DEG),
        "gyro_k2_1e-17_deg_s_pulse2": (g.scale_quadratic - tg.scale_quadratic) / (1e-17 * DEG),
        "gyro_misalignment_1e-4": np.array([g.misalignment[i] - tg.misalignment[i] for i in low]) / 1e-4,
    }


#: Wang 2019, Tables 2-3: RMS of the 500-run Monte Carlo per axis (x, y, z; misalignments yx, zx, zy)
PAPER_RMS = {
    "3arcsec": {"acc_bias_ug": [1.90, 2.02, 1.96], "acc_k1_ug_per_pulse": [1.90e-5, 3.35e-5, 1.86e-5],
                "acc_k2_fg_per_pulse2": [4.93e-2, 4.64e-2, 4.72e-2], "acc_k3_zg_per_pulse3": [0.37, 0.62, 0.37],
                "acc_misalignment_1e-4": [1.91e-2, 1.90e-2, 1.87e-2],
                "gyro_bias_1e-6_deg_s": [1.58e-2, 1.94e-3, 2.04e-3],
                "gyro_k1_1e-7_deg_s_pulse": [3.14e-8, 6.27e-8, 3.88e-8],
                "gyro_k2_1e-17_deg_s_pulse2": [9.40e-2, 2.73e-2, 7.18e-2],
                "gyro_misalignment_1e-4": [1.18e-4, 1.18e-4, 8.02e-5]},
    "3arcmin": {"acc_bias_ug": [1.91, 2.01, 1.96], "acc_k1_ug_per_pulse": [1.90e-5, 3.35e-5, 1.86e-5],
                "acc_k2_fg_per_pulse2": [4.94e-2, 4.64e-2, 4.72e-2], "acc_k3_zg_per_pulse3": [0.38, 0.62, 0.37],
                "acc_misalignment_1e-4": [1.91e-2, 1.90e-2, 1.87e-2],
                "gyro_bias_1e-6_deg_s": [1.58e-2, 1.95e-3, 2.03e-3],
                "gyro_k1_1e-7_deg_s_pulse": [1.73e-8, 4.50e-8, 1.90e-8],
                "gyro_k2_1e-17_deg_s_pulse2": [0.15, 2.92e-2, 3.53e-2],
                "gyro_misalignment_1e-4": [1.90e-4, 1.90e-4, 4.17e-5]},
    "3deg": {"acc_bias_ug": [2.11, 1.95, 2.06], "acc_k1_ug_per_pulse": [2.04e-5, 3.41e-5, 1.81e-5],
             "acc_k2_fg_per_pulse2": [5.40e-2, 4.52e-2, 4.94e-2], "acc_k3_zg_per_pulse3": [0.40, 0.63, 0.35],
             "acc_misalignment_1e-4": [1.90e-2, 1.87e-2, 1.97e-2],
             "gyro_bias_1e-6_deg_s": [1.57e-2, 1.94e-3, 2.01e-3],
             "gyro_k1_1e-7_deg_s_pulse": [1.87e-8, 6.51e-8, 1.68e-8],
             "gyro_k2_1e-17_deg_s_pulse2": [0.10, 6.14e-2, 1.19e-2],
             "gyro_misalignment_1e-4": [1.41e-4, 1.31e-4, 1.81e-5]},
}


def _mc_run(args):
    seed, turntable_error, initial, noise, dwell_s = args
    sim = session(seed, turntable_error=turntable_error, noise=noise, dwell_s=dwell_s)
    try:
        cal = calibrate(sim, initial=initial)
    except (ValueError, np.linalg.LinAlgError) as exc:
        return {"seed": seed, "error": str(exc)}
    return {"seed": seed, "errors": parameter_errors_wang_units(cal, sim.truth)}


#: divergence: an error beyond the parameter's own spread (its §5.1 distribution's half-width)
DIVERGENCE = {"acc_bias_ug": 1e4, "acc_k1_ug_per_pulse": 2.0, "acc_k2_fg_per_pulse2": 5.0,
              "acc_k3_zg_per_pulse3": 5.0, "acc_misalignment_1e-4": 5.0,
              "gyro_bias_1e-6_deg_s": 5.0, "gyro_k1_1e-7_deg_s_pulse": 2.0,
              "gyro_k2_1e-17_deg_s_pulse2": 5.0, "gyro_misalignment_1e-4": 5.0}


def montecarlo(runs: int = 500, *, turntable_error: str = "3arcsec", seed: int = 0,
               initial: str = "estimate", workers: int = 1, noise: dict | None = None,
               dwell_s: float = 300.0) -> dict:
    """Wang 2019 §5.1 Monte Carlo: RMS errors per parameter (Tables 2–3 units), divergent runs.

    A run diverges when any error exceeds :data:`DIVERGENCE` (the half-width of
    that parameter's distribution: the estimate is no better than a guess).
    ``paper_rms`` holds the same column of Tables 2–3; ``within_paper`` says,
    per parameter group, whether the largest axis's RMS is at or below the
    table's largest. Groups are compared by their largest axis because which
    axis carries the larger error depends on the rotation plan, and the
    paper's plan (its Figs. 2–3) is not in its text.
    """
    if runs < 1:
        raise ValueError(f"runs must be at least 1; got {runs}")
    jobs = [(seed + i, turntable_error, initial, noise, dwell_s) for i in range(runs)]
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as ex:
            results = list(ex.map(_mc_run, jobs, chunksize=8))
    else:
        results = [_mc_run(j) for j in jobs]
    ok = [r for r in results if "errors" in r]
    diverged = [r["seed"] for r in ok
                if any(np.any(np.abs(r["errors"][k]) > lim) for k, lim in DIVERGENCE.items())]
    good = [r for r in ok if r["seed"] not in set(diverged)]
    rms = {k: np.sqrt(np.mean([r["errors"][k] ** 2 for r in good], axis=0)).tolist() if good else None
           for k in DIVERGENCE}
    mean = {k: np.mean([r["errors"][k] for r in good], axis=0).tolist() if good else None
            for k in DIVERGENCE}
    paper = PAPER_RMS[turntable_error]
    within = {k: bool(rms[k] is not None and max(rms[k]) <= max(paper[k])) for k in DIVERGENCE}
    return {"scenario": "wang2019", "method": "wang2019", "runs": runs,
            "turntable_error": turntable_error, "initial": initial, "noise": noise or {}, "dwell_s": dwell_s,
            "rms": rms, "mean": mean, "paper_rms": paper, "within_paper": within,
            "divergent_runs": len(diverged), "divergent_seeds": diverged[:20],
            "failures": [{"seed": r["seed"], "message": r["error"]} for r in results if "error" in r]}


def plan_report(seed: int = 0) -> dict:
    """The position and rotation plan with each parameter's sensitivity and Fisher information.

    For a typical truth (drawn with ``seed``) and the noise of the scenario, the
    Jacobians of eqs. (18), (30) and (35) at the truth give, per parameter, the
    RMS sensitivity of the residuals (eqs. 20–25, 31–34) and the diagonal of
    the Fisher information ``JᵀJ/σ²`` with the Cramér–Rao standard deviation
    from its inverse; finite values for every parameter show that the plan
    observes them all.
    """
    sim = session(seed)
    t = sim.truth
    positions, axes = plan()
    a, g = t.accelerometer, t.gyroscope
    na, ng = sim.positions_acc, sim.positions_gyro
    ns, ns2 = sim.turn_sum, sim.turn_sum2
    low = [(1, 0), (2, 0), (2, 1)]
    xa = np.concatenate([a.scale, a.scale_quadratic, a.scale_cubic, [a.misalignment[i] for i in low],
                         a.output_bias])
    xg = np.concatenate([g.scale, g.scale_quadratic, [g.misalignment[i] for i in low]])
    one = np.ones(15)
    _, ja = _poly_norm_residuals(xa, one, [na, na**2, na**3], 3, sim.gravity**2, True, jac=True)
    _, jg = _poly_norm_residuals(xg, np.ones(9), [ns, ns2], 2, (2 * sim.turn_angle) ** 2, False, jac=True)
    kg = xg[:6].reshape(2, 3)
    _, jb = _poly_norm_residuals(g.output_bias, np.ones(3), [ng, ng**2], 2, EARTH_RATE**2, True,
                                 k_fixed=(kg, xg[6:9]), jac=True)
    # residual noise: σ of ‖f‖² − g² from the position means (white noise averaged over the dwell);
    # of ‖2θ‖² from the turn integrals (white noise integrated over a clockwise and a counter-clockwise turn)
    o = sim.options
    per_mean = 1.0 / np.sqrt(o["dwell_s"] * o["sample_rate"])
    s_a = 2 * sim.gravity * o["noise"]["accelerometer"] * per_mean
    s_g = 2 * (4 * np.pi) * np.sqrt(2 * 360 / o["rate_deg_s"] / o["sample_rate"]) * o["noise"]["gyroscope"]
    s_b = 2 * EARTH_RATE * o["noise"]["gyroscope"] * per_mean
    names_a = [f"K_a1{c}" for c in "xyz"] + [f"K_a2{c}" for c in "xyz"] + [f"K_a3{c}" for c in "xyz"] \
        + ["E_ayx", "E_azx", "E_azy"] + [f"bias_a{c}" for c in "xyz"]
    names_g = [f"K_g1{c}" for c in "xyz"] + [f"K_g2{c}" for c in "xyz"] + ["E_gyx", "E_gzx", "E_gzy"]
    names_b = [f"bias_g{c}" for c in "xyz"]
    out = []
    for names, jac, sigma, x in ((names_a, ja, s_a, xa), (names_g, jg, s_g, xg),
                                 (names_b, jb, s_b, g.output_bias)):
        fisher = jac.T @ jac / sigma**2
        col = np.linalg.norm(jac, axis=0)
        js = jac / col  # scaled columns keep the inverse accurate across 40 orders of magnitude
        cov_s = np.linalg.pinv(js.T @ js) * sigma**2
        crlb = np.sqrt(np.clip(np.diag(cov_s), 0, None)) / col
        rank = int(np.linalg.matrix_rank(js))
        for k, name in enumerate(names):
            out.append({"parameter": name, "value": float(x[k]),
                        "sensitivity_rms": float(np.sqrt(np.mean(jac[:, k] ** 2))),
                        "fisher_information": float(fisher[k, k]), "crlb_std": float(crlb[k]),
                        "observable": bool(rank == len(names))})
    return {"positions_gravity_body": positions.tolist(), "rotation_axes_body": axes.tolist(),
            "turn_angle_deg": 360.0, "parameters": out}
