"""Commands about the sensor and the plan rather than one calibration: noise, plan."""

from __future__ import annotations

import argparse
import math

from ..io.atomic import atomic_write, refuse_overwriting_inputs
from ..methodinfo import declared, needing
from ._common import (
    CliError,
    add_init_static_option,
    add_method_option,
    add_reader_options,
    positive_float,
    print_json,
    read_recording,
    show_warning,
)

__all__ = ["register"]


# ------------------------------------------------------------------ commands
def cmd_noise(args: argparse.Namespace) -> int:
    """``imucalib noise``: :func:`imucalib.noise.noise_summary` of the initial rest, optionally a Kalibr file."""
    from ..calibration import Calibration  # imucalib.calibration costs 79 ms at start-up
    from ..noise import check_rest, kalibr_yaml, noise_summary  # imucalib.noise costs 91 ms at start-up
    from ..recording import ImucalibWarning  # imucalib.recording costs 51 ms at start-up
    from ..segment import initial_rest  # imucalib.segment costs 97 ms at start-up
    from ..verdict import check_rate  # imucalib.verdict costs 112 ms at start-up

    refuse_overwriting_inputs([args.kalibr, args.plot], [*args.data, args.calibration])
    rec = read_recording(args, args.data)
    check_rate(rec)  # before the rest is looked for: a wrong time base makes any window wrong
    if args.calibration:  # noise in SI units, through the calibration
        rec = Calibration.load(args.calibration).apply(rec)
    part = rec if args.whole else rec[initial_rest(rec, args.init_static)]
    for text in check_rest(part):
        show_warning(text, ImucalibWarning, "", 0)
    result = noise_summary(part)
    for name in ("accelerometer", "gyroscope"):
        for text in result.get(name, {}).get("notes", []):
            show_warning(text, ImucalibWarning, "", 0)
    if args.kalibr:
        if part.gyro is None:
            raise CliError("the Kalibr noise file needs a gyroscope's noise; this recording is accelerometer-only")
        if (part.acc_unit, part.gyro_unit) != ("m/s^2", "rad/s"):
            raise CliError(f"the Kalibr file needs SI units; this recording is in {part.acc_unit} and "
                           f"{part.gyro_unit}: pass --calibration CALIBRATION.json (or read data in m/s^2, rad/s)")
        text, notes = kalibr_yaml(result["accelerometer"], result["gyroscope"], part.rate,
                                  topic=rec.metadata.get("topic") or "/imu0")
        with atomic_write(args.kalibr, "w", encoding="utf-8") as fh:
            fh.write(text)
        for n in notes:
            show_warning(n, ImucalibWarning, "", 0)
        result["kalibr"] = str(args.kalibr)
        result["kalibr_bounds"] = notes
    if args.plot:
        from ..report import plot_allan  # imucalib.report costs 102 ms at start-up

        plot_allan(part, args.plot)
    if args.json:
        return print_json(result)
    if args.plot:
        print(f"plot written to {args.plot}")
    if args.kalibr:
        print(f"Kalibr noise file written to {args.kalibr}")
    print(f"noise over {result['seconds']:.1f} s of rest ({result['samples']} samples, "
          f"{result['rate_hz']:.4g} Hz), Allan deviation (IEEE 952 slopes; '<' an upper bound where the curve "
          "does not show the term's slope or too few clusters read it within 20 %, 'const' a column below the "
          "resolution):")
    for name in ("accelerometer", "gyroscope"):
        if name not in result:
            print(f"  {name}: none in this recording (accelerometer-only)")
            continue
        r = result[name]
        u = r["unit"]
        print(f"  {name}: white noise {_triple(r, 'white_noise_density')} {u}·√s, bias instability "
              f"{_triple(r, 'bias_instability')} {u}, random walk {_triple(r, 'random_walk')} {u}/√s")
    return 0


def _triple(r: dict, key: str) -> str:
    """The three axes of a figure: the value, '<bound' where only its bound holds, 'const' for a constant column."""
    out = []
    for j, v in enumerate(r[key]):
        bound = r.get(f"{key}_bound", [None] * 3)[j]
        if r.get("constant", [False] * 3)[j]:
            out.append("const")
        elif v is not None and math.isfinite(v):
            out.append(f"{v:.3g}")
        elif bound is not None and math.isfinite(bound):
            out.append(f"<{bound:.3g}")
        else:
            out.append("-")
    return "[" + ", ".join(out) + "]"


def cmd_plan(args: argparse.Namespace) -> int:
    """``imucalib plan``: the turntable plan of wang2019, else the method's accelerometer pose plan.

    Over :func:`imucalib.experiments.wang2019.plan_report` and :func:`imucalib.plans.accelerometer_plan`.
    """
    if args.method not in declared():
        raise CliError(f"unknown method {args.method!r}; use one of {', '.join(declared())}")
    if args.method not in needing("turntable aggregates"):
        return _plan_accelerometer(args)
    from ..experiments.wang2019 import plan_report  # imucalib.experiments.wang2019 costs 234 ms at start-up

    rep = plan_report(args.seed)
    if args.json:
        return print_json(rep)
    print("positions (gravity direction in the body frame):")
    for k, p in enumerate(rep["positions_gravity_body"], 1):
        print(f"  {k:2d}: [{p[0]: .3f} {p[1]: .3f} {p[2]: .3f}]")
    print(f"rotation pairs ({rep['turn_angle_deg']:g}° clockwise then counter-clockwise) about:")
    for k, a in enumerate(rep["rotation_axes_body"], 1):
        print(f"  {k:2d}: [{a[0]: .3f} {a[1]: .3f} {a[2]: .3f}]")
    print(f"{'parameter':<10}{'value':>14}{'sensitivity':>14}{'Fisher info':>14}{'CRLB std':>12}  observable")
    for p in rep["parameters"]:
        print(f"{p['parameter']:<10}{p['value']:>14.4g}{p['sensitivity_rms']:>14.4g}"
              f"{p['fisher_information']:>14.4g}{p['crlb_std']:>12.3g}  {'yes' if p['observable'] else 'NO'}")
    return 0


def _plan_accelerometer(args: argparse.Namespace) -> int:
    from ..plans import accelerometer_plan  # imucalib.plans costs 86 ms at start-up

    poses = args.poses or ("six" if args.method in needing("six faces") else "nine")
    rep = accelerometer_plan(poses, noise=args.noise_acc)
    short = None
    if args.method not in needing("six faces"):  # a fitted model: the verdict wants redundant poses
        from ..verdict import THRESHOLDS  # imucalib.verdict costs 112 ms at start-up

        want, floor = THRESHOLDS["poses_per_parameter"]
        n_par = len(rep["parameters"])
        rep["poses_for_accepted"] = need = max(math.ceil(want * n_par), math.floor(floor * n_par) + 1)
        if rep["poses"] < need:
            level = "rejected" if rep["poses"] <= floor * n_par else "suspect"
            short = (f"observable is not enough for an accepted calibration: its verdict wants {want:g} poses per "
                     f"parameter ({need} for these {n_par}); a fit of {rep['poses']} poses can follow the noise and "
                     f"is {level}: hold {need} or more poses (--poses {need} prints such a plan)")
    if args.json:
        return print_json(rep)
    print(f"{rep['poses']} static poses (up direction in the body frame), for the linear accelerometer "
          f"model of {args.method}:")
    for k, d in enumerate(rep["directions"], 1):
        print(f"  {k:2d}: [{d[0]: .3f} {d[1]: .3f} {d[2]: .3f}]")
    print(f"Cramér–Rao bound with {rep['noise']:g} m/s^2 of noise on each pose's mean "
          "(scales relative, misalignments in rad, biases in m/s^2):")
    for p in rep["parameters"]:
        bound = f"{p['crlb_std']:.3g}" if p["observable"] else "-"
        verdict = "observable" if p["observable"] else "NOT determined by these poses"
        print(f"  {p['parameter']:<34}{bound:>12}  {verdict}")
    if short:
        print(short)
    return 0


# -------------------------------------------------------------------- parsers
def register(sub: argparse._SubParsersAction) -> None:
    """Add noise and plan to the ``imucalib`` sub-commands."""
    p = sub.add_parser("noise", help="Allan-deviation noise parameters of the initial rest",
                       description="Estimate white noise, bias instability and random walk of both "
                       "sensors from the Allan deviation of the recording's initial rest.")
    p.add_argument("data", nargs="+", help="data file(s), as for calibrate")
    p.add_argument("--whole", action="store_true", help="use the whole recording (it must be at rest)")
    add_init_static_option(p)
    p.add_argument("--plot", metavar="FILE", help="also draw the Allan deviation (PNG/SVG/PDF; plot extra)")
    p.add_argument("--calibration", metavar="CALIBRATION.json",
                   help="apply this calibration first: the noise in m/s^2 and rad/s")
    p.add_argument("--kalibr", metavar="imu.yaml",
                   help="write the IMU noise file of Kalibr/OpenVINS/VINS (needs SI units)")
    p.add_argument("--json", action="store_true")
    add_reader_options(p)
    p.set_defaults(func=cmd_noise)

    p = sub.add_parser("plan", help="print a method's calibration plan and parameter observability",
                       description="Print the positions and rotations of a method's optimal plan "
                       "and, per parameter, its sensitivity and Fisher information.")
    add_method_option(p, required=True, help="the method: a turntable plan for one that needs turntable "
                      "aggregates, else its accelerometer pose plan")
    p.add_argument("--seed", type=int, default=0, help="wang2019: seed of the typical truth used")
    p.add_argument("--poses", help="six, nine (Ru 2022 Table 3) or a number of evenly spread poses "
                   "(default: six for a method that takes the six faces, else nine)")
    p.add_argument("--noise-acc", type=positive_float, default=0.002,
                   help="noise of one pose's mean [m/s^2] (default 0.002)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_plan)
