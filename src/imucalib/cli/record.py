"""``imucalib record``: a guided recording session over :func:`imucalib.record.record`."""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

from ..io.atomic import move_into_place, output_target, refuse_overwriting_inputs, temporary_prefix
from . import calibration
from ._common import CliError, add_gravity_option, add_method_option, normalise_argv, positive_float

__all__ = ["register", "cmd_record"]


def _held_as(k: int | None) -> str:
    return "" if k is None else " (already held as the initial rest)" if k == 0 else f" (already held as pose {k})"


def _lines_for(event: dict) -> list[str]:
    """An event in words, one or more lines."""
    kind = event["event"]
    if kind == "format":
        notes = [f"  note: {n}" for n in event.get("notes", [])]
        return [f"reading the stream: accelerometer in {event['acc_unit']}, gyroscope in {event['gyro_unit']}, "
                f"time from the {event['time'] if event['time'] != 'column' else 'time column'}", *notes]
    if kind == "rest":
        if event.get("restart"):
            return [f"initial rest: {event['message']}"]
        if event.get("remaining_s"):
            return [f"initial rest: keep the sensor still on the table … {event['remaining_s']} s"]
        return [f"initial rest done ({event['t']:.1f} s): take the first pose and hold it still"]
    if kind == "holding":
        to = (f"; the suggested pose is {event['to_suggestion_deg']:.0f}° away" if "to_suggestion_deg" in event
              else "")
        if event.get("already_held") is not None:
            return [f"  holding {event['words']} … {event['seconds']:.1f} s{_held_as(event['already_held'])}: "
                    "turn to a new orientation"]
        if event.get("enough"):
            return [f"  holding {event['words']} … {event['seconds']:.1f} s: held — now turn to the next pose{to}"]
        return [f"  holding {event['words']} … {event['seconds']:.1f} s, keep still{to}"]
    if kind == "pose":
        cl = event.get("checklist") or {}
        missing = cl.get("missing")
        src = "" if event.get("directions_from") != "raw" else " (direction from raw readings: rough)"
        out = [f"pose {event['pose']} done ({event['seconds']:.1f} s at t = {event['t_start']:.1f} s): "
               f"{event['words']}{src}{_held_as(event.get('already_held'))}"]
        if cl:
            faces = " ".join(f"[{'x' if ok else ' '}] {name}" for name, ok in cl["faces"].items())
            out.append(f"  faces {faces}   corners {cl['corners']}/8   turned about "
                       + " ".join(f"[{'x' if ok else ' '}] {a}" for a, ok in cl["turned"].items()))
        if missing:
            out.append(f"  still missing: {', '.join(missing)}")
        return out
    if kind == "next_pose":
        then = f" (then {', then '.join(event['then'])})" if event.get("then") else ""
        return [f"  now turn to {event['words']} — {event.get('turn_deg', float('nan')):.0f}° from this pose{then}"]
    if kind == "warning":
        return [f"warning: {event['message']}"]
    if kind == "silence":
        return [f"waiting: {event['message']}"]
    if kind == "complete":
        return [f"COMPLETE after pose {event['poses']} (t = {event['t']:.1f} s): {event['message']}"]
    if kind == "end":
        out = [f"end of the stream: {event['lines']} lines, {event['samples']} samples, {event['poses']} poses"
               + (f", {event['bad_lines']} line(s) left out" if event.get("bad_lines") else "")
               + (f", {event['gaps']} gap(s)" if event.get("gaps") else "")]
        return out
    return [json.dumps(event)]


def verdict_line(event: dict) -> str:
    """The last line of a session: the verdict of its calibration and what to redo (an ``end`` event)."""
    verdict = event.get("verdict")
    redo = "; ".join(event.get("redo") or ["record the session again"])
    if verdict == "accepted":
        return "verdict: accepted — the session calibrates; nothing to redo"
    if verdict is not None:
        return f"verdict: {verdict} — redo: {redo}"
    return ("verdict: none, the session does not calibrate" + (f" ({event['error']})" if event.get("error") else "")
            + f" — redo: {redo}")


class PlainView:
    """Every event as plain lines on ``out``; a terminal bell with each pose when ``bell``."""

    def __init__(self, out, *, bell: bool = False) -> None:
        self.out, self.bell = out, bell

    def __call__(self, event: dict) -> None:
        lines = _lines_for(event)
        if self.bell and event["event"] == "pose" and lines:
            lines[0] = "\a" + lines[0]
        for line in lines:
            print(line, file=self.out, flush=True)

    def close(self) -> None:
        pass


class RichView:
    """A live terminal view (rich): the rest countdown, poses held, coverage, the next pose, the last warnings."""

    def __init__(self, out, *, bell: bool = False) -> None:
        from rich.console import Console  # optional: pip install imucalib[live]
        from rich.live import Live  # optional: pip install imucalib[live]

        self.console = Console(file=out)
        self.out, self.bell = out, bell
        self.state = {"status": "waiting for the stream …", "poses": [], "next": "", "warnings": [],
                      "coverage": {}, "complete": None}
        self.live = Live(self._render(), console=self.console, refresh_per_second=8, transient=False)
        self.live.start()

    def _render(self):
        from rich.table import Table  # optional: pip install imucalib[live]

        s = self.state
        table = Table(title="imucalib record", show_header=False, expand=False)
        table.add_column("what", style="bold")
        table.add_column("value")
        table.add_row("status", s["status"])
        table.add_row("poses held", str(len(s["poses"])) + (f"  (last: {s['poses'][-1]})" if s["poses"] else ""))
        if s["coverage"]:
            table.add_row("coverage", "  ".join(f"{a} {lo:+.1f}..{hi:+.1f}" for a, (lo, hi) in s["coverage"].items()))
        if s.get("missing"):
            table.add_row("still missing", ", ".join(s["missing"]))
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
            s["missing"] = (event.get("checklist") or {}).get("missing", [])
            if self.bell:
                self.out.write("\a")
        elif kind == "holding":
            s["status"] = _lines_for(event)[0].strip()
        elif kind == "next_pose":
            s["next"] = event["words"]
        elif kind == "warning":
            s["warnings"].append(event["message"])
        elif kind == "complete":
            s["complete"] = event["message"]
            s["next"] = ""
        elif kind in ("format", "end", "silence"):
            s["status"] = " ".join(_lines_for(event))
        self.live.update(self._render())

    def close(self) -> None:
        self.live.stop()


def _view(out, *, bell: bool = True):
    """Rich's live view on a terminal that has it, else plain lines; the bell on a terminal only."""
    if out.isatty():
        try:
            return RichView(out, bell=bell)
        except ImportError:
            pass
    return PlainView(out, bell=bell and out.isatty())


class EventLog:
    """Each event as one JSON line: on stdout (``-``), into a FIFO or device as a stream, or into a file.

    A file is written under a hidden temporary name next to it and moved into
    place at the end (:mod:`imucalib.io.atomic`'s rules: a symbolic link
    followed, a read-only file, a directory, a block device or socket refused).
    """

    def __init__(self, target: str | None) -> None:
        self.target = target
        self.fh = None
        self.tmp = None
        if target == "-":
            self.fh = sys.stdout
        elif target:
            try:
                path, stream = output_target(target)
            except (ValueError, OSError) as exc:
                raise CliError(f"--events {exc}") from None
            if not path.parent.is_dir():
                raise CliError(f"--events {target}: its directory does not exist")
            self.path = path
            if stream:
                flags = os.O_WRONLY | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
                self.fh = os.fdopen(os.open(path, flags), "w", encoding="utf-8")
            else:
                fd, name = tempfile.mkstemp(dir=path.parent, prefix=temporary_prefix(path), suffix=".tmp")
                self.tmp = Path(name)
                self.fh = os.fdopen(fd, "w", encoding="utf-8")

    def __call__(self, event: dict) -> None:
        if self.fh is not None:
            self.fh.write(json.dumps(event, allow_nan=False) + "\n")
            self.fh.flush()

    def close(self) -> None:
        if self.fh is None or self.target == "-":
            return
        self.fh.close()
        self.fh = None
        if self.tmp is not None:
            move_into_place(self.tmp, self.path)


def _live_page(args: argparse.Namespace):
    """The live view in the browser (``--view``), its address said and opened."""
    import webbrowser  # 10 ms, on imucalib --help's start-up too (it loads this module)

    from ..record.view import LiveView  # imucalib.record.view costs 155 ms at start-up

    page = LiveView(port=args.view_port)
    (print if args.events != "-" else lambda m: print(m, file=sys.stderr))(f"live view: {page.url}")
    webbrowser.open(page.url)
    return page


def _calibrate_session(args: argparse.Namespace, path) -> int:
    """``imucalib calibrate`` of the session just written (``--calibrate``), with the recording's options; its
    exit code (2, said here, on an error: the verdict stays the last line)."""

    parser = argparse.ArgumentParser(prog="imucalib")
    calibration.register(parser.add_subparsers(dest="command"))
    argv = ["calibrate", str(path), "--method", args.method, "--gravity", str(args.gravity),
            "-o", args.calibrate]
    for flag, value in (("--columns", args.columns), ("--acc-unit", args.acc_unit),
                        ("--gyro-unit", args.gyro_unit), ("--time-unit", args.time_unit), ("--rate", args.rate)):
        if value is not None:
            argv += [flag, str(value)]
    if args.events == "-":
        argv.append("--json")
    cal_args = parser.parse_args(normalise_argv(argv))
    try:
        code = int(cal_args.func(cal_args) or 0)
    except (ValueError, OSError, CliError) as exc:  # said here, so that the verdict stays the last line
        print(f"imucalib calibrate: error: {exc}", file=sys.stderr)
        code = 2
    return code


def cmd_record(args: argparse.Namespace) -> int:
    """``imucalib record``: :func:`imucalib.record.record` with a live view, the events, then calibrate."""
    from ..record import Recorder, SessionWriter, open_source, record  # imucalib.record costs 83 ms at start-up

    refuse_overwriting_inputs([args.output, args.events if args.events != "-" else None, args.calibrate],
                              [args.source[len("serial:"):].split("?")[0]] if args.source.startswith("serial:")
                              else [])
    if args.calibrate:
        output_target(args.calibrate)  # refused now, not after the session
    writer = SessionWriter(args.output, force=args.force, resume=args.resume)
    ended: dict = {}
    try:
        view = _view(sys.stderr if args.events == "-" else sys.stdout, bell=not args.no_bell)
        log = EventLog(args.events)
    except BaseException:
        writer.finish(rename=False)
        if not writer.resumed:
            writer.partial.unlink()
        raise

    page = _live_page(args) if args.view else None

    def on_event(event: dict) -> None:
        log(event)
        view(event)
        if page is not None:
            page(event)
        if event["event"] == "end":
            ended.update(event)

    try:
        recorder = Recorder(on_event, method=args.method, gravity=args.gravity, rest=args.rest,
                            columns=args.columns.split(",") if args.columns else None, acc_unit=args.acc_unit,
                            gyro_unit=args.gyro_unit, time_unit=args.time_unit, rate=args.rate,
                            gyro_range=args.gyro_range, directory=writer.output.parent)
        if page is not None:
            page.recorder = recorder
        with open_source(args.source) as stream:
            result = record(stream, writer, recorder)
    except BaseException:
        if writer.lines == 0 and not writer.resumed:  # nothing was recorded: no empty .partial left behind
            writer.finish(rename=False)
            writer.partial.unlink(missing_ok=True)
        raise
    finally:
        view.close()
        log.close()
        if page is not None:
            page.close()
    say = (lambda m: print(m, file=sys.stderr)) if args.events == "-" else print
    how = " (interrupted: the lines read until then)" if result.interrupted else \
        f" ({result.ended}: the session ends there)" if result.ended else ""
    say(f"session written to {result.path}{how}")
    code = _calibrate_session(args, result.path) if args.calibrate else 0
    if ended:
        say(verdict_line(ended))
    return code


def register(sub: argparse._SubParsersAction) -> None:
    """Add record to the ``imucalib`` sub-commands."""
    p = sub.add_parser("record", help="record a session from a live stream, guided pose by pose",
                       description="Read a sensor's live text stream (one sample per line, any layout the CSV "
                       "reader takes), write its header and rows to OUTPUT as they come (OUTPUT.partial until the "
                       "end; lines that are not rows are left out, each with a note), and say what to do: the "
                       "initial rest's countdown, each pose while held and once done, the checklist of what is "
                       "missing, the next pose to take, warnings (too fast, wobbling, gaps) and 'complete' once "
                       "the poses support an accepted calibration; the last line is the session's verdict. "
                       "Ctrl-C, SIGTERM or the end of the stream finishes.")
    p.add_argument("source", help="- (standard input), serial:/dev/ttyUSB0?baud=115200 (pyserial), tcp://HOST:PORT, "
                   "or phyphox://HOST:8080 (phyphox's remote access)")
    p.add_argument("-o", "--output", required=True, help="the session file to write (CSV: the header and rows as "
                   "read); an existing one is kept unless --force")
    p.add_argument("--events", metavar="FILE", help="also write every event as one JSON line to FILE (- for "
                   "stdout, the view then on stderr)")
    add_method_option(p, help="the method the session is for")
    p.add_argument("--force", action="store_true", help="replace an existing session at OUTPUT at the end (it is "
                   "kept otherwise)")
    p.add_argument("--view", action="store_true", help="open a live picture in the browser (a local page: the "
                   "coverage sphere with the poses held, the current orientation, the suggested next one, the "
                   "checklist)")
    p.add_argument("--view-port", type=int, default=0, metavar="PORT", help="the local port of --view (default: "
                   "any free one)")
    p.add_argument("--resume", action="store_true", help="continue the session an earlier run left in "
                   "OUTPUT.partial (killed, or its stream lost): its lines are followed again, the stream's rows "
                   "appended (its header lines and rows stamped before the last one are left out)")
    p.add_argument("--no-bell", action="store_true", help="no terminal bell when a pose is held")
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
