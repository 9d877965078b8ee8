"""Zhang et al. (IEEE TII 2021): nonlinear scale factors, g-sensitivity and lever arm.

Model (canonical form; Zhang 2021 eqs. 1–8 with the bias sign flipped)::

    a = T_a · f_a(u_a − b_a)                 T_a unit upper-triangular (eq. 4)
    ω = T_g · f_g(u_g − b_g − G · a)          T_g unit-diagonal (eq. 8), G eq. (6)
    f(x)_i = k1_i x_i + k2_i x_i² + k3_i x_i³   (eqs. 2, 7)

Paper → canonical: ``b^a = −b_a``, ``b^g = −b_g``, ``G^g = −G`` (the paper adds
``b + G a`` to the raw reading), ``k_{i1}, k_{i2}, k_{i3}`` = ``scale``,
``scale_quadratic``, ``scale_cubic`` of axis ``i``; ``T^a`` entries
``(−α_yz, α_zy, −α_zx)`` = ``misalignment.xy, .xz, .yz``.

Data: RD1 — static poses with rotations between them (an initial rest first);
RD2 — spinning tosses in free fall ("weightless"), where the accelerometer
senses only the centripetal and Euler accelerations of the lever arm ``r``
(eqs. 16–18).

Cost (eq. 21), as weighted least squares::

    C1 Σ_k (‖a_k‖² − g²)²                       static means, eq. (10)
    C2 Σ_k ‖u_g,k − b_g − G a_k‖²               static means, eq. (11)
    C3 Σ_k ‖a_k − R_{k−1,k}ᵀ a_{k−1}‖²          poses, RK4 between them, eq. (14)
    C4 Σ_j ‖a_j − f_C(ω_j, r) − f_E(ω̇_j, r)‖²   weightless samples, eq. (19)

with ``f_C(ω, r) = ‖ω‖² r − ω(ω·r)`` (eq. 17), ``f_E(ω̇, r) = r × ω̇`` (eq. 18),
``ω̇`` by the five-point stencil (eq. 20), and weights ``C1…C4`` from the
noise of the initial rest (eqs. 25–30). (The paper writes ``R_{k−1,k} a_{k−1}``
for the gravity carried into pose ``k``; with our attitude convention that is
``Rᵀ``.)

The recipe (:func:`calibrate`) runs over the stages every method shares, the
same as :mod:`imucalib.methods.tedaldi2014`: the static poses by the
gyroscope-gated accelerometer detector (:func:`imucalib.segment.detect_intervals`),
the rotations whose integration cannot be trusted left out
(:func:`imucalib.segment.unreliable_transitions`), the accelerometer on the
static means alone (eq. 10, :func:`imucalib.fit.accelerometer.gravity_norm_fit`)
and the gyroscope by :func:`imucalib.fit.gyroscope.fit_gyroscope` (bias and
``G`` from the static poses, eq. 11; ``T_g``, ``k1`` from the rotations, eq. 14).
Its own terms come after: the gyroscope's polynomial scale factors on the
rotations (eq. 14), and with tosses Step 2 of the paper, eq. (21) over every
parameter from those estimates (Step 1). Without tosses no joint cost is
minimised: in eq. (21) the rotations' unmodelled residuals (hand tremor, bias
drift between poses) pull the accelerometer away from what its static poses
say.

Model variants (Zhang 2021, Table II): ``linear`` (RD1 only, C4 = 0, no r),
``quadratic`` (k2, r), ``cubic`` (k2, k3, r), ``all`` (k2, k3, G, r). ``all``
always estimates ``G``; the others keep it where the static poses support it
(the shared gyroscope stage's criterion), as a sensor with a g-sensitivity
leaves it in every rotation otherwise; with tosses, ``G`` enters the joint
fit of ``all`` only.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..assembly import assemble, rest_seconds
from ..calibration import Calibration, units_of
from ..constants import STANDARD_GRAVITY
from ..fit.accelerometer import GravityNormFit, accelerometer_covariance, gravity_norm_fit
from ..fit.gyroscope import GyroFit, fit_gyroscope
from ..fit.zhang_cost import (
    MODELS,
    ZhangLayout,
    concat_segments,
    fitted_layout,
    gyro_problem,
    joint_errors,
    lever_arm_matrix,
    rotation_rows,
    solve_joint,
    weights,
)
from ..fitreport import FitReport, GyroscopeReport, MethodReport
from ..kinematics import five_point_derivative, segmented_five_point
from ..methodinfo import MethodInfo, Option, accelerometer_only
from ..metrics import interval_means
from ..models import TriadModel
from ..presets import MIN_HOLD, MIN_INTERVALS
from ..recording import ImucalibWarning, Interval, Recording
from ..segment import (
    detect_intervals,
    detect_static_gyro,
    find_initial_rest,
    gyro_norm_variance,
    runs,
    unreliable_transitions,
)
from ..verdict import THRESHOLDS, plausible

METHOD = MethodInfo(
    name="zhang2021",
    summary="the main method: 3rd-order scale factors, misalignment, biases, gyro g-sensitivity and lever "
            "arm; the model variant chosen by Akaike's criterion",
    needs=("static poses", "rotations", "tosses", "gyroscope"),
    models=("all", "linear", "quadratic", "cubic"),
    options=(
        Option("weightless", None, "", "spinning weightless tosses (recordings) for the lever arm"),
        Option("intervals", None, "samples", "static intervals given instead of found"),
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
        Option("min_hold", 1.0, "s", "shortest hold that is a pose (sets the static detector's window)"),
        Option("initial", "step1", "", "the starting point of the joint fit (step1: the two-step estimate)"),
        Option("noise_weights", True, "", "weigh each residual by its noise (False: for noise-free data)"),
        Option("max_iter", 200, "", "Levenberg–Marquardt iterations at most"),
        Option("fall_threshold", 2.5, "m/s^2", "eq. (19) loss below which a sample is falling"),
        Option("select", True, "", "drop nonlinear terms Akaike's criterion does not support"),
        Option("detector", "accelerometer", "", "static detector: accelerometer variance or the gyroscope "
               "norm of eq. (22)"),
        Option("estimate_gyro_bias", "auto", "", "fit the gyroscope bias with the rotations (auto: when the "
               "rests do not give it)"),
    ),
    paper="zhang2021_nonlinear_scale_factors.md (Zhang et al., IEEE TII 2021), eqs. 1–22",
)

__all__ = [
    "MODELS",
    "ZhangLayout",
    "calibrate",
    "detect_weightless",
    "detect_fall",
    "fall_loss",
    "lever_arm_matrix",
    "weights",
]




# ------------------------------------------------------------- weightless part
def detect_weightless(
    recording: Recording,
    *,
    rest: Interval,
    window: float = 0.05,
    multiplier: float = 1000.0,
    min_length: float = 0.2,
    min_rate: float | None = None,
    relative: float = 0.01,
) -> list[Interval]:
    """Weightless (spinning free-fall) intervals by the detector of Zhang 2021, eq. (22).

    ``ζ(t) = var_{t_w}(‖u_g‖)``, the variance of the raw gyroscope norm over a
    window of ``window`` seconds, must stay below the threshold while the body
    spins (the bias-free gyroscope norm exceeds ``min_rate``, raw units;
    default 50 × the rest's noise). The threshold is ``multiplier × ζ_init``
    (ζ over the initial rest, the paper's ``n ζ_init``) or, if larger,
    ``(relative × ‖u_g‖)²``: with a low-noise sensor the raw norm of a
    free spin still drifts slowly as the axis cones (axis-dependent scale and
    misalignment errors), which ``n ζ_init`` alone would reject, while the
    spin-up in the hand and the catch change the norm far faster. The
    accelerometer confirms the fall later, in :func:`calibrate`, through the
    loss of eq. (19).
    """
    rate = recording.rate
    win = max(int(round(window * rate)) | 1, 3)
    norm, zeta = gyro_norm_variance(recording, rest, window)  # eq. (22)
    zeta_init = float(np.median(zeta[rest.slice]))
    noise = float(np.std(norm[rest.slice]))
    if min_rate is None:
        min_rate = 50.0 * max(noise, np.finfo(float).tiny)
    threshold = np.maximum(multiplier * zeta_init, (relative * norm) ** 2)
    mask = (zeta < threshold) & (norm > min_rate)
    shrink = win // 2  # drop the window's reach into the toss and the catch
    n_min = max(int(round(min_length * rate)), 5)
    return [Interval(iv.start + shrink, iv.stop - shrink, "weightless")
            for iv in runs(mask) if len(iv) - 2 * shrink >= n_min]


def fall_loss(calibration: Calibration, recording: Recording) -> np.ndarray:
    """Per-sample loss ``‖a − f_C(ω, r) − f_E(ω̇, r)‖`` [m/s²] of eq. (19) (Zhang 2021, §IV-C).

    Near zero in free fall; about ``g`` at rest.
    """
    if calibration.lever_arm is None:
        raise ValueError("this calibration has no lever arm: calibrate with model 'quadratic', "
                         "'cubic' or 'all' and weightless data")
    out = calibration.apply(recording)
    dt = 1.0 / recording.rate
    wd = five_point_derivative(out.gyro, dt)
    e = out.acc - lever_arm_matrix(out.gyro, wd) @ calibration.lever_arm
    return np.linalg.norm(e, axis=1)


def detect_fall(calibration: Calibration, recording: Recording, *, threshold: float = 2.5,
                min_length: float = 0.05) -> list[Interval]:
    """Falling-state intervals: eq. (19) loss below ``threshold`` m/s² (Zhang 2021, §IV-C)."""
    if len(recording) < 5:
        raise ValueError("fall detection needs at least 5 samples")
    loss = fall_loss(calibration, recording)
    return runs(loss < threshold, max(int(round(min_length * recording.rate)), 1), "weightless")


def _without_lever_arm(layout: ZhangLayout, model: str, why: str) -> ZhangLayout:
    warnings.warn(
        f"zhang2021 model {model!r}: {why}; the lever arm is not estimated and the weightless "
        "term (eq. 19) is left out, so the nonlinear terms rest on the static poses and "
        "rotations alone (record spinning tosses for the full method)",
        ImucalibWarning,
        stacklevel=3,
    )
    return replace(layout, with_r=False)


@dataclass
class _Stages:
    """One model variant fitted by the shared stages (and, for the nonlinear variants, eq. 21 after them)."""

    layout: ZhangLayout
    acc: TriadModel
    acc_residuals: np.ndarray  # ‖a_k‖ − g over the static poses [m/s²]
    gyro: GyroFit  # the shared gyroscope stage: the bias source and the rotations left out
    gyroscope: TriadModel  # with the polynomial scale factors of the variant
    errors: dict[str, float]
    converged: bool
    iterations: int


def _pose_budget(layout: ZhangLayout, poses: int) -> bool:
    """Whether ``poses`` static poses are enough for the variant's accelerometer by the verdict's own limit.

    The verdict rejects a calibration with at most ``THRESHOLDS["poses_per_parameter"][1]`` poses per
    estimated accelerometer parameter (:mod:`imucalib.verdict`); model selection never picks such a variant.
    """
    return poses / layout.n_acc > THRESHOLDS["poses_per_parameter"][1]


def _drift(gyro: GyroFit) -> tuple[np.ndarray, float] | None:
    """The bias drift the shared stage kept, with its reference time, for :func:`solve_joint`; None without."""
    return None if gyro.drift is None else (np.asarray(gyro.drift, dtype=float), float(gyro.t_ref))


def _stages(layout: ZhangLayout, recording: Recording, static: list[Interval], rest: Interval, gravity: float, *,
            linear: GravityNormFit, exclude: dict[int, str], estimate_gyro_bias: bool | str,
            noise_weights: bool, max_iter: int) -> _Stages:
    """Fit one variant by the shared stages, as :mod:`imucalib.methods.tedaldi2014` does, then its own terms.

    1. Accelerometer: ``‖a_k‖ = g`` on the static means alone (eq. 10,
       ``linear``, from :func:`imucalib.fit.accelerometer.gravity_norm_fit`).
    2. Gyroscope: :func:`imucalib.fit.gyroscope.fit_gyroscope` with that
       accelerometer — the bias (and ``G`` of eq. 6: always for ``all``, where
       the static poses support it otherwise) from the static poses (eq. 11),
       ``T_g`` and ``k1`` from the rotations (eq. 14), the unreliable rotations
       and outliers left out.
    3. The nonlinear variants (eqs. 2, 7): eq. (21) without the tosses' term,
       started at 1–2, on the rotations 2 kept. Their polynomial terms need the
       gravity directions the rotations carry: fitted to the static norms alone,
       a cubic accelerometer follows the poses and fails on held-out ones.
    """
    means = interval_means(recording.acc, static)
    acc_cov = accelerometer_covariance(linear.model, means, gravity)
    gyro = fit_gyroscope(recording, static, linear.model, estimate_bias=estimate_gyro_bias,
                         g_sensitivity=True if layout.with_g else "auto", acc_cov=acc_cov, exclude=exclude)
    if layout.order == 1:
        return _Stages(layout, linear.model, linear.residuals, gyro, gyro.model, linear.errors(1) | gyro.errors,
                       linear.converged, linear.iterations)
    lay = fitted_layout(layout, gyro.model)
    sol, problem, c = solve_joint(recording, static, rest, lay, gravity, linear.model, gyro.model, gyro.left_out,
                                  None, noise_weights=noise_weights, max_iter=max_iter, drift=_drift(gyro))
    acc, gyroscope, _ = lay.models(sol.x)
    residuals = np.linalg.norm(acc.forward(means), axis=1) - gravity
    errors = joint_errors(lay, sol, c, len(static))
    return _Stages(layout, acc, residuals, gyro, gyroscope, errors, linear.converged and sol.success,
                   linear.iterations + int(sol.njev))


def _criterion(st: _Stages, recording: Recording, static: list[Interval], gravity: float,
               left_out: set[int]) -> float:
    """Akaike's criterion of a variant with the small-sample correction, summed over the terms of eq. (21).

    One Gaussian term per block ``b`` with its own variance and its own
    parameters ``p_b``: ``n_b ln(RSS_b/n_b) + 2 p_b + 2 p_b (p_b + 1)/(n_b − p_b − 1)``
    (AICc; Hurvich & Tsai, Biometrika 1989). The blocks: eq. (10) (``M``
    residuals, the accelerometer's parameters), eq. (11) (``3M``, the bias and
    ``G``) and eq. (14) on the rotations no variant left out (``2`` degrees of
    freedom each, ``T_g`` and the scale factors). The correction matters where
    it should: 20 poses for 15 accelerometer parameters leave almost nothing to
    judge a fit by, and the uncorrected criterion then favours the polynomial.
    """
    lay = fitted_layout(st.layout, st.gyroscope)
    m = len(static)
    prob = gyro_problem(lay, recording, static, gravity, {k: "" for k in left_out}, _drift(st.gyro))
    res = prob.residuals(lay.pack(st.acc, st.gyroscope, None))[rotation_rows(m)]
    a = st.acc.forward(interval_means(recording.acc, static))
    e11 = prob.static_gyro - st.gyroscope.bias - a @ st.gyroscope.g_sensitivity.T
    p14 = 6 + 3 * lay.order + (3 if st.gyro.bias_source == "fit" else 0)
    blocks = [(st.acc_residuals, m, lay.n_acc), (e11.ravel(), 3 * m, lay.n_gyro - p14),
              (res, 2 * (len(prob.w3) // 3 - len(left_out)), p14)]
    total = 0.0
    for r, n, p in blocks:
        if n - p - 1 <= 0:
            return float("inf")
        total += n * np.log(max(float(r @ r), 1e-300) / n) + 2 * p + 2 * p * (p + 1) / (n - p - 1)
    return float(total)


def _poses(recording: Recording, gravity: float, intervals, init_static, detector,
           min_hold: float = MIN_HOLD) -> tuple[list[Interval], Interval]:
    """The static poses (the initial rest first): given, or by the shared detector, or by eq. (22)."""
    if intervals is not None:
        static = [iv for iv in intervals if iv.kind == "static"]
        rest = static[0] if static else None
    elif detector == "gyroscope":
        rest0 = (find_initial_rest(recording) if init_static is None
                 else Interval(0, int(round(init_static * recording.rate)), "static"))
        static = detect_static_gyro(recording, rest0)  # eq. (22), t_w = 2 s, n = 6
        if len(static) < MIN_INTERVALS:
            raise ValueError(f"the gyroscope detector (eq. 22) found {len(static)} static intervals; "
                             f"at least {MIN_INTERVALS} are needed")
        rest = static[0]
    elif detector == "accelerometer":
        static, _, rest, _ = detect_intervals(recording, gravity, init_static=init_static, min_hold=min_hold)
    else:
        raise ValueError(f"detector must be 'accelerometer' or 'gyroscope'; got {detector!r}")
    if len(static) < MIN_INTERVALS:
        raise ValueError(f"zhang2021 needs at least {MIN_INTERVALS} static intervals; got {len(static)}")
    return static, rest


def calibrate(
    recording: Recording,
    *,
    weightless: Sequence[Recording] | None = None,
    model: str = "all",
    gravity: float = STANDARD_GRAVITY,
    intervals: Sequence[Interval] | None = None,
    init_static: float | None = None, min_hold: float = MIN_HOLD,
    initial: str = "step1",
    noise_weights: bool = True,
    max_iter: int = 200,
    fall_threshold: float = 2.5,
    select: bool = True,
    detector: str = "accelerometer",
    estimate_gyro_bias: bool | str = "auto",
    progress: Callable[[str], None] | None = None,
) -> Calibration:
    """Calibrate by Zhang et al. 2021 over the shared stages, with its own terms.

    The static poses, the rotations left out, the accelerometer and the
    gyroscope come from the stages every method shares (:func:`_stages`; the
    same as :func:`imucalib.methods.tedaldi2014.calibrate`); Zhang 2021 adds
    the polynomial scale factors (eqs. 2, 7), the g-sensitivity (eq. 6) and,
    with spinning tosses, the lever arm (eqs. 16–19). With tosses the shared
    stages' linear estimates are Step 1 and eq. (21) is minimised over every
    parameter (Step 2): only the tosses reach the large rates and accelerations
    that determine the nonlinear terms together, and no rotation the stages
    left out enters.

    Parameters
    ----------
    recording : Recording
        RD1: an initial rest, then static poses with rotations between them
        (raw units). When ``weightless`` is None, spinning free-fall segments
        in this recording are detected (eq. 22) and used as RD2.
    weightless : sequence of Recording, optional
        RD2 segments (each entirely weightless, ≥ 5 samples, same rate).
    model : {"linear", "quadratic", "cubic", "all"}
        Table II variants.
    gravity : float
        Local gravity [m/s²].
    intervals : sequence of Interval, optional
        Static intervals of ``recording`` (the first is the initial rest);
        detected by default with ``detector``.
    init_static : float, optional
        Length of the initial rest [s] for the detector.
    min_hold : float
        The shortest hold that is a pose [s], for the accelerometer detector
        (:func:`imucalib.presets.hold_settings`).
    initial : {"step1", "identity"}
        Start the joint fit with tosses from the Step-1 estimates (the paper)
        or from the identity model (unit scales, zero biases) — for robustness
        studies.
    noise_weights : bool
        Weights of the joint fit from eqs. (25)–(30); ``False`` weighs every residual by 1.
    max_iter : int
        Most Levenberg–Marquardt iterations of each fit.
    fall_threshold : float
        Detected weightless segments whose eq. (19) loss RMS with the Step-1
        parameters exceeds this [m/s²] are not free fall and are dropped.
    select : bool
        Without weightless data, also fit the simpler variants and return the
        one Akaike's criterion (small-sample corrected, :func:`_criterion`) prefers (``fit.method.model_selection``
        says which), among the variants the poses can carry: never one with so few
        poses per accelerometer parameter that the verdict rejects it.
    detector : {"accelerometer", "gyroscope"}
        The shared detector (Tedaldi 2014's accelerometer variance with its
        threshold scan, gated by the gyroscope; default), or the
        gyroscope-norm detector of Zhang 2021, eq. (22).
    estimate_gyro_bias : bool or "auto"
        The gyroscope bias from the static poses (False), with the rotations
        (True), or as the data decide (:func:`imucalib.fit.gyroscope.fit_gyroscope`).
    progress : callable, optional
        Called with a message at each stage.

    Returns
    -------
    Calibration
        Accelerometer and gyroscope models (with polynomial scales and g-sensitivity as ``model`` has
        them, and the lever arm with tosses) in the recording's raw units, with the fit's figures, 1σ
        errors and verdict in ``fit``.

    Raises
    ------
    ValueError
        An accelerometer-only recording, an unknown ``model``, ``detector`` or ``initial``, fewer static
        intervals than the fit needs, or an initial rest with zero noise.

    Examples
    --------
    Zhang et al.'s simulated session (static poses, rotations and weightless spins), fitted with the linear
    model; the scale factors come out within 0.5 % of the truth:

    >>> from imucalib.methods import zhang2021
    >>> from imucalib.scenarios import session
    >>> sim = session("zhang2021", rng=1)
    >>> cal = zhang2021.calibrate(sim.recording, weightless=sim.weightless, model="linear",
    ...                           gravity=sim.truth.gravity)
    >>> (cal.accelerometer.scale / sim.truth.accelerometer.scale).round(2)
    array([1., 1., 1.])
    """
    if recording.gyro is None:
        raise ValueError("zhang2021 calibrates the gyroscope with the accelerometer and this recording is "
                         f"accelerometer-only; the methods that take it are {', '.join(accelerometer_only())}")
    say = progress or (lambda msg: None)
    layout = ZhangLayout.of(model)
    if initial not in ("step1", "identity"):
        raise ValueError(f"initial must be 'step1' or 'identity'; got {initial!r}")
    say("detecting static intervals")
    static, rest = _poses(recording, gravity, intervals, init_static, detector, min_hold)
    exclude = unreliable_transitions(recording, static)
    static_acc = interval_means(recording.acc, static)
    linear = gravity_norm_fit(static_acc, gravity, max_iter=max_iter)
    fitted: dict[tuple[int, bool], _Stages] = {}

    def stages(lay: ZhangLayout) -> _Stages:
        key = (lay.order, lay.with_g)
        if key not in fitted:
            fitted[key] = _stages(lay, recording, static, rest, gravity, linear=linear, exclude=exclude,
                                  estimate_gyro_bias=estimate_gyro_bias, noise_weights=noise_weights,
                                  max_iter=max_iter)
        return fitted[key]

    say("calibrating the accelerometer and the gyroscope")
    if layout.with_r:
        step1 = stages(replace(layout, order=1, with_r=False))
        tosses = _tosses(recording, weightless, rest, step1, fall_threshold)
        if isinstance(tosses, str):
            layout = _without_lever_arm(layout, model, tosses)
        else:
            say("step 2: global optimisation with the tosses")
            return _joint(recording, static, rest, layout, model, gravity, step1, tosses, initial=initial,
                          noise_weights=noise_weights, max_iter=max_iter)
    chosen, selection = (_select(model, static, recording, gravity, stages) if select and layout.order > 1
                         else (stages(layout), None))
    method = MethodReport(iterations=chosen.iterations, converged=chosen.converged)
    return assemble("zhang2021", recording, static, chosen.acc, chosen.gyroscope, gravity=gravity,
                    model=model if selection is None else selection["selected"], uncertainty=chosen.errors,
                    unreliable=exclude,
                    figures=[chosen.gyro.report(), rest_seconds(recording, rest),
                             method if selection is None else method.with_(model_selection=selection)])


def _select(model: str, static: list[Interval], recording: Recording, gravity: float,
            stages: Callable[[ZhangLayout], _Stages]) -> tuple[_Stages, dict]:
    """Without tosses: the variant up to ``model`` Akaike's criterion prefers (:func:`_criterion`), among those
    the poses carry and that converged to plausible parameters, and the selection's record (``model_selection``
    of the fit report), with a warning when it is not ``model``."""
    names = MODELS[: MODELS.index(model) + 1]
    budget = {name: _pose_budget(ZhangLayout.of(name), len(static)) for name in names}
    cands, unfit = {}, {}
    for name in names:
        if budget[name] or name == "linear":
            try:
                cands[name] = stages(replace(ZhangLayout.of(name), with_r=False))
            except ValueError as exc:  # more parameters than poses: that variant cannot be fitted at all
                if name == "linear":
                    raise
                unfit[name] = str(exc)
    left_out = set().union(*(set(st.gyro.left_out) for st in cands.values()))
    aic = {name: _criterion(st, recording, static, gravity, left_out) for name, st in cands.items()}
    # a fit that did not converge, or whose parameters are implausible (a cross-axis term of tens of
    # degrees, a scale far from the unit's nominal), is never chosen, however low its criterion
    usable = {name: aic[name] for name, st in cands.items()
              if st.converged and plausible(_stage_calibration(st, gravity, recording))}
    best = min(usable or aic, key=(usable or aic).get)
    over = [name for name in names if not budget[name]]
    selection = {"criterion": "aicc", "aic": aic, "requested": model, "selected": best,
                 "excluded": sorted(set(aic) - set(usable)) + sorted(unfit), "over_pose_budget": over}
    if best != model:
        why = (f"{len(static)} static poses carry at most "
               f"{len(static) / THRESHOLDS['poses_per_parameter'][1]:.3g} accelerometer parameters"
               if model in over else "the poses do not support the extra terms")
        warnings.warn(
            f"zhang2021 model {model!r}: without weightless data {why} (Akaike's criterion prefers "
            f"{best!r} among the variants they carry); the {best!r} solution is returned with the other "
            "terms at zero (to keep them: select=False, on the command line --keep-terms)",
            ImucalibWarning, stacklevel=3,
        )
    return cands[best], selection


def _stage_calibration(st: _Stages, gravity: float, recording: Recording) -> Calibration:
    return Calibration(accelerometer=st.acc, gyroscope=st.gyroscope, gravity=gravity,
                       units=units_of(recording), fit=FitReport.of(MethodReport(converged=st.converged)))


def _tosses(recording: Recording, weightless, rest: Interval, step1: _Stages, fall_threshold: float):
    """RD2 as ``(acc, gyro, starts, stops, r0, segments)``, or why there is none (a string).

    Detected tosses (``weightless`` None, eq. 22) are confirmed by the
    accelerometer: a segment whose eq. (19) loss RMS with the Step-1 parameters
    and the lever arm fitted to them exceeds ``fall_threshold`` is not free fall
    (Zhang 2021, §IV-C); ``r̂`` is refitted on the rest.
    """
    detected = weightless is None
    if detected:
        weightless = [recording[iv] for iv in detect_weightless(recording, rest=rest)]
    weightless = [w for w in weightless if len(w) >= 5]
    if not weightless:
        return "no weightless segments were found"
    cal0 = Calibration(accelerometer=step1.acc, gyroscope=step1.gyroscope)
    dt = 1.0 / recording.rate

    def lever(segments):
        acc, gyro, starts, stops = concat_segments(segments)
        a_w = cal0.accelerometer_si(acc)
        w_w = cal0.gyroscope_si(gyro, acc)
        lm = lever_arm_matrix(w_w, segmented_five_point(w_w, starts, stops, dt))
        r0, *_ = np.linalg.lstsq(lm.reshape(-1, 3), a_w.ravel(), rcond=None)  # eq. (19), linear in r
        return acc, gyro, starts, stops, r0, a_w, lm

    acc, gyro, starts, stops, r0, a_w, lm = lever(weightless)
    if detected:
        loss = np.linalg.norm(a_w - lm @ r0, axis=1)
        seg_rms = np.sqrt(np.add.reduceat(loss**2, starts) / (stops - starts))
        keep = seg_rms < fall_threshold
        if not np.any(keep):
            return (f"none of the {len(keep)} candidate weightless segments fits free fall "
                    f"(eq. 19 loss ≥ {fall_threshold} m/s²)")
        if not np.all(keep):
            weightless = [w for w, k in zip(weightless, keep, strict=True) if k]
            acc, gyro, starts, stops, r0, _, _ = lever(weightless)
    return acc, gyro, starts, stops, r0, weightless


def _joint(recording: Recording, static: list[Interval], rest: Interval, layout: ZhangLayout, model: str,
           gravity: float, step1: _Stages, tosses, *, initial: str, noise_weights: bool,
           max_iter: int) -> Calibration:
    """Step 2 with tosses: eq. (21) by Levenberg–Marquardt from the shared stages' linear estimates (Step 1)."""
    wl_acc, wl_gyro, wl_starts, wl_stops, _, weightless = tosses
    dt = 1.0 / recording.rate
    sol, problem, c = solve_joint(recording, static, rest, layout, gravity, step1.acc, step1.gyroscope,
                                  step1.gyro.left_out, tosses, initial=initial, noise_weights=noise_weights,
                                  max_iter=max_iter, drift=_drift(step1.gyro))
    m = len(static)
    acc, gyro, r = layout.models(sol.x)
    figures = [step1.gyro.report(), GyroscopeReport(g_sensitivity="estimated" if layout.with_g else "none"),
               MethodReport(weights={k: float(np.mean(v)) for k, v in c.items()},  # means over intervals
                            cost=float(sol.cost), iterations=int(sol.njev), converged=bool(sol.success),
                            weightless_segments=len(weightless)),
               rest_seconds(recording, rest)]
    # 1σ errors from the weighted Jacobian at the solution, σ² from the weighted residuals of each cost term
    cal = assemble("zhang2021", recording, static, acc, gyro, gravity=gravity, model=model, lever_arm=r,
                   figures=figures, uncertainty=joint_errors(layout, sol, c, m))
    cal_w = cal.apply(Recording(np.arange(wl_acc.shape[0]) * dt, wl_acc, wl_gyro,  # the constant bias, as fitted
                                acc_unit=recording.acc_unit, gyro_unit=recording.gyro_unit), bias_drift="off")
    wd = segmented_five_point(cal_w.gyro, wl_starts, wl_stops, dt)
    e4 = cal_w.acc - lever_arm_matrix(cal_w.gyro, wd) @ r
    rms = float(np.sqrt(np.mean(np.sum(e4**2, axis=1))))
    return cal.with_(fit=cal.fit.add(MethodReport(weightless_residual_rms=rms)))
