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

import numpy as np

from ..calibration import Calibration
from ..constants import DEG, DEG_PER_HOUR, EARTH_RATE, G0, MICRO_G
from ..kinematics import quat_from_rotvec, quat_to_matrix
from ..models import TriadModel
from ..sessions import WangSession

__all__ = ["EARTH_RATE", "G0", "NOISE", "TURNTABLE_ERRORS", "WangSession", "plan", "random_truth", "session"]

#: §5.1's "random bias" (1σ), applied as white noise per sample (module docstring)
NOISE = {"accelerometer": 100.0 * MICRO_G, "gyroscope": 0.01 * DEG_PER_HOUR}
TURNTABLE_ERRORS = {"3arcsec": 3 / 3600 * DEG, "3arcmin": 3 / 60 * DEG, "3deg": 3 * DEG}


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
