"""``imucalib compare`` on sessions with a magnetometer: whole-command wall times; prints JSON.

Sessions: a simulated hand-held session with an MPU-9250-like magnetometer (30 poses), and the MPU-9250
session of ``../shared/data/public/mpu9250_gesture/caldata.mat`` (its magnetometer columns as a ``mag``
variable beside ``data``, written once into a temporary folder; left out when the data are absent).

For each session, in turns ``--runs`` times after one warm-up round (``_common.time_processes``):

* ``after``: ``compare`` with this checkout's package (the folds never calibrate the magnetometer);
* ``after_no_magnetometer``: the same with ``--no-magnetometer``;
* ``calibrate``: one ``calibrate`` (tedaldi2014, with the magnetometer), for scale;
* ``before``: ``compare`` with the package in ``--baseline`` (a ``src`` folder of an older checkout), when given.

The figures are the medians of the whole process's wall time [s] (reading, importing, every method's
calibration and its folds), with the CPU seconds other programs used meanwhile.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

from _common import DATA, SRC, time_processes

from imucalib.io.atomic import atomic_path
from imucalib.scenarios import session, write_session


def _mpu9250(directory: Path) -> Path | None:
    """The MPU-9250 session as ``data`` (t, acc, gyro) and ``mag`` variables, or None without the data."""
    source = DATA / "public" / "mpu9250_gesture" / "caldata.mat"
    if not source.is_file():
        return None
    from scipy.io import loadmat, savemat

    d = loadmat(source)["cal_data"]
    target = directory / "mpu9250_mag.mat"
    with atomic_path(target) as tmp:
        savemat(tmp, {"data": d[:, :7], "mag": d[:, 7:10]})
    return target


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3, help="timed runs of each command (default 3)")
    ap.add_argument("--baseline", help="a src folder of an older checkout: its compare is timed as 'before'")
    ap.add_argument("--folds", type=int, default=12, help="compare's --folds (default 12, its default)")
    args = ap.parse_args()

    env = {**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    after = {**env, "PYTHONPATH": str(SRC)}
    before = None if args.baseline is None else {**env, "PYTHONPATH": str(Path(args.baseline).resolve())}
    cli = [sys.executable, "-m", "imucalib.cli"]
    out: dict = {"runs": args.runs, "folds": args.folds, "baseline": args.baseline,
                 "load_average_start": os.getloadavg()[0], "sessions": {}}
    with tempfile.TemporaryDirectory() as tmp:
        sessions = {"simulated_handheld": write_session(session("handheld", rng=3, magnetometer=True),
                                                        Path(tmp) / "handheld")}
        mpu = _mpu9250(Path(tmp))
        if mpu is not None:
            sessions["mpu9250_gesture"] = mpu
        for name, path in sessions.items():
            compare = [*cli, "compare", str(path), "--json", "--folds", str(args.folds)]
            commands = {"after": (compare, after),
                        "after_no_magnetometer": ([*compare, "--no-magnetometer"], after),
                        "calibrate": ([*cli, "calibrate", str(path), "--json"], after)}
            if before is not None:
                commands["before"] = (compare, before)
            out["sessions"][name] = time_processes(commands, args.runs)
    out["load_average_end"] = os.getloadavg()[0]
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
