"""Print a recording's lines at its own pace (times a speed-up), as a device would stream them.

    python tools/replay.py sim/recording.csv --speed 20 | imucalib record - -o session.csv

The first column is the time [s]; lines before the first numeric one (a header) go out at once.
"""

from __future__ import annotations

import argparse
import sys
import time


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("csv", help="a CSV file whose first column is the time in seconds")
    p.add_argument("--speed", type=float, default=1.0, help="times real time (default 1)")
    args = p.parse_args()
    if not args.speed > 0:
        p.error("--speed must be positive")
    out = sys.stdout.buffer
    start = first = None
    with open(args.csv, "rb") as fh:
        for line in fh:
            try:
                t = float(line.split(b",", 1)[0])
            except ValueError:
                t = None
            if t is not None:
                if start is None:
                    start, first = time.monotonic(), t
                lag = (t - first) / args.speed - (time.monotonic() - start)
                if lag > 0:
                    time.sleep(lag)
            try:
                out.write(line)
                out.flush()
            except BrokenPipeError:
                return 0
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
