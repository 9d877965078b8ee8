"""Each public recording (``../shared/data/public``) calibrated with the one command a user writes; prints JSON.

Per recording: the command (the flags the file cannot tell and nothing else), the exit code, the verdict and
its reasons, the poses found, the gravity-norm residual and the gyroscope's gravity-direction error (in
sample), the magnetometer's dip and norm spreads where there is one, and the seconds the command took. The
peers' own figures are in ``tests/test_public_recordings.py`` and ``tests/test_peer_calibrations.py``, which
check these numbers; this script only prints them, e.g. for a release note::

    python benchmarks/public_recordings.py > public.json
"""

from __future__ import annotations

import contextlib
import io
import json
import time
import warnings

from _common import require_data

from imucalib.cli import main

MIKOV = ["--rate", "100", "--acc-unit", "m/s^2", "--gyro-unit", "rad/s"]
IMUTK = ["--gravity", "9.81744", "--acc-unit", "m/s^2", "--gyro-unit", "rad/s"]

#: name → (files under public/, flags)
COMMANDS: dict[str, tuple[list[str], list[str]]] = {
    **{f"mpu9150_mikov/imu{k}": ([f"mpu9150_mikov/imu{k}.log"], MIKOV) for k in range(5)},
    "mpu9250_gesture": (["mpu9250_gesture/caldata.mat"], []),
    **{f"imutk_sessions/data{k}": ([f"imutk_sessions/data{k}/acc_data.txt", f"imutk_sessions/data{k}/gyro_data.txt"],
                                   IMUTK) for k in range(1, 5)},
    "ferraris_imucal": (["ferraris_imucal/example_ferraris_session.csv"],
                        ["--rate", "102.4", "--acc-unit", "m/s^2", "--gyro-unit", "deg/s"]),
    "wt901_position": (["wt901_position/Data.mat"], []),
    "mpu6050_faces": ([f"mpu6050_faces/{a}_axis_{s}.csv" for a in "xyz" for s in ("pos", "neg")],
                      ["--acc-unit", "m/s^2", "--gyro-unit", "rad/s"]),
    "fxos8700_blocks": (["fxos8700_blocks/data_sample2.csv"], ["--rate", "400", "--acc-unit", "m/s^2"]),
    "mpu6050_suarez": (["mpu6050_suarez/example_data_calibration.csv"], ["--rate", "100"]),
}

#: the fit's figures printed, where the calibration has them
FIGURES = ("static_intervals", "accelerometer_residual_rms", "accelerometer_residual_rms_raw",
           "gyroscope_angle_error_mean_deg", "magnetometer_dip_spread_deg", "magnetometer_norm_spread")


def run(files: list[str], flags: list[str]) -> dict:
    """``imucalib calibrate FILES FLAGS --json`` in this process: its exit code, verdict and figures."""
    out = io.StringIO()
    start = time.perf_counter()
    with warnings.catch_warnings(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        code = main(["calibrate", *files, *flags, "--json"])
    seconds = time.perf_counter() - start
    row = {"exit_code": code, "seconds": round(seconds, 2)}
    if out.getvalue().strip():
        cal = json.loads(out.getvalue())
        fit = cal["fit"]
        row |= {"method": cal["method"], "verdict": fit["verdict"], "reasons": fit.get("verdict_reasons", [])}
        row |= {k: fit[k] for k in FIGURES if fit.get(k) is not None}
    return row


def main_() -> None:
    public = require_data("public")
    rows = {}
    for name, (files, flags) in COMMANDS.items():
        paths = [str(public / f) for f in files]
        rows[name] = {"command": "imucalib calibrate " + " ".join([*files, *flags]), **run(paths, flags)}
    print(json.dumps({"benchmark": "public_recordings", "recordings": rows}, indent=1))


if __name__ == "__main__":
    main_()
