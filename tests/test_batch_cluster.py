"""Dask: a batch and a Monte Carlo study on a LocalCluster give what local processes give."""

from __future__ import annotations

import warnings

import pytest

from imucalib.batch import BatchError, run_batch
from imucalib.experiments.evaluate import montecarlo
from imucalib.store import Store
from test_batch import write_fleet, write_manifest


@pytest.fixture(autouse=True)
def dask():
    """Dask, or the test skips; imported by the tests, not at the top: every test process imports this file to
    collect it, and Dask with distributed takes half a second to import."""
    pytest.importorskip("distributed", reason='Dask distributed is not installed (the cluster extra: '
                        'pip install "imucalib[cluster]")')
    return pytest.importorskip("dask")


def _by_device(path):
    with Store(path, create=False) as st:
        out = {}
        for r in st.records(with_calibration=True):
            cal = r.pop("calibration")
            if cal is not None:
                cal.pop("created")  # the time the file was made
            out[r["device"]] = (cal, {k: r[k] for k in ("status", "verdict", "error", "files", "source_sha256",
                                                          "recorded_at", "settings", "notes")})
        return out


@pytest.mark.slow
def test_a_local_cluster_batch_equals_the_local_one(tmp_path):
    devices = write_fleet(tmp_path, seeds=(21, 22, 23))
    (tmp_path / "bad.csv").write_text("t,ax\n", encoding="utf-8")
    manifest = write_manifest(tmp_path / "m.csv", [
        *(f"{n},{(d / 'recording.csv').relative_to(tmp_path).as_posix()},2024-0{k + 1}-01,"
          for k, (n, d) in enumerate(devices.items())), "BAD,bad.csv,,"])
    local = run_batch(manifest, tmp_path / "local.sqlite", workers=1)
    dask = run_batch(manifest, tmp_path / "dask.sqlite", scheduler="local", workers=2)
    for key in ("rows", "calibrated", "failed", "skipped", "verdicts", "errors"):
        assert local[key] == dask[key], key
    assert (dask["calibrated"], dask["failed"]) == (3, 1)
    a, b = _by_device(tmp_path / "local.sqlite"), _by_device(tmp_path / "dask.sqlite")
    assert a.keys() == b.keys() == {*devices, "BAD"}
    for name in a:
        assert a[name] == b[name], name  # every number of every calibration, bit for bit
    again = run_batch(manifest, tmp_path / "dask.sqlite", scheduler="local", workers=2)
    assert again["skipped"] == 4


@pytest.mark.slow
def test_montecarlo_on_a_local_cluster_equals_local_processes():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kw = {"runs": 2, "seed": 5, "sim_options": {"rest": 15.0, "n_poses": 20}}
        local = montecarlo("handheld", "tedaldi2014", workers=1, **kw)
        dask = montecarlo("handheld", "tedaldi2014", scheduler="local", workers=2, **kw)
    assert local == dask


def test_an_unreachable_scheduler_is_a_clear_error(tmp_path, dask):
    manifest = write_manifest(tmp_path / "m.csv", ["A,a.csv,,"])
    (tmp_path / "a.csv").write_text("x\n")
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}), \
            pytest.raises(BatchError, match="cannot reach the Dask scheduler at tcp://127.0.0.1:9"):
        run_batch(manifest, tmp_path / "s.sqlite", scheduler="tcp://127.0.0.1:9")
