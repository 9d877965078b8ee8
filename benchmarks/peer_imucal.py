"""imucal's Ferraris calibration of its own example session beside imucalib's, on the same poses (prints JSON).

imucal (mad-lab-fau/imucal, from PyPI) is run in a Python that has it (``--imucal-python``, e.g. a venv made
with ``python -m venv V && V/bin/pip install imucal``) on the sections its users marked by hand
(``example_ferraris_session_list.json``). Its model, ``a = R_a⁻¹ K_a⁻¹ (u_a − b_a)``,
``ω = R_g⁻¹ K_g⁻¹ (u_g − K_ga a − b_g)``, is linear, so it is one of imucalib's calibrations:
``T_a diag(k1_a) = R_a⁻¹ K_a⁻¹`` (a unit-diagonal T and its diagonal), ``b_a``, ``G = K_ga``, and the same for
the gyroscope with deg/s → rad/s. Both are then scored by ``imucalib compare --peer`` on the poses imucalib
finds: imucalib's methods held out pose by pose, imucal's as it is (fitted on those poses).

Usage: ``python benchmarks/peer_imucal.py --imucal-python /path/to/venv/bin/python``
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from _common import require_data

IMUCAL_RUN = """
import json, sys, numpy as np, pandas as pd
from imucal import FerrarisCalibration, ferraris_regions_from_section_list
folder = sys.argv[1]
data = pd.read_csv(folder + "/example_ferraris_session.csv", header=0, index_col=0)
sections = pd.read_json(folder + "/example_ferraris_session_list.json").T
cal = FerrarisCalibration().compute(ferraris_regions_from_section_list(data, sections), 102.4,
                                    from_acc_unit="m/s^2", from_gyr_unit="deg/s")
print(json.dumps({k: np.asarray(getattr(cal, k)).tolist() for k in ("K_a", "R_a", "b_a", "K_g", "R_g", "K_ga", "b_g")}))
"""


def as_imucalib(p: dict):
    """imucal's parameters as an imucalib :class:`~imucalib.Calibration` (module docstring)."""
    from imucalib import Calibration
    from imucalib.models import TriadModel

    def triad(r, k, b, unit_to_si, g=None):
        m = unit_to_si * np.linalg.inv(np.asarray(r)) @ np.linalg.inv(np.asarray(k))
        d = np.diag(m).copy()
        return TriadModel(misalignment=m / d, scale=d, bias=np.asarray(b),
                          g_sensitivity=np.zeros((3, 3)) if g is None else np.asarray(g), shape="full")

    return Calibration(accelerometer=triad(p["R_a"], p["K_a"], p["b_a"], 1.0),
                       gyroscope=triad(p["R_g"], p["K_g"], p["b_g"], np.pi / 180, p["K_ga"]),
                       method="imucal", units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
                                               "gyroscope": {"raw": "deg/s", "calibrated": "rad/s"}})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--imucal-python", required=True, help="a Python with imucal installed")
    args = ap.parse_args()
    folder = require_data("public/ferraris_imucal")
    out = subprocess.run([args.imucal_python, "-c", IMUCAL_RUN, str(folder)], capture_output=True, text=True,
                         check=True)
    peer = as_imucalib(json.loads(out.stdout.strip().splitlines()[-1]))
    from imucalib.cli import main as imucalib_main

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "imucal.json"
        peer.save(path)
        sys.argv = ["imucalib"]
        import contextlib
        import io

        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            imucalib_main(["compare", str(folder / "example_ferraris_session.csv"), "--rate", "102.4",
                           "--acc-unit", "m/s^2", "--gyro-unit", "deg/s", "--folds", "0", "--peer", str(path),
                           "--json"])
    result = json.loads(buf.getvalue())
    keys = ("cv_accelerometer_residual_rms", "cv_gyroscope_angle_error_mean_deg")
    print(json.dumps({
        "recording": "public/ferraris_imucal/example_ferraris_session.csv",
        "poses": result["static_intervals"], "best": result["best"],
        "imucalib": [{"method": r["method"], "verdict": r["verdict"], **{k: r[k] for k in keys}}
                     for r in result["methods"] if r["ok"]],
        "imucal_in_sample": {k: result["peers"][0][k] for k in keys},
    }, indent=1))


if __name__ == "__main__":
    main()
