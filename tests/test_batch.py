"""imucalib batch: a manifest of simulated devices into a store; failing rows, resuming, killing."""

from __future__ import annotations

import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib.batch import ManifestError, read_manifest, run_batch
from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.scenarios import session, write_session
from imucalib.store import Store

SRC = Path(__file__).resolve().parent.parent / "src"
#: short hand-held sessions (15 s rest, 20 poses: about 2.5 min of 100 Hz data), one truth per seed
SHORT = {"rest": 15.0, "n_poses": 20}
SEEDS = (11, 12, 13, 14, 15)
#: accelerometer bias error allowed against the device's own truth: 10 counts (0.6 mg at 16384 counts/g)
BIAS_TOL = 10.0


def write_fleet(directory: Path, seeds=SEEDS) -> dict[str, Path]:
    """One simulated hand-held session per seed (each with its own drawn truth): device name → session dir."""
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for seed in seeds:
            out[f"IMU-{seed:04d}"] = write_session(session("handheld", rng=seed, **SHORT), directory / f"s{seed}")
    return out


def write_manifest(path: Path, lines: list[str], header: str = "device,files,recorded_at,temperature_c") -> Path:
    path.write_text("\n".join([header, *lines]) + "\n", encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """Five devices' sessions, a manifest of them (one given as its session directory) and two broken rows."""
    d = tmp_path_factory.mktemp("fleet")
    devices = write_fleet(d / "data")
    (d / "data" / "garbage.csv").write_text("t,ax,ay,az,gx,gy,gz\n0,1,2\nnot,a,number\n", encoding="utf-8")
    lines = []
    for k, (name, sdir) in enumerate(devices.items()):
        rel = sdir.relative_to(d)
        files = rel if k == 4 else rel / "recording.csv"  # the last one read as a simulated session directory
        lines.append(f"{name},{files.as_posix()},2024-05-0{k + 1},{20 + 5 * k}")
    lines += ["IMU-BROKEN-1,data/nowhere.csv,2024-05-06,", "IMU-BROKEN-2,data/garbage.csv,2024-05-07,"]
    write_manifest(d / "manifest.csv", lines)
    return d, devices


def truths(devices: dict[str, Path]) -> dict[str, np.ndarray]:
    return {name: Calibration.load(sdir / "truth.json").accelerometer.bias for name, sdir in devices.items()}


def test_broken_files_are_stored_as_failures_and_the_rest_calibrated(fleet, tmp_path):
    d, devices = fleet
    store = tmp_path / "fleet.sqlite"
    result = run_batch(d / "manifest.csv", store)
    assert (result["rows"], result["calibrated"], result["failed"], result["skipped"]) == (7, 5, 2, 0)
    assert [e["device"] for e in result["errors"]] == ["IMU-BROKEN-1", "IMU-BROKEN-2"]
    with Store(store, create=False) as st:
        counts = st.counts()
        records = {r["device"]: r for r in st.records(with_calibration=True)}
    assert (counts["records"], counts["ok"], counts["failed"], counts["devices"]) == (7, 5, 2, 7)
    missing, garbage = records["IMU-BROKEN-1"], records["IMU-BROKEN-2"]
    assert missing["status"] == garbage["status"] == "failed"
    assert missing["calibration"] is None and garbage["calibration"] is None
    assert "nowhere.csv" in missing["error"] and "not found" in missing["error"]
    assert "garbage.csv" in garbage["error"] and "line 2" in garbage["error"]
    # each device's calibration is its own: nearest to its own truth, within 10 counts of it
    true_bias = truths(devices)
    for name in devices:
        rec = records[name]
        assert rec["status"] == "ok" and rec["verdict"] in ("accepted", "suspect")
        cal = Calibration.from_dict(rec["calibration"])
        assert cal.device == name
        err = {other: float(np.linalg.norm(cal.accelerometer.bias - b)) for other, b in true_bias.items()}
        assert min(err, key=err.get) == name
        assert err[name] < BIAS_TOL
        assert rec["files"][0]["sha256"] is not None and rec["files"][0]["bytes"] > 0
    assert records["IMU-0011"]["recorded_at"] == "2024-05-01" and records["IMU-0011"]["temperature_c"] == 20.0


def test_a_second_run_skips_everything_force_redoes_and_a_changed_file_is_new(fleet, tmp_path):
    d0, _ = fleet
    d = tmp_path / "copy"
    shutil.copytree(d0, d)
    store = tmp_path / "fleet.sqlite"
    first = run_batch(d / "manifest.csv", store, workers=2)
    assert (first["calibrated"], first["failed"]) == (5, 2)
    again = run_batch(d / "manifest.csv", store, workers=2)
    assert (again["calibrated"], again["failed"], again["skipped"]) == (0, 0, 7)
    forced = run_batch(d / "manifest.csv", store, force=True)
    assert (forced["calibrated"], forced["failed"], forced["skipped"]) == (5, 2, 0)
    with Store(store) as st:
        assert len(st) == 7  # replaced, not added
    # the broken file repaired: new contents, a new record beside the failed one
    shutil.copy(d / "data" / "s11" / "recording.csv", d / "data" / "garbage.csv")
    fixed = run_batch(d / "manifest.csv", store)
    assert (fixed["calibrated"], fixed["failed"], fixed["skipped"]) == (1, 0, 6)  # the missing file: as before
    with Store(store) as st:
        statuses = sorted(r["status"] for r in st.records("IMU-BROKEN-2"))
    assert statuses == ["failed", "ok"]


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (Linux /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _stored(store: Path) -> int:
    try:
        with sqlite3.connect(store, timeout=5) as db:
            return db.execute("SELECT COUNT(*) FROM calibrations").fetchone()[0]
    except sqlite3.Error:
        return 0


@pytest.mark.slow
def test_a_batch_killed_half_way_finishes_on_the_next_run_with_each_row_once(fleet, tmp_path):
    d, devices = fleet
    sessions = list(devices.values())
    rows = 16
    manifest = write_manifest(tmp_path / "manifest.csv", [
        f"UNIT-{k:02d},{(sessions[k % len(sessions)] / 'recording.csv').as_posix()},2024-06-{k + 1:02d},"
        for k in range(rows)])
    store = tmp_path / "fleet.sqlite"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, "-m", "imucalib.cli", "batch", str(manifest), "--store", str(store),
                             "--workers", "2"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None and _stored(store) < 3:
            time.sleep(0.02)
        assert proc.poll() is None, f"the batch ended before it could be killed: {proc.stderr.read().decode()}"
        workers = _children(proc.pid) if Path("/proc").is_dir() else []
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    done_before = _stored(store)
    assert 3 <= done_before < rows
    assert workers or not Path("/proc").is_dir()
    # the pool's workers notice their parent is gone and end
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(Path(f"/proc/{p}").exists() and
                                              "zombie" not in _state(p) for p in workers):
        time.sleep(0.1)
    assert not [p for p in workers if Path(f"/proc/{p}").exists() and "zombie" not in _state(p)]

    result = run_batch(manifest, store, workers=2)
    assert result["skipped"] == done_before
    assert result["calibrated"] + result["failed"] == rows - done_before
    with Store(store) as st:
        names = [r["device"] for r in st.records()]
    assert sorted(names) == [f"UNIT-{k:02d}" for k in range(rows)]  # every row, each once


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/status").read_text().split("State:")[1].split("\n")[0].lower()
    except (OSError, IndexError):
        return "zombie"


def test_the_manifest_is_checked_whole_before_anything_runs(tmp_path):
    (tmp_path / "a.csv").write_text("x\n", encoding="utf-8")
    bad = write_manifest(tmp_path / "m.csv", [
        "A,a.csv,2024-13-01,",          # no such month
        ",a.csv,,",                      # no device
        "C,,,",                          # no files
        "D,a.csv,,warm",                 # temperature not a number
        "# a comment line",
        "E,a.csv,2024-05-01T10:00:00+02:00,21.5",
    ])
    with pytest.raises(ManifestError) as err:
        run_batch(bad, tmp_path / "s.sqlite")
    text = str(err.value)
    assert "4 invalid line(s)" in text and "nothing was run" in text
    for line, what in ((2, "recorded_at '2024-13-01'"), (3, "device is empty"), (4, "files is empty"),
                       (5, "temperature_c must be a number")):
        assert f"line {line}: {what}" in text
    assert not (tmp_path / "s.sqlite").exists()

    unknown = write_manifest(tmp_path / "u.csv", ["A,a.csv,tedaldi"], header="device,files,methd")
    with pytest.raises(ManifestError, match=r"line 1 \(the header\): unknown column\(s\) methd"):
        read_manifest(unknown)
    with pytest.raises(ManifestError, match="missing column"):
        read_manifest(write_manifest(tmp_path / "v.csv", ["a.csv"], header="files"))
    with pytest.raises(ManifestError, match="method 'nope' is unknown"):
        read_manifest(write_manifest(tmp_path / "w.csv", ["A,a.csv,nope"], header="device,files,method"))
    rows = read_manifest(write_manifest(tmp_path / "x.csv", ['A,a.csv;b.csv,10,"t,ax,ay,az,gx,gy,gz",g'],
                                        header="device,files,rate,columns,acc_unit"))
    assert rows[0].files == (str(tmp_path / "a.csv"), str(tmp_path / "b.csv"))
    assert rows[0].rate == 10.0 and rows[0].columns == ("t", "ax", "ay", "az", "gx", "gy", "gz")
    assert rows[0].acc_unit == "g" and rows[0].method == "tedaldi2014"


def test_the_store_may_not_be_an_input(fleet, tmp_path):
    d, _ = fleet
    with pytest.raises(ValueError, match="would destroy the input"):
        run_batch(d / "manifest.csv", d / "manifest.csv")


def test_cli_batch_json_and_store_list(fleet, tmp_path, capsys):
    d, devices = fleet
    store = tmp_path / "s.sqlite"
    code = main(["batch", str(d / "manifest.csv"), "--store", str(store), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 3  # rows failed
    assert (out["calibrated"], out["failed"], out["skipped"]) == (5, 2, 0)
    assert sum(out["verdicts"].values()) == 5
    assert main(["store", "list", "--store", str(store), "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    assert len(records) == 7
    assert {r["device"]: r["status"] for r in records} == {**{n: "ok" for n in devices},
                                                          "IMU-BROKEN-1": "failed", "IMU-BROKEN-2": "failed"}
    for r in records:
        assert set(r) >= {"device", "recorded_at", "status", "verdict", "error"}
        assert (r["error"] is None) == (r["status"] == "ok")
    assert main(["store", "list", "--store", str(store), "--device", "IMU-0012", "--json"]) == 0
    assert [r["device"] for r in json.loads(capsys.readouterr().out)] == ["IMU-0012"]
    assert main(["batch", str(d / "manifest.csv"), "--store", str(store), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["skipped"] == 7


def test_rows_read_from_fsspec_urls_match_the_local_files(fleet, tmp_path):
    fsspec = pytest.importorskip("fsspec", reason="fsspec is not installed (it comes with the cluster extra)")
    d, devices = fleet
    name, sdir = next(iter(devices.items()))
    fs = fsspec.filesystem("memory")
    fs.pipe("/fleet-test/run.csv", (sdir / "recording.csv").read_bytes())
    manifest = write_manifest(tmp_path / "m.csv", [f"{name},memory://fleet-test/run.csv,2024-05-01,",
                                                   f"{name}-local,{sdir / 'recording.csv'},2024-05-01,",
                                                   "GONE,memory://fleet-test/gone.csv,,"])
    try:
        result = run_batch(manifest, tmp_path / "s.sqlite", allow_urls=["memory"])
    finally:
        fs.rm("/fleet-test", recursive=True)
    assert (result["calibrated"], result["failed"]) == (2, 1)
    assert result["errors"][0]["error"] == "memory://fleet-test/gone.csv: file not found"
    with Store(tmp_path / "s.sqlite") as st:
        remote, local = (st.records(n, with_calibration=True)[0] for n in (name, f"{name}-local"))
    assert remote["source_sha256"] == local["source_sha256"]
    assert Calibration.from_dict(remote["calibration"]).parameters() == \
        Calibration.from_dict(local["calibration"]).parameters()


def test_montecarlo_scheduler_is_refused_for_the_papers_own_experiments(capsys):
    assert main(["montecarlo", "--scenario", "wang2019", "--method", "wang2019", "--scheduler", "local"]) == 2
    assert "the wang2019 experiment runs on local processes" in capsys.readouterr().err


@pytest.mark.parametrize(("name", "ok"), [
    ("Capteur nº 7 – bâti Ω", True),
    ("D" * 256, True),
    ("D" * 257, False),
    ("IMU\x07bell", False),
    ("IMU\tcolumn", False),
    ("IMU\x1b[31mred", False),
    ("IMU\u200bzero-width", False),
])
def test_a_device_name_the_store_cannot_read_back_is_refused_with_the_manifest(tmp_path, name, ok):
    """The manifest accepts exactly the device names a calibration file (and so the store) reads back."""
    (tmp_path / "a.csv").write_text("x\n", encoding="utf-8")
    cell = '"' + name.replace('"', '""') + '"'
    manifest = write_manifest(tmp_path / "m.csv", ["A,a.csv", f"{cell},a.csv"], header="device,files")
    doc = Calibration(device=name, units={"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
                                          "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}}).to_dict()
    if ok:
        assert [r.device for r in read_manifest(manifest)] == ["A", name]
        Calibration.from_dict(doc)  # the same name read back from a calibration
        return
    with pytest.raises(ManifestError) as err:
        run_batch(manifest, tmp_path / "s.sqlite")
    text = str(err.value)
    assert "1 invalid line(s)" in text and "nothing was run" in text
    assert "line 3: 'device': " in text and "printable text of at most 256 characters" in text, text
    assert not any(c in text for c in "\x07\t\x1b\u200b")  # quoted, escaped: the message itself is printable
    assert not (tmp_path / "s.sqlite").exists()
    with pytest.raises(ValueError, match="'device'"):
        Calibration.from_dict(doc)  # the same name refused by the calibration file's check
