"""The ``handheld`` scenario: a consumer IMU calibrated by hand, with what real hands add.

Real calibration sessions recorded by people differ from the clean simulations
of the papers (Zhang 2021, §IV-A) in ways that break methods: the "static"
poses shake, some motions are turns about the vertical that the accelerometer
cannot see, the hand settles for a moment after each pose, the logger drops
samples and jitters its timestamps, and the gyroscope bias drifts. This
scenario reproduces them one knob at a time, so that each failure can be
replayed in a test; :data:`CLEAN` switches every one of them off.

The sensor
----------
:func:`consumer_truth` draws an MPU-6050/ICM-20948-class IMU in raw 16-bit
counts from the tolerances of the MPU-6000/MPU-6050 Product Specification
(rev. 3.4, §6.1 gyroscope, §6.2 accelerometer): ±2 g at 16384 counts/g,
±250 °/s at 131 counts/(°/s), ±3 % scale tolerance, ±2 % cross-axis
sensitivity, 0.1 °/s/g linear-acceleration sensitivity. Its noise
(:func:`datasheet_noise`) is the datasheet's spectral densities, 400 µg/√Hz
and 0.005 °/s/√Hz, times √(rate/2) (white noise over the Nyquist band).
Raw readings follow the canonical model inverted (Zhang 2021, eqs. 31–32,
:func:`~imucalib.scenarios.base.distort`), then bias drift, rounding to
integer counts and saturation at the int16 range.

The motion
----------
True body rates are built on the sensor's own uniform sample clock from
fixed-axis rotations with an asymmetric speed profile
``s(τ) ∝ τ^α (1 − τ)^β`` (α, β random in [1.2, 3]: the bell of point-to-point
hand movements, Flash & Hogan 1985, made asymmetric as aiming movements are,
MacKenzie et al. 1987). The attitude is the RK4 integral of those sampled
rates (:func:`~imucalib.kinematics.integrate`, body → world), so the true
gravity directions and the true gyroscope agree as in
:func:`~imucalib.scenarios.base.pose_session`. The specific force in the body
frame is

    f = Rᵀ (g ẑ + p̈) + ω̇ × ρ + ω × (ω × ρ)

with ``g ẑ`` the reaction to gravity in the world frame (z up), ``p̈`` the
hand's translation (a minimum-jerk displacement during each motion, Flash &
Hogan 1985, eq. 2: ``p(τ) = d (10τ³ − 15τ⁴ + 6τ⁵)``) and the last two terms
the rigid-body acceleration of a sensor held at ``ρ`` from the rotation centre
of the hand (Zhang 2021, eqs. 17–18 with ``ρ = −r``). All of it is zero while
the hand is still.

Hand tremor is band-limited rate noise in two bands, postural sway
(0.5–2 Hz) and physiological tremor (8–12 Hz), of equal power: Gaussian noise
through zero-phase 2nd-order Butterworth band-passes, scaled to ``tremor``
°/s RMS (times a per-pose factor in [0.5, 1.5]), added to the body rate and
integrated into the attitude like any motion; its angular acceleration moves
the sensor through the ``ω̇ × ρ`` term. The initial rest lies on a table: no
tremor there.

Procedures
----------
``"poses"`` (Tedaldi 2014 as users do it): an initial rest, then ``n_poses``
holds of ``dwell`` s each, at gravity directions spread over the sphere (a
Fibonacci lattice in random order, each next one 40–140° away when possible),
joined by hand rotations with a random twist about the new vertical; some of
them (``hesitation``) in two sub-moves about different axes with a short
hesitation, some (``vertical_turns``) pure turns about the vertical, some
preceded or followed by a re-grasp (``reposition``): a tilt of
``regrasp_deg`` and back by the same angle ±5 %, with short pauses.

``"ferraris"`` (Ferraris 1995 as users do it): the initial rest (optionally a
``nudge_deg`` turn about the vertical at its end, set down on the same face),
six faces (+z first, the others in random order) held ``face_dwell`` s each
with re-grasps between them, then for each axis in random order: make it point
up, hold, re-grasp (tilt of tens of degrees and back), pause, four hand
quarter-turns of ``quarter`` s about that axis with ``quarter_pause`` s
between them, pause, re-grasp, hold.

Session layout
--------------
``segments`` are the truth in the recorded sample indices (after drops):
``"static"`` for every hold (the initial rest first, creep included as a
user's pose would include it) and ``"motion"`` for everything between (short
pauses included). ``options`` holds every knob and the facts: dropped samples,
creep and pause ranges, turns about the vertical, clipped values, drift, and
for the Ferraris procedure ``sections`` ``x_p, x_a, y_p, y_a, z_p, z_a`` (the
face holds; ``_p`` axis up, ``_a`` axis down) and ``x_rot, y_rot, z_rot`` (the
four quarter-turns with a few still samples either side), all ``[start, stop)``.

The returned ``truth`` is the calibration at the start of the session: the
given (or drawn) truth with its gyroscope bias moved by the turn-on offset.
The bias then drifts linearly and by a random walk; ``options`` records the
slopes and the bias at the end.

References: T. Flash, N. Hogan, "The coordination of arm movements", J.
Neurosci. 5(7), 1985; C. L. MacKenzie et al., "Three-dimensional movement
trajectories in Fitts' task", Q. J. Exp. Psychol. 39A, 1987; F. Ferraris et
al., "Procedure for effortless in-field calibration of three-axial rate gyro
and accelerometers", Sensors and Materials 7(5), 1995.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..calibration import Calibration
from ..kinematics import integrate, quat_from_rotvec, quat_multiply, quat_to_matrix
from ..recording import STANDARD_GRAVITY, ImucalibWarning, Interval, Recording
from ..thermal import REFERENCE_C, ThermalModel, decompensate, evaluate
from .base import attitude_with_up, distort
from .consumer_imu import (
    ACC_COUNTS_PER_G,
    ACC_NOISE_DENSITY,
    COUNTS_RANGE,
    GYRO_COUNTS_PER_DPS,
    GYRO_NOISE_DENSITY,
    MAGNETOMETER,
    consumer_truth,
    datasheet_noise,
    datasheet_thermal,
    noise_per_sample,
    simulate_magnetometer,
    thermometer_reading,
)
from .handmotion import UP, Timeline, ferraris_procedure, poses_procedure, tremor_noise, unit_vector

__all__ = ["ACC_COUNTS_PER_G", "ACC_NOISE_DENSITY", "CLEAN", "COUNTS_RANGE", "GYRO_COUNTS_PER_DPS",
           "GYRO_NOISE_DENSITY", "MAGNETOMETER", "consumer_truth", "datasheet_noise", "datasheet_thermal",
           "generate",
           "simulate_magnetometer"]

#: knob values that switch every nuisance off (a clean session of the same procedure)
CLEAN: dict = {
    "tremor": 0.0, "creep": 0, "hesitation": 0.0, "reposition": 0.0, "vertical_turns": 0.0,
    "lin_acc": 0.0, "lever": 0.0, "jitter": 0.0, "drop": 0.0, "gap": 0.0, "turn_on": 0.0,
    "gyro_drift": 0.0, "gyro_rw": 0.0, "acc_drift": 0.0, "quantise": False, "full_scale": None,
}


# ------------------------------------------------------------------ checks
def _range(name: str, v) -> tuple[float, float]:
    lo, hi = (v, v) if isinstance(v, int | float) else v
    if not (0 <= lo <= hi):
        raise ValueError(f"{name} must be a number ≥ 0 or a range (low, high) with 0 ≤ low ≤ high; got {v!r}")
    return float(lo), float(hi)


def _probability(name: str, v: float) -> float:
    if not 0 <= v <= 1:
        raise ValueError(f"{name} is a probability in [0, 1]; got {v!r}")
    return float(v)


def _non_negative(name: str, v: float) -> float:
    if not (np.isfinite(v) and v >= 0):
        raise ValueError(f"{name} must be a finite number ≥ 0; got {v!r}")
    return float(v)


def _plain(x):
    """JSON-ready copy (numpy scalars and arrays to Python)."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    return x


# --------------------------------------------------------------- scenario
def generate(rng, *, truth: Calibration | None = None, noise=None, procedure: str = "poses",
             rate: float = 100.0, rest: float = 30.0, n_poses: int = 30, dwell=(2.0, 5.0), move=(1.0, 3.0),
             max_rate: float | None = 220.0, hesitation: float = 0.3, reposition: float = 0.4,
             regrasp_deg=(3.0, 30.0), vertical_turns: float = 0.15, tremor: float = 0.15, creep: int = 2,
             lin_acc: float = 1.0, lever: float = 0.05, jitter: float = 0.001, resolution: float = 0.001,
             drop: float = 0.005, gap: float = 0.0, turn_on: float = 0.5, gyro_drift: float = 0.01,
             gyro_rw: float = 1e-4, acc_drift: float = 0.0, quantise: bool = True, full_scale: int | None = 32768,
             face_dwell=(5.0, 7.0), quarter=(0.3, 0.8), quarter_pause=(0.2, 0.4),
             nudge_deg: float = 0.0, magnetometer: bool | dict | None = None, temperature: float | None = None,
             ramp: tuple | None = None, thermal: dict | None = None, vibration: tuple | None = None) -> dict:
    """Simulate a hand-held calibration session of a consumer IMU (see the module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of every random choice; the same seed gives the same session.
    truth : Calibration, optional
        True calibration in raw counts (default: :func:`consumer_truth` drawn from ``rng``).
    noise : dict or float, optional
        Per-sample σ, ``{"accelerometer": m/s², "gyroscope": rad/s}`` (default
        :func:`datasheet_noise` at ``rate``; 0 for noise-free).
    procedure : {"poses", "ferraris"}
        Static poses spread over directions, or the Ferraris six faces and three turns.
    rate : float
        Sample rate [Hz] of the sensor's clock (100).
    rest : float
        Initial rest [s] on a table (30).
    n_poses : int
        Number of hand-held poses after the rest (``"poses"``; 30).
    dwell : float or (low, high)
        Hold of each pose [s], uniform (2–5).
    move : float or (low, high)
        Duration of a hand rotation between poses [s], uniform (1–3).
    max_rate : float or None
        Peak body rate [°/s] a hand rotation may reach: longer rotations are
        slowed down to it (220, below the ±250 °/s range; ``None``: no limit,
        fast hands then saturate the gyroscope).
    hesitation : float
        Probability that a rotation is split in two sub-moves about axes up to
        20° apart with a 0.1–0.4 s hesitation (0.3).
    reposition : float
        Probability of a re-grasp before or after a rotation (0.4).
    regrasp_deg : float or (low, high)
        Tilt of a re-grasp [deg] (3–30).
    vertical_turns : float
        Probability that a pose is reached by a turn of 45–180° about the
        vertical instead (``"poses"``; 0.15).
    tremor : float
        Hand tremor, body-rate RMS [°/s] while held (0.15).
    creep : int
        Number of holds that begin with a settling tilt of 0.8–1.2° over 0.5–1 s (0.8–2.4 °/s) (2).
    lin_acc : float
        Peak translational acceleration of the hand during a rotation [m/s²] (1.0).
    lever : float
        Distance [m] of the sensor from the rotation centre of the hand (0.05).
    jitter : float
        Timestamp jitter [s], uniform in ±jitter (0.001; < half a sample period).
    resolution : float
        Timestamp resolution [s]: recorded times are rounded to it (0.001; 0 keeps them exact).
    drop : float
        Fraction of samples dropped at random (0.005).
    gap : float
        One extra gap [s] of dropped samples at a random time after the rest (0: none).
    turn_on : float
        σ [°/s] of the gyroscope's turn-on bias offset, added to the truth's bias (0.5).
    gyro_drift : float
        σ [°/s per minute] of a linear gyroscope bias drift per axis (0.01; warm-up).
    gyro_rw : float
        Gyroscope bias random walk [°/s/√s] (1e-4, about 20 °/h/√h).
    acc_drift : float
        σ [m/s² per minute] of a linear accelerometer bias drift per axis (0).
    quantise : bool
        Round readings to integer counts (True).
    full_scale : int or None
        Saturation: readings clipped to ``[−full_scale, full_scale − 1]`` counts (32768; ``None``: off).
    face_dwell : float or (low, high)
        Hold of each face [s] (``"ferraris"``; 5–7).
    quarter : float or (low, high)
        Duration of each quarter-turn [s] (``"ferraris"``; 0.3–0.8, stretched to ``max_rate``).
    quarter_pause : float or (low, high)
        Pause between quarter-turns [s] (``"ferraris"``; 0.2–0.4; e.g. 2 makes them separate motions).
    nudge_deg : float
        A 0.5 s turn of this many degrees about the vertical right after the rest (``"ferraris"``; 0: none).
    magnetometer : bool or dict, optional
        Add a magnetometer (True: the defaults of :data:`MAGNETOMETER`; a dict overrides some of them):
        a uniform local field with a dip, hard and soft iron, the die's axes permuted/reflected and
        slightly rotated relative to the accelerometer's, noise and quantisation, in counts. Its truth
        (normalised: ``F = 1``) is the ``magnetometer`` of the returned truth. None/False: no magnetometer,
        and the session is the same as without this option.
    temperature : float, optional
        The sensor's temperature [°C] for the whole session: the truth's parameters are the thermal
        model's at that temperature (:func:`datasheet_thermal` around 25 °C, or ``thermal``), and the
        recording gets a temperature column. The returned truth holds the parameters at ``temperature``.
    ramp : (start, end, tau), optional
        A warm-up instead: the temperature goes from ``start`` to ``end`` [°C] as ``1 − exp(−t/tau)``
        (``tau`` [s]); the returned truth is the model at 25 °C with its thermal model.
    thermal : dict, optional
        Thermal coefficients ``{"gyroscope.bias.x": [c1, c2], …}`` (raw units per °C, per °C²) around
        25 °C (default: drawn by :func:`datasheet_thermal` when ``temperature`` or ``ramp`` is given).
    vibration : (frequency, amplitude), optional
        A vibrating table: the accelerometer's readings alone are shaken along the world vertical by
        ``amplitude · sin(2π · frequency · t)`` [Hz, m/s² peak] for the whole session; the gyroscope
        (its g-sensitivity included) and the attitude are untouched. None: no vibration, and the
        session is the same as without this option (it draws no random number).

    Returns
    -------
    dict
        Fields of :class:`~imucalib.sessions.Session`: ``recording``,
        ``segments``, ``truth``, ``noise``, ``options``.

    Raises
    ------
    ValueError
        For an option out of its range (an unknown ``procedure``, a negative duration, a probability
        outside [0, 1], a jitter of half a sample period or more, ``temperature`` and ``ramp`` together,
        an unknown magnetometer option…), the message naming it.

    Examples
    --------
    :func:`imucalib.scenarios.session` calls it (``session("handheld", ...)``); its fields, for a short
    session of a 10 s rest and 14 poses:

    >>> import numpy as np
    >>> from imucalib.scenarios.handheld import generate
    >>> fields = generate(np.random.default_rng(1), rest=10, n_poses=14)
    >>> sorted(fields), fields["recording"].acc_unit
    (['noise', 'options', 'recording', 'segments', 'truth'], 'counts')
    >>> generate(np.random.default_rng(1), procedure="figure-eight")
    Traceback (most recent call last):
        ...
    ValueError: procedure must be 'poses' or 'ferraris'; got 'figure-eight'
    """
    if procedure not in ("poses", "ferraris"):
        raise ValueError(f"procedure must be 'poses' or 'ferraris'; got {procedure!r}")
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate must be a positive number of Hz; got {rate!r}")
    if int(n_poses) != n_poses or n_poses < 1:
        raise ValueError(f"n_poses must be a positive integer; got {n_poses!r}")
    if int(creep) != creep or creep < 0:
        raise ValueError(f"creep must be an integer ≥ 0 (the number of holds that creep); got {creep!r}")
    if max_rate is not None and not max_rate > 0:
        raise ValueError(f"max_rate must be a positive number of °/s or None; got {max_rate!r}")
    if full_scale is not None and not (int(full_scale) == full_scale and full_scale > 0):
        raise ValueError(f"full_scale must be a positive integer number of counts or None; got {full_scale!r}")
    k = {"procedure": procedure, "rate": float(rate), "rest": _non_negative("rest", rest), "n_poses": int(n_poses),
         "dwell": _range("dwell", dwell), "move": _range("move", move),
         "max_rate": None if max_rate is None else float(max_rate),
         "hesitation": _probability("hesitation", hesitation), "reposition": _probability("reposition", reposition),
         "regrasp_deg": _range("regrasp_deg", regrasp_deg),
         "vertical_turns": _probability("vertical_turns", vertical_turns),
         "tremor": _non_negative("tremor", tremor), "creep": int(creep),
         "lin_acc": _non_negative("lin_acc", lin_acc), "lever": _non_negative("lever", lever),
         "jitter": _non_negative("jitter", jitter), "resolution": _non_negative("resolution", resolution),
         "drop": _non_negative("drop", drop), "gap": _non_negative("gap", gap),
         "turn_on": _non_negative("turn_on", turn_on), "gyro_drift": _non_negative("gyro_drift", gyro_drift),
         "gyro_rw": _non_negative("gyro_rw", gyro_rw), "acc_drift": _non_negative("acc_drift", acc_drift),
         "quantise": bool(quantise), "full_scale": None if full_scale is None else int(full_scale),
         "face_dwell": _range("face_dwell", face_dwell), "quarter": _range("quarter", quarter),
         "quarter_pause": _range("quarter_pause", quarter_pause), "nudge_deg": float(nudge_deg)}
    dt = 1.0 / rate
    if k["jitter"] >= 0.5 * dt:
        raise ValueError(f"jitter must be less than half a sample period ({0.5 * dt:g} s); got {jitter!r}")
    if k["drop"] >= 0.5:
        raise ValueError(f"drop is the fraction of samples lost and must be below 0.5; got {drop!r}")
    if k["dwell"][0] <= 0 or k["face_dwell"][0] <= 0:
        raise ValueError("dwell and face_dwell must be positive: a pose is held for some time")
    if k["rest"] <= 0:
        raise ValueError(f"rest must be a positive number of seconds; got {rest!r}")
    if min(k["move"][0], k["quarter"][0]) <= 0:
        raise ValueError("move and quarter durations must be positive")
    k["quarter_pause"] = (max(k["quarter_pause"][0], dt), max(k["quarter_pause"][1], dt))

    nominal = truth if truth is not None else consumer_truth(rng, STANDARD_GRAVITY)
    raw_units = {nominal.units[name]["raw"] for name in ("accelerometer", "gyroscope")}
    if raw_units != {"counts"} and (k["quantise"] or k["full_scale"] is not None):
        raise ValueError(f"quantise and full_scale work in integer counts, but the truth's raw units are "
                         f"{sorted(raw_units)}: pass quantise=False, full_scale=None, or a truth in counts")
    g = nominal.gravity
    noise = noise_per_sample(noise, rate)
    k_gyro, k_acc = nominal.gyroscope.scale, nominal.accelerometer.scale
    temp_profile = None
    if temperature is not None or ramp is not None:
        if temperature is not None and ramp is not None:
            raise ValueError("give the session one temperature or one ramp, not both")
        model = ThermalModel(reference_c=REFERENCE_C, source="simulated",
                             coefficients=thermal if thermal is not None else datasheet_thermal(rng, nominal))
        if temperature is not None:
            if not (np.isfinite(temperature) and -60 <= temperature <= 150):
                raise ValueError(f"temperature must be a sensor temperature in °C (-60 to 150); got {temperature!r}")
            nominal = evaluate(nominal.with_(thermal=model), float(temperature))
            k["temperature"] = float(temperature)
        else:
            t_start, t_end, tau = (float(v) for v in ramp)
            if not tau > 0:
                raise ValueError(f"the ramp's time constant must be positive seconds; got {tau!r}")
            nominal = nominal.with_(thermal=model)
            k["ramp"] = [t_start, t_end, tau]
        k["thermal"] = {name: c.tolist() for name, c in model.coefficients.items()}

    # ---- the session's gyroscope bias: a turn-on offset from the truth's, then drift
    offset = rng.normal(size=3) * math.radians(k["turn_on"]) / k_gyro  # counts
    truth_s = nominal.with_(gyroscope=nominal.gyroscope.with_(bias=nominal.gyroscope.bias + offset))

    # ---- the motion on the sensor's clock
    tilt = math.radians(rng.uniform(0.0, 1.5))  # the table is not quite level
    up0 = np.array([*(unit_vector(rng.normal(size=2)) * math.sin(tilt)), math.cos(tilt)])
    q0 = quat_multiply(quat_from_rotvec(UP * rng.uniform(-math.pi, math.pi)), attitude_with_up(up0))
    tl = Timeline(rng, rate, q0, max_rate=k["max_rate"], lin_acc=k["lin_acc"], lever=k["lever"])
    tl.hold(k["rest"])
    facts = poses_procedure(tl, rng, k) if procedure == "poses" else ferraris_procedure(tl, rng, k)
    w, wd, p_acc, rho, level = tl.arrays()
    n = w.shape[0]
    t = np.arange(n) * dt
    if k["tremor"]:
        box = max(1, int(round(0.3 * rate)))  # the tremor level changes over 0.3 s, not in a step
        env = np.convolve(level, np.ones(box) / box, mode="same")
        w_tr = tremor_noise(rng, n, rate) * np.radians(env)[:, None]
        w = w + w_tr
        wd = wd + np.gradient(w_tr, dt, axis=0)
    q = integrate(t, w, q0)  # RK4 of the sampled true rates: body → world
    r = quat_to_matrix(q)
    # f = Rᵀ(g ẑ + p̈) + ω̇ × ρ + ω × (ω × ρ)   (rigid body; Zhang 2021, eqs. 17–18 with ρ = −r)
    f = np.einsum("nji,nj->ni", r, g * UP + p_acc) + np.cross(wd, rho) + np.cross(w, np.cross(w, rho))
    hand = np.linalg.norm(f - np.einsum("nji,j->ni", r, g * UP), axis=1)
    shake = None
    if vibration is not None:
        freq, amp = (float(v) for v in vibration)
        if not (freq > 0 and amp >= 0 and np.isfinite(freq) and np.isfinite(amp)):
            raise ValueError(f"vibration is (frequency [Hz] > 0, amplitude [m/s²] ≥ 0); got {vibration!r}")
        k["vibration"] = [freq, amp]
        shake = np.einsum("nji,j->ni", r, UP) * (amp * np.sin(2 * np.pi * freq * t))[:, None]

    # ---- readings: the canonical model inverted (Zhang 2021, eqs. 31–32), noise, drift, counts
    acc, gyro = distort(truth_s.with_(thermal=None), f, w, rng, noise, None, None)
    if shake is not None:  # the accelerometer's readings only: not the gyroscope's g-sensitivity
        model = truth_s.accelerometer
        acc = acc + model.inverse(f + shake) - model.inverse(f)
    if "temperature" in k:
        temp_profile = np.full(n, k["temperature"])
    elif "ramp" in k:
        t_start, t_end, tau = k["ramp"]
        temp_profile = t_end + (t_start - t_end) * np.exp(-t / tau)
        acc, gyro = decompensate(truth_s, (acc, gyro), temp_profile, f)  # the parameters follow it (thermal.py)
    minutes = t / 60.0
    g_slope = rng.normal(size=3) * math.radians(k["gyro_drift"]) / k_gyro  # counts per minute
    g_walk = np.cumsum(rng.normal(size=(n, 3)), axis=0) * (math.radians(k["gyro_rw"]) * math.sqrt(dt) / k_gyro)
    g_walk -= g_walk[0]
    gyro += np.outer(minutes, g_slope) + g_walk
    a_slope = rng.normal(size=3) * k["acc_drift"] / k_acc  # counts per minute
    acc += np.outer(minutes, a_slope)
    if k["quantise"]:
        acc, gyro = np.round(acc), np.round(gyro)
    clipped = {"accelerometer": 0, "gyroscope": 0}
    if k["full_scale"] is not None:
        lo, hi = -k["full_scale"], k["full_scale"] - 1
        for name, arr in (("accelerometer", acc), ("gyroscope", gyro)):
            clipped[name] = int(np.count_nonzero((arr < lo) | (arr > hi)))
            if clipped[name]:
                np.clip(arr, lo, hi, out=arr)
                warnings.warn(f"{clipped[name]} {name} values beyond [{lo}, {hi}] counts were clipped, as the "
                              "saturated sensor reports them", ImucalibWarning, stacklevel=2)

    # ---- the logger: dropped samples, one optional gap, jittered and rounded timestamps
    kept = np.ones(n, dtype=bool)
    n_rest = tl.static[0][1]
    gap_range = None
    if k["gap"]:
        n_gap = int(round(k["gap"] * rate))
        if n - 1 - n_gap > n_rest:
            g0 = int(rng.integers(n_rest, n - 1 - n_gap))
            kept[g0:g0 + n_gap] = False
            gap_range = [float(t[g0]), float(t[g0 + n_gap - 1])]
    if k["drop"]:
        candidates = np.nonzero(kept[1:-1])[0] + 1  # never the first or last sample, nor twice
        lost = rng.choice(candidates, size=min(int(round(k["drop"] * n)), candidates.size), replace=False)
        kept[lost] = False
    stamp = t + rng.uniform(-k["jitter"], k["jitter"], n) if k["jitter"] else t.copy()
    if k["resolution"]:
        stamp = np.round(stamp / k["resolution"]) * k["resolution"]
    stamp = stamp[kept]
    step = k["resolution"] or 1e-9  # a logger never repeats a timestamp: keep them strictly increasing
    idx = np.arange(stamp.size) * step
    stamp = np.maximum.accumulate(stamp - idx) + idx
    cnt = np.concatenate([[0], np.cumsum(kept)])

    def remap(s0: int, s1: int) -> list[int] | None:
        a, b = int(cnt[s0]), int(cnt[s1])
        return [a, b] if b > a else None

    segments, static_map = [], {}
    for j, (s0, s1) in enumerate(tl.static):
        if j:
            m = remap(tl.static[j - 1][1], s0)
            if m:
                segments.append(Interval(*m, "motion"))
        s = remap(s0, s1)
        if s:
            static_map[j] = sum(iv.kind == "static" for iv in segments)
            segments.append(Interval(*s, "static"))
    mag = mag_facts = None
    if magnetometer:  # drawn after everything else: a session with a magnetometer is the same session plus it
        mag_model, mag, mag_facts = simulate_magnetometer(rng, r, {} if magnetometer is True else magnetometer)
        truth_s = truth_s.with_(magnetometer=mag_model,
                                units={**truth_s.units, "magnetometer": {"raw": "counts", "calibrated": "normalised"}})
        mag = mag[kept]
    units = truth_s.units
    rec = Recording(stamp, acc[kept], gyro[kept], acc_unit=units["accelerometer"]["raw"],
                    gyro_unit=units["gyroscope"]["raw"], metadata={"scenario": "handheld", "procedure": procedure},
                    mag=mag, temperature=None if temp_profile is None else thermometer_reading(rng, temp_profile)[kept])

    # ---- facts, in recorded indices
    options = dict(k)
    options.update({
        "duration_s": float(t[-1]), "samples_simulated": int(n), "samples": int(kept.sum()),
        "dropped": int(n - kept.sum()), "gap_s": gap_range, "static_poses": len(static_map),
        "creep_sections": [{**c, "static": static_map.get(c["static"]), "range": remap(*c["range"])}
                           for c in tl.creeps],
        "pauses": [m for m in (remap(*p) for p in tl.pauses) if m],
        "clipped": clipped,
        "hand_acceleration_max": float(hand.max()),
        "rate_max_deg_s": float(np.degrees(np.linalg.norm(w, axis=1).max())),
        "gyro_bias_nominal": nominal.gyroscope.bias, "gyro_turn_on_offset": offset,
        "gyro_drift_counts_per_min": g_slope,
        "gyro_bias_end": truth_s.gyroscope.bias + g_slope * minutes[-1] + g_walk[-1],
        "acc_drift_counts_per_min": a_slope,
        "acc_bias_end": truth_s.accelerometer.bias + a_slope * minutes[-1],
        "truth": "given" if truth is not None else "consumer_truth",
    })
    if mag_facts is not None:
        options["magnetometer"] = mag_facts
    if procedure == "poses":
        options["vertical_turns"] = [
            {"motion": remap(*v["range"]), "angle_deg": v["angle_deg"],
             "static_before": static_map.get(v["static_before"]),
             "static_after": static_map.get(v["static_before"] + 1)}
            for v in facts["vertical_turns"]]
    else:
        options["sections"] = {name: remap(*rg) for name, rg in facts["sections"].items()}
        options["turn_signs"] = facts["turn_signs"]
        options["face_order"] = facts["face_order"]
    return {"recording": rec, "segments": segments, "truth": truth_s, "noise": noise, "options": _plain(options)}
