"""CSV write and read of a long recording (1 M rows, 7 columns by default); prints JSON."""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
from _common import median_time

from imucalib.io import read, write_csv
from imucalib.recording import Recording


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    n = args.rows
    rec = Recording(np.arange(n) / 1000.0, np.round(rng.normal(2000, 100, (n, 3))),
                    np.round(rng.normal(0, 10, (n, 3))))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.csv"
        w, w_all = median_time(lambda: write_csv(path, rec), args.runs)
        r, r_all = median_time(lambda: read(path), args.runs)
        size = path.stat().st_size
    print(json.dumps({"benchmark": "csv_io", "rows": n, "file_mb": round(size / 1e6, 1),
                      "write_median_s": round(w, 3), "read_median_s": round(r, 3),
                      "write_times_s": [round(t, 3) for t in w_all], "read_times_s": [round(t, 3) for t in r_all]}))


if __name__ == "__main__":
    main()
