"""CSV write and read of a long recording (1 M rows, 7 columns by default); prints JSON.

Two files are read: ``counts`` (integer readings, as a logger of raw counts
writes them) and ``float`` (readings with 9 significant digits and a time in
seconds with microseconds, as a logger of physical units writes them). They
are written by this script, not by imucalib, so that every version reads the
same bytes. ``write`` times :func:`imucalib.io.write_csv` of the recording
from its values (what it writes depends on the version: imucalib 0.1 wrote 10
significant digits, later versions every double exactly).

``--engine`` picks the reader's CSV parser. ``--apply-write`` also times what ``imucalib apply`` writes (the file read
back, six calibrated columns added). ``--save FILE`` stores the figures; ``--before FILE`` reads figures stored
earlier (from the code before a change) and prints them next to today's, with
the speed-up. ``--candidates`` also times the bare numeric parsers that the
reader could use on the body of the same files (no header logic): numpy's
``fromstring`` (the reader's path until 0.1), ``numpy.loadtxt``, pandas' C
parser (when pandas is installed) and the reader's own.

All times are medians of ``--runs`` runs after one warm-up run.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import warnings
from pathlib import Path

import numpy as np
from _common import median_time

from imucalib.io import read, write_csv
from imucalib.recording import Recording


def recordings(n: int) -> dict[str, Recording]:
    rng = np.random.default_rng(0)
    t = np.arange(n) / 1000.0
    counts = Recording(t, np.round(rng.normal(2000, 100, (n, 3))), np.round(rng.normal(0, 10, (n, 3))))
    floats = Recording(np.round(t + rng.uniform(0, 2e-4, n), 6), rng.normal(0, 5, (n, 3)),
                       rng.normal(0, 0.5, (n, 3)), acc_unit="m/s^2", gyro_unit="rad/s")
    return {"counts": counts, "float": floats}


def write_fixed(path: Path, rec: Recording, kind: str) -> None:
    """The recording as a logger would write it, independently of imucalib's writer."""
    fmt = "%.3f" + ",%d" * 6 if kind == "counts" else "%.6f" + ",%.9g" * 6
    header = f"t [s],ax [{rec.acc_unit}],ay [{rec.acc_unit}],az [{rec.acc_unit}],gx [{rec.gyro_unit}]," \
             f"gy [{rec.gyro_unit}],gz [{rec.gyro_unit}]"
    data = np.column_stack([rec.t, rec.acc, rec.gyro])
    with path.open("w", encoding="utf-8") as fh:
        fh.write(header + "\n")
        for start in range(0, len(data), 100_000):
            rows = data[start:start + 100_000].tolist()
            fh.write("\n".join(fmt % tuple(r) for r in rows) + "\n")


def candidates(path: Path, runs: int) -> dict[str, float]:
    """Median seconds of each bare parser on the numeric body of ``path`` (header line skipped)."""
    out: dict[str, float] = {}

    def fromstring():
        text = path.read_text(encoding="utf-8")
        body = text[text.index("\n") + 1:]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return np.fromstring(body.replace(",", " "), dtype=np.float64, sep=" ").reshape(-1, 7)

    out["numpy_fromstring_s"] = median_time(fromstring, runs)[0]
    out["numpy_loadtxt_s"] = median_time(
        lambda: np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64), runs)[0]
    try:
        import pandas as pd
    except ImportError:
        out["pandas_c_s"] = None
    else:
        out["pandas_c_s"] = median_time(
            lambda: pd.read_csv(path, engine="c", dtype=np.float64).to_numpy(), runs)[0]
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            out["pandas_pyarrow_s"] = None
        else:
            out["pandas_pyarrow_s"] = median_time(
                lambda: pd.read_csv(path, engine="pyarrow").to_numpy(np.float64), runs)[0]
    return {k: (None if v is None else round(v, 3)) for k, v in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--candidates", action="store_true", help="also time the bare numeric parsers")
    parser.add_argument("--apply-write", action="store_true",
                        help="also time writing what apply writes (the file read back, six columns added)")
    parser.add_argument("--engine", choices=("auto", "numpy", "pandas", "python"),
                        help="the reader's CSV parser (imucalib.io.csvparse.ENGINE; default: its own choice)")
    parser.add_argument("--save", metavar="FILE", help="store the figures (JSON) here")
    parser.add_argument("--before", metavar="FILE", help="figures stored earlier, printed with the speed-up")
    args = parser.parse_args()
    n = args.rows
    if args.engine:
        from imucalib.io import csvparse

        csvparse.ENGINE = args.engine
    result: dict = {"benchmark": "csv_io", "rows": n, "runs": args.runs, "engine": args.engine or "default",
                    "files": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for kind, rec in recordings(n).items():
            path = Path(tmp) / f"{kind}.csv"
            write_fixed(path, rec, kind)
            written = Path(tmp) / f"{kind}_written.csv"
            w, w_all = median_time(lambda rec=rec, written=written: write_csv(written, rec), args.runs)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r, r_all = median_time(lambda path=path: read(path), args.runs)
            entry = {"file_mb": round(path.stat().st_size / 1e6, 1),
                     "write_median_s": round(w, 3), "read_median_s": round(r, 3),
                     "write_times_s": [round(t, 3) for t in w_all], "read_times_s": [round(t, 3) for t in r_all]}
            if args.apply_write:
                # what apply writes: the recording read from the file, with six calibrated columns added
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    back = read(path)
                out = Path(tmp) / f"{kind}_calibrated.csv"
                a, a_all = median_time(lambda back=back, out=out: write_csv(out, back, back.acc * 1e-3,
                                                                             back.gyro * 1e-3), args.runs)
                entry["apply_write_median_s"] = round(a, 3)
                entry["apply_write_times_s"] = [round(t, 3) for t in a_all]
            if args.candidates:
                entry["parsers_median_s"] = candidates(path, args.runs)
            result["files"][kind] = entry
    if args.save:
        Path(args.save).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    if args.before:
        before = json.loads(Path(args.before).read_text(encoding="utf-8"))
        result = {"benchmark": "csv_io", "rows": n, "before": before, "after": result, "speedup": {
            kind: {op: round(before["files"][kind][f"{op}_median_s"] / result["files"][kind][f"{op}_median_s"], 2)
                   for op in ("read", "write", "apply_write")
                   if f"{op}_median_s" in before["files"][kind] and f"{op}_median_s" in result["files"][kind]}
            for kind in result["files"] if kind in before.get("files", {})}}
    print(json.dumps(result))


if __name__ == "__main__":
    main()
