"""Ferraris et al. (1995): six static faces and known-angle turns, in closed form.

The method the ``imucal`` package implements, so its users can move over.
With the sensor resting on each face of a cube (axis ``i`` up, then down) and
turned by a known angle ``θ`` (360° by default) about each axis while that
axis is vertical, the linear model ``u = S s + b (+ G a)`` gives, per axis::

    accelerometer   S_a e_i = (ū₊ᵢ − ū₋ᵢ) / (2g),      b_a = mean of the six faces
    gyroscope       b_g + G a: from the same faces,  G e_i = (ū_g₊ᵢ − ū_g₋ᵢ) / (2g)
                    S_g e_i = ± (∫(u_g − b_g) dt − G ā T) / θ   (turn about axis i)

Canonically ``a = T_a k (u − b)`` with ``T_a diag(k) = S_a⁻¹``; the cube's faces
define the frame, so both misalignments are full (``shape="full"``; Ferraris
does not use the accelerometer's own frame). ``G`` is linear g-sensitivity.

Sections are found automatically: static intervals by the accelerometer's
variance (10× the rest's), cut to where the gyroscope is still (a turn about
the vertical leaves the accelerometer still); the faces as the poses nearest ``±x, ±y, ±z`` (within ``max_tilt``);
the turns as chains of motions between rests in one pose whose rate,
integrated with the rough scale the poses give, turns about one axis by ``θ``
± 20 % (:func:`imucalib.segment.find_turns`). A turn that does not match the
known angle is still used, and the verdict rejects the calibration. Known
sections may be given instead, as named sample ranges ``[start, stop)``:
``x_p, x_a, y_p, y_a, z_p, z_a`` (axis up, axis down) and ``x_rot, y_rot, z_rot``.

The accelerometer bias is each axis's own pair, ``b_i = (ū₊ᵢ,ᵢ + ū₋ᵢ,ᵢ)/2``,
not the mean of all six faces: a face put down tilted by ``δ`` moves the
axis's own reading by ``g(1 − cos δ)`` (second order) but the other axes'
by ``g sin δ`` (first order), which the mean of six carries into every bias
(``tests/test_ferraris.py`` shows it on faces tilted by a few degrees).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..assembly import assemble
from ..calibration import Calibration
from ..fit.accelerometer import faces_full, full_from_sensitivity, mean_variance
from ..fit.gyroscope import fit_known_turns, rough_scale
from ..fitreport import GyroscopeReport, SegmentationReport
from ..methodinfo import MethodInfo, Option
from ..metrics import interval_means
from ..presets import MIN_HOLD, hold_settings
from ..recording import Interval, Recording
from ..segment import (
    FACE_NAMES,
    Turn,
    find_faces,
    find_turns,
    gyro_still,
    initial_rest,
    static_at,
    still_intervals,
)

METHOD = MethodInfo(
    name="ferraris",
    summary="closed form from six static faces and a known-angle turn about each axis: full misalignments, "
            "linear gyro g-sensitivity (what `imucal` implements)",
    needs=("static poses", "six faces", "known-angle turns", "gyroscope"),
    models=("linear",),
    options=(
        Option("intervals", None, "samples", "static intervals given instead of found"),
        Option("angle", 360.0, "deg", "the known angle of each turn"),
        Option("max_tilt", 15.0, "deg", "largest tilt of a face from its axis"),
        Option("init_static", None, "s", "length of the initial rest (found automatically)"),
        Option("min_hold", 1.0, "s", "shortest hold that is a pose (sets the static detector's window)"),
        Option("sections", None, "samples", "named sample ranges of the faces and turns, instead of finding "
               "them"),
    ),
    paper="Ferraris et al., Sensors and Materials 1995 (not among the papers; the equations are in this module's "
          "docstring)",
)

__all__ = ["SECTION_NAMES", "calibrate", "closed_form_errors", "parse_sections", "sections_from_ranges"]

#: the named sections of a Ferraris session: each axis up (``_p``) and down (``_a``), and its turn
SECTION_NAMES = ("x_p", "y_p", "z_p", "x_a", "y_a", "z_a", "x_rot", "y_rot", "z_rot")


def parse_sections(doc) -> dict[str, list[int]]:
    """A sections document (parsed JSON) as ``{name: [start, stop]}``, sample indices, ``stop`` exclusive.

    Two forms are read: imucalib's ``{"x_p": [start, stop], …}`` and imucal's ``{"x_p": {"start": s, "end": e},
    …}`` (the section list its annotation tool saves; imucal slices ``data.iloc[start:end]``, so its ``end`` is
    exclusive too and is taken as it is). Raises ValueError naming what is wrong.
    """
    example = '{"x_p": [start, stop], …} or imucal\'s {"x_p": {"start": s, "end": e}, …}'
    if not isinstance(doc, dict):
        raise ValueError(f"expected a JSON object {example}; got a {type(doc).__name__}")
    missing = [n for n in SECTION_NAMES if n not in doc]
    unknown = sorted(set(doc) - set(SECTION_NAMES))
    if missing or unknown:
        raise ValueError(f"the object must name exactly {', '.join(SECTION_NAMES)}"
                         + (f"; missing {', '.join(missing)}" if missing else "")
                         + (f"; unknown {', '.join(unknown)}" if unknown else ""))
    out = {}
    for name in SECTION_NAMES:
        value = doc[name]
        if isinstance(value, dict) and set(value) == {"start", "end"}:
            value = [value["start"], value["end"]]
        if not (isinstance(value, list) and len(value) == 2 and all(type(v) is int for v in value)
                and 0 <= value[0] < value[1]):
            raise ValueError(f"{name!r} must be [start, stop] or {{\"start\": start, \"end\": stop}}, sample "
                             f"indices with 0 <= start < stop; got {value!r}")
        out[name] = list(value)
    return out


def sections_from_ranges(recording: Recording, ranges: dict, bias: np.ndarray | None = None
                         ) -> tuple[list[Interval], dict[int, list[Turn]]]:
    """Faces (+x, +y, +z, −x, −y, −z) and turns from named sample ranges ``{name: [start, stop)}``."""
    missing = [n for n in SECTION_NAMES if n not in ranges]
    unknown = sorted(set(ranges) - set(SECTION_NAMES))
    if missing or unknown:
        raise ValueError("the sections must name exactly " + ", ".join(SECTION_NAMES)
                         + (f"; missing {', '.join(missing)}" if missing else "")
                         + (f"; unknown {', '.join(unknown)}" if unknown else ""))
    n = len(recording)
    bounds = {}
    for name in SECTION_NAMES:
        try:
            s0, s1 = (int(v) for v in ranges[name])
        except (TypeError, ValueError):
            raise ValueError(f"section {name!r} must be [start, stop) sample indices; got {ranges[name]!r}") from None
        if not 0 <= s0 < s1 <= n:
            raise ValueError(f"section {name!r} [{s0}, {s1}) is outside the recording's {n} samples")
        if name in SECTION_NAMES[6:] and s1 - s0 < 3:
            raise ValueError(f"section {name!r} [{s0}, {s1}) holds {s1 - s0} sample(s): a turn needs the samples "
                             "from the rest before it to the rest after it")
        bounds[name] = (s0, s1)
    ordered = sorted(bounds.items(), key=lambda kv: kv[1])
    for (a, (a0, a1)), (b, (b0, b1)) in zip(ordered, ordered[1:], strict=False):
        if b0 < a1:  # sorted by start: a section overlaps the one before it
            raise ValueError(f"sections {a!r} [{a0}, {a1}) and {b!r} [{b0}, {b1}) overlap: each sample is on one "
                             "face or in one turn; give each face and turn its own samples")
    faces = [Interval(*bounds[name], "static") for name in SECTION_NAMES[:6]]
    b = interval_means(recording.gyro, faces).mean(axis=0) if bias is None else bias
    turns: dict[int, list[Turn]] = {}
    for axis, name in enumerate(SECTION_NAMES[6:]):
        s0, s1 = bounds[name]
        phi = np.trapezoid(recording.gyro[s0:s1] - b, recording.t[s0:s1], axis=0)
        turns[axis] = [Turn(axis, s0, s1 - 1, int(np.sign(phi[axis])), float("nan"), True)]
    return faces, turns


#: the parameter groups the closed form estimates (the linear model's, g-sensitivity for the gyroscope)
ESTIMATED = ("misalignment", "scale", "bias", "g_sensitivity")


def _wander(rate: np.ndarray, dt: float) -> np.ndarray:
    """Variance [raw² s²] of the angle a hand wanders by while holding still: the integral of the rate less its
    straight line (the bias and its drift), per axis."""
    t = np.arange(len(rate)) * dt
    design = np.column_stack([np.ones_like(t), t - t.mean()])
    coef = np.linalg.lstsq(design, rate, rcond=None)[0]
    return np.var(np.cumsum((rate - design @ coef) * dt, axis=0), axis=0)


def _closed_form(x: dict, gravity: float, angle: float) -> dict[str, float]:
    """The closed form (module docstring) from its inputs, as named canonical parameters.

    ``x``: the faces' raw means ``acc`` and ``gyro`` (+x, +y, +z, −x, −y, −z), and per turn
    ``integral`` (∫u_g dt), ``duration``, ``force`` (∫a dt, calibrated), ``axis``, ``sign`` and
    ``bias_shift`` (the bias at the turn less the faces' mean, 0 as estimated), ``turn_dt`` (its mean time
    less the faces'); ``drift`` (0 as estimated: the closed form has none) moves the faces' readings by
    ``drift · face_dt`` and each turn's bias by ``drift · turn_dt``.
    """
    acc = faces_full(x["acc"], gravity)
    g_f = x["gyro"] + np.outer(x["face_dt"], x["drift"])
    g_sens = (g_f[:3] - g_f[3:]).T / (2 * gravity)
    b_g = g_f.mean(axis=0)
    s_g = np.zeros((3, 3))
    count = np.zeros(3)
    for integral, duration, force, axis, sign, shift, dt in zip(x["integral"], x["duration"], x["force"], x["axis"],
                                                               x["sign"], x["bias_shift"], x["turn_dt"], strict=True):
        s_g[:, axis] += sign * (integral - (b_g + shift + x["drift"] * dt) * duration - g_sens @ force) / angle
        count[axis] += 1
    gyro = full_from_sensitivity(s_g / count[None, :], b_g, g_sensitivity=g_sens)
    out = acc.parameters("accelerometer") | gyro.parameters("gyroscope")
    return {k: v for k, v in out.items() if k.split(".")[1] in ESTIMATED and not k.startswith("accelerometer.g_")}


def _face_noise(recording: Recording, faces: list[Interval], rest: Interval | None) -> tuple:
    """The variances of the faces' mean rates (6, 3), the rate's per-sample variance (3,) and the variances of
    the faces' mean accelerations (6, 3), for :func:`closed_form_errors`."""
    noise = recording.gyro[rest.slice] if rest is not None and len(rest) > 2 else None
    if noise is not None:  # the rate's white noise (the rest lies on a table); the hand's wander is in τ² below
        rate_var = np.var(noise, axis=0, ddof=1)
        g_faces = np.array([rate_var / len(iv) for iv in faces])
    else:
        g_faces = np.array([mean_variance(recording.gyro[iv.slice]) for iv in faces])
        rate_var = np.median([np.var(recording.gyro[iv.slice], axis=0, ddof=1) for iv in faces], axis=0)
    a_faces = np.array([mean_variance(recording.acc[iv.slice]) for iv in faces])
    return g_faces, rate_var, a_faces


def _tilt_variances(acc_m: np.ndarray, a_faces: np.ndarray, gravity: float, face_axis: np.ndarray) -> np.ndarray:
    """The variance (6, 3) the faces' tilts add to each face's mean acceleration (:func:`closed_form_errors`)."""
    s_a = (acc_m[:3] - acc_m[3:]).T / (2 * gravity)
    # a tilt δ of face f moves reading j by g Σ_m S_jm δ_m over the two directions m off the face's axis
    q = np.array([[gravity**2 * sum(s_a[j, m] ** 2 for m in range(3) if m != face_axis[f]) for j in range(3)]
                  for f in range(6)])

    def pair_scatter(m):  # Σ_i (c_ij − c̄_j)² of the pairs' centres c_ij = (ū₊ᵢ,ⱼ + ū₋ᵢ,ⱼ)/2, per component j
        c = (m[:3] + m[3:]) / 2
        return np.sum((c - c.mean(axis=0)) ** 2, axis=0)

    def pair_variance(v):  # ⅔ Σ_i var c_ij: what the scatter's expectation is
        return 2 / 3 * np.sum((v[:3] + v[3:]) / 4, axis=0)

    tilt = max(float(np.sum(pair_scatter(acc_m) - pair_variance(a_faces)) / np.sum(pair_variance(q))), 0.0)
    # and the face's own axis by g (1 − cos δ)/k ≈ g δ²/(2k) (second order): δ² = σ_δ² χ²₂ has the variance 4σ_δ⁴
    k_a = np.abs(1.0 / np.diag(s_a))
    q_tilt = tilt * q
    q_tilt[np.arange(6), face_axis] += (gravity / k_a[face_axis]) ** 2 * tilt**2
    return q_tilt


def _gyro_drift(t: np.ndarray, faces: list[Interval], gyr_m: np.ndarray, g_faces: np.ndarray, gravity: float,
                face_axis: np.ndarray) -> tuple:
    """The faces' mean times and their mean ``t_ref``, the gyroscope bias's squared drift ``d²`` (3,) and the
    scatter ``τ²`` between the faces beyond their noise (:func:`closed_form_errors`)."""
    # the gyroscope's bias drifts between the faces: u = b + d (t − t_ref) + G g d_f + ε, 15 unknowns in 18
    # readings per axis-triad; the closed form leaves d out (b holds at t_ref, the faces' mean time), which
    # moves G by d (t₊ − t₋)/(2g) and each turn's bias by d (t_turn − t_ref): d² is carried, estimated without
    # bias by d̂² − var d̂ (E d̂² = d² + var d̂; at least 0), var d̂ the fit's plus what the faces' scatter adds;
    # the three readings left over give that scatter τ² beyond their noise
    times = np.array([np.mean(t[iv.slice]) for iv in faces])
    t_ref = float(times.mean())
    design = np.zeros((6, 5))
    design[:, 0] = 1.0
    design[:, 1] = times - t_ref
    design[np.arange(6), 2 + face_axis] = np.where(np.arange(6) < 3, gravity, -gravity)
    drift, drift_var, tau2 = np.zeros(3), np.zeros(3), 0.0
    leftover = 0.0
    for j in range(3):
        w = 1.0 / g_faces[:, j]
        cov = np.linalg.pinv(design.T @ (design * w[:, None]))
        coef = cov @ (design.T @ (w * gyr_m[:, j]))
        r = gyr_m[:, j] - design @ coef
        h = np.einsum("ij,jk,ik->i", design, cov, design * w[:, None])
        leftover += float(np.sum(r**2 - (1 - h) * g_faces[:, j]))
        drift[j], drift_var[j] = coef[1], cov[1, 1]
    tau2 = max(leftover / 3.0, 0.0)  # one left over per axis, pooled
    drift_ms = np.maximum(drift**2 - drift_var - tau2 / max(float(np.sum((times - t_ref) ** 2)), 1e-300), 0.0)
    return times, t_ref, drift_ms, tau2


def _turn_inputs(recording: Recording, turns: dict[int, list[Turn]], acc_si: np.ndarray, x: dict, t_ref: float,
                 noise: tuple, wander: np.ndarray, gyro_scale: np.ndarray) -> list:
    """Each turn's inputs of the closed form, appended to ``x``, and the variances of its integral: (white noise
    and jitter, off the axis) per turn. ``noise``: the rate's per-sample variance, the step, the jitter's
    variance (:func:`closed_form_errors`)."""
    rate_var, dt, jitter_var = noise
    var_turn, tilts = [], []
    window = max(int(round(0.25 * recording.rate)), 3)
    for i in range(3):
        for tr in turns[i]:
            sl = slice(tr.start, tr.stop + 1)
            t = recording.t[sl]
            x["integral"].append(np.trapezoid(recording.gyro[sl], t, axis=0))
            x["duration"].append(float(t[-1] - t[0]))
            x["force"].append(np.trapezoid(acc_si[sl], t, axis=0))
            x["axis"].append(i)
            x["sign"].append(int(tr.sign))
            x["bias_shift"].append(np.zeros(3))
            x["turn_dt"].append(float(np.mean(t)) - t_ref)
            # the hand turns about the vertical only on average: the tilt gravity shows across the turn
            # (rests before and after) is the turn's rotation off its axis, which the off-axis integrals hold;
            # about the axis, the angle differs from the known one by the hand's wander at either end
            before = acc_si[max(tr.start - window, 0):tr.start + 1].mean(axis=0)
            after = acc_si[tr.stop:tr.stop + window + 1].mean(axis=0)
            tilt_turn = float(np.sum((after / np.linalg.norm(after) - before / np.linalg.norm(before)) ** 2)) / 2
            tilts.append(tilt_turn)
            # the trapezoid ∫ ≈ Σ u_k (t_{k+1} − t_{k−1})/2 on jittered stamps: Σ_k σ_t² ((u_{k−1} − u_{k+1})/2)²
            u = recording.gyro[sl]
            jitter = jitter_var * np.sum(((u[:-2] - u[2:]) / 2) ** 2, axis=0)
            var_turn.append(rate_var * dt * x["duration"][-1] + jitter)
    # each turn's own tilt: measured (to the accelerometer's noise), only how it splits between the two
    # off-axis integrals is not
    return [(v_int, np.where(np.arange(3) == axis, 2 * wander[axis], tilt) / np.asarray(gyro_scale) ** 2)
            for v_int, axis, tilt in zip(var_turn, x["axis"], tilts, strict=True)]


def _variance_parts(x: dict, gravity: float, angle: float, variances: tuple) -> tuple[list[str], dict]:
    """The closed form's parameter names and the variance of every parameter from each group of inputs' errors
    ("noise", "tilt", "tau", "turn"), by central differences. ``variances``: the faces' accelerations' noise and
    tilt, the faces' rates' noise, ``τ²``, the drift's ``d²`` and the turns' (:func:`closed_form_errors`)."""
    a_faces, q_tilt, g_faces, tau2, drift_ms, var_turn = variances
    base = _closed_form(x, gravity, angle)
    names = list(base)
    parts: dict[str, np.ndarray] = {}  # variance of every parameter from each group of inputs' errors

    def add(group, key, index, var):  # central differences of the closed form in one input, times its variance
        h = float(np.sqrt(var)) if var > 0 else 0.0
        if h == 0.0:
            return
        out = []
        for sgn in (1.0, -1.0):
            y = {k: (v.copy() if isinstance(v, np.ndarray) else
                     [a.copy() if isinstance(a, np.ndarray) else a for a in v]) for k, v in x.items()}
            if isinstance(y[key], list):
                y[key][index[0]][index[1]] += sgn * h
            else:
                y[key][index] += sgn * h
            out.append(_closed_form(y, gravity, angle))
        d = np.array([(out[0][n] - out[1][n]) / 2 for n in names])
        parts[group] = parts.get(group, 0.0) + d**2

    for f in range(6):
        for j in range(3):
            add("noise", "acc", (f, j), a_faces[f, j])
            add("tilt", "acc", (f, j), q_tilt[f, j])
            add("noise", "gyro", (f, j), g_faces[f, j])
            add("tau", "gyro", (f, j), tau2)
    for j in range(3):
        add("noise", "drift", j, drift_ms[j])
    for n, (v_int, v_off) in enumerate(var_turn):
        for j in range(3):
            add("noise", "integral", (n, j), v_int[j])
            add("turn", "integral", (n, j), v_off[j])
            add("tau", "bias_shift", (n, j), tau2)
    return names, parts


def closed_form_errors(recording: Recording, faces: list[Interval], turns: dict[int, list[Turn]], angle: float,
                       acc_si: np.ndarray, gravity: float, gyro_scale: np.ndarray,
                       rest: Interval | None = None) -> dict[str, float]:
    """1σ of every parameter of the closed form from the scatter its own equations leave.

    The closed form is linear in its inputs: the six faces' mean readings of
    both sensors and each turn's integral ``∫u_g dt``. Their errors:

    * a face mean's noise: the variance of its mean by batch means
      (:func:`~imucalib.fit.accelerometer.mean_variance`, tremor included);
    * a face set down tilted by ``δ`` off its axis: the other two axes read
      ``g δ`` (first order) where the equations expect zero, and its own axis
      ``g cos δ`` for ``g`` (second order; a degree or two moves a 16-bit
      accelerometer's bias by counts). The faces are 18
      readings for 12 unknowns of ``u = S (g d) + b`` (``d = ±e_i``); the six
      left over are the pairs' centres ``(ū₊ᵢ,ⱼ + ū₋ᵢ,ⱼ)/2``, which should all
      equal ``b_j``. Their scatter, less what the faces' noise explains
      (``E Σ_i (c_ij − c̄_j)² = ⅔ Σ_i var c_ij``), gives the tilts' variance
      ``σ_δ²`` (one for the faces, moment estimate, ≥ 0): each off-axis
      reading then has ``σ_δ² (g/k_j)²`` more, each own-axis reading
      ``σ_δ⁴ (g/k_j)²`` (``δ²`` is ``σ_δ² χ²₂``);
    * the gyroscope's bias, which moves between the faces (drift, a random
      walk): the same centres of the gyroscope's pairs give its variance
      ``τ²`` beyond the faces' noise; it enters each face and, as the bias's
      deviation at a turn from the faces' mean, each turn's integral
      (``τ² T²``);
    * a turn's integral: the rate's white noise over the turn,
      ``σ_ω² T dt`` per axis (``σ_ω²`` the per-sample variance at the initial
      rest, else at the faces), and the timestamps' jitter ``σ_t`` (half the
      variance of the regular steps), which moves the trapezoid's integral by
      ``Σ_k ε_k (u_{k−1} − u_{k+1})/2``: ``σ_t² Σ_k ((u_{k−1} − u_{k+1})/2)²``,
      large on a fast turn (a ±1 ms logger moves a 360° hand turn by a few
      tenths of a degree).

    The errors are carried to the canonical parameters by the closed form's
    Jacobian (central differences of :func:`_closed_form`, which is linear
    in them but for ``S⁻¹``). The turn's angle is taken as known, as the method
    assumes (the verdict rejects a turn that does not match it). The
    accelerometer's errors in ``∫a dt`` (the g-sensitivity term) are left out:
    a second-order term.
    """
    g_faces, rate_var, a_faces = _face_noise(recording, faces, rest)
    acc_m = interval_means(recording.acc, faces)
    gyr_m = interval_means(recording.gyro, faces)
    face_axis = np.tile(np.arange(3), 2)
    q_tilt = _tilt_variances(acc_m, a_faces, gravity, face_axis)
    times, t_ref, drift_ms, tau2 = _gyro_drift(recording.t, faces, gyr_m, g_faces, gravity, face_axis)
    steps = np.diff(recording.t)
    dt = float(np.median(steps))
    # timestamp jitter: a step is the clock's period plus the difference of two jitters, var = 2 σ_t² (gaps left out)
    regular = steps[steps < 1.5 * dt]
    jitter_var = float(np.var(regular)) / 2 if regular.size > 2 else 0.0
    # the hand's wander about each axis while it holds a face [rad²]: the variance of the integrated rate
    wander = np.median([_wander(recording.gyro[iv.slice], dt) for iv in faces], axis=0) * np.asarray(gyro_scale) ** 2
    x = {"acc": acc_m, "gyro": gyr_m, "integral": [], "duration": [], "force": [], "axis": [], "sign": [],
         "bias_shift": [], "drift": np.zeros(3), "face_dt": times - t_ref, "turn_dt": []}
    var_turn = _turn_inputs(recording, turns, acc_si, x, t_ref, (rate_var, dt, jitter_var), wander, gyro_scale)
    names, parts = _variance_parts(x, gravity, angle, (a_faces, q_tilt, g_faces, tau2, drift_ms, var_turn))
    dof = {"tilt": 6.0, "tau": 3.0}  # the estimated variances' degrees of freedom (the others' are measured)
    total = sum(parts.values())
    # Satterthwaite's degrees of freedom of the sum, and the 1σ of a t with them (as for the joint fit's
    # rotations, imucalib.fit.gyroscope): estimated from a handful of leftovers, the variance is right on
    # average, yet the error over its root has the variance ν/(ν − 2)
    spread = sum(parts[g] ** 2 / dof[g] for g in parts if g in dof)
    nu = np.maximum(total**2 / np.where(spread > 0, spread, 1.0), 3.0)
    factor = np.where(spread > 0, np.sqrt(nu / (nu - 2.0)), 1.0)
    return {n: float(v) for n, v in zip(names, np.sqrt(total) * factor, strict=True)}


def calibrate(recording, *, gravity: float, intervals=None, angle: float = 360.0,
              max_tilt: float = 15.0, init_static: float | None = None, min_hold: float = MIN_HOLD,
              sections: dict | None = None) -> Calibration:
    """Ferraris calibration in closed form.

    Parameters
    ----------
    recording : Recording or Session
        The recording: an initial rest, then static poses with rotations between them.
        It holds the six faces and a turn about each axis by ``angle``.
    gravity : float
        Local gravity [m/s²].
    intervals : list of Interval, optional
        The static poses as sample ranges; by default found by the method's detector.
    angle : float
        The known turn angle [deg] (360 by default).
    max_tilt : float
        The largest tilt [deg] of a pose from its face for it to count as that face.
    init_static : float, optional
        Length of the initial rest [s]; by default found automatically.
    sections : dict, optional
        Named sample ranges ``{"x_p": [start, stop), …}`` (:data:`SECTION_NAMES`)
        instead of finding the faces and turns.

    Returns
    -------
    Calibration
        The calibration, with its fit figures, 1σ errors and verdict in ``fit``.

    Raises
    ------
    ValueError
        When the poses lack one of the six faces, no turn about an axis is found, or ``angle`` is not a
        positive number of degrees.

    Examples
    --------
    A simulated Ferraris procedure (the six faces, and a full turn about each axis):

    >>> from imucalib.methods import ferraris
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, procedure="ferraris", rest=5)
    >>> cal = ferraris.calibrate(sim.recording, gravity=sim.truth.gravity)
    >>> (cal.gyroscope.scale / sim.truth.gyroscope.scale).round(3)
    array([1.   , 1.001, 1.   ])
    >>> cal.fit.poses.sections  # the faces and turns were found in the recording
    'found'
    """
    if not np.isfinite(angle) or angle <= 0:
        raise ValueError(f"the turn angle must be a positive number of degrees; got {angle!r}")
    theta = np.radians(angle)
    if sections is None:
        rest = initial_rest(recording, init_static)
        if intervals is None:
            # the accelerometer's variance at a fixed multiple of the rest's (Tedaldi 2014's detector; the
            # gyroscope-norm detector of Zhang 2021 eq. 22 sets its threshold on a tremor-free table rest and
            # then finds no hand-held face still); turns about the vertical, which leave the accelerometer
            # still, are cut out below by the gyroscope gate
            window, run = hold_settings(min_hold)
            intervals = static_at(recording, rest, 10.0, window=window, min_interval=run)
        intervals = [iv for iv in intervals if iv.kind == "static"]
        idx = find_faces(interval_means(recording.acc, intervals), gravity, max_tilt=max_tilt)
        rough_acc = faces_full(interval_means(recording.acc, [intervals[j] for j in idx]), gravity)
        bias0 = recording.gyro[rest.slice].mean(axis=0)
        scale = rough_scale(recording, intervals, rough_acc, bias0)
        still = gyro_still(recording, rest, scale, intervals)
        intervals = still_intervals(intervals, still, max(int(recording.rate), 2))
        idx = find_faces(interval_means(recording.acc, intervals), gravity, max_tilt=max_tilt)
        faces = [intervals[j] for j in idx]
    else:
        faces, turns = sections_from_ranges(recording, sections)
        intervals = sorted(faces, key=lambda iv: iv.start)
    acc = faces_full(interval_means(recording.acc, faces), gravity)
    gyr_f = interval_means(recording.gyro, faces)
    g_sens = (gyr_f[:3] - gyr_f[3:]).T / (2 * gravity)  # G e_i, raw per m/s²
    b_g = gyr_f.mean(axis=0)
    scale = rough_scale(recording, intervals, acc, b_g)
    if sections is None:
        turns = find_turns(recording, intervals, b_g, scale, angle=theta)
    else:  # the given turns measured as find_turns measures its own, with the poses' rough scale
        turns = {i: [replace(tr, angle_deg=float(np.degrees(abs(scale) * abs(
            np.trapezoid(recording.gyro[tr.start:tr.stop + 1, i] - b_g[i], recording.t[tr.start:tr.stop + 1])))),
            matches=True) for tr in turns[i]] for i in range(3)}
    missing = [("x", "y", "z")[i] for i in range(3) if not turns.get(i)]
    if missing:
        raise ValueError(f"no turn about the {', '.join(missing)} axis found: turn the sensor by "
                         f"{angle:g}° about each axis while that axis is vertical, resting before "
                         "and after (or give the sections with --sections)")
    gyro = fit_known_turns(recording, {i: [(tr.start, tr.stop, tr.sign) for tr in turns[i]] for i in range(3)},
                           theta, b_g, g_sens, acc.forward(recording.acc))
    figures = [
        SegmentationReport(faces={name: [faces[k].start, faces[k].stop] for k, name in enumerate(FACE_NAMES)},
                           sections="given" if sections is not None else "found"),
        GyroscopeReport(turns={("x", "y", "z")[i]: len(turns[i]) for i in range(3)}, turn_angle_deg=float(angle),
                        turn_sections=[tr.to_dict() for i in range(3) for tr in turns[i]],
                        # the bias is the six faces' mean: with a drifting bias, the bias at their mean time
                        bias_time_s=float(np.mean([np.mean(recording.t[iv.slice]) for iv in faces])))]
    return assemble("ferraris", recording, intervals, acc, gyro, gravity=gravity, figures=figures,
                    uncertainty=closed_form_errors(recording, faces, turns, theta, acc.forward(recording.acc),
                                                   gravity, gyro.scale, rest=None if sections is not None else rest))
