"""Command line: ``imucalib <command>``; thin commands over the library.

Every command has ``--help``. With ``--json`` the machine-readable result is
the only thing printed on stdout; errors go to stderr with a non-zero exit.

One module per group of commands, each adding its own sub-parsers
(``register``): :mod:`.calibration` (calibrate, apply, compare, detect-fall),
:mod:`.export` (export), :mod:`.validation` (validate), :mod:`.simulation` (simulate,
montecarlo, demo), :mod:`.analysis` (noise, plan), :mod:`.thermal` (thermal), :mod:`.fleet`
(batch, store) and :mod:`.record` (record); :mod:`._common` holds what they share.
A command imports only its own group (:data:`GROUPS`); the help of ``imucalib`` itself,
and a name that is no command, import them all.

Exit codes: 0 success, 2 an error (:data:`EXIT_ERROR`), 3 a calibration that
is rejected (:data:`EXIT_REJECTED`: calibrate made one, validate finds it no
longer holds; batch had rows that failed), 130 interrupted.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from collections.abc import Sequence

from .. import __version__
from ._common import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    EXIT_REJECTED,
    CliError,
    PrintableStream,
    check_paths,
    normalise_argv,
    report_error,
    show_warning,
    tolerant_encoding,
)

__all__ = ["EXIT_ERROR", "EXIT_REJECTED", "GROUPS", "CliError", "build_parser", "main"]

#: each command's group: the module of this package whose ``register`` adds it (in the order of the help)
GROUPS = {
    "calibrate": "calibration", "apply": "calibration", "compare": "calibration", "detect-fall": "calibration",
    "export": "export",
    "validate": "validation",
    "simulate": "simulation", "montecarlo": "simulation", "demo": "simulation", "reproduce": "simulation",
    "noise": "analysis", "plan": "analysis",
    "thermal": "thermal",
    "batch": "fleet", "store": "fleet",
    "record": "record",
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``imucalib`` argument parser with every command's sub-parser, or only ``command``'s group's.

    Parameters
    ----------
    command : str, optional
        A command of :data:`GROUPS`: only its group's module is imported and registered (a command's
        parsing and its own help are the same as with every group). ``""``: no command at all (what
        ``--version`` needs). Default: every group, as the help of ``imucalib`` lists them.
    """
    parser = argparse.ArgumentParser(
        prog="imucalib",
        description="Calibrate the accelerometer and gyroscope of low-cost MEMS IMUs.",
    )
    parser.add_argument("--version", action="version", version=f"imucalib {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    if command is None or command in GROUPS:
        groups = dict.fromkeys(GROUPS.values()) if command is None else [GROUPS[command]]
        for group in groups:
            importlib.import_module(f".{group}", __name__).register(sub)
    return parser


def _command_of(argv: Sequence[str]) -> str | None:
    """What :func:`build_parser` needs for ``argv``: its command, ``""`` for ``--version`` alone, else None."""
    if argv and argv[0] in GROUPS:
        return argv[0]
    return "" if list(argv[:1]) == ["--version"] else None


#: the environment variables that set the number of threads of numpy's BLAS (OpenBLAS, MKL, OpenMP)
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS")


def one_blas_thread() -> None:
    """Let numpy's BLAS run one thread, unless the user has chosen a number or numpy is already loaded.

    The products of the fits are small or thin ((3 × 3n)·(3n × P), (N × 3)·(3 × 3)): a second BLAS
    thread does not shorten them, and its waiting costs CPU that the program's other processes (batch
    workers) or other programs need. Measured on a 2-core machine shared with other work: zhang2021
    ``all`` on a simulated session took 0.64–0.71 s of CPU (3.1–3.4 s wall) with one thread and
    3.2–4.6 s of CPU (13–17 s wall) with two. The variables are read when numpy loads, so this acts
    only before that; child processes inherit it.
    """
    if "numpy" in sys.modules or any(v in os.environ for v in BLAS_THREAD_VARIABLES):
        return
    for v in BLAS_THREAD_VARIABLES:
        os.environ[v] = "1"


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``imucalib`` with ``argv`` (default: the process's arguments); the exit code."""
    one_blas_thread()
    argv = normalise_argv(sys.argv[1:] if argv is None else argv)
    args = build_parser(_command_of(argv)).parse_args(argv)
    from ..recording import ImucalibWarning  # after parsing: --version and --help import no numpy

    stdout = sys.stdout
    tolerant_encoding()
    if args.command != "record":  # the recorder's live view draws with control sequences of its own
        sys.stdout = PrintableStream(stdout)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", ImucalibWarning)
            warnings.showwarning = show_warning
            check_paths(args)
            return int(args.func(args) or 0)
    except BrokenPipeError:  # output piped into e.g. head: not an error
        sys.stderr.close()
        return 0
    except (ValueError, TypeError, OSError, CliError) as exc:
        return report_error(args.command, exc)
    except MemoryError:
        return report_error(args.command, "out of memory: the input is larger than this computer's memory can "
                            "hold as a recording; give a shorter recording (or cut it into parts)")
    except RecursionError:
        return report_error(args.command, "an input nested too deeply to read (a crafted or damaged file)")
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        sys.stdout = stdout
