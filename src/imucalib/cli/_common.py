"""What every command shares: the error type, exit codes, reading options, progress output, number parsing, verdicts."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

import numpy as np

from ..progress import Progress, stage_printer
from ..recording import STANDARD_GRAVITY, Recording

__all__ = ["EXIT_ERROR", "EXIT_INTERRUPTED", "EXIT_REJECTED", "STANDARD_GRAVITY", "CliError", "Progress",
           "add_force_option", "add_gravity_option", "add_init_static_option", "add_reader_options",
           "check_verdict", "positive_float", "print_json", "print_verdict", "progress", "read",
           "read_recording", "show_warning"]

#: exit code of a command that failed with a reported error
EXIT_ERROR = 2
#: exit code of a calibration that is rejected: made but rejected (calibrate), or no longer holding (validate)
EXIT_REJECTED = 3
#: exit code after Ctrl-C (128 + SIGINT)
EXIT_INTERRUPTED = 130


class CliError(Exception):
    """An error reported to the user as one line on stderr."""


# ---------------------------------------------------------------- arguments
def positive_float(text: str) -> float:
    """An argparse type: a finite number above zero."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number; got {text!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number; got {text!r}")
    return v


def add_gravity_option(p: argparse.ArgumentParser) -> None:
    """``--gravity`` with the standard gravity as its default."""
    p.add_argument("--gravity", type=positive_float, default=STANDARD_GRAVITY,
                   help=f"local gravity [m/s^2] (default: {STANDARD_GRAVITY})")


def add_reader_options(p: argparse.ArgumentParser) -> None:
    """The options of :func:`imucalib.io.read`, for commands that read a recording."""
    g = p.add_argument_group("reading the data")
    g.add_argument("--reader", choices=("csv", "imutk", "mat", "phone", "rosbag", "session"),
                   help="input format (default: guessed from the file)")
    g.add_argument("--topic", help="ROS bags: the sensor_msgs/Imu topic (needed when there are several)")
    g.add_argument("--columns", help="comma-separated column names or 0-based indices in the "
                   "order t,ax,ay,az,gx,gy,gz ('-' for no time column)")
    g.add_argument("--acc-unit", choices=("counts", "g", "m/s^2"),
                   help="accelerometer unit of the input (default: from the header, else counts)")
    g.add_argument("--gyro-unit", choices=("counts", "deg/s", "rad/s"),
                   help="gyroscope unit of the input (default: from the header, else counts)")
    g.add_argument("--time-unit", choices=("s", "ms", "us", "ns"),
                   help="unit of the time column (default: from the header or its values)")
    g.add_argument("--rate", type=positive_float, help="sampling rate [Hz] when there is no time column")
    g.add_argument("--variable", help="name of the matrix in a MATLAB .mat file")


def add_init_static_option(p: argparse.ArgumentParser) -> None:
    """``--init-static``: the length of the initial rest, found automatically by default."""
    p.add_argument("--init-static", type=positive_float, metavar="SECONDS",
                   help="length of the initial rest (default: found automatically)")


def add_force_option(p: argparse.ArgumentParser) -> None:
    """``--force``: use a calibration whose verdict is ``rejected``."""
    p.add_argument("--force", action="store_true",
                   help="use the calibration even though its verdict is 'rejected'")


# ------------------------------------------------------------------ reading
def read(args: argparse.Namespace, paths: Sequence[str]):
    """The data in ``paths`` as the reader options say: a recording or a simulated session."""
    from ..io.data import read_data

    columns = args.columns.split(",") if args.columns else None
    return read_data(
        list(paths), reader=args.reader, columns=columns, acc_unit=args.acc_unit,
        gyro_unit=args.gyro_unit, rate=args.rate, variable=args.variable,
        time_unit=args.time_unit, topic=args.topic,
    )


def read_recording(args: argparse.Namespace, paths: Sequence[str]) -> Recording:
    """The recording in ``paths`` (a simulated session's main recording); a clear error for turntable aggregates."""
    data = read(args, paths)
    rec = getattr(data, "recording", data)
    if not isinstance(rec, Recording):
        raise CliError(f"imucalib {args.command} needs a recording of samples; {paths[0]} holds turntable "
                       "aggregates (a wang2019 session), which only 'calibrate --method wang2019' reads")
    return rec


# ------------------------------------------------------------------- output
def print_json(obj) -> int:
    """Print ``obj`` as one line of strict JSON on stdout (non-finite numbers as ``null``); 0, the exit code."""
    from ..io.jsontext import dumps

    print(dumps(obj))
    return 0


def progress(enabled: bool) -> Callable[[str], None] | None:
    """Time-stamped stage messages on stderr, or None when not ``enabled``."""
    return stage_printer(enabled)


def print_verdict(result: dict, headline: str) -> None:
    """``headline``, then one line per reason of ``result["verdict_reasons"]``, then its notes indented further."""
    print(headline)
    for reason in result.get("verdict_reasons") or []:
        print(f"  - {reason}")
    for note in result.get("verdict_notes") or []:
        print(f"      note: {note}")


def check_verdict(calibration, path, force: bool) -> None:
    """Refuse a rejected calibration unless ``force``; warn on stderr about a suspect one (or a forced one).

    A calibration without a verdict (a file from before verdicts) is used as it is.
    """
    fit = calibration.fit or {}
    verdict = fit.get("verdict")
    reasons = "; ".join(fit.get("verdict_reasons") or []) or "no reason recorded"
    if verdict == "rejected" and not force:
        raise CliError(f"the calibration in {path} was rejected when it was made: {reasons}. Calibrate again, "
                       "or pass --force to use it all the same")
    if verdict in ("rejected", "suspect"):
        show_warning(f"the calibration in {path} is {verdict}"
                     + (" (used because of --force)" if verdict == "rejected" else "") + f": {reasons}")


def show_warning(message, category=None, filename=None, lineno=None, file=None, line=None) -> None:
    """``warnings.showwarning`` for the command line: one line on stderr."""
    print(f"imucalib: warning: {message}", file=sys.stderr)
