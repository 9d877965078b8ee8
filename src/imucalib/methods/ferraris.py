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

from ..calibration import Calibration, units_of
from ..fit.accelerometer import faces_full
from ..fit.gyroscope import fit_known_turns, rough_scale
from ..methodinfo import MethodInfo, Option
from ..metrics import fit_summary, interval_means
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
        Option("sections", None, "samples", "named sample ranges of the faces and turns, instead of finding "
               "them"),
    ),
    paper="Ferraris et al., Sensors and Materials 1995 (not among the papers; the equations are in this module's "
          "docstring)",
)

__all__ = ["SECTION_NAMES", "calibrate", "sections_from_ranges"]

#: the named sections of a Ferraris session: each axis up (``_p``) and down (``_a``), and its turn
SECTION_NAMES = ("x_p", "y_p", "z_p", "x_a", "y_a", "z_a", "x_rot", "y_rot", "z_rot")


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
        bounds[name] = (s0, s1)
    faces = [Interval(*bounds[name], "static") for name in SECTION_NAMES[:6]]
    b = interval_means(recording.gyro, faces).mean(axis=0) if bias is None else bias
    turns: dict[int, list[Turn]] = {}
    for axis, name in enumerate(SECTION_NAMES[6:]):
        s0, s1 = bounds[name]
        phi = np.trapezoid(recording.gyro[s0:s1] - b, recording.t[s0:s1], axis=0)
        turns[axis] = [Turn(axis, s0, s1 - 1, int(np.sign(phi[axis])), float("nan"), True)]
    return faces, turns


def calibrate(recording, *, gravity: float, intervals=None, angle: float = 360.0,
              max_tilt: float = 15.0, init_static: float | None = None,
              sections: dict | None = None) -> Calibration:
    """Ferraris calibration in closed form.

    Parameters
    ----------
    angle : float
        The known turn angle [deg] (360 by default).
    sections : dict, optional
        Named sample ranges ``{"x_p": [start, stop), …}`` (:data:`SECTION_NAMES`)
        instead of finding the faces and turns.
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
            intervals = static_at(recording, rest, 10.0)
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
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, method="ferraris",
                      model="linear", units=units_of(recording))
    fit = fit_summary(cal, recording, intervals, gravity)
    fit["faces"] = {name: [faces[k].start, faces[k].stop] for k, name in enumerate(FACE_NAMES)}
    fit["turns"] = {("x", "y", "z")[i]: len(turns[i]) for i in range(3)}
    fit["turn_angle_deg"] = float(angle)
    fit["turn_sections"] = [tr.to_dict() for i in range(3) for tr in turns[i]]
    fit["sections"] = "given" if sections is not None else "found"
    fit["uncertainty_unavailable"] = ("the closed form determines every parameter exactly from the six faces "
                                      "and the turns, which leaves no residual to estimate the noise from")
    return cal.with_(fit=fit)
