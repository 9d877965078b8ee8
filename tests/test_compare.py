"""Cross-validation and the method comparison on the real Xsens data."""

import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib.compare import compare, even_folds
from imucalib.crossval import leave_one_pose_out
from imucalib.io import read
from imucalib.methods import calibrate, tedaldi2014

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"
G = 9.81744


@pytest.fixture(scope="module")
def xsens():
    if not DATA.is_dir():
        pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): real-data test skipped")
    rec = read([DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat"], reader="imutk")
    return rec, tedaldi2014.detect_intervals(rec, G)[0]


def test_even_folds():
    assert even_folds(5, None) == [1, 2, 3, 4]
    assert even_folds(38, 4) == [1, 13, 25, 37]


def test_compare_on_xsens(xsens):
    rec, iv = xsens
    out = compare(rec, gravity=G, methods=["tedaldi2014", "ellipsoid", "six_position", "wang2019"],
                  intervals=iv, folds=6)
    rows = {r["method"]: r for r in out["methods"]}
    assert out["static_intervals"] == 38 and out["folds"] == 6
    base = rows["tedaldi2014"]["cv_accelerometer_residual_rms"]
    assert 0 < base < 0.003  # m/s²
    assert rows["ellipsoid"]["ok"]
    assert rows["ellipsoid"]["cv_accelerometer_residual_rms"] <= 2 * base
    # the Xsens poses hold no face within 15° of +x: the six-position method says so
    assert not rows["six_position"]["ok"] and "+x" in rows["six_position"]["reason"]
    assert not rows["wang2019"]["ok"] and "turntable data" in rows["wang2019"]["reason"]


def test_cubic_without_tosses_does_not_overfit(xsens):
    rec, iv = xsens
    folds = even_folds(len(iv), 4)

    def cv(model, **kw):
        def fit(training):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return calibrate(rec, method="zhang2021", model=model, gravity=G, intervals=training, **kw)
        return leave_one_pose_out(rec, iv, fit, gravity=G, folds=folds)["cv_accelerometer_residual_rms"]

    linear, cubic = cv("linear"), cv("cubic")
    assert cubic <= 1.05 * linear
    assert np.isfinite(linear) and linear < 0.003
