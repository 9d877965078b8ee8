"""Commands around one calibration.

Make it (calibrate, compare the methods) and use it (detect-fall; apply is in :mod:`.apply`, export in
:mod:`.export`); checking it on another recording (validate) is in :mod:`.validation`.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from typing import TYPE_CHECKING

from ..io.atomic import refuse_overwriting_inputs
from ..methodinfo import DEFAULT_METHOD
from ..presets import FALL_THRESHOLD
from . import apply as apply_command
from ._common import (
    EXIT_REJECTED,
    CliError,
    add_gravity_option,
    add_init_static_option,
    add_method_option,
    add_min_hold_option,
    add_poses_option,
    add_reader_options,
    load_calibration,
    positive_float,
    print_json,
    print_verdict,
    progress,
    read,
    read_recording,
)

if TYPE_CHECKING:
    from ..calibration import Calibration

__all__ = ["VERDICT_KEYS", "print_calibration", "register"]

#: the entries of ``fit`` that make the verdict, printed before the parameters
VERDICT_KEYS = ("verdict", "verdict_reasons", "verdict_notes")


# ------------------------------------------------------------------ printing
def print_calibration(cal: Calibration) -> None:
    """The calibration for a person: every parameter, with ± its 1σ error where the method gives one."""
    import numpy as np  # numpy costs 47 ms at start-up

    unc = cal.fit.uncertainty.sigma or {}

    def pm(name: str, value: float, fmt: str = ".7g") -> str:
        s = unc.get(name)
        return f"{value:{fmt}}" + (f" ± {s:.2g}" if s is not None and np.isfinite(s) else "")

    def vec(prefix: str, key: str, values) -> str:
        return "  ".join(pm(f"{prefix}.{key}.{ax}", v) for ax, v in zip("xyz", values, strict=True))

    def matrix(prefix: str, key: str, m) -> str:
        cells = [[pm(f"{prefix}.{key}.{'xyz'[i]}{'xyz'[j]}", v, " .7g") for j, v in enumerate(row)]
                 for i, row in enumerate(m)]
        width = max(len(c) for row in cells for c in row)
        return "\n".join("    [" + "  ".join(c.ljust(width) for c in row) + "]" for row in cells)

    a, g = cal.accelerometer, cal.gyroscope
    ua, ug = cal.units["accelerometer"]["raw"], (cal.units.get("gyroscope") or {}).get("raw")
    print(f"method: {cal.method}   model: {cal.model}   gravity: {cal.gravity} m/s^2")
    if unc:
        print("(± : 1σ standard error of the fit)")
    for prefix, t, unit, cal_unit, formula in (
            ("accelerometer", a, ua, "m/s^2", "a = T_a · f(u − b)"),
            ("gyroscope", g, ug, "rad/s", "ω = T_g · f(u − b − G·a)")):
        if t is None:
            why = cal.fit.gyroscope.not_calibrated or "an accelerometer-only recording"
            print(f"{prefix}: none ({why})")
            continue
        print(f"{prefix}  {formula}")
        print(f"  misalignment T:\n{matrix(prefix, 'misalignment', t.misalignment)}")
        print(f"  scale k1 [{cal_unit} per {unit}]: {vec(prefix, 'scale', t.scale)}")
        if not t.is_linear:
            print(f"  scale k2: {vec(prefix, 'scale_quadratic', t.scale_quadratic)}")
            print(f"  scale k3: {vec(prefix, 'scale_cubic', t.scale_cubic)}")
        print(f"  bias b [{unit}]: {vec(prefix, 'bias', t.bias)}")
        if np.any(t.output_bias):
            print(f"  output bias d [{cal_unit}]: {vec(prefix, 'output_bias', t.output_bias)}")
        if np.any(t.g_sensitivity):
            print(f"  g-sensitivity G [{unit} per m/s^2]:\n{matrix(prefix, 'g_sensitivity', t.g_sensitivity)}")
    if cal.lever_arm is not None:
        print("lever arm r [m]: " + "  ".join(pm(f"lever_arm.{ax}", v, ".6g")
                                               for ax, v in zip("xyz", cal.lever_arm, strict=True)))
    if cal.fit:
        print("fit:")
        for k, v in cal.fit.to_flat().items():  # as the file holds them
            if k in VERDICT_KEYS:
                continue  # printed first, by cmd_calibrate
            if k == "intervals":
                print(f"  intervals: {len(v)} (sample ranges in the JSON)")
            elif k == "uncertainty":
                continue
            elif isinstance(v, list) and len(v) > 6:
                print(f"  {k}: {len(v)} values (in the JSON)")
            elif k == "pose_coverage":
                print("  pose_coverage (gravity component, min..max): "
                      + "  ".join(f"{a} {lo:+.2f}..{hi:+.2f}" for a, (lo, hi) in v.items()))
            elif k == "next_poses":
                print("  next_poses (up directions in the body frame): "
                      + "  ".join("[" + " ".join(f"{c:+.2f}" for c in u) + "]" for u in v))
            elif k == "quality_flags":
                for flag in v:
                    print(f"  quality flag: {flag}")
            else:
                print(f"  {k}: {v:.6g}" if isinstance(v, float) else f"  {k}: {v}")


# ------------------------------------------------------------------ commands
_SECTIONS_BYTES = 1 << 16  # a sections file is nine pairs of integers: a few hundred bytes


def _sections(path: str) -> dict:
    """The named Ferraris sections in the JSON file ``path`` (:func:`imucalib.methods.ferraris.parse_sections`)."""
    from ..io.jsontext import SmallFileError, read_json  # imucalib.io.jsontext costs 49 ms at start-up
    from ..methods.ferraris import parse_sections  # imucalib.methods.ferraris costs 177 ms at start-up

    try:
        doc = read_json(path, _SECTIONS_BYTES, "sections file",
                        'nine pairs of sample indices {"x_p": [start, stop], …} in JSON')
        return parse_sections(doc)
    except (SmallFileError, ValueError) as exc:
        raise CliError(f"--sections {path}: {exc}") from None


def _method_options(args: argparse.Namespace) -> dict:
    """The method options given on the command line; the Ferraris ones only with ``--method ferraris``."""
    given = {flag: (key, value) for flag, key, value in (("--turn-angle", "angle", args.turn_angle),
                                                        ("--sections", "sections", args.sections))
             if value is not None}
    if given and args.method is None:  # the Ferraris options name the method
        args.method = "ferraris"
    if given and args.method != "ferraris":
        raise CliError(f"{' and '.join(given)} {'apply' if len(given) > 1 else 'applies'} to --method ferraris "
                       f"only, not {args.method}")
    ferraris = dict(given.values())
    if "sections" in ferraris:
        ferraris["sections"] = _sections(args.sections)
    zhang = {flag: (key, False) for flag, key, on in (("--keep-terms", "select", args.keep_terms),
                                                      ("--no-noise-weights", "noise_weights", args.no_noise_weights))
             if on}
    if zhang and args.method != "zhang2021":
        raise CliError(f"{' and '.join(zhang)} {'apply' if len(zhang) > 1 else 'applies'} to --method zhang2021 "
                       f"only, not {args.method or DEFAULT_METHOD}")
    sensors = {k: v for k, v in (("temperature_model", args.temperature_model), ("mag_field", args.mag_field),
                                 ("mag_hemisphere", args.mag_hemisphere)) if v is not None}
    if args.no_magnetometer:
        sensors["magnetometer"] = False
    return {**{k: v for k, v in (("init_static", args.init_static), ("min_hold", args.min_hold),
                                 ("detector", args.detector)) if v is not None},
            **ferraris, **dict(zhang.values()), **sensors}


def cmd_calibrate(args: argparse.Namespace) -> int:
    """``imucalib calibrate``: :func:`imucalib.methods.calibrate`, then the file, figure and report asked for.

    The verdict comes first; a rejected calibration is still written (``fit.verdict`` marks it) and exits
    with :data:`EXIT_REJECTED`.
    """
    from ..methods import calibrate  # imucalib.methods costs 183 ms at start-up
    from ..recording import ImucalibWarning, Interval  # imucalib.recording costs 52 ms at start-up

    refuse_overwriting_inputs([args.output, args.plot, args.report], [*args.data, args.sections])
    options = _method_options(args)
    say = progress(not args.json and sys.stderr.isatty())
    data = read(args, args.data)
    if say is not None:
        options["progress"] = say
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImucalibWarning)
        cal = calibrate(data, method=args.method, model=args.model, gravity=args.gravity, **options)
    for w in caught:  # shown as usual, and kept for the report
        warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    if args.output:
        cal.save(args.output)
    # turntable aggregates and pose tables have no samples
    rec = None if args.poses or hasattr(data, "positions_acc") else getattr(data, "recording", data)
    ivs = [Interval(a, b) for a, b in cal.fit.poses.intervals or []]
    if args.plot:
        from ..report import plot_fit  # imucalib.report costs 101 ms at start-up

        if rec is None or not ivs:
            raise CliError("a table of averaged poses has no samples to plot" if args.poses else
                           "this method's data has no static poses to plot")
        plot_fit(cal, rec, ivs, args.plot)
    if args.report:
        from ..report import html_report  # imucalib.report costs 101 ms at start-up

        html_report(cal, args.report, recording=rec, intervals=ivs,
                    notes=[str(w.message) for w in caught if issubclass(w.category, ImucalibWarning)])
    verdict = cal.fit.verdict.level
    code = EXIT_REJECTED if verdict == "rejected" else 0
    if code:
        print("imucalib calibrate: the calibration is rejected"
              + (f"; {args.output} is written all the same, marked \"rejected\" in fit.verdict (apply and "
                 "export refuse it without --force)" if args.output else ""), file=sys.stderr)
        if args.json:
            for reason in cal.fit.verdict.reasons or []:
                print(f"  - {reason}", file=sys.stderr)
    if args.json:
        print(cal.to_json())  # strict JSON, as in the file
        return code
    if verdict:
        print_verdict(cal.fit.verdict, f"verdict: {verdict.upper()}", advise=True)
    print_calibration(cal)
    for done, what in ((args.output, "saved to"), (args.plot, "plot written to"),
                       (args.report, "report written to")):
        if done:
            print(f"{what} {done}")
    return code


def cmd_compare(args: argparse.Namespace) -> int:
    """``imucalib compare``: :func:`imucalib.comparison.compare`, as a table."""
    from ..comparison import compare  # imucalib.comparison costs 182 ms at start-up

    say = progress(not args.json and sys.stderr.isatty())
    rec = read_recording(args, args.data)
    peers = {path: load_calibration(path, rec, args.gravity) for path in args.peer or []}
    result = compare(rec, gravity=args.gravity, methods=args.methods.split(",") if args.methods else None,
                     folds=None if args.folds == 0 else args.folds, progress=say, init_static=args.init_static,
                     peers=peers, magnetometer=not args.no_magnetometer,
                     **({} if args.min_hold is None else {"min_hold": args.min_hold}))
    if args.json:
        return print_json(result)
    print(f"{result['static_intervals']} static intervals; leave-one-pose-out over "
          f"{result['folds']} held-out poses; ranked by {result['ranked_by']}")
    print(f"{'#':>2} {'method':<14}{'model':<18}{'verdict':<10}{'CV |a|-g RMS [m/s^2]':>22}"
          f"{'CV angle mean [deg]':>22}{'score':>8}")
    for row in result["methods"]:
        model = row["model"] or "-"
        if row.get("model_selected") and row["model_selected"] != row["model"]:
            model = f"{model}->{row['model_selected']}"
        head = f"{row['rank']:>2} {row['method']:<14}{model:<18}{row.get('verdict') or '-':<10}"
        if row["ok"]:
            angle = row["cv_gyroscope_angle_error_mean_deg"]
            print(head + f"{row['cv_accelerometer_residual_rms']:>22.5f}"
                  + (f"{angle:>22.4f}" if angle is not None else f"{'- (no gyroscope)':>22}")
                  + (f"{row['score']:>8.2f}" if row["score"] is not None else f"{'-':>8}")
                  + (f"   ({row['cv_folds_skipped']} folds could not run)" if row["cv_folds_skipped"] else ""))
        else:
            print(head + f"  cannot run: {row['reason']}")
    if result["best"]:
        print(f"best: {result['best']}")
    elif result.get("tied"):
        print(f"best: a tie between {', '.join(result['tied'][:-1])} and {result['tied'][-1]} (the same verdict "
              "and score: nothing here prefers one)")
    else:
        print("best: none (every method was rejected or could not run)")
    if result.get("peers"):
        print("peers, scored as they are on the same held-out poses (not refitted, not ranked: in sample when "
              "made from this recording):")
    for row in result.get("peers", []):
        name = os.path.basename(row["name"])
        if not row["ok"]:
            print(f"   {name}: cannot be scored: {row['reason']}")
            continue
        angle = row["cv_gyroscope_angle_error_mean_deg"]
        print(f"   {name:<40}{row['cv_accelerometer_residual_rms']:>22.5f}"
              + (f"{angle:>22.4f}" if angle is not None else f"{'-':>22}"))
    return 0


def cmd_detect_fall(args: argparse.Namespace) -> int:
    """``imucalib detect-fall``: :func:`imucalib.methods.zhang2021.detect_fall`, with the intervals' times."""
    from ..calibration import Calibration  # imucalib.calibration costs 77 ms at start-up
    from ..methods.zhang2021 import detect_fall  # imucalib.methods.zhang2021 costs 174 ms at start-up

    cal = Calibration.load(args.calibration)
    rec = read_recording(args, [args.data])
    falls = detect_fall(cal, rec, threshold=args.threshold)
    out = {"threshold": args.threshold, "falls": [
        {"start": iv.start, "stop": iv.stop, "t_start": float(rec.t[iv.start]),
         "t_stop": float(rec.t[iv.stop - 1]), "duration": float(rec.t[iv.stop - 1] - rec.t[iv.start])}
        for iv in falls]}
    if args.json:
        return print_json(out)
    print(f"{len(falls)} falling intervals (eq. 19 loss < {args.threshold} m/s^2)")
    for f in out["falls"]:
        print(f"  {f['t_start']:10.3f} s .. {f['t_stop']:10.3f} s  ({f['duration']:.3f} s)")
    return 0


# -------------------------------------------------------------------- parsers
def register(sub: argparse._SubParsersAction) -> None:
    """Add calibrate, apply, compare and detect-fall to the ``imucalib`` sub-commands."""
    p = sub.add_parser("calibrate", help="estimate a calibration from a recording",
                       description="Estimate biases, scale factors and misalignments from a "
                       "recording of static poses and rotations between them. The verdict (accepted, suspect "
                       "or rejected, with its reasons) is printed first; a rejected calibration is still "
                       "written, marked as such, and the command exits with code 3.")
    p.add_argument("data", nargs="+", help="data file(s): one CSV/MAT file, two imu_tk files "
                   "(accelerometer then gyroscope), a ROS bag, or a simulated session directory")
    add_method_option(p, chosen=True)
    p.add_argument("--model", help="model variant, e.g. linear, quadratic, cubic, all")
    add_gravity_option(p)
    add_init_static_option(p)
    add_min_hold_option(p)
    p.add_argument("--detector", choices=("accelerometer", "gyroscope"),
                   help="zhang2021: static detector, Tedaldi's accelerometer variance (default) or "
                   "the gyroscope norm of Zhang 2021 eq. (22)")
    p.add_argument("--keep-terms", action="store_true", help="zhang2021: keep the model's nonlinear terms even "
                   "where Akaike's criterion prefers fewer (the library's select=False)")
    p.add_argument("--no-noise-weights", action="store_true", help="zhang2021: weigh every residual alike, "
                   "for noise-free data (the library's noise_weights=False)")
    p.add_argument("-o", "--output", help="write the calibration file (JSON) here")
    p.add_argument("--plot", metavar="FILE.png", help="write a figure of the fit (needs matplotlib)")
    p.add_argument("--report", metavar="FILE.html",
                   help="write a self-contained HTML report: fit, parameters with errors, warnings, figure")
    p.add_argument("--turn-angle", type=positive_float, metavar="DEG",
                   help="ferraris: the known angle of each turn [deg] (default 360)")
    p.add_argument("--sections", metavar="FILE", help="ferraris: a JSON object of named sample ranges "
                   "[start, stop): x_p, x_a, y_p, y_a, z_p, z_a (each axis up, down) and x_rot, y_rot, z_rot "
                   "(the turns), instead of finding them; imucal's section lists ({\"x_p\": {\"start\": s, "
                   "\"end\": e}, ...}, end exclusive) are read too")
    p.add_argument("--temperature-model", choices=("linear",), help="a session recorded while the temperature "
                   "changed (a warm-up): biases, and scale factors where the data show it, linear in temperature "
                   "(needs a temperature column)")
    g = p.add_argument_group("magnetometer (when the data have mx, my, mz columns)")
    g.add_argument("--no-magnetometer", action="store_true", help="leave the magnetometer uncalibrated")
    g.add_argument("--mag-field", type=positive_float, metavar="UT", help="the local field magnitude [µT] (e.g. "
                   "from a geomagnetic model): the calibrated field in µT (default: normalised for counts)")
    g.add_argument("--mag-hemisphere", choices=("north", "south"), help="magnetic hemisphere: the field points "
                   "below (north, the default) or above (south) the horizontal")
    p.add_argument("--json", action="store_true", help="print the calibration as JSON on stdout")
    add_poses_option(p, "its accelerometer is calibrated from the pose means (the gyroscope needs rotations)")
    add_reader_options(p)
    p.set_defaults(func=cmd_calibrate)

    apply_command.register(sub)

    p = sub.add_parser("compare", help="run every method the data supports and cross-validate",
                       description="Calibrate with every method the recording supports and "
                       "report leave-one-pose-out cross-validated gravity residuals and "
                       "gyroscope angle errors; methods that cannot run say why.")
    p.add_argument("data", nargs="+", help="data file(s), as for calibrate")
    add_gravity_option(p)
    add_init_static_option(p)
    add_min_hold_option(p)
    p.add_argument("--methods", help="comma-separated methods (default: all)")
    p.add_argument("--folds", type=int, default=12,
                   help="held-out poses, spread evenly (0: every pose; default 12)")
    p.add_argument("--peer", action="append", metavar="CALIBRATION", help="a calibration made elsewhere (imucalib's "
                   "JSON, or imu_tk's NAME_acc.calib with NAME_gyro.calib beside it), scored on the same held-out "
                   "poses without refitting and printed beneath the methods, not ranked (repeatable)")
    p.add_argument("--no-magnetometer", action="store_true", help="leave the magnetometer uncalibrated (the "
                   "cross-validation folds never calibrate it: their figures judge the accelerometer and gyroscope)")
    p.add_argument("--json", action="store_true", help="print the comparison as JSON")
    add_reader_options(p)
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("detect-fall", help="find free-fall intervals (Zhang 2021, §IV-C)",
                       description="Mark samples whose weightless loss (Zhang 2021, eq. 19) is "
                       "below a threshold as falling; needs a calibration with a lever arm.")
    p.add_argument("calibration", help="calibration file (JSON) with a lever arm")
    p.add_argument("data", help="data file")
    p.add_argument("--threshold", type=positive_float, default=FALL_THRESHOLD,
                   help=f"loss threshold [m/s^2] (default {FALL_THRESHOLD})")
    p.add_argument("--json", action="store_true", help="print the intervals as JSON")
    add_reader_options(p)
    p.set_defaults(func=cmd_detect_fall)
