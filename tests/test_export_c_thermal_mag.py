"""The C header's temperature path and magnetometer function, compiled, against Calibration.apply."""

import shutil
import subprocess

import numpy as np
import pytest

from imucalib.export import to_c
from imucalib.methods import calibrate
from imucalib.recording import Recording
from imucalib.scenarios import handheld
from imucalib.thermal import ThermalModel

CC = shutil.which("cc") or shutil.which("gcc")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler on this machine")


def _compile_and_run(tmp_path, header: str, body: str, rows: np.ndarray, n_in: int, n_out: int) -> np.ndarray:
    (tmp_path / "cal.h").write_text(header)
    scan = " ".join(["%lf"] * n_in)
    refs = ", ".join(f"&v[{i}]" for i in range(n_in))
    prints = " ".join(["%.17g"] * n_out)
    outs = ", ".join(f"o[{i}]" for i in range(n_out))
    (tmp_path / "main.c").write_text(f"""
#include <stdio.h>
#include "cal.h"
int main(void) {{
    double v[{n_in}], o[{n_out}];
    while (scanf("{scan}", {refs}) == {n_in}) {{
        {body}
        printf("{prints}\\n", {outs});
    }}
    return 0;
}}
""")
    exe = tmp_path / "run"
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Werror", "-o", str(exe), str(tmp_path / "main.c"), "-lm"],
                   check=True, capture_output=True)
    text = "\n".join(" ".join(f"{x:.17g}" for x in row) for row in rows)
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True).stdout
    return np.loadtxt(out.splitlines(), ndmin=2)


def test_the_temperature_path_matches_apply(tmp_path):
    rng = np.random.default_rng(2)
    truth = handheld.consumer_truth(rng)
    coeffs = handheld.datasheet_thermal(rng, truth, quadratic=True)
    coeffs["accelerometer.misalignment.xy"] = [1e-5, 2e-7]
    coeffs["gyroscope.misalignment.zx"] = [-3e-5, 0.0]
    cal = truth.with_(thermal=ThermalModel(coefficients=coeffs, range_c=(0.0, 50.0)))
    n = 300
    rec = Recording(np.arange(n) * 0.01, rng.normal(size=(n, 3)) * 9000, rng.normal(size=(n, 3)) * 800,
                    temperature=rng.uniform(-5.0, 55.0, n))
    expected = cal.apply(rec)
    got = _compile_and_run(tmp_path, to_c(cal), "imucalib_apply(&v[0], &v[3], v[6], &o[0], &o[3]);",
                           np.column_stack([rec.acc, rec.gyro, rec.temperature]), 7, 6)
    np.testing.assert_allclose(got[:, :3], expected.acc, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(got[:, 3:], expected.gyro, rtol=1e-10, atol=1e-12)
    # and it does follow temperature: the same readings at another temperature differ
    assert np.max(np.abs(cal.apply(Recording(rec.t, rec.acc, rec.gyro, temperature=rec.temperature + 10)).acc
                         - expected.acc)) > 1e-3


def test_the_magnetometer_function_matches_apply(tmp_path):
    d = handheld.generate(np.random.default_rng(9), magnetometer=True)
    rec = d["recording"]
    cal = calibrate(rec, method="tedaldi2014")
    assert cal.magnetometer is not None
    idx = np.linspace(0, len(rec) - 1, 200).astype(int)
    expected = cal.magnetometer.forward(rec.mag[idx])
    header = to_c(cal)
    assert "imucalib_apply_mag" in header
    got = _compile_and_run(tmp_path, header, "imucalib_apply_mag(v, o);", rec.mag[idx], 3, 3)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14)
