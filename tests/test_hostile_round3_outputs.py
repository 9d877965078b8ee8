"""Hostile inputs, third round (outputs and messages): exports that write no impossible value, thermal models
that name what they lack, a store nested without end, a full disk, and messages that name the right cause.

The commands run in a child under resource limits (:mod:`hostile_child`).
"""

from __future__ import annotations

import gzip
import io
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from hostile_child import in_process, limited, one_line


@pytest.fixture(scope="module")
def session_files(tmp_path_factory):
    from imucalib.io import write_csv
    from synth import tedaldi_session

    d = tmp_path_factory.mktemp("controls")
    rec, truth, _ = tedaldi_session(seed=12, noise_acc=0.003, noise_gyro=0.002)
    write_csv(d / "s.csv", rec)
    truth.save(d / "c.json")
    return d


# ------------------------------------------------------------------ export --temperature
@pytest.fixture(scope="module")
def thermal_cal(tmp_path_factory):
    from imucalib.scenarios import handheld
    from imucalib.thermal import ThermalModel

    rng = np.random.default_rng(0)
    truth = handheld.consumer_truth(rng)
    cal = truth.with_(thermal=ThermalModel(coefficients=handheld.datasheet_thermal(rng, truth),
                                           range_c=(10.0, 40.0)))
    path = tmp_path_factory.mktemp("thermal") / "c.json"
    cal.save(path)
    return path


@pytest.mark.parametrize("temperature", ["-300", "1e6", "1e300", "nan", "inf"])
def test_export_refuses_a_temperature_no_sensor_is_at(thermal_cal, tmp_path, temperature, capsys):
    code, out, err, _ = in_process(capsys, "export", thermal_cal, "--format", "kalibr", f"--temperature={temperature}",
                                           "--raw-scale", "1,1", "-o", tmp_path / "k.yaml")
    assert code == 2 and one_line(err) and "no temperature a working sensor is at" in err, err
    assert not (tmp_path / "k.yaml").exists()


def test_export_warns_when_the_temperature_extrapolates(thermal_cal, tmp_path, capsys):
    code, out, err, _ = in_process(capsys, "export", thermal_cal, "--format", "kalibr", "--temperature", "70",
                                           "--raw-scale", "1,1", "-o", tmp_path / "k.yaml")
    assert code == 0, err
    assert "70 °C is outside the 10.0–40.0 °C the thermal calibration was made from: it extrapolates" in err, err
    code, _, err, _ = in_process(capsys, "export", thermal_cal, "--format", "kalibr", "--temperature", "30",
                                         "--raw-scale", "1,1", "-o", tmp_path / "k2.yaml")
    assert code == 0 and "extrapolates" not in err, err


# ------------------------------------------------------------------ export: values no file may hold
@pytest.fixture(scope="module")
def counts_cal(tmp_path_factory):
    from imucalib.calibration import Calibration

    cal = Calibration(method="tedaldi2014", fit={"verdict": "accepted", "verdict_reasons": []}).with_parameters(
        {**{f"accelerometer.scale.{a}": 5.98e-4 for a in "xyz"}, **{f"gyroscope.scale.{a}": 1.33e-4 for a in "xyz"}})
    path = tmp_path_factory.mktemp("export") / "c.json"
    cal.save(path)
    return path


@pytest.mark.parametrize("scale", ["1e308,1e308", "1e-320,1", "-1,1", "nan,1", "inf,1"])
@pytest.mark.parametrize("fmt", ["openvins", "kalibr"])
def test_export_refuses_a_raw_scale_that_is_no_scale(counts_cal, tmp_path, scale, fmt, capsys):
    code, out, err, _ = in_process(capsys, "export", counts_cal, "--format", fmt, f"--raw-scale={scale}",
                                           "-o", tmp_path / "x.yaml")
    assert code == 2 and one_line(err.splitlines()[-1]) and "Traceback" not in err, err
    assert not (tmp_path / "x.yaml").exists()


def _noise_json(tmp_path, **changes):
    doc = {"accelerometer": {"unit": "m/s^2", "white_noise_density": [1e-3] * 3, "random_walk": [1e-4] * 3},
           "gyroscope": {"unit": "rad/s", "white_noise_density": [1e-4] * 3, "random_walk": [1e-5] * 3},
           "rate_hz": 200.0}
    for key, value in changes.items():
        part, _, name = key.partition("__")
        if name:
            if value is None:
                del doc[part][name]
            else:
                doc[part][name] = value
        elif value is None:
            del doc[part]
        else:
            doc[part] = value
    path = tmp_path / "noise.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


@pytest.mark.parametrize("changes, words", [
    ({"accelerometer__random_walk": None}, "no 'random_walk' entry"),
    ({"gyroscope__white_noise_density": None}, "no 'white_noise_density' entry"),
    ({"rate_hz": "1e999"}, "rate_hz must be a positive number"),
    ({"rate_hz": -100}, "rate_hz must be a positive number"),
    ({"rate_hz": "fast"}, "could not convert"),
    ({"accelerometer__white_noise_density": [-1e-3] * 3}, "accelerometer_noise_density must be a positive"),
])
def test_export_refuses_a_noise_json_missing_or_bad_entries(counts_cal, tmp_path, changes, words, capsys):
    noise = _noise_json(tmp_path, **changes)
    code, out, err, _ = in_process(capsys, "export", counts_cal, "--format", "kalibr", "--raw-scale", "1,1",
                                           "--noise", noise, "-o", tmp_path / "x.yaml")
    assert code == 2 and one_line(err) and words in err, err
    assert not (tmp_path / "x.yaml").exists()
    good = _noise_json(tmp_path)
    code, out, err, _ = in_process(capsys, "export", counts_cal, "--format", "kalibr", "--raw-scale", "1,1",
                                           "--noise", good, "-o", tmp_path / "x.yaml")
    assert code == 0 and "update_rate: 200.0" in (tmp_path / "x.yaml").read_text(encoding="utf-8"), err


CC = __import__("shutil").which("cc") or __import__("shutil").which("gcc")


@pytest.mark.skipif(CC is None, reason="no C compiler")
def test_a_float_header_with_constants_below_floats_range_compiles_with_werror(tmp_path):
    from imucalib.calibration import Calibration
    from imucalib.export import to_c
    from imucalib.recording import ImucalibWarning

    cal = Calibration(method="tedaldi2014").with_parameters({"accelerometer.scale_cubic.x": 1e-50,
                                                             "gyroscope.scale_quadratic.y": -3e-47})
    with pytest.warns(ImucalibWarning, match=r"2 constant\(s\) below float's range .* written as 0"):
        header = to_c(cal, ctype="float")
    (tmp_path / "cal.h").write_text(header, encoding="utf-8")
    (tmp_path / "main.c").write_text('#include "cal.h"\nint main(void){float a[3],g[3];const float r[3]={1,2,3};'
                                     "imucalib_apply(r,r,a,g);return a[0]!=a[0];}\n", encoding="utf-8")
    r = subprocess.run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", "-o", str(tmp_path / "m"),
                        str(tmp_path / "main.c"), "-lm"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    huge = Calibration(method="tedaldi2014").with_parameters({"accelerometer.scale_cubic.x": 1e39})
    with pytest.raises(ValueError, match="beyond float's range"):
        to_c(huge, ctype="float")
    assert "1e-50" in to_c(cal) and "e-47" in to_c(cal)  # double holds them


# ------------------------------------------------------------------ thermal: names and temperatures a file may hold
def test_a_thermal_parameter_the_calibration_lacks_is_a_plain_error(thermal_cal, tmp_path, capsys):
    d = json.loads(thermal_cal.read_text(encoding="utf-8"))
    d["gyroscope"] = None  # an accelerometer-only calibration whose thermal model varies the gyroscope
    d["units"]["gyroscope"] = d["units"].get("gyroscope")
    d["thermal"]["parameters"]["gyroscope.bias.x"] = {"coefficients": [1e-4, 0.0], "order": 1}
    path = tmp_path / "c.json"
    path.write_text(json.dumps(d), encoding="utf-8")
    for args in (["export", path], ["export", path, "--format", "kalibr", "--temperature", "30"],
                 ["validate", path, thermal_cal]):
        code, out, err, _ = in_process(capsys, *args)
        assert code == 2 and one_line(err) and "which the calibration does not have" in err, err


@pytest.mark.parametrize("temperature", [[[20.0, 21.0], [22.0, 23.0]], [25.0], "hot", [1.0, "x", 2.0], True])
def test_thermal_refuses_a_fit_temperature_that_is_no_temperature(session_files, tmp_path, temperature, capsys):
    paths = []
    for k, t in enumerate((temperature, 35.0)):
        d = json.loads((session_files / "c.json").read_text(encoding="utf-8"))
        d.setdefault("fit", {})["temperature_c"] = t
        paths.append(tmp_path / f"c{k}.json")
        paths[-1].write_text(json.dumps(d), encoding="utf-8")
    code, out, err, _ = in_process(capsys, "thermal", *paths, "-o", tmp_path / "t.json")
    assert code == 2 and one_line(err) and "calibration 1" in err, err
    assert not (tmp_path / "t.json").exists()


# ------------------------------------------------------------------ a store record nested without end
@pytest.mark.parametrize("column", ["notes", "files", "calibration"])
def test_a_store_record_nested_100000_deep_is_a_plain_error(tmp_path, column):
    import sqlite3

    from imucalib.calibration import Calibration
    from imucalib.store import Store

    with Store(tmp_path / "s.sqlite") as st:
        st.add({"device": "A", "recorded_at": None, "temperature_c": None, "method": "tedaldi2014",
                "status": "ok", "verdict": "accepted",
                "calibration": Calibration(method="tedaldi2014", fit={"verdict": "accepted", "verdict_reasons": []}),
                "files": [], "source_sha256": "x", "settings": {"method": "tedaldi2014"}, "error": None})
    db = sqlite3.connect(tmp_path / "s.sqlite")
    db.execute(f"UPDATE calibrations SET {column} = ?", ("[" * 100_000 + "]" * 100_000,))
    db.commit()
    db.close()
    for args in (["store", "list"], ["store", "get", "A", "-o", tmp_path / "c.json"],
                 ["store", "export", "-o", tmp_path / "x.csv"]):
        code, out, err, _ = limited(*args, "--store", tmp_path / "s.sqlite")
        if column == "calibration" and args[1] == "list":
            assert code == 0, err  # the list does not read the calibration
            continue
        assert code == 2 and one_line(err) and "nested more than" in err, err


@pytest.mark.slow
def test_running_out_of_memory_is_a_one_line_error(tmp_path):
    path = tmp_path / "big.csv"
    with path.open("w", encoding="ascii") as f:
        f.write("ax,ay,az,gx,gy,gz\n")
        block = "0,0,1,0,0,0\n" * 100_000
        for _ in range(40):
            f.write(block)
    code, out, err, peak = limited("calibrate", path, "--rate", "100", space=450 << 20)
    assert code == 2 and one_line(err) and "out of memory" in err, err


# ------------------------------------------------------------------ a full disk
@pytest.fixture
def tiny_disk(tmp_path):
    """A 96 kB file system (tmpfs), nearly filled; skipped where it cannot be mounted (not root, a container)."""
    where = tmp_path / "tiny"
    where.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=96k", "tmpfs", str(where)],
                                           capture_output=True).returncode != 0:
        pytest.skip("a small file system cannot be mounted here (needs root and mount)")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], capture_output=True)


def _fill(where: Path, leave: int) -> None:
    free = os.statvfs(where).f_bavail * os.statvfs(where).f_frsize
    (where / "fill").write_bytes(b"\0" * max(free - leave, 0))


def test_a_full_disk_is_named_for_an_output_file(tiny_disk, session_files):
    _fill(tiny_disk, 4096)
    (tiny_disk / "c.json").write_text("before", encoding="utf-8")
    code, out, err, _ = limited("calibrate", session_files / "s.csv", "-o", tiny_disk / "c.json")
    assert code == 2 and one_line(err) and "the disk is full" in err and str(tiny_disk / "c.json") in err, err
    assert (tiny_disk / "c.json").read_text(encoding="utf-8") == "before"
    assert sorted(p.name for p in tiny_disk.iterdir()) == ["c.json", "fill"]  # no temporary file left


def test_a_full_disk_is_named_for_the_store(tiny_disk, session_files, tmp_path):
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"device,files\nA,{session_files / 's.csv'}\n", encoding="utf-8")
    _fill(tiny_disk, 8192)
    code, out, err, _ = limited("batch", manifest, "--store", tiny_disk / "s.sqlite")
    assert code == 2 and one_line(err) and "the disk holding it is full" in err, err


# ------------------------------------------------------------------ misleading messages
@pytest.mark.parametrize("encoding", ["utf-32", "utf-32-le", "utf-32-be"])
def test_utf32_is_called_utf32(tmp_path, encoding, capsys):
    path = tmp_path / "u.csv"
    text = "t,ax,ay,az,gx,gy,gz\n" + "0.0,1,2,3,4,5,6\n" * 50
    path.write_bytes(text.encode(encoding))
    code, out, err, _ = in_process(capsys, "calibrate", path)
    assert code == 2 and one_line(err) and "UTF-32" in err and "UTF-16" not in err, err


def test_apply_to_a_gz_name_writes_gzip(tmp_path, session_files, capsys):
    from imucalib.io import read

    for name in ("out.csv.gz", "OUT.CSV.GZ"):
        code, out, err, _ = in_process(capsys, "apply", session_files / "c.json", session_files / "s.csv",
                                               "-o", tmp_path / name)
        assert code == 0, err
        assert (tmp_path / name).read_bytes()[:2] == b"\x1f\x8b"
        back = read(tmp_path / name)
        np.testing.assert_array_equal(back.acc, read(session_files / "s.csv").acc)
        assert "acc_x_cal" in gzip.decompress((tmp_path / name).read_bytes()).decode().splitlines()[0]


def test_apply_on_a_file_cut_while_it_is_read_says_so(tmp_path, session_files, monkeypatch, capsys):
    import shutil

    from imucalib.cli import main
    from imucalib.io import csvparse

    source = tmp_path / "r.csv"
    shutil.copy(session_files / "s.csv", source)
    planned = csvparse.plan

    def plan_then_cut(layout, *a, **k):
        out = planned(layout, *a, **k)
        lines = source.read_text(encoding="utf-8").splitlines(True)
        source.write_text("".join(lines[:len(lines) // 2]), encoding="utf-8")  # a copy still in progress
        return out

    monkeypatch.setattr(csvparse, "plan", plan_then_cut)
    code = main(["apply", str(session_files / "c.json"), str(source), "-o", str(tmp_path / "out.csv")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "the file changed while it was read" in err and "broadcast" not in err, err
    assert not (tmp_path / "out.csv").exists()


def test_a_long_batch_does_not_start_by_announcing_hundreds_of_hours(monkeypatch):
    from imucalib.progress import Progress

    now = [0.0]
    monkeypatch.setattr("imucalib.progress.time.perf_counter", lambda: now[0])
    out = io.StringIO()
    bar = Progress("batch", total=100_000, stream=out, interval=0.0, unit="row")
    now[0] = 19.0  # starting the workers and the first row: 19 s
    bar(1)
    for k in range(2, 8):
        now[0] += 0.01  # then a row every 10 ms
        bar(k)
    lines = out.getvalue().splitlines()
    assert "left" not in lines[0], lines  # one row says nothing of the rate
    # 99,993 rows left at 10 ms: 16 min 40 s (elapsed 19.06 s / 7 rows would say 75 h)
    assert lines[-1] == "batch: 7/100000 rows, 19 s, about 16 min 40 s left", lines


# ------------------------------------------------------------------ Ferraris sections that overlap
@pytest.fixture(scope="module")
def ferraris_session(tmp_path_factory):
    from imucalib.io import write_csv
    from imucalib.scenarios import session

    sim = session("handheld", rng=1, procedure="ferraris", tremor=0)
    d = tmp_path_factory.mktemp("ferraris")
    write_csv(d / "f.csv", sim.recording)
    return d / "f.csv", {k: [int(a), int(b)] for k, (a, b) in sim.options["sections"].items()}


@pytest.mark.parametrize("name, inside, words", [
    ("x_p", "z_p", "overlap"), ("x_rot", "x_p", "overlap"), ("y_rot", "x_rot", "overlap"),
    ("x_rot", None, "a turn needs the samples"),
])
def test_overlapping_or_empty_ferraris_sections_are_named(tmp_path, ferraris_session, name, inside, words, capsys):
    path, sections = ferraris_session
    bad = dict(sections)
    bad[name] = [sections[inside][0] + 10, sections[inside][1] - 10] if inside else \
        [sections[name][0], sections[name][0] + 1]
    (tmp_path / "s.json").write_text(json.dumps(bad), encoding="utf-8")
    code, out, err, _ = in_process(capsys, "calibrate", path, "--method", "ferraris", "--sections", tmp_path / "s.json",
                                           "-o", tmp_path / "c.json")
    assert code == 2 and one_line(err) and words in err and f"'{name}'" in err, err
    assert "stops[i]" not in err and not (tmp_path / "c.json").exists()
