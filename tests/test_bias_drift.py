"""The gyroscope bias's drift in apply: the calibrated session corrected with it, any other with the constant bias."""

import json
import math
import warnings

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.io import read, write_csv
from imucalib.methods import calibrate
from imucalib.recording import ImucalibWarning, Interval
from imucalib.scenarios import session

#: the limit on the calibrated rate at rest [°/s]
LIMIT = 0.02
#: the session's drift, σ per axis [°/s per minute]: five times the hand-held default, so that the constant bias
#: reads ~0.1 °/s at the session's ends
DRIFT = 0.05
NEW_FIELDS = ("gyroscope_bias_session_s", "gyroscope_bias_session_check", "gyroscope_bias_drift_over_session_deg_s")


def _drifting(seed: int):
    # no tremor nor creep: the last pose is as still as the initial rest, so its mean reads the bias error alone
    return session("handheld", rng=seed, gyro_drift=DRIFT, tremor=0.0, creep=0)


@pytest.fixture(scope="module")
def drifting():
    sim = _drifting(5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = calibrate(sim.recording, method="tedaldi2014", gravity=sim.truth.gravity)
    return sim, cal


def _rests(cal):
    intervals = [Interval(int(a), int(b), "static") for a, b in cal.fit["intervals"]]
    return intervals[0], intervals[-1]


def _deg_s(out, iv):
    return np.degrees(out.gyro[iv.slice].mean(axis=0))


def test_the_fit_finds_the_simulated_drift(drifting):
    sim, cal = drifting
    true = np.asarray(sim.options["gyro_drift_counts_per_min"]) / 60.0  # counts per s
    fitted = np.asarray(cal.fit["gyroscope_bias_drift_per_s"])
    se = np.asarray(cal.fit["gyroscope_bias_drift_se_per_s"])
    assert np.all(np.abs(fitted - true) < 3 * se), (fitted, true, se)
    assert cal.fit["verdict"] == "accepted"  # a drift the fit models is no reason


def test_apply_reads_the_initial_and_final_rests_at_zero(drifting):
    sim, cal = drifting
    rec = sim.recording
    first, last = _rests(cal)
    out = cal.apply(rec)
    assert out.metadata["gyroscope_bias_drift"] == "applied"
    constant = cal.apply(rec, bias_drift="off")
    assert constant.metadata["gyroscope_bias_drift"] == "constant"
    for iv in (first, last):
        assert np.all(np.abs(_deg_s(out, iv)) < LIMIT), (iv, _deg_s(out, iv))
        assert np.max(np.abs(_deg_s(constant, iv))) > 3 * LIMIT  # the constant bias reads the drift: teeth
    # what the constant bias reads at the rests is the true drift's d (t − t_ref) through the calibration
    g = cal.gyroscope
    true_d = np.asarray(sim.options["gyro_drift_counts_per_min"]) / 60.0
    for iv in (first, last):
        tau = float(np.mean(rec.t[iv.slice])) - cal.fit["gyroscope_bias_time_s"]
        expected = np.degrees((g.misalignment * g.scale[None, :]) @ true_d) * tau
        np.testing.assert_allclose(_deg_s(constant, iv), expected, atol=LIMIT)
    # the model is linear: the two differ by exactly T diag(k1) d (t − t_ref) at every sample
    shift = cal.bias_offset(rec.t) @ (g.misalignment * g.scale[None, :]).T
    np.testing.assert_allclose(constant.gyro - out.gyro, shift, rtol=1e-9, atol=1e-15)
    assert np.array_equal(cal.apply(rec, bias_drift="on").gyro, out.gyro)
    np.testing.assert_array_equal(out.acc, constant.acc)


def test_the_drift_over_the_session_is_reported_not_rejected(drifting):
    sim, cal = drifting
    rec = sim.recording
    fit = cal.fit
    assert fit["gyroscope_bias_session_s"] == [float(rec.t[0]), float(rec.t[-1])]
    start, end = (np.asarray(r) for r in fit["gyroscope_bias_drift_over_session_deg_s"])
    # independently: the constant bias's reading at the first and last sample, less the drifting bias's
    both = [cal.apply(rec[k], bias_drift=mode).gyro for k in (slice(0, 1), slice(len(rec) - 1, None))
            for mode in ("off", "on")]
    np.testing.assert_allclose(start, np.degrees(both[0] - both[1])[0], rtol=1e-9)
    np.testing.assert_allclose(end, np.degrees(both[2] - both[3])[0], rtol=1e-9)
    assert np.max(np.abs(start)) > 3 * LIMIT
    notes = [n for n in fit["verdict_notes"] if "bias drifted over the session" in n]
    assert len(notes) == 1 and f"{start[np.argmax(np.maximum(np.abs(start), np.abs(end)))]:+.3g}" in notes[0]
    assert not any("drift" in r for r in fit["verdict_reasons"])


def test_a_part_of_the_calibrated_session_is_recognised(drifting):
    sim, cal = drifting
    rec = sim.recording
    part = rec[len(rec) // 4: len(rec) // 2]
    assert cal.is_own_session(rec) and cal.is_own_session(part)
    out = cal.apply(part)
    assert out.metadata["gyroscope_bias_drift"] == "applied"
    np.testing.assert_array_equal(out.gyro, cal.apply(rec).gyro[len(rec) // 4: len(rec) // 2])


def test_another_recording_keeps_the_constant_bias(drifting):
    sim, cal = drifting
    other = _drifting(6).recording
    # the harder case: the same clock from zero, and a span within the calibrated one
    other = other[: int(np.searchsorted(other.t, cal.fit["gyroscope_bias_session_s"][1] - 10.0))]
    assert not cal.is_own_session(other)
    with pytest.warns(ImucalibWarning, match="not the recording the calibration was made from") as caught:
        out = cal.apply(other)
    assert len([w for w in caught if "not extrapolated" in str(w.message)]) == 1  # said once
    assert out.metadata["gyroscope_bias_drift"] == "constant"
    np.testing.assert_array_equal(out.gyro, cal.apply(other, bias_drift="off").gyro)
    assert not np.array_equal(out.gyro, cal.apply(other, bias_drift="on").gyro)  # forced: it would move
    # a recording too short for the drift to move its rest reading by the limit: no warning
    rate = np.max(np.abs(cal.drift_rate()))
    short = other[: int(np.searchsorted(other.t, other.t[0] + 0.5 * math.radians(LIMIT) / rate))]
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImucalibWarning)
        assert cal.apply(short).metadata["gyroscope_bias_drift"] == "constant"


def test_a_changed_sample_is_another_recording(drifting):
    sim, cal = drifting
    rec = sim.recording
    check = np.asarray(cal.fit["gyroscope_bias_session_check"])
    k = int(np.searchsorted(rec.t, check[3, 0]))
    gyro = rec.gyro.copy()
    gyro[k, 1] += 1.0  # one count at one of the check samples
    from dataclasses import replace

    with pytest.warns(ImucalibWarning):
        assert cal.apply(replace(rec, gyro=gyro)).metadata["gyroscope_bias_drift"] == "constant"
    with pytest.raises(ValueError, match="bias_drift must be one of"):
        cal.apply(rec, bias_drift="yes")


def test_an_old_file_without_the_new_fields_loads_and_applies(drifting, tmp_path):
    sim, cal = drifting
    rec = sim.recording
    doc = json.loads(cal.to_json())
    for key in NEW_FIELDS:
        del doc["fit"][key]
    doc["fit"]["verdict_notes"] = [n for n in doc["fit"]["verdict_notes"] if "drifted over" not in n]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImucalibWarning)  # no undeclared field, and no drift said on load
        old = Calibration.load(path)
    assert not old.is_own_session(rec)
    with pytest.warns(ImucalibWarning, match="not extrapolated"):
        out = old.apply(rec)  # as before these fields: the constant bias
    np.testing.assert_array_equal(out.gyro, cal.apply(rec, bias_drift="off").gyro)
    np.testing.assert_array_equal(old.apply(rec, bias_drift="on").gyro, cal.apply(rec).gyro)
    # a file without any drift: the three modes are one
    for key in ("gyroscope_bias_drift_per_s", "gyroscope_bias_drift_se_per_s", "gyroscope_bias_time_s"):
        del doc["fit"][key]
    path.write_text(json.dumps(doc))
    plain = Calibration.load(path)
    assert plain.bias_drift is None
    outs = [plain.apply(rec, bias_drift=m).gyro for m in ("auto", "on", "off")]
    assert np.array_equal(outs[0], outs[1]) and np.array_equal(outs[0], outs[2])
    # the new file round-trips its fields
    cal.save(tmp_path / "new.json")
    again = Calibration.load(tmp_path / "new.json")
    assert {k: again.fit[k] for k in NEW_FIELDS} == {k: cal.fit[k] for k in NEW_FIELDS}
    assert again.is_own_session(rec)


def _cli(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_bias_drift_round_trip(capsys, tmp_path):
    sim = _drifting(5)
    data = tmp_path / "session.csv"
    write_csv(data, sim.recording)
    code, out, err = _cli(capsys, "calibrate", data, "-o", tmp_path / "c.json", "--gravity",
                          repr(sim.truth.gravity), "--json")
    assert code == 0, err
    cal = Calibration.load(tmp_path / "c.json")
    rec = read(data)
    first, last = _rests(cal)
    for mode, expected in (("auto", "applied"), ("on", "applied"), ("off", "constant")):
        target = tmp_path / f"{mode}.csv"
        code, out, err = _cli(capsys, "apply", tmp_path / "c.json", data, "-o", target, "--json",
                              "--bias-drift", mode)
        assert code == 0, err
        assert json.loads(out)["gyroscope_bias_drift"] == expected
        back = read(target)
        gyro = np.column_stack([back.extra[f"gyro_{a}_cal [rad/s]"] for a in "xyz"])
        np.testing.assert_allclose(gyro, cal.apply(rec, bias_drift=mode).gyro, rtol=1e-9, atol=1e-12)
        rests = [np.degrees(gyro[iv.slice].mean(axis=0)) for iv in (first, last)]
        assert (max(np.max(np.abs(r)) for r in rests) < LIMIT) == (expected == "applied")
    with pytest.raises(SystemExit) as stop:  # argparse's own usage error: exit 2, one line, no traceback
        main(["apply", str(tmp_path / "c.json"), str(data), "-o", str(tmp_path / "x.csv"), "--bias-drift",
              "sometimes"])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and "invalid choice: 'sometimes'" in err and "Traceback" not in err
    assert not (tmp_path / "x.csv").exists()
    other = tmp_path / "other.csv"
    write_csv(other, _drifting(6).recording)
    code, out, err = _cli(capsys, "apply", tmp_path / "c.json", other, "-o", tmp_path / "o.csv")
    assert code == 0 and err.count("not extrapolated") == 1
    assert "drifting as fitted" not in out


def test_cli_bag_output_takes_the_constant_bias(capsys, tmp_path, drifting):
    _, cal = drifting
    cal.save(tmp_path / "c.json")
    bag = tmp_path / "run.bag"
    bag.write_bytes(b"#ROSBAG V2.0\n")  # recognised as a bag; refused before it is read
    code, out, err = _cli(capsys, "apply", tmp_path / "c.json", bag, "-o", tmp_path / "out.bag", "--bias-drift", "on")
    assert code == 2 and "--bias-drift on needs a CSV output" in err and "Traceback" not in err
    assert not (tmp_path / "out.bag").exists()


def test_zhang2021_nonlinear_variant_holds_the_drift():
    # eq. (21)'s joint solve of a nonlinear variant refits the bias and G from the poses' means: without the drift
    # the shared stage found, G absorbs it (seen as a rest reading 0.021 °/s and G 4–5σ off on a hand-held seed)
    # (the default hand-held seed 11, tremor included: the initial rest lies on the table, the last pose is held)
    sim = session("handheld", rng=11)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = calibrate(sim.recording, method="zhang2021", model="quadratic", gravity=sim.truth.gravity)
    assert "gyroscope_bias_drift_per_s" in cal.fit
    first, _ = _rests(cal)
    assert np.all(np.abs(_deg_s(cal.apply(sim.recording), first)) < LIMIT / 2), _deg_s(cal.apply(sim.recording), first)
    g_true = np.asarray(sim.truth.gyroscope.g_sensitivity)
    g_fit = np.asarray(cal.gyroscope.g_sensitivity)
    se = np.array([[cal.fit["uncertainty"][f"gyroscope.g_sensitivity.{a}{b}"] for b in "xyz"] for a in "xyz"])
    assert np.all(np.abs(g_fit - g_true) < 3 * se), ((g_fit - g_true) / se).round(1)
