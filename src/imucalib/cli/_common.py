"""What every command shares: the error type, exit codes, reading options, progress output, number parsing, verdicts."""

from __future__ import annotations

import argparse
import errno
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from ..constants import GRAVITY_RANGE, STANDARD_GRAVITY, earth_gravity_text
from ..presets import MIN_HOLD
from ..printable import printable
from ..progress import Progress, stage_printer

if TYPE_CHECKING:
    from ..recording import Recording

__all__ = ["EXIT_ERROR", "EXIT_INTERRUPTED", "EXIT_REJECTED", "STANDARD_GRAVITY", "CliError", "PrintableStream",
           "Progress",
           "add_force_option", "add_gravity_option", "add_init_static_option", "add_method_option",
           "add_min_hold_option", "add_poses_option", "add_reader_options", "check_paths", "check_verdict",
           "gravity_value", "load_calibration", "normalise_argv", "positive_float", "print_json", "print_verdict",
           "progress", "read", "read_recording", "reading_progress", "report_error", "show_warning",
           "tolerant_encoding"]

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
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number; got {text!r}")
    return v


def gravity_value(text: str) -> float:
    """An argparse type: a gravity in :data:`imucalib.calibration.GRAVITY_LIMITS` (a warning when not the Earth's)."""
    from ..calibration import GRAVITY_LIMITS  # kept off --version's start-up (78 ms)

    g = positive_float(text)
    if not GRAVITY_LIMITS[0] <= g <= GRAVITY_LIMITS[1]:
        raise argparse.ArgumentTypeError(f"{text} m/s^2 is not a gravity (expected {GRAVITY_LIMITS[0]:g}-"
                                         f"{GRAVITY_LIMITS[1]:g} m/s^2; the Earth's is {earth_gravity_text()})")
    lo, hi = GRAVITY_RANGE
    if not lo <= g <= hi:
        show_warning(f"--gravity {text}: {g:g} m/s^2 is outside {lo}-{hi} m/s^2, the gravity on the Earth's "
                     f"surface; it is used as given (the default is {STANDARD_GRAVITY})")
    return g


def add_gravity_option(p: argparse.ArgumentParser) -> None:
    """``--gravity`` with the standard gravity as its default."""
    p.add_argument("--gravity", type=gravity_value, default=STANDARD_GRAVITY,
                   help=f"local gravity [m/s^2] (default: {STANDARD_GRAVITY}; a value outside "
                   f"{GRAVITY_RANGE[0]}-{GRAVITY_RANGE[1]} is used with a warning)")


def normalise_argv(argv: Sequence[str]) -> list[str]:
    """``--columns -,0,1,…`` as ``--columns=-,0,1,…``: argparse reads a value starting with '-' as an option."""
    out = [str(a) for a in argv]
    for i in range(len(out) - 1, 0, -1):
        if out[i - 1] == "--columns" and out[i].startswith("-") and (out[i] == "-" or "," in out[i]):
            out[i - 1:i + 1] = [f"--columns={out[i]}"]
    return out


def add_reader_options(p: argparse.ArgumentParser) -> None:
    """The options of :func:`imucalib.io.read`, for commands that read a recording."""
    g = p.add_argument_group("reading the data")
    g.add_argument("--reader", choices=("csv", "imutk", "mat", "phone", "rosbag", "session"),
                   help="input format (default: guessed from the file)")
    g.add_argument("--topic", help="ROS bags: the sensor_msgs/Imu topic (needed when there are several)")
    g.add_argument("--mag-topic", help="ROS bags: a sensor_msgs/MagneticField topic to calibrate beside the IMU")
    g.add_argument("--columns", metavar="T,AX,AY,AZ,GX,GY,GZ",
                   help="which column is which (CSV header names, any case, or 0-based indices; for a .mat matrix "
                   "indices). Positional: in the order t,ax,ay,az,gx,gy,gz, '-' for t when there is no time column "
                   "(with --rate), e.g. --columns -,0,1,2,3,4,5; 4 entries t,ax,ay,az (or '-' for gx,gy,gz) for an "
                   "accelerometer-only log; 10 entries add mx,my,mz (a magnetometer), 11 add temp. By field, in any "
                   "order: --columns t=Time,ax=AccX,ay=AccY,az=AccZ,gx=GyrX,gy=GyrY,gz=GyrZ[,mx=..,my=..,mz=..]"
                   "[,temp=..]; a field left out is absent (t too: then --rate). Rows where all the named sensor "
                   "cells are empty (another packet's rows in a vendor's log) are skipped, with a note")
    g.add_argument("--acc-unit", choices=("counts", "g", "m/s^2"),
                   help="accelerometer unit of the input (default: from the header, else counts)")
    g.add_argument("--gyro-unit", choices=("counts", "deg/s", "rad/s"),
                   help="gyroscope unit of the input (default: from the header, else counts)")
    g.add_argument("--time-unit", choices=("s", "ms", "us", "ns"),
                   help="unit of the time column (default: from the header, else the unit in which its median step "
                   "is a rate IMUs record at, said in a note when not plain: millis() stamps are ms, 1.6e18 epoch "
                   "stamps ns). Stamps printed coarser than the sampling (repeating every other row) are put on "
                   "their straight line, rows repeated exactly are dropped: both with a note")
    g.add_argument("--rate", type=positive_float, help="sampling rate [Hz] when there is no time column (a sample "
                   "counter such as n_samples is not one: it needs --rate)")
    g.add_argument("--variable", help="name of the matrix in a MATLAB .mat file")
    g.add_argument("--mag-unit", choices=("counts", "uT", "gauss"),
                   help="magnetometer unit of the mx,my,mz (or mag_x,…) columns (default: from the header, else "
                   "counts)")


def add_poses_option(p: argparse.ArgumentParser, what: str) -> None:
    """``--poses``: the data are a table of averaged poses (:func:`imucalib.io.read_pose_table`)."""
    p.add_argument("--poses", action="store_true", help="the data are a table of averaged poses, one row per "
                   f"orientation (ax ay az [gx gy gz] [n] [σ], with or without a header): {what}")


def add_method_option(p: argparse.ArgumentParser, *, required: bool = False, help: str | None = None,
                      chosen: bool = False) -> None:
    """``--method``: one of the declared methods (:func:`imucalib.methodinfo.declared`), by default the library's.

    The help names them; an unknown name is the command's error (exit 2, the known names in the message).
    ``chosen``: the default is None, the library's choice (:func:`imucalib.methods.calibrate`).
    """
    from ..methodinfo import DEFAULT_METHOD, declared  # kept off --version's start-up: it loads only the parser

    names = list(declared())
    text = help or "calibration method"
    default = None if required or chosen else DEFAULT_METHOD
    said = (f" (default: {DEFAULT_METHOD}; ferraris when the static poses are only the six faces and "
            f"{DEFAULT_METHOD}'s calibration is rejected)") if chosen else "" if required else \
        f" (default: {DEFAULT_METHOD})"
    p.add_argument("--method", metavar="METHOD", required=required, default=default,
                   help=f"{text}: {', '.join(names)}{said}")


def add_init_static_option(p: argparse.ArgumentParser) -> None:
    """``--init-static``: the length of the initial rest, found automatically by default."""
    p.add_argument("--init-static", type=positive_float, metavar="SECONDS",
                   help="length of the initial rest (default: found automatically)")


def add_min_hold_option(p: argparse.ArgumentParser) -> None:
    """``--min-hold``: the shortest hold that is a pose."""
    p.add_argument("--min-hold", type=positive_float, metavar="SECONDS",
                   help=f"shortest hold that is a pose (default {MIN_HOLD:g} s; poses held longer are found, "
                   "the static detector's window is half of it, at most 1 s)")


def add_force_option(p: argparse.ArgumentParser) -> None:
    """``--force``: use a calibration whose verdict is ``rejected``."""
    p.add_argument("--force", action="store_true",
                   help="use the calibration even though its verdict is 'rejected'")


# -------------------------------------------------------------------- paths
#: the options that name files a command reads, and those it writes
INPUT_OPTIONS = ("data", "calibration", "calibrations", "sections", "noise", "manifest")
OUTPUT_OPTIONS = ("output", "plot", "report", "kalibr")
#: commands whose output is a folder they create with its parents
_FOLDER_OUTPUTS = ("simulate",)


#: path options that are always given by their flag (the others are positional in some commands)
_FLAGGED = ("sections", "noise", "plot", "report", "kalibr")


def _named(args: argparse.Namespace, names: Sequence[str]) -> list[tuple[str, str]]:
    """``(how the message names it, path)`` of each path given in ``names``: the flag and the path for
    :data:`_FLAGGED` options, else the path."""
    out = []
    for name in names:
        value = getattr(args, name, None)
        values = value if isinstance(value, list | tuple) else [value]
        out += [(f"--{name} {v}" if name in _FLAGGED else str(v), str(v))
                for v in values if v is not None and str(v) != "-"]
    return out


def check_paths(args: argparse.Namespace) -> None:
    """Refuse, before anything is read or written, paths no command can use, naming the cause.

    An input or output that is a symbolic link loop; an input that is a FIFO, socket or device (reading
    it would block or never end; :func:`imucalib.io.inputs.check_input_path`); an output in a folder that
    does not exist (or is not a folder). Inputs that are missing are left to the readers, which say so.
    """
    from ..io.errors import ReaderError  # kept off --version's start-up (with the io package)
    from ..io.inputs import check_input_path  # kept off --version's start-up (63 ms)

    for label, name in _named(args, INPUT_OPTIONS):
        try:
            check_input_path(name)
        except ReaderError as exc:
            if "not found" not in str(exc):
                text = str(exc)
                raise CliError(text if label == name else f"{label.split()[0]} {text}") from None
    for _, name in _named(args, OUTPUT_OPTIONS):
        try:
            os.stat(name)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise CliError(f"{name}: the output is a symbolic link loop (the link leads back to itself "
                               "through other links); remove the link or choose another output name") from None
        folder = os.path.dirname(os.path.abspath(name))
        if getattr(args, "command", None) in _FOLDER_OUTPUTS:
            continue
        if not os.path.isdir(folder):
            what = "is not a folder" if os.path.lexists(folder) else "does not exist"
            raise CliError(f"{name}: the folder {folder} {what}; create it first (mkdir -p '{folder}') or choose "
                           "another output path")


# ------------------------------------------------------------------ reading
def read(args: argparse.Namespace, paths: Sequence[str]):
    """The data in ``paths`` as the reader options say: a recording or a simulated session."""
    from ..reading import read as read_data  # kept off --version's start-up (84 ms with the readers)

    columns = args.columns.split(",") if args.columns else None
    with reading_progress(args, f"reading {paths[0]}") as bar:
        return read_data(
            list(paths), reader=args.reader, columns=columns, acc_unit=args.acc_unit,
            gyro_unit=args.gyro_unit, rate=args.rate, variable=args.variable,
            time_unit=args.time_unit, topic=args.topic, progress=bar,
            mag_unit=getattr(args, "mag_unit", None), mag_topic=getattr(args, "mag_topic", None),
            poses=getattr(args, "poses", False),
        )


class _LateProgress:
    """A :class:`Progress` that appears only once the work has taken ``delay`` seconds (quick reads stay silent)."""

    def __init__(self, label: str, unit: str, delay: float = 2.0) -> None:
        self.label, self.unit, self.delay = label, unit, delay
        self.start = time.perf_counter()
        self.bar: Progress | None = None

    def __call__(self, done: int, total: int | None = None) -> None:
        if self.bar is None:
            if time.perf_counter() - self.start < self.delay:
                return
            self.bar = Progress(self.label, total, unit=self.unit)
        self.bar(done, total)

    def __enter__(self) -> _LateProgress:
        return self

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            self.bar.close()


def reading_progress(args: argparse.Namespace, label: str) -> _LateProgress:
    """Progress (on stderr, never stdout) of reading or copying a long input, message by message."""
    return _LateProgress(label, "message")


def read_recording(args: argparse.Namespace, paths: Sequence[str]) -> Recording:
    """The recording in ``paths`` (a simulated session's main recording); a clear error for turntable aggregates."""
    from ..recording import Recording  # kept off --version's start-up (50 ms)

    data = read(args, paths)
    rec = getattr(data, "recording", data)
    if not isinstance(rec, Recording):
        raise CliError(f"imucalib {args.command} needs a recording of samples; {paths[0]} holds turntable "
                       "aggregates (a wang2019 session), which only 'calibrate --method wang2019' reads")
    return rec


# ------------------------------------------------------------------- output
def print_json(obj) -> int:
    """Print ``obj`` as one line of strict JSON on stdout (non-finite numbers as ``null``); 0, the exit code."""
    from ..io.jsontext import dumps  # kept off --version's start-up (50 ms)

    print(dumps(obj))
    return 0


def progress(enabled: bool) -> Callable[[str], None] | None:
    """Time-stamped stage messages on stderr, or None when not ``enabled``."""
    return stage_printer(enabled)


def print_verdict(verdict, headline: str, *, advise: bool = False) -> None:
    """``headline``, then one line per reason of ``verdict`` (a :class:`~imucalib.fitreport.VerdictReport`), then
    its notes indented further.

    With ``advise``, a verdict other than accepted is followed by the poses to
    record next (``verdict.next_poses``) in words.
    """
    print(headline)
    for reason in verdict.reasons or []:
        print(f"  - {reason}")
    if advise and verdict.level != "accepted" and verdict.next_poses:
        from ..plans import describe_poses  # kept off --version's start-up (73 ms)

        print(f"  record next: {describe_poses(verdict.next_poses)}")
    for note in verdict.notes or []:
        print(f"      note: {note}")


def check_verdict(calibration, path, force: bool) -> None:
    """Refuse a rejected calibration unless ``force``; warn on stderr about a suspect one (or a forced one).

    A calibration without a verdict (a file from before verdicts) is used as it is.
    """
    fit = calibration.fit
    verdict = fit.verdict.level
    reasons = "; ".join(fit.verdict.reasons or []) or "no reason recorded"
    if verdict == "rejected" and not force:
        raise CliError(f"the calibration in {path} was rejected when it was made: {reasons}. Calibrate again, "
                       "or pass --force to use it all the same")
    if verdict in ("rejected", "suspect"):
        show_warning(f"the calibration in {path} is {verdict}"
                     + (" (used because of --force)" if verdict == "rejected" else "") + f": {reasons}")


def show_warning(message, category=None, filename=None, lineno=None, file=None, line=None) -> None:
    """``warnings.showwarning`` for the command line: one line on stderr (numpy's arithmetic warnings in words),
    its control characters escaped (:func:`imucalib.printable.printable`)."""
    if category is not None and issubclass(category, RuntimeWarning):
        message = ("a computation went out of range (a number overflowed or was undefined), so the result may "
                   "not be reliable: check the input for extreme or constant readings")
    print(f"imucalib: warning: {printable(message)}", file=sys.stderr)


def report_error(command: str, error) -> int:
    """Print ``error`` as the command's one-line error on stderr (control characters escaped); the exit code."""
    print(f"imucalib {command}: error: {printable(error)}", file=sys.stderr)
    return EXIT_ERROR


class PrintableStream:
    """A text stream (standard output) whose writes have their control characters escaped, but for tab, line
    feed and carriage return (CSV's line end): what a file, a header or the store holds cannot reach the
    terminal as a control sequence (:mod:`imucalib.printable`)."""

    def __init__(self, stream) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        return self._stream.write(printable(text, keep="\t\n\r"))

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def tolerant_encoding() -> None:
    """Standard output and error write what their encoding cannot hold as escapes (``\\u00b0`` for °)
    instead of failing: a terminal that is not UTF-8 gets the whole message, after the files are written."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            try:
                reconfigure(errors="backslashreplace")
            except (ValueError, OSError):  # a stream that cannot change (closed, detached)
                pass


def load_calibration(path: str, recording, gravity: float | None):
    """A calibration file named on the command line: imucalib's JSON, or imu_tk's ``NAME_acc.calib`` pair.

    imu_tk's files hold neither units nor gravity: they map the raw units of the readings they were made from,
    taken as ``recording``'s, with ``gravity`` (default: standard gravity) as given to imu_tk.
    """
    from ..calibration import Calibration  # kept off --version's start-up (78 ms)

    if not str(path).endswith(".calib"):
        return Calibration.load(path)
    from ..export.imutk import from_imutk, imutk_pair  # kept off --version's start-up (94 ms)
    from ..recording import STANDARD_GRAVITY  # kept off --version's start-up (50 ms)

    acc, gyro = imutk_pair(path)
    return from_imutk(acc, gyro if recording.gyro is not None else None, acc_unit=recording.acc_unit,
                      gyro_unit=recording.gyro_unit, gravity=gravity or STANDARD_GRAVITY)
