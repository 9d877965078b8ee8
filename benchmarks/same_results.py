"""Calibrations of reference inputs as JSON, and their comparison with a stored set; prints JSON.

A change meant to make the package faster must leave its results as they
were. This script calibrates

* imu_tk's Xsens session (``../shared/data/xsens_imu_tk``, when present) with
  tedaldi2014 at the local gravity 9.81744 m/s², as ``imucalib calibrate`` does;
* the hand-held simulated sessions of seeds 1, 2 and 3 with tedaldi2014;
* the Zhang 2021 simulated session of seed 1 with zhang2021 ``all``;

and with ``--methods a,b,…`` also each of those methods on the Xsens session and the hand-held seeds
(six_position, ferraris and qureshi2017 also on the hand-held Ferraris procedure of those seeds)
(spelled out, so that the same list runs on code from before a method's declaration existed); it
writes every calibration's file content (parameters, uncertainties, the
verdict and its reasons; the creation time and the format's version left out) to ``--save FILE``.
``--compare FILE`` compares with a stored set instead: every number within a
relative 1e-12 (absolute 1e-15 near zero), every string and shape equal. Run
it once with the starting code on ``PYTHONPATH`` (``--save``), then with the
changed code (``--compare``); the exit code is 1 when anything differs.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from _common import DATA

RTOL, ATOL = 1e-12, 1e-15


def results(methods: list[str] | None = None) -> dict:
    """Every reference calibration as its JSON dictionary, by name (``methods``: more, see the module)."""
    from imucalib.io import read
    from imucalib.methods import calibrate
    from imucalib.scenarios import session

    out = {}
    xsens = DATA / "xsens_imu_tk"
    if xsens.is_dir():
        rec = read([str(xsens / "xsens_acc.mat"), str(xsens / "xsens_gyro.mat")], reader="imutk")
        out["xsens/tedaldi2014"] = calibrate(rec, method="tedaldi2014", gravity=9.81744)
    for seed in (1, 2, 3):
        out[f"handheld{seed}/tedaldi2014"] = calibrate(session("handheld", rng=seed), method="tedaldi2014")
    out["zhang2021_1/zhang2021_all"] = calibrate(session("zhang2021", rng=1), method="zhang2021", model="all")
    for method in methods or []:
        if xsens.is_dir():
            out[f"xsens/{method}"] = _attempt(calibrate, rec, method=method, gravity=9.81744)
        for seed in (1, 2, 3):
            out[f"handheld{seed}/{method}"] = _attempt(calibrate, session("handheld", rng=seed), method=method)
            if method in ("six_position", "ferraris", "qureshi2017"):  # the cube's faces, as users do Ferraris
                faces = session("handheld", rng=seed, procedure="ferraris")
                out[f"handheld_ferraris{seed}/{method}"] = _attempt(calibrate, faces, method=method)
    docs = {}
    for name, cal in out.items():
        if isinstance(cal, str):  # the method's error, which must stay the same too
            docs[name] = {"error": cal}
            continue
        d = json.loads(cal.to_json())
        d.pop("created", None)
        d.pop("format_version", None)  # the file format's version, not a result: a new format keeps the numbers
        docs[name] = d
    return docs


def _attempt(fn, *args, **kwargs):
    """``fn(*args, **kwargs)``, or the text of the ValueError it raises."""
    try:
        return fn(*args, **kwargs)
    except ValueError as exc:
        return f"ValueError: {exc}"


def differences(a, b, where: str = "") -> list[str]:
    """Where ``a`` and ``b`` differ beyond the tolerance (empty when they agree)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = [f"{where}: keys {sorted(set(a) ^ set(b))} in one only"] if set(a) != set(b) else []
        for k in sorted(set(a) & set(b)):
            out += differences(a[k], b[k], f"{where}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: lengths {len(a)} and {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in differences(x, y, f"{where}[{i}]")]
    numbers = (int, float)
    if isinstance(a, numbers) and isinstance(b, numbers) and not isinstance(a, bool) and not isinstance(b, bool):
        if math.isclose(a, b, rel_tol=RTOL, abs_tol=ATOL):
            return []
        return [f"{where}: {a!r} and {b!r} (relative {abs(a - b) / max(abs(a), abs(b)):.3g})"]
    return [] if a == b else [f"{where}: {a!r} and {b!r}"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--save", metavar="FILE", help="write the calibrations here")
    group.add_argument("--compare", metavar="FILE", help="compare with the calibrations stored here")
    parser.add_argument("--methods", help="comma-separated methods to run on the Xsens session and hand-held seeds too")
    args = parser.parse_args()
    docs = results(args.methods.split(",") if args.methods else None)
    if args.save:
        Path(args.save).write_text(json.dumps(docs, indent=1) + "\n", encoding="utf-8")
        print(json.dumps({"saved": args.save, "calibrations": sorted(docs)}))
        return
    stored = json.loads(Path(args.compare).read_text(encoding="utf-8"))
    for doc in stored.values():  # a set stored with the format's version (as older scripts wrote it)
        doc.pop("format_version", None)
    diff = differences(stored, docs)
    print(json.dumps({"compared": sorted(docs), "rtol": RTOL, "atol": ATOL, "same": not diff,
                      "differences": diff[:50]}))
    sys.exit(1 if diff else 0)


if __name__ == "__main__":
    main()
