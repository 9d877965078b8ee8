"""Print every calibration's parameters on the shared Xsens session and three hand-held seeds, as JSON.

A refactoring that moves code must leave these numbers unchanged: run the script before and after, and
compare the two files with ``--compare``::

    python tools/calibration_fingerprint.py > before.json
    ... change the code ...
    python tools/calibration_fingerprint.py --compare before.json   # exit 1 when a number moved > 1e-12

The shared session is read from ``../shared/data/xsens_imu_tk`` beside the repository (skipped, and
said so, where it is absent). Each hand-held seed is simulated with :func:`imucalib.scenarios.session`.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
DATA = REPO_ROOT.parent / "shared" / "data" / "xsens_imu_tk"
#: methods run on the shared session (a recording) and on each hand-held seed
METHODS = ("tedaldi2014", "zhang2021", "ellipsoid", "six_position")
SEEDS = (1, 2, 3)
TOLERANCE = 1e-12


def _parameters(cal) -> dict[str, float]:
    return {k: float(v) for k, v in cal.parameters().items()}


def _run(name: str, data, out: dict) -> None:
    from imucalib.methods import calibrate

    for method in METHODS:
        key = f"{name}/{method}"
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out[key] = _parameters(calibrate(data, method=method))
        except Exception as exc:  # noqa: BLE001 - a method refusing the data is part of the fingerprint
            out[key] = {"error": f"{type(exc).__name__}: {exc}"}


def fingerprint() -> dict[str, dict]:
    """Method × data → parameter name → value (or ``{"error": message}``)."""
    from imucalib.io import read
    from imucalib.scenarios import session

    out: dict[str, dict] = {}
    if (DATA / "xsens_acc.mat").is_file():
        rec = read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk")
        _run("xsens", rec, out)
    else:
        print(f"{DATA} not present: shared session skipped", file=sys.stderr)
    for seed in SEEDS:
        _run(f"handheld{seed}", session("handheld", rng=seed), out)
    return out


def differences(before: dict, after: dict, tol: float = TOLERANCE) -> list[str]:
    """Readable lines for every key, parameter or error that differs by more than ``tol``."""
    lines = []
    for key in sorted(set(before) | set(after)):
        a, b = before.get(key), after.get(key)
        if a is None or b is None:
            lines.append(f"{key}: only {'after' if a is None else 'before'}")
            continue
        for p in sorted(set(a) | set(b)):
            x, y = a.get(p), b.get(p)
            if isinstance(x, float) and isinstance(y, float):
                if not abs(x - y) <= tol * max(1.0, abs(x)):
                    lines.append(f"{key} {p}: {x!r} → {y!r}")
            elif x != y:
                lines.append(f"{key} {p}: {x!r} → {y!r}")
    return lines


def main(argv: list[str] | None = None) -> int:
    """Print the fingerprint, or compare it with a stored one (exit 1 on any difference)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="a fingerprint printed earlier by this script")
    args = parser.parse_args(argv)
    now = fingerprint()
    if args.compare is None:
        print(json.dumps(now, indent=1, sort_keys=True))
        return 0
    lines = differences(json.loads(args.compare.read_text(encoding="utf-8")), now)
    n = sum(len(v) for v in now.values())
    for line in lines:
        print(line)
    print(json.dumps({"calibrations": len(now), "numbers": n, "differences": len(lines), "tolerance": TOLERANCE}))
    return 1 if lines else 0


if __name__ == "__main__":
    sys.exit(main())
