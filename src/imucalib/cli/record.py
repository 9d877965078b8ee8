"""``imucalib record``: a guided recording session over :func:`imucalib.record.record`."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ._common import CliError, add_gravity_option, normalise_argv, positive_float

__all__ = ["register", "cmd_record"]


def _lines_for(event: dict) -> list[str]:
    """An event in words, one or more lines."""
    kind = event["event"]
    if kind == "format":
        notes = [f"  note: {n}" for n in event.get("notes", [])]
        return [f"reading the stream: accelerometer in {event['acc_unit']}, gyroscope in {event['gyro_unit']}, "
                f"time from the {event['time'] if event['time'] != 'column' else 'time column'}", *notes]
    if kind == "rest":
        if event.get("remaining_s"):
            return [f"initial rest: keep the sensor still on the table … {event['remaining_s']} s"]
        return [f"initial rest done ({event['t']:.1f} s): take the first pose"]
    if kind == "pose":
        cov = " ".join(f"{a}[{lo:+.1f},{hi:+.1f}]" for a, (lo, hi) in event["coverage"].items())
        return [f"pose {event['pose']} held {event['seconds']:.1f} s at t = {event['t_start']:.1f} s: "
                f"{event['words']}   coverage {cov}"]
    if kind == "next_pose":
        then = f" (then {', then '.join(event['then'])})" if event.get("then") else ""
        return [f"  next: {event['words']}{then}"]
    if kind == "warning":
        return [f"warning: {event['message']}"]
    if kind == "complete":
        return [f"COMPLETE after pose {event['poses']} (t = {event['t']:.1f} s): {event['message']}"]
    if kind == "end":
        return [f"end of the stream: {event['lines']} lines, {event['samples']} samples, {event['poses']} poses"
                + (f", {event['unparsed_lines']} line(s) that do not parse (kept in the file)"
                   if event["unparsed_lines"] else "")
                + ("" if event["complete"] else "; not yet enough for an accepted calibration")]
    return [json.dumps(event)]


class PlainView:
    """Every event as plain lines on ``out``."""

    def __init__(self, out) -> None:
        self.out = out

    def __call__(self, event: dict) -> None:
        for line in _lines_for(event):
            print(line, file=self.out, flush=True)

    def close(self) -> None:
        pass


class RichView:
    """A live terminal view (rich): the rest countdown, poses held, coverage, the next pose, the last warnings."""

    def __init__(self, out) -> None:
        from rich.console import Console
        from rich.live import Live

        self.console = Console(file=out)
        self.state = {"status": "waiting for the stream …", "poses": [], "next": "", "warnings": [],
                      "coverage": {}, "complete": None}
        self.live = Live(self._render(), console=self.console, refresh_per_second=8, transient=False)
        self.live.start()

    def _render(self):
        from rich.table import Table

        s = self.state
        table = Table(title="imucalib record", show_header=False, expand=False)
        table.add_column("what", style="bold")
        table.add_column("value")
        table.add_row("status", s["status"])
        table.add_row("poses held", str(len(s["poses"])) + (f"  (last: {s['poses'][-1]})" if s["poses"] else ""))
        if s["coverage"]:
            table.add_row("coverage", "  ".join(f"{a} {lo:+.1f}..{hi:+.1f}" for a, (lo, hi) in s["coverage"].items()))
        if s["next"]:
            table.add_row("next pose", f"[bold cyan]{s['next']}[/]")
        if s["complete"]:
            table.add_row("complete", f"[bold green]{s['complete']}[/]")
        for w in s["warnings"][-3:]:
            table.add_row("warning", f"[yellow]{w}[/]")
        return table

    def __call__(self, event: dict) -> None:
        s, kind = self.state, event["event"]
        if kind == "rest":
            s["status"] = (f"initial rest: keep still … {event['remaining_s']} s" if event.get("remaining_s")
                           else "recording poses: take the next pose and hold it still")
        elif kind == "pose":
            s["poses"].append(event["words"])
            s["coverage"] = event["coverage"]
        elif kind == "next_pose":
            s["next"] = event["words"]
        elif kind == "warning":
            s["warnings"].append(event["message"])
        elif kind == "complete":
            s["complete"] = event["message"]
            s["next"] = ""
        elif kind in ("format", "end"):
            s["status"] = _lines_for(event)[0]
        self.live.update(self._render())

    def close(self) -> None:
        self.live.stop()


def _view(out):
    """Rich's live view on a terminal that has it, else plain lines."""
    if out.isatty():
        try:
            return RichView(out)
        except ImportError:
            pass
    return PlainView(out)


class EventLog:
    """Each event as one JSON line: on stdout (``-``) or in ``FILE.partial``, renamed to ``FILE`` at the end."""

    def __init__(self, target: str | None) -> None:
        self.target = target
        self.fh = None
        if target == "-":
            self.fh = sys.stdout
        elif target:
            path = Path(target)
            if not path.parent.is_dir():
                raise CliError(f"--events {target}: its directory does not exist")
            self.partial = path.with_name(path.name + ".partial")
            self.fh = open(self.partial, "w", encoding="utf-8")  # noqa: SIM115 (closed by close)

    def __call__(self, event: dict) -> None:
        if self.fh is not None:
            self.fh.write(json.dumps(event, allow_nan=False) + "\n")
            self.fh.flush()

    def close(self) -> None:
        if self.fh is not None and self.target != "-":
            from ..io.atomic import move_into_place

            self.fh.close()
            move_into_place(self.partial, Path(self.target))


def cmd_record(args: argparse.Namespace) -> int:
    """``imucalib record``: :func:`imucalib.record.record` with a live view, the events, then calibrate."""
    from ..io.atomic import refuse_overwriting_inputs
    from ..record import Recorder, open_source, record

    out = Path(args.output)
    if out.suffix == ".partial":
        raise CliError(f"-o {out}: name the finished file; {out}.partial is written while recording")
    refuse_overwriting_inputs([args.output, args.events if args.events != "-" else None, args.calibrate],
                              [args.source[len("serial:"):].split("?")[0]] if args.source.startswith("serial:")
                              else [])
    view = _view(sys.stderr if args.events == "-" else sys.stdout)
    log = EventLog(args.events)

    def on_event(event: dict) -> None:
        log(event)
        view(event)

    try:
        recorder = Recorder(on_event, method=args.method, gravity=args.gravity, rest=args.rest,
                            columns=args.columns.split(",") if args.columns else None, acc_unit=args.acc_unit,
                            gyro_unit=args.gyro_unit, time_unit=args.time_unit, rate=args.rate,
                            gyro_range=args.gyro_range, directory=out.parent)
        with open_source(args.source) as stream:
            result = record(stream, out, recorder)
    finally:
        view.close()
        log.close()
    say = (lambda m: print(m, file=sys.stderr)) if args.events == "-" else print
    say(f"session written to {result.path}" + (" (interrupted: the lines read until then)"
                                                 if result.interrupted else ""))
    if not args.calibrate:
        return 0
    from . import calibration

    parser = argparse.ArgumentParser(prog="imucalib")
    calibration.register(parser.add_subparsers(dest="command"))
    argv = ["calibrate", str(result.path), "--method", args.method, "--gravity", str(args.gravity),
            "-o", args.calibrate]
    for flag, value in (("--columns", args.columns), ("--acc-unit", args.acc_unit), ("--gyro-unit", args.gyro_unit),
                        ("--time-unit", args.time_unit), ("--rate", args.rate)):
        if value is not None:
            argv += [flag, str(value)]
    if args.events == "-":
        argv.append("--json")
    cal_args = parser.parse_args(normalise_argv(argv))
    return int(cal_args.func(cal_args) or 0)


def register(sub: argparse._SubParsersAction) -> None:
    """Add record to the ``imucalib`` sub-commands."""
    p = sub.add_parser("record", help="record a session from a live stream, guided pose by pose",
                       description="Read a sensor's live text stream (one sample per line, any layout the CSV "
                       "reader takes), write every line to OUTPUT as it comes (OUTPUT.partial until the end), "
                       "and say what to do: the initial rest's countdown, each pose held, the coverage, the next "
                       "pose to take, warnings (too fast, wobbling) and 'complete' once the poses support an "
                       "accepted calibration. Ctrl-C or the end of the stream finishes.")
    p.add_argument("source", help="- (standard input), serial:/dev/ttyUSB0?baud=115200 (pyserial), tcp://HOST:PORT, "
                   "or phyphox://HOST:8080 (phyphox's remote access)")
    p.add_argument("-o", "--output", required=True, help="the session file to write (CSV, the lines as read)")
    p.add_argument("--events", metavar="FILE", help="also write every event as one JSON line to FILE (- for "
                   "stdout, the view then on stderr)")
    p.add_argument("--method", default="tedaldi2014", help="the method the session is for (default tedaldi2014)")
    p.add_argument("--calibrate", metavar="CAL.json", help="calibrate the session at the end and write this file")
    p.add_argument("--rest", type=positive_float, default=5.0, help="seconds of initial rest to count down "
                   "(default 5)")
    p.add_argument("--gyro-range", type=positive_float, help="the gyroscope's full scale in its raw unit "
                   "(default: 32768 for counts)")
    g = p.add_argument_group("reading the stream")
    g.add_argument("--columns", metavar="T,AX,AY,AZ,GX,GY,GZ",
                   help="column names or 0-based indices in the order t,ax,ay,az,gx,gy,gz ('-' for no time column)")
    g.add_argument("--acc-unit", choices=("counts", "g", "m/s^2"), help="accelerometer unit (default: header, "
                   "else counts)")
    g.add_argument("--gyro-unit", choices=("counts", "deg/s", "rad/s"), help="gyroscope unit (default: header, "
                   "else counts)")
    g.add_argument("--time-unit", choices=("s", "ms", "us", "ns"), help="unit of the time column")
    g.add_argument("--rate", type=positive_float, help="sampling rate [Hz] when there is no time column")
    add_gravity_option(p)
    p.set_defaults(func=cmd_record)
