"""A calibration file whose numbers are absurd, non-finite, or nested without end is a plain error.

A scale factor or g-sensitivity of 1e308 made every figure NaN, and since no
comparison with NaN is true, ``validate`` called it ACCEPTED; a bias of 1e308
was applied as −5.8e304 m/s². Now such files are refused on loading (exit 2,
naming the entry), and the verdict rejects any NaN or infinite figure of a
calibration made in Python. A document nested 10 000 deep or a gravity of
1e308 is a one-line error, not a RecursionError or OverflowError.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from imucalib.calibration import Calibration, CalibrationFileError, check_magnitudes  # noqa: E402
from imucalib.cli import main  # noqa: E402
from imucalib.io import write_csv  # noqa: E402
from imucalib.scenarios import pose_session  # noqa: E402
from imucalib.validation import validate  # noqa: E402
from imucalib.verdict import assess  # noqa: E402
from synth import linear_truth  # noqa: E402

#: (entry, index) of each parameter a file gives, and the value that made validate say ACCEPTED or apply
#: write −5.8e304 m/s²
ENTRIES = [("accelerometer", "scale", (0,)), ("accelerometer", "bias", (1,)), ("gyroscope", "scale", (2,)),
           ("gyroscope", "g_sensitivity", (0, 0)), ("gyroscope", "bias", (0,)),
           ("accelerometer", "misalignment", (0, 1)), ("gyroscope", "output_bias", (2,)),
           ("accelerometer", "scale_cubic", (0,))]


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    truth = linear_truth()
    rec, _ = pose_session(truth, [([1.0, 0.0, 0.0], np.pi / 2)], rng=4, rest=5, hold=2)
    d = tmp_path_factory.mktemp("limits")
    write_csv(d / "short.csv", rec)
    return rec, truth, d


def _document(cal: Calibration, sensor: str, key: str, index: tuple, value: float) -> dict:
    doc = cal.to_dict()
    entry = doc[sensor].setdefault(key, np.zeros((3, 3) if key == "g_sensitivity" else 3).tolist())
    if len(index) == 1:
        entry[index[0]] = value
    else:
        entry[index[0]][index[1]] = value
    return doc


def run(capsys, *args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(("sensor", "key", "index"), ENTRIES)
def test_validate_and_apply_refuse_a_parameter_of_1e308(capsys, session, sensor, key, index):
    rec, truth, d = session
    path = d / f"{sensor}.{key}.json"
    path.write_text(json.dumps(_document(truth, sensor, key, index, 1e308)), encoding="utf-8")
    code, out, err = run(capsys, "validate", path, d / "short.csv")
    assert code == 2 and "ACCEPTED" not in out
    assert f"'{sensor}.{key}'" in err and "Traceback" not in err
    code, out, err = run(capsys, "apply", path, d / "short.csv", "-o", d / "out.csv")
    assert code == 2 and f"'{sensor}.{key}'" in err and not (d / "out.csv").exists()


@pytest.mark.parametrize(("sensor", "key", "index"), ENTRIES[:5])
def test_the_verdict_rejects_a_calibration_whose_figures_are_not_finite(session, sensor, key, index):
    rec, truth, _ = session
    doc = _document(truth, sensor, key, index, 1e308)
    with pytest.raises(CalibrationFileError):
        Calibration.from_dict(doc)
    models = {s: getattr(truth, s).to_dict(gyroscope=s == "gyroscope") for s in ("accelerometer", "gyroscope")}
    models[sensor] = doc[sensor]
    from imucalib.models import TriadModel

    bad = truth.with_(accelerometer=TriadModel.from_dict(models["accelerometer"], default_shape="upper"),
                      gyroscope=TriadModel.from_dict(models["gyroscope"], default_shape="full"))
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = validate(bad, rec)
    assert result["verdict"] == "rejected"
    assert any("not a finite number" in r for r in result["verdict_reasons"]), result["verdict_reasons"]
    assert validate(truth, rec)["verdict"] == "accepted"


def test_a_nan_figure_or_parameter_rejects_whatever_else_passes():
    truth = linear_truth()
    assert assess(truth)["verdict"] == "accepted"
    result = assess(truth.with_(fit={"accelerometer_residual_rms": float("nan")}))
    assert result["verdict"] == "rejected" and "accelerometer_residual_rms" in result["verdict_reasons"][0]
    listed = assess(truth.with_(fit={"temperature_c": [20.0, float("inf"), 30.0]}))
    assert listed["verdict"] == "rejected" and "temperature_c" in listed["verdict_reasons"][0]
    assert assess(truth.with_(fit={"temperature_c": None}))["verdict"] == "accepted"  # not available: fine


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.sampled_from(ENTRIES), st.floats(allow_nan=False, allow_infinity=False, min_value=-1e308, max_value=1e308))
def test_an_entry_loads_only_within_its_bounds(tmp_path, entry, value):
    """Refused exactly when the value is out of bounds: each bound computed here from the model."""
    sensor, key, index = entry
    truth = linear_truth()
    doc = _document(truth, sensor, key, index, value)
    path = tmp_path / "c.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    k1 = abs(float(doc[sensor]["scale"][index[0]]))  # the scale of the axis the entry acts on
    full = 1e4 if sensor == "accelerometer" else 1e3
    with np.errstate(over="ignore"):
        out_of_bounds = {
            "scale": lambda: not full * 2.0**-48 <= abs(value) <= full,
            "bias": lambda: np.float64(abs(value)) * k1 > full,
            "g_sensitivity": lambda: np.float64(abs(value)) * k1 > 1.0,
            "misalignment": lambda: abs(value) > 10.0,
            "output_bias": lambda: abs(value) > full,
            "scale_cubic": lambda: np.float64(abs(value)) * (16 * 9.80665 / k1) ** 3 > full,
        }[key]()
    if key == "scale" and value == 0:
        with pytest.raises(CalibrationFileError, match="non-zero"):
            Calibration.load(path)
        return
    if out_of_bounds:
        with pytest.raises(CalibrationFileError, match=f"'{sensor}.{key}'"):
            Calibration.load(path)
    else:
        cal = Calibration.load(path)
        with np.errstate(over="raise", invalid="raise"):  # within the bounds a 16-bit reading cannot overflow
            out = cal.apply(rec_of(cal))
        assert np.all(np.isfinite(out.acc)) and np.all(np.isfinite(out.gyro))


def rec_of(cal):
    from imucalib.recording import Recording

    raw = np.array([[-32768.0] * 3, [32767.0] * 3, [0.0, 1.0, -1.0]])
    return Recording(np.arange(3) * 0.01, raw, raw, acc_unit=cal.units["accelerometer"]["raw"],
                     gyro_unit=cal.units["gyroscope"]["raw"])


def test_real_and_simulated_calibrations_pass_the_bounds():
    from imucalib.scenarios.handheld import consumer_truth
    from imucalib.scenarios.wang2019 import session

    for cal in (linear_truth(), consumer_truth(np.random.default_rng(3)), session(0).truth):
        check_magnitudes(cal)
        assert Calibration.from_dict(json.loads(cal.to_json())).parameters() == cal.parameters()


def test_gravity_out_of_bounds_is_refused(capsys, session, tmp_path):
    _, truth, d = session
    doc = truth.to_dict()
    doc["gravity"] = 1e308
    (tmp_path / "g.json").write_text(json.dumps(doc), encoding="utf-8")
    code, _, err = run(capsys, "export", tmp_path / "g.json")
    assert code == 2 and "'gravity': 1e+308 m/s^2 is not a gravity" in err
    with pytest.raises(SystemExit) as exc:
        main(["calibrate", str(d / "short.csv"), "--gravity", "1e200", "-o", str(tmp_path / "c.json")])
    assert exc.value.code == 2
    assert "1e200 m/s^2 is not a gravity" in capsys.readouterr().err and not (tmp_path / "c.json").exists()


@pytest.mark.parametrize("text", ["[" * 10_000 + "]" * 10_000,
                                  '{"format": "imucalib.calibration", "fit": ' + '{"a": ' * 10_000 + "1"
                                  + "}" * 10_001,
                                  '{"format": "imucalib.calibration", "gravity": NaN}',
                                  '{"format": "imucalib.calibration", "gravity": 1e999}'])
def test_hostile_json_is_a_plain_error(capsys, tmp_path, text):
    path = tmp_path / "c.json"
    path.write_text(text, encoding="utf-8")
    code, out, err = run(capsys, "export", path)
    assert code == 2 and out == "" and "Traceback" not in err
    assert any(w in err for w in ("nested more than 64 levels", "NaN", "out of range"))


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="the child's peak memory is read from /proc")
def test_a_huge_or_endless_calibration_file_is_refused_in_bounded_memory(tmp_path):
    sparse = tmp_path / "huge.json"
    with sparse.open("wb") as fh:
        fh.truncate(4 << 30)  # 4 GB of zeros, stored sparse
    # the child's own peak (VmHWM): its ru_maxrss would include the peak of this test process, the pre-exec
    # memory of a vforked child
    script = ("import sys\nfrom imucalib.cli import main\n"
              "code = [main(['export', p]) for p in sys.argv[1:]]\n"
              "print(code, next(ln.split()[1] for ln in open('/proc/self/status') if ln.startswith('VmHWM:')))")
    start = time.perf_counter()
    run_ = subprocess.run([sys.executable, "-c", script, str(sparse), "/dev/zero"], capture_output=True, text=True,
                          timeout=60)
    assert time.perf_counter() - start < 30
    codes, rss_kb = run_.stdout.split("]")
    assert codes == "[2, 2", run_.stderr
    assert "larger than 16 MB" in run_.stderr and "Traceback" not in run_.stderr
    assert int(rss_kb) < 400_000  # kB, the child's peak: the interpreter and numpy, plus at most 16 MB read


@pytest.mark.parametrize("noise", ["deep", "/dev/zero"])
def test_a_hostile_noise_file_is_a_plain_error(capsys, cal_file, tmp_path, noise):
    if noise == "deep":
        noise = tmp_path / "noise.json"
        noise.write_text('{"accelerometer": ' + "[" * 10_000 + "]" * 10_000 + "}", encoding="utf-8")
    code, out, err = run(capsys, "export", cal_file, "--format", "kalibr", "--raw-scale", "1,1", "--noise", noise)
    assert code == 2 and out == "" and "Traceback" not in err and "--noise" in err


@pytest.fixture
def cal_file(tmp_path):
    path = tmp_path / "c.json"
    linear_truth().save(path)
    return path
