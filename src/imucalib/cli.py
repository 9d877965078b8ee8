"""Command line: ``imucalib <command>``; thin commands over the library.

Every command has ``--help``. With ``--json`` the machine-readable result is
the only thing printed on stdout; errors go to stderr with a non-zero exit.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from . import __version__
from .calibration import Calibration
from .recording import STANDARD_GRAVITY, ImucalibWarning

EXIT_ERROR = 2


class CliError(Exception):
    """An error reported to the user as one line on stderr."""


# --------------------------------------------------------------------- helpers
def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number; got {text!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number; got {text!r}")
    return v


def _add_reader_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("reading the data")
    g.add_argument("--reader", choices=("csv", "imutk", "mat", "session"),
                   help="input format (default: guessed from the file)")
    g.add_argument("--columns", help="comma-separated column names or 0-based indices in the "
                   "order t,ax,ay,az,gx,gy,gz ('-' for no time column)")
    g.add_argument("--acc-unit", choices=("counts", "g", "m/s^2"),
                   help="accelerometer unit of the input (default: from the header, else counts)")
    g.add_argument("--gyro-unit", choices=("counts", "deg/s", "rad/s"),
                   help="gyroscope unit of the input (default: from the header, else counts)")
    g.add_argument("--time-unit", choices=("s", "ms", "us", "ns"),
                   help="unit of the time column (default: from the header or its values)")
    g.add_argument("--rate", type=_positive_float, help="sampling rate [Hz] when there is no time column")
    g.add_argument("--variable", help="name of the matrix in a MATLAB .mat file")


def _read(args: argparse.Namespace, paths: Sequence[str]):
    if args.reader == "session" or (len(paths) == 1 and Path(paths[0]).is_dir()):
        from .simulate import read_session

        return read_session(paths[0])
    from .io import read

    columns = args.columns.split(",") if args.columns else None
    return read(
        list(paths), reader=args.reader, columns=columns, acc_unit=args.acc_unit,
        gyro_unit=args.gyro_unit, rate=args.rate, variable=args.variable,
        time_unit=args.time_unit,
    )


def _progress(enabled: bool):
    if not enabled:
        return None
    start = time.perf_counter()

    def say(msg: str) -> None:
        print(f"[{time.perf_counter() - start:6.2f} s] {msg}", file=sys.stderr, flush=True)

    return say


def _fmt_matrix(m: np.ndarray) -> str:
    return "\n".join("    [" + "  ".join(f"{v: .7g}" for v in row) + "]" for row in m)


def _print_calibration(cal: Calibration) -> None:
    a, g = cal.accelerometer, cal.gyroscope
    ua, ug = cal.units["accelerometer"]["raw"], cal.units["gyroscope"]["raw"]
    print(f"method: {cal.method}   model: {cal.model}   gravity: {cal.gravity} m/s^2")
    print("accelerometer  a = T_a · f(u − b)")
    print("  misalignment T_a:\n" + _fmt_matrix(a.misalignment))
    print(f"  scale k1 [m/s^2 per {ua}]: " + "  ".join(f"{v:.7g}" for v in a.scale))
    if not a.is_linear:
        print("  scale k2: " + "  ".join(f"{v:.7g}" for v in a.scale_quadratic))
        print("  scale k3: " + "  ".join(f"{v:.7g}" for v in a.scale_cubic))
    print(f"  bias b [{ua}]: " + "  ".join(f"{v:.7g}" for v in a.bias))
    print("gyroscope  ω = T_g · f(u − b − G·a)")
    print("  misalignment T_g:\n" + _fmt_matrix(g.misalignment))
    print(f"  scale k1 [rad/s per {ug}]: " + "  ".join(f"{v:.7g}" for v in g.scale))
    if not g.is_linear:
        print("  scale k2: " + "  ".join(f"{v:.7g}" for v in g.scale_quadratic))
        print("  scale k3: " + "  ".join(f"{v:.7g}" for v in g.scale_cubic))
    print(f"  bias b [{ug}]: " + "  ".join(f"{v:.7g}" for v in g.bias))
    if np.any(g.g_sensitivity):
        print("  g-sensitivity G:\n" + _fmt_matrix(g.g_sensitivity))
    if cal.lever_arm is not None:
        print("lever arm r [m]: " + "  ".join(f"{v:.6g}" for v in cal.lever_arm))
    if cal.fit:
        print("fit:")
        for k, v in cal.fit.items():
            print(f"  {k}: {v:.6g}" if isinstance(v, float) else f"  {k}: {v}")


# -------------------------------------------------------------------- commands
def cmd_calibrate(args: argparse.Namespace) -> int:
    from .methods import calibrate

    say = _progress(not args.json and sys.stderr.isatty())
    data = _read(args, args.data)
    options = {}
    if args.init_static is not None:
        options["init_static"] = args.init_static
    if say is not None:
        options["progress"] = say
    cal = calibrate(data, method=args.method, model=args.model, gravity=args.gravity, **options)
    if args.output:
        cal.save(args.output)
    if args.json:
        print(cal.to_json())
    else:
        _print_calibration(cal)
        if args.output:
            print(f"saved to {args.output}")
    return 0


def cmd_apply(args: argparse.Namespace) -> int:
    from .io import write_csv

    cal = Calibration.load(args.calibration)
    rec = _read(args, [args.data])
    out = cal.apply(rec)
    write_csv(args.output, rec, calibrated_acc=out.acc, calibrated_gyro=out.gyro)
    summary = {"input": str(args.data), "output": str(args.output), "samples": len(rec),
               "calibration": str(args.calibration), "method": cal.method}
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"wrote {len(rec)} calibrated samples to {args.output}")
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from .compare import compare

    say = _progress(not args.json and sys.stderr.isatty())
    data = _read(args, args.data)
    rec = getattr(data, "recording", data)
    methods = args.methods.split(",") if args.methods else None
    result = compare(rec, gravity=args.gravity, methods=methods,
                     folds=None if args.folds == 0 else args.folds, progress=say)
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"{result['static_intervals']} static intervals; leave-one-pose-out over "
          f"{result['folds']} held-out poses")
    print(f"{'method':<14}{'model':<11}{'CV |a|-g RMS [m/s^2]':>22}{'CV angle mean [deg]':>22}")
    for row in result["methods"]:
        if row["ok"]:
            print(f"{row['method']:<14}{row['model'] or '-':<11}"
                  f"{row['cv_accelerometer_residual_rms']:>22.5f}"
                  f"{row['cv_gyroscope_angle_error_mean_deg']:>22.4f}")
        else:
            print(f"{row['method']:<14}{row['model'] or '-':<11}  cannot run: {row['reason']}")
    return 0


def cmd_detect_fall(args: argparse.Namespace) -> int:
    from .methods.zhang2021 import detect_fall

    cal = Calibration.load(args.calibration)
    data = _read(args, [args.data])
    rec = getattr(data, "recording", data)
    falls = detect_fall(cal, rec, threshold=args.threshold)
    out = {"threshold": args.threshold, "falls": [
        {"start": iv.start, "stop": iv.stop, "t_start": float(rec.t[iv.start]),
         "t_stop": float(rec.t[iv.stop - 1]), "duration": float(rec.t[iv.stop - 1] - rec.t[iv.start])}
        for iv in falls]}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{len(falls)} falling intervals (eq. 19 loss < {args.threshold} m/s^2)")
        for f in out["falls"]:
            print(f"  {f['t_start']:10.3f} s .. {f['t_stop']:10.3f} s  ({f['duration']:.3f} s)")
    return 0


# ---------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="imucalib",
        description="Calibrate the accelerometer and gyroscope of low-cost MEMS IMUs.",
    )
    parser.add_argument("--version", action="version", version=f"imucalib {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("calibrate", help="estimate a calibration from a recording",
                       description="Estimate biases, scale factors and misalignments from a "
                       "recording of static poses and rotations between them.")
    p.add_argument("data", nargs="+", help="data file(s): one CSV/MAT file, two imu_tk files "
                   "(accelerometer then gyroscope), or a simulated session directory")
    p.add_argument("--method", default="tedaldi2014", help="calibration method (default: tedaldi2014)")
    p.add_argument("--model", help="model variant, e.g. linear, quadratic, cubic, all")
    p.add_argument("--gravity", type=_positive_float, default=STANDARD_GRAVITY,
                   help=f"local gravity [m/s^2] (default: {STANDARD_GRAVITY})")
    p.add_argument("--init-static", type=_positive_float, metavar="SECONDS",
                   help="length of the initial rest (default: found automatically)")
    p.add_argument("-o", "--output", help="write the calibration file (JSON) here")
    p.add_argument("--json", action="store_true", help="print the calibration as JSON on stdout")
    _add_reader_options(p)
    p.set_defaults(func=cmd_calibrate)

    p = sub.add_parser("apply", help="apply a calibration to a recording",
                       description="Write the recording with calibrated columns added "
                       "(every input row and column is kept).")
    p.add_argument("calibration", help="calibration file (JSON)")
    p.add_argument("data", help="data file to correct")
    p.add_argument("-o", "--output", required=True, help="output CSV file")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    _add_reader_options(p)
    p.set_defaults(func=cmd_apply)

    p = sub.add_parser("compare", help="run every method the data supports and cross-validate",
                       description="Calibrate with every method the recording supports and "
                       "report leave-one-pose-out cross-validated gravity residuals and "
                       "gyroscope angle errors; methods that cannot run say why.")
    p.add_argument("data", nargs="+", help="data file(s), as for calibrate")
    p.add_argument("--gravity", type=_positive_float, default=STANDARD_GRAVITY,
                   help=f"local gravity [m/s^2] (default: {STANDARD_GRAVITY})")
    p.add_argument("--methods", help="comma-separated methods (default: all)")
    p.add_argument("--folds", type=int, default=12,
                   help="held-out poses, spread evenly (0: every pose; default 12)")
    p.add_argument("--json", action="store_true", help="print the comparison as JSON")
    _add_reader_options(p)
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("detect-fall", help="find free-fall intervals (Zhang 2021, §IV-C)",
                       description="Mark samples whose weightless loss (Zhang 2021, eq. 19) is "
                       "below a threshold as falling; needs a calibration with a lever arm.")
    p.add_argument("calibration", help="calibration file (JSON) with a lever arm")
    p.add_argument("data", help="data file")
    p.add_argument("--threshold", type=_positive_float, default=2.5,
                   help="loss threshold [m/s^2] (default 2.5)")
    p.add_argument("--json", action="store_true", help="print the intervals as JSON")
    _add_reader_options(p)
    p.set_defaults(func=cmd_detect_fall)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", ImucalibWarning)
            warnings.showwarning = _show_warning
            return int(args.func(args) or 0)
    except (ValueError, TypeError, OSError, CliError) as exc:
        print(f"imucalib {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"imucalib: warning: {message}", file=sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
