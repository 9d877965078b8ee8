"""Progress of long work on stderr: a bar on a terminal, a plain line every few seconds when piped.

Library functions that take a while accept a ``progress`` callback called as ``progress(done, total)``;
:class:`Progress` is such a callback. On a terminal it draws a ``tqdm`` bar when the ``progress`` extra is
installed (``pip install "imucalib[progress]"``); without it, and whenever stderr is a pipe or a file, it
prints one plain line (``label: done/total, elapsed, remaining``) at most every ``interval`` seconds, and
a last line when the work is done, so a log shows the work moving without a wall of carriage returns.
Nothing is ever written to stdout, which stays free for ``--json`` output.

Examples
--------
>>> with Progress("reading run.bag", total=3, enabled=False) as bar:
...     for i in range(3):
...         bar.update()
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from .printable import printable

__all__ = ["Progress", "stage_printer"]


#: steps after the first from which the time left is estimated
RATE_STEPS = 2


def _clock(seconds: float) -> str:
    seconds = max(0.0, seconds)
    if seconds < 60:
        return f"{seconds:.0f} s"
    minutes, sec = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes} min {sec:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


class Progress:
    """A progress display for a job of ``total`` steps (``None`` when unknown).

    Parameters
    ----------
    label : str
        What is being done, e.g. ``"montecarlo tedaldi2014"``.
    total : int, optional
        Number of steps; may be given later through :meth:`__call__`.
    enabled : bool
        False makes every call a no-op.
    stream : file, optional
        Where to write; stderr by default.
    interval : float
        Seconds between plain lines when not drawing a bar.
    unit : str
        Name of one step in the bar (``"run"``, ``"file"``, ``"message"``).
    bar : bool, optional
        Force (True) or forbid (False) the ``tqdm`` bar; by default a bar is drawn when ``stream`` is a
        terminal and ``tqdm`` is installed.
    """

    def __init__(self, label: str, total: int | None = None, *, enabled: bool = True,
                 stream: TextIO | None = None, interval: float = 5.0, unit: str = "it",
                 bar: bool | None = None) -> None:
        self.label, self.total, self.enabled = printable(label), total, enabled  # a file name's controls escaped
        self.stream = stream if stream is not None else sys.stderr
        self.interval, self.unit = interval, unit
        self.done = 0
        self.start = time.perf_counter()
        self._last_line = self.start
        self._first: tuple[float, int] | None = None  # (when, count) of the first step done: the rate is from it
        self._closed = False
        self._bar = None
        if not enabled:
            return
        is_tty = bool(getattr(self.stream, "isatty", lambda: False)())
        if bar is None:
            bar = is_tty
        if bar:
            try:
                from tqdm import tqdm  # optional: pip install imucalib[progress]
            except ImportError:  # the optional extra is not installed: plain lines instead
                tqdm = None
            if tqdm is not None:
                self._bar = tqdm(total=total, desc=label, unit=unit, file=self.stream, leave=True,
                                 dynamic_ncols=True, mininterval=0.2)

    # ---------------------------------------------------------------- updates
    def __call__(self, done: int, total: int | None = None) -> None:
        """Set the count to ``done`` (of ``total``, when given): the ``progress(done, total)`` callback."""
        if total is not None and total != self.total:
            self.total = total
            if self._bar is not None:
                self._bar.total = total
                self._bar.refresh()
        self.update(done - self.done)

    def update(self, n: int = 1) -> None:
        """Advance by ``n`` steps."""
        if not self.enabled or self._closed:
            self.done += n
            return
        self.done += n
        if self._first is None and self.done > 0:
            self._first = (time.perf_counter(), self.done)
        if self._bar is not None:
            self._bar.update(n)
            if self.total is not None and self.done >= self.total:
                self.close()
            return
        now = time.perf_counter()
        finished = self.total is not None and self.done >= self.total
        if finished or now - self._last_line >= self.interval:
            self._line(now)
            self._last_line = now
            if finished:
                self._closed = True

    def _line(self, now: float) -> None:
        elapsed = now - self.start
        if self.total:
            text = f"{self.label}: {self.done}/{self.total} {self.unit}s, {_clock(elapsed)}"
            left = self._left(now)
            if left is not None:
                text += f", about {_clock(left)} left"
        else:
            text = f"{self.label}: {self.done} {self.unit}s, {_clock(elapsed)}"
        print(text, file=self.stream, flush=True)

    def _left(self, now: float) -> float | None:
        """Seconds left at the rate since the first step was done, once :data:`RATE_STEPS` more have been: the
        time to the first step (starting workers, importing, a first large file) is not a step's time, and
        counting it made a 100,000-row batch start by announcing hundreds of hours."""
        if self._first is None or not self.total or self.done >= self.total:
            return None
        t0, n0 = self._first
        steps = self.done - n0
        if steps < RATE_STEPS or now <= t0:
            return None
        return (now - t0) / steps * (self.total - self.done)

    def close(self) -> None:
        """End the display (idempotent); a bar is left on screen with its final count."""
        if self._closed:
            return
        self._closed = True
        if self._bar is not None:
            self._bar.close()

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def stage_printer(enabled: bool, stream: TextIO | None = None):
    """A ``say(message)`` callback printing time-stamped stage messages on stderr, or None when not ``enabled``."""
    if not enabled:
        return None
    out = stream if stream is not None else sys.stderr
    start = time.perf_counter()

    def say(msg: str) -> None:
        print(f"[{time.perf_counter() - start:6.2f} s] {printable(msg)}", file=out, flush=True)

    return say
