"""pandas in and out: ``read(DataFrame)``, ``Recording.to_dataframe()``, ``Calibration.apply(DataFrame)``."""

import sys

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.io import ReaderError, read
from imucalib.recording import Recording
from imucalib.scenarios.handheld import consumer_truth

pd = pytest.importorskip("pandas", reason="pandas not installed (the pandas extra)")


def _frame(n=400, seed=0):
    rng = np.random.default_rng(seed)
    return pd.DataFrame({
        "time [ms]": np.arange(n) * 10.0,
        "acc_x [g]": rng.normal(0, 1, n), "acc_y [g]": rng.normal(0, 1, n), "acc_z [g]": rng.normal(0, 1, n),
        **{f"gyr_{x} [deg/s]": rng.normal(0, 5, n) for x in "xyz"},
        "temperature": np.linspace(20, 25, n), "label": [f"L{i}" for i in range(n)],
    })


def test_a_frame_reads_as_the_same_table_in_a_csv_file(tmp_path):
    df = _frame()
    df.to_csv(tmp_path / "same.csv", index=False, float_format="%.17g")
    from_csv = read(tmp_path / "same.csv")
    from_frame = read(df)
    assert from_frame.metadata["reader"] == "dataframe"
    assert (from_frame.acc_unit, from_frame.gyro_unit) == ("g", "deg/s") == (from_csv.acc_unit, from_csv.gyro_unit)
    np.testing.assert_array_equal(from_frame.t, from_csv.t)
    np.testing.assert_array_equal(from_frame.acc, df[["acc_x [g]", "acc_y [g]", "acc_z [g]"]].to_numpy())
    np.testing.assert_array_equal(from_frame.gyro, from_csv.gyro)
    np.testing.assert_array_equal(from_frame.temperature, from_csv.temperature)
    assert list(from_frame.extra["label"][:2]) == ["L0", "L1"]
    assert from_frame.metadata["time_unit"] == "ms"


def test_frame_options_and_errors():
    df = _frame()
    rec = read(df, columns=["time [ms]", "gyr_x [deg/s]", "gyr_y [deg/s]", "gyr_z [deg/s]",
                            "acc_x [g]", "acc_y [g]", "acc_z [g]"], acc_unit="counts", gyro_unit="counts")
    np.testing.assert_array_equal(rec.acc[:, 1], df["gyr_y [deg/s]"].to_numpy())
    assert rec.acc_unit == "counts"
    with pytest.raises(ReaderError, match="unknown accelerometer unit 'furlong'"):
        read(df, acc_unit="furlong")
    with pytest.raises(ReaderError, match="has a time column .* and --rate was given"):
        read(df, rate=100.0)
    with pytest.raises(ReaderError, match="a DataFrame is read as a table"):
        read(df, reader="mat")
    bad = df.copy()
    bad.loc[7, "acc_y [g]"] = np.nan
    with pytest.raises(ReaderError, match=r"DataFrame: row 8, acc_y \[g\]: nan is not finite"):
        read(bad)
    text = df.astype({"gyr_z [deg/s]": object})
    text.loc[3, "gyr_z [deg/s]"] = "fast"
    with pytest.raises(ReaderError, match=r"DataFrame: row 4, gyr_z \[deg/s\]: 'fast' is not a number"):
        read(text)
    back = df.copy()
    back.loc[5, "time [ms]"] = 0.0
    with pytest.raises(ReaderError, match=r"timestamp goes backwards"):
        read(back)


def test_datetime_and_nanosecond_time_columns():
    n = 300
    rng = np.random.default_rng(2)
    values = {k: rng.normal(size=n) for k in ("ax", "ay", "az", "gx", "gy", "gz")}
    stamps = pd.date_range("2025-03-01 12:00", periods=n, freq="2500us")
    rec = read(pd.DataFrame({"timestamp": stamps, **values}))
    assert rec.metadata["time_unit"] == "ns" and rec.metadata["t0"] == stamps[0].value
    np.testing.assert_allclose(np.diff(rec.t), 2.5e-3, rtol=0, atol=1e-12)
    ns = stamps.as_unit("ns").asi8  # int64 ns since the epoch: beyond float precision
    rec2 = read(pd.DataFrame({"#timestamp [ns]": ns, **values}))
    np.testing.assert_array_equal(rec2.t, rec.t)
    assert rec2.metadata["t0"] == int(ns[0])


def test_to_dataframe_round_trip():
    rng = np.random.default_rng(3)
    n = 250
    rec = Recording(np.arange(n) / 200.0, rng.normal(0, 2000, (n, 3)), rng.normal(0, 30, (n, 3)),
                    acc_unit="counts", gyro_unit="deg/s", temperature=np.full(n, 31.5),
                    extra={"pose": np.repeat(np.arange(5), 50)})
    df = rec.to_dataframe()
    assert list(df.columns) == ["t [s]", "ax [counts]", "ay [counts]", "az [counts]", "gx [deg/s]", "gy [deg/s]",
                                "gz [deg/s]", "temperature [C]", "pose"]
    df.iloc[0, 1] = -1.0  # a copy: the recording is not changed through the frame
    assert rec.acc[0, 0] != -1.0
    back = read(rec.to_dataframe())
    np.testing.assert_array_equal(back.t, rec.t)
    np.testing.assert_array_equal(back.acc, rec.acc)
    np.testing.assert_array_equal(back.gyro, rec.gyro)
    np.testing.assert_array_equal(back.temperature, rec.temperature)
    np.testing.assert_array_equal(back.extra["pose"], rec.extra["pose"])
    assert (back.acc_unit, back.gyro_unit) == (rec.acc_unit, rec.gyro_unit)


def test_apply_to_a_frame_adds_the_calibrated_columns():
    truth = consumer_truth(np.random.default_rng(4))
    rng = np.random.default_rng(4)
    n = 500
    df = pd.DataFrame({"t": np.arange(n) * 0.01, **{f"a{x}": rng.normal(0, 4000, n) for x in "xyz"},
                       **{f"g{x}": rng.normal(0, 300, n) for x in "xyz"}, "id": np.arange(n) + 10**17})
    out = truth.apply(df)
    assert list(out.columns[:8]) == list(df.columns)
    pd.testing.assert_frame_equal(out[df.columns], df)  # the input columns as they were
    assert list(df.columns) == ["t", "ax", "ay", "az", "gx", "gy", "gz", "id"]  # the input is not changed
    raw_a, raw_g = df[["ax", "ay", "az"]].to_numpy(), df[["gx", "gy", "gz"]].to_numpy()
    a = truth.accelerometer.forward(raw_a)
    np.testing.assert_allclose(out[[f"acc_{x}_cal [m/s^2]" for x in "xyz"]].to_numpy(), a, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out[[f"gyro_{x}_cal [rad/s]" for x in "xyz"]].to_numpy(),
                               truth.gyroscope.forward(raw_g, a), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="already has the column"):
        truth.apply(out)
    with pytest.raises(ValueError, match="maps accelerometer readings in 'counts'"):
        truth.apply(df, acc_unit="g")
    with pytest.raises(TypeError, match="only with a DataFrame"):
        truth.apply(read(df), acc_unit="counts")
    with pytest.raises(TypeError, match="a Recording or a pandas DataFrame"):
        Calibration().apply([1, 2, 3])


def test_without_pandas_the_message_names_the_extra(monkeypatch):
    rec = Recording(np.arange(3.0), np.zeros((3, 3)), np.zeros((3, 3)))
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas now fails
    with pytest.raises(ValueError, match=r'Recording.to_dataframe needs pandas: pip install "imucalib\[pandas\]"'):
        rec.to_dataframe()
