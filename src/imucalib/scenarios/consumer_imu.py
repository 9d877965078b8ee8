"""The sensor of the ``handheld`` scenario (:mod:`imucalib.scenarios.handheld`, "The sensor" there): an
MPU-6050/ICM-20948-class IMU in raw counts, its noise and thermal coefficients, and a magnetometer beside it.
"""

from __future__ import annotations

import math

import numpy as np

from ..calibration import Calibration
from ..kinematics import quat_from_rotvec, quat_to_matrix
from ..models import MagnetometerModel, TriadModel
from ..recording import STANDARD_GRAVITY
from .handmotion import UP

__all__ = ["ACC_COUNTS_PER_G", "ACC_NOISE_DENSITY", "COUNTS_RANGE", "GYRO_COUNTS_PER_DPS", "GYRO_NOISE_DENSITY",
           "MAGNETOMETER", "consumer_truth", "datasheet_noise", "datasheet_thermal", "noise_per_sample",
           "simulate_magnetometer", "thermometer_reading"]

#: MPU-6050 accelerometer sensitivity at AFS_SEL=0 (±2 g) [counts/g] (datasheet §6.2)
ACC_COUNTS_PER_G = 16384.0
#: MPU-6050 gyroscope sensitivity at FS_SEL=0 (±250 °/s) [counts/(°/s)] (datasheet §6.1)
GYRO_COUNTS_PER_DPS = 131.0
#: accelerometer noise power spectral density [g/√Hz] (datasheet §6.2)
ACC_NOISE_DENSITY = 400e-6
#: gyroscope rate noise spectral density [(°/s)/√Hz] (datasheet §6.1)
GYRO_NOISE_DENSITY = 0.005
#: the int16 output registers: readings are clipped to this range
COUNTS_RANGE = (-32768, 32767)


def consumer_truth(rng=None, gravity: float = STANDARD_GRAVITY) -> Calibration:
    """A random MPU-6050/ICM-20948-class IMU in raw counts (linear model).

    Drawn uniformly within the MPU-6000/MPU-6050 Product Specification (rev.
    3.4) tolerances, narrowed where a factory trim makes real parts better:

    * accelerometer ±2 g, ``k1 = g₀/16384 · (1 ± 3 %)`` (§6.2 "initial
      calibration tolerance ±3 %"), bias within ±25 mg on x, y and ±40 mg on z
      (half the zero-g tolerance of ±50/±80 mg: a few hundred counts),
      upper-triangular misalignment within ±0.015 (cross-axis ±2 %);
    * gyroscope ±250 °/s, ``k1 = (π/180)/131 · (1 ± 3 %)`` (§6.1 "sensitivity
      scale factor tolerance ±3 %"), bias within ±80 counts (±0.6 °/s, a
      trimmed part; the untrimmed ZRO tolerance is ±20 °/s), full misalignment
      within ±0.02 (cross-axis ±2 %), g-sensitivity within ±0.1 °/s/g per
      entry (§6.1 "linear acceleration sensitivity 0.1 °/s/g") in counts per
      m/s².

    Parameters
    ----------
    rng : int or numpy.random.Generator, optional
        Seed or generator; ``None`` gives one fixed representative device.
    gravity : float
        Local gravity [m/s²] stored in the calibration.
    """
    rng = np.random.default_rng(6050 if rng is None else rng)
    g0 = STANDARD_GRAVITY  # the datasheet's g
    k_acc = g0 / ACC_COUNTS_PER_G  # m/s² per count
    k_gyro = math.radians(1.0) / GYRO_COUNTS_PER_DPS  # rad/s per count
    ta = np.eye(3)
    ta[0, 1], ta[0, 2], ta[1, 2] = rng.uniform(-0.015, 0.015, 3)
    tg = np.eye(3)
    for (i, j), v in zip(((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)), rng.uniform(-0.02, 0.02, 6), strict=True):
        tg[i, j] = v
    mg = ACC_COUNTS_PER_G * 1e-3  # counts per mg
    acc = TriadModel(misalignment=ta, scale=k_acc * (1 + rng.uniform(-0.03, 0.03, 3)),
                     bias=rng.uniform(-1, 1, 3) * np.array([25 * mg, 25 * mg, 40 * mg]), shape="upper")
    g_sens = 0.1 * GYRO_COUNTS_PER_DPS / g0  # 0.1 °/s/g → counts per m/s²
    gyro = TriadModel(misalignment=tg, scale=k_gyro * (1 + rng.uniform(-0.03, 0.03, 3)),
                      bias=rng.uniform(-80, 80, 3), g_sensitivity=rng.uniform(-g_sens, g_sens, (3, 3)),
                      shape="full")
    return Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="truth", model="linear",
                       device="MPU-6050-class (simulated)",
                       units={"accelerometer": {"raw": "counts", "calibrated": "m/s^2"},
                              "gyroscope": {"raw": "counts", "calibrated": "rad/s"}})


def datasheet_noise(rate: float) -> dict:
    """Per-sample white-noise σ of an MPU-6050 sampled at ``rate`` [Hz].

    ``σ = density · √(rate/2)``: the datasheet's spectral densities (400 µg/√Hz,
    0.005 °/s/√Hz) over the Nyquist band. At 100 Hz: 0.028 m/s², 0.035 °/s,
    near the datasheet's total RMS figures (4 mg at DLPF 94 Hz; 0.05 °/s at
    DLPF 100 Hz).
    """
    bw = math.sqrt(rate / 2.0)
    return {"accelerometer": ACC_NOISE_DENSITY * STANDARD_GRAVITY * bw,
            "gyroscope": math.radians(GYRO_NOISE_DENSITY) * bw}


def noise_per_sample(noise, rate: float) -> dict:
    """Per-sample white-noise σ of a session from ``noise`` as :func:`~imucalib.scenarios.handheld.generate` takes it
    (None: :func:`datasheet_noise` at ``rate``; a number: both sensors; a dict: those it names), checked."""
    out = datasheet_noise(rate)
    if noise is None:
        return out
    if isinstance(noise, int | float):
        return {"accelerometer": float(noise), "gyroscope": float(noise)}
    unknown = set(noise) - {"accelerometer", "gyroscope"}
    if unknown:
        raise ValueError(f"noise keys must be 'accelerometer' and 'gyroscope'; got {sorted(unknown)}")
    out.update({k: float(v) for k, v in noise.items()})
    if any(v < 0 for v in out.values()):
        raise ValueError(f"noise levels must be ≥ 0; got {out}")
    return out



def datasheet_thermal(rng, truth: Calibration, quadratic: bool = False) -> dict:
    """Thermal coefficients of an MPU-6050/ICM-20948-class IMU around 25 °C, in raw units (datasheet-like).

    Per axis, 1σ: accelerometer bias 0.5 mg/°C, gyroscope bias 0.03 °/s/°C, scale factors 0.02 %/°C;
    with ``quadratic``, a second-order term of 1 % of the slope per °C.
    """
    out = {}
    for sensor, tri, bias_sd in (("accelerometer", truth.accelerometer, 0.5e-3 * truth.gravity),
                                 ("gyroscope", truth.gyroscope, math.radians(0.03))):
        for i, axis in enumerate("xyz"):
            slope = rng.normal() * bias_sd / abs(tri.scale[i])  # raw per °C
            out[f"{sensor}.bias.{axis}"] = [slope, 0.01 * slope * rng.normal() if quadratic else 0.0]
            out[f"{sensor}.scale.{axis}"] = [rng.normal() * 2e-4 * tri.scale[i], 0.0]
    return out


def thermometer_reading(rng, temperature: np.ndarray) -> np.ndarray:
    """The temperature sensor's reading: 0.05 °C of noise, 1/340 °C steps (MPU-6050 datasheet §4.18)."""
    return np.round((temperature + rng.normal(size=temperature.shape) * 0.05) * 340.0) / 340.0


#: defaults of the simulated magnetometer (an AK8963-class die beside an MPU-6500-class IMU, as on the MPU-9250)
MAGNETOMETER = {
    "field_uT": 48.0,           # local field magnitude [µT]
    "dip_deg": 60.0,            # inclination below the horizontal (northern hemisphere > 0)
    "resolution_uT": 0.15,      # µT per count
    "noise_uT": 0.4,            # white noise per sample, 1σ [µT]
    "hard_iron_uT": 30.0,       # 1σ per axis of the hard-iron bias [µT]
    "soft_iron": 0.03,          # 1σ of the symmetric soft-iron deviation from the identity
    "misalignment_deg": 1.0,    # 1σ per axis of the die's small rotation [deg]
    # magnetometer axes in terms of the accelerometer's (m_mag = P m_acc): the MPU-9250's x ↔ y, z reversed
    "axes": [[0, 1, 0], [1, 0, 0], [0, 0, -1]],
}


def simulate_magnetometer(rng, body_to_world: np.ndarray, options: dict) -> tuple:
    """Raw magnetometer counts (N, 3) for the attitudes ``body_to_world`` (N, 3, 3), its truth and facts.

    The world field is ``h = F (cos δ · north − sin δ · up)`` with a random north; the die reads
    ``u = b + S⁻¹ Oᵀ (m / F)`` in counts (:class:`~imucalib.models.MagnetometerModel` inverted) with
    ``O = Pᵀ Exp(ε)``, then noise and rounding.
    """
    unknown = set(options) - set(MAGNETOMETER)
    if unknown:
        raise ValueError(f"unknown magnetometer option(s) {sorted(unknown)}; known: {sorted(MAGNETOMETER)}")
    k = {**MAGNETOMETER, **options}
    p = np.asarray(k["axes"], dtype=float)
    if p.shape != (3, 3) or not np.allclose(p @ p.T, np.eye(3)):
        raise ValueError("the magnetometer's axes must be an orthogonal 3×3 matrix (a signed permutation)")
    res = float(k["resolution_uT"])
    field_uT, dip = float(k["field_uT"]), math.radians(float(k["dip_deg"]))
    heading = rng.uniform(-math.pi, math.pi)
    north = np.array([math.cos(heading), math.sin(heading), 0.0])
    h = field_uT * (math.cos(dip) * north - math.sin(dip) * UP)
    m_body = np.einsum("nji,j->ni", body_to_world, h)  # µT in the accelerometer's frame
    eps = rng.normal(size=3) * math.radians(float(k["misalignment_deg"]))
    o = p.T @ quat_to_matrix(quat_from_rotvec(eps))
    e = rng.normal(size=(3, 3)) * float(k["soft_iron"])
    soft = np.eye(3) + 0.5 * (e + e.T)  # raw µT = soft · (ideal µT); S = soft⁻¹ scaled to the unit sphere
    s = np.linalg.inv(soft) * (res / field_uT)  # counts → unit field: S (u − b) = soft⁻¹ (u − b) res / F
    s = 0.5 * (s + s.T)
    bias = rng.normal(size=3) * float(k["hard_iron_uT"]) / res  # counts
    model = MagnetometerModel(bias=bias, soft_iron=s, alignment=o, field_norm=1.0, unit="normalised")
    raw = model.inverse(m_body / field_uT)
    raw += rng.normal(size=raw.shape) * float(k["noise_uT"]) / res
    raw = np.round(raw)
    facts = {**k, "counts_per_uT": 1.0 / res, "heading_deg": math.degrees(heading)}
    return model, raw, facts
