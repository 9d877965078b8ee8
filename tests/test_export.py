"""C export: the generated header, compiled, corrects samples exactly as Calibration.apply."""

import shutil
import subprocess
import warnings

import numpy as np
import pytest

from imucalib.export import to_c
from imucalib.recording import Recording

CC = shutil.which("cc") or shutil.which("gcc")


def _run_c(tmp_path, header: str, acc_raw: np.ndarray, gyro_raw: np.ndarray, ctype="double") -> np.ndarray:
    (tmp_path / "cal.h").write_text(header)
    fmt = "%lf" if ctype == "double" else "%f"
    (tmp_path / "main.c").write_text(f"""
#include <stdio.h>
#include "cal.h"
int main(void) {{
    {ctype} u[3], g[3], a[3], w[3];
    while (scanf("{fmt} {fmt} {fmt} {fmt} {fmt} {fmt}", &u[0], &u[1], &u[2], &g[0], &g[1], &g[2]) == 6) {{
        imucalib_apply(u, g, a, w);
        printf("%.17g %.17g %.17g %.17g %.17g %.17g\\n", a[0], a[1], a[2], w[0], w[1], w[2]);
    }}
    return 0;
}}
""")
    exe = tmp_path / "apply"
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Werror", "-o", str(exe), str(tmp_path / "main.c"), "-lm"],
                   check=True, capture_output=True)
    text = "\n".join(" ".join(f"{v:.17g}" for v in row) for row in np.hstack([acc_raw, gyro_raw]))
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True).stdout
    return np.loadtxt(out.splitlines(), ndmin=2)


@pytest.mark.skipif(CC is None, reason="no C compiler on this machine")
def test_compiled_c_matches_apply_for_the_full_model(tmp_path):
    from imucalib.methods import calibrate
    from imucalib.scenarios import session

    sim = session("zhang2021", rng=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = calibrate(sim, method="zhang2021", model="all", gravity=sim.truth.gravity)
    assert np.any(cal.gyroscope.g_sensitivity) and np.any(cal.accelerometer.scale_cubic)
    rec = sim.recording
    idx = np.random.default_rng(0).choice(len(rec), 200, replace=False)
    expected = cal.apply(Recording(np.arange(200) * 0.01, rec.acc[idx], rec.gyro[idx], acc_unit=rec.acc_unit,
                                   gyro_unit=rec.gyro_unit))
    got = _run_c(tmp_path, to_c(cal), rec.acc[idx], rec.gyro[idx])
    np.testing.assert_allclose(got[:, :3], expected.acc, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got[:, 3:], expected.gyro, rtol=1e-12, atol=1e-12)


@pytest.mark.skipif(CC is None, reason="no C compiler on this machine")
def test_compiled_c_with_an_output_bias_in_single_precision(tmp_path):
    from imucalib.scenarios.wang2019 import session

    cal = session(0).truth  # Wang's model: lower-triangular T, output bias, quadratic and cubic terms
    rng = np.random.default_rng(1)
    acc_raw = rng.uniform(-4e6, 4e6, (50, 3))
    gyro_raw = rng.uniform(-5e7, 5e7, (50, 3))
    expected_a = cal.accelerometer.forward(acc_raw)
    expected_w = cal.gyroscope.forward(gyro_raw)
    got = _run_c(tmp_path, to_c(cal), acc_raw, gyro_raw)
    np.testing.assert_allclose(got[:, :3], expected_a, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got[:, 3:], expected_w, rtol=1e-12, atol=1e-15)
    got32 = _run_c(tmp_path, to_c(cal, ctype="float"), acc_raw, gyro_raw, ctype="float")
    np.testing.assert_allclose(got32[:, :3], expected_a, rtol=1e-5, atol=1e-5)


def test_export_command_and_errors(tmp_path, capsys):
    from imucalib.cli import main
    from imucalib.scenarios.wang2019 import session

    session(0).truth.save(tmp_path / "c.json")
    assert main(["export", str(tmp_path / "c.json"), "--prefix", "imu0"]) == 0
    out = capsys.readouterr().out
    assert "static inline void imu0_apply(" in out and "IMU0_GYRO_G" in out
    assert main(["export", str(tmp_path / "c.json"), "--prefix", "9bad"]) == 2
    assert "prefix must be a C identifier" in capsys.readouterr().err
