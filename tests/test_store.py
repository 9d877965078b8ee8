"""The calibration store: records, the closest calibration in time or temperature, exports."""

from __future__ import annotations

import csv
import json
import sqlite3

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.store import Store, StoreError, parse_time
from imucalib.verdict import LEVELS


def cal_with_bias(bias_x: float, verdict: str = "accepted") -> Calibration:
    cal = Calibration(method="tedaldi2014", fit={"verdict": verdict, "verdict_reasons": []})
    return cal.with_(accelerometer=cal.accelerometer.with_parameters("accelerometer", {"accelerometer.bias.x": bias_x}))


def add(store: Store, device: str, at: str | None, bias_x: float, *, verdict: str = "accepted",
        temperature: float | None = None, failed: bool = False) -> int:
    rec = {"device": device, "recorded_at": at, "temperature_c": temperature, "method": "tedaldi2014",
           "status": "failed" if failed or verdict == "rejected" else "ok",
           "verdict": None if failed else verdict, "calibration": None if failed else cal_with_bias(bias_x, verdict),
           "files": [{"path": f"/data/{device}-{bias_x}.csv", "sha256": f"{bias_x}", "bytes": 1}],
           "source_sha256": f"sha-{bias_x}", "settings": {"method": "tedaldi2014"},
           "error": "boom" if failed else None}
    return store.add(rec)


@pytest.fixture
def store(tmp_path):
    """Device A: accepted calibrations on Jan 1, Mar 1 and Jun 1 (bias.x 1, 3, 6), a rejected one on Feb 14
    (bias.x 2), a suspect one on Feb 20 (bias.x 2.5), a failed row on Feb 15; device B: one undated."""
    path = tmp_path / "s.sqlite"
    with Store(path) as st:
        add(st, "A", "2024-01-01", 1.0, temperature=20.0)
        add(st, "A", "2024-03-01T00:00:00", 3.0, temperature=35.0)
        add(st, "A", "2024-06-01", 6.0, temperature=30.0)
        add(st, "A", "2024-02-14", 2.0, verdict="rejected", temperature=21.0)
        add(st, "A", "2024-02-20", 2.5, verdict="suspect")
        add(st, "A", "2024-02-15", 9.0, failed=True)
        add(st, "B", None, 7.0)
    return path


@pytest.mark.parametrize(("at", "expected"), [
    ("2024-02-10", 3.0),            # 19 days to Mar 1, 40 days to Jan 1
    ("2024-01-30", 1.0),            # 29 days to Jan 1, 31 to Mar 1; the rejected Feb 14 is closer but not used
    ("2024-04-15T12:00", 3.0),      # 45.5 days to Mar 1, 46.5 to Jun 1
    ("2024-04-16T12:00", 6.0),
    ("2024-03-01T01:00:00+02:00", 3.0),  # Feb 29 23:00 UTC
    ("2030-01-01", 6.0),
    (None, 6.0),                    # the latest
])
def test_get_picks_the_accepted_calibration_closest_in_time(store, at, expected):
    with Store(store, create=False) as st:
        cal, record = st.get("A", at=at)
    assert cal.accelerometer.bias[0] == expected
    assert record["verdict"] == "accepted" and record["device"] == "A"


def test_get_by_temperature_and_with_suspect_ones(store):
    with Store(store, create=False) as st:
        assert st.get("A", temperature=33.0)[0].accelerometer.bias[0] == 3.0   # 35 °C
        assert st.get("A", temperature=24.0)[0].accelerometer.bias[0] == 1.0   # 20 °C (21 °C is rejected)
        assert st.get("A", temperature=25.0, at="2024-05-01")[0].accelerometer.bias[0] == 6.0  # tie 20/30: in time
        assert st.get("A", at="2024-02-19", verdicts=("accepted", "suspect"))[0].accelerometer.bias[0] == 2.5
        assert st.get("B")[0].accelerometer.bias[0] == 7.0
        with pytest.raises(StoreError, match="no accepted calibration of 'B' has a recorded_at time"):
            st.get("B", at="2024-01-01")
        with pytest.raises(StoreError, match="no record of device 'C'; it holds A, B"):
            st.get("C")
        with pytest.raises(StoreError, match="no accepted calibration of 'B' has a temperature_c"):
            st.get("B", temperature=20.0)


def test_cli_store_get_writes_the_closest_calibration(store, tmp_path, capsys):
    out = tmp_path / "a.json"
    assert main(["store", "get", "A", "--store", str(store), "--at", "2024-02-10", "-o", str(out)]) == 0
    assert "recorded 2024-03-01T00:00:00 at 35 °C" in capsys.readouterr().out
    assert Calibration.load(out).accelerometer.bias[0] == 3.0
    assert main(["store", "get", "A", "--store", str(store), "--at", "2024-01-02"]) == 0
    assert json.loads(capsys.readouterr().out)["accelerometer"]["bias"][0] == 1.0
    assert main(["store", "get", "A", "--store", str(store), "--temperature", "29", "--json", "-o", str(out)]) == 0
    assert json.loads(capsys.readouterr().out)["recorded_at"] == "2024-06-01"
    assert main(["store", "get", "A", "--store", str(store), "--at", "last week"]) == 2
    assert "--at 'last week' is not an ISO date or time" in capsys.readouterr().err
    assert main(["store", "get", "A", "--store", str(store), "-o", str(store)]) == 2
    assert "would destroy the input" in capsys.readouterr().err


def test_records_counts_and_the_key(store):
    with Store(store) as st:
        counts = st.counts()
        assert counts == {"records": 7, "ok": 5, "failed": 2, "accepted": 4, "suspect": 1, "rejected": 1,
                          "devices": 2}
        recs = st.records("A")
        assert [r["recorded_at"] for r in recs] == ["2024-01-01", "2024-02-14", "2024-02-15", "2024-02-20",
                                                    "2024-03-01T00:00:00", "2024-06-01"]
        # the same device, time, settings and sources: the same record
        assert add(st, "A", "2024-01-01", 1.0, temperature=20.0) is None
        assert len(st) == 7
        with pytest.raises(ValueError, match="status is 'ok' or 'failed'"):
            st.add({"status": "done"})
    assert set(LEVELS) <= set(counts)


def test_exports(store, tmp_path, capsys):
    with Store(store) as st:
        as_json = st.export(tmp_path / "all.json")
        as_csv = st.export(tmp_path / "all.csv", device="A")
        as_dir = st.export(tmp_path / "calibrations")
        with pytest.raises(FileExistsError):
            st.export(tmp_path / "calibrations")
        with pytest.raises(StoreError, match="is the store itself"):
            st.export(store)
        expected = {r["id"]: r for r in st.records(with_calibration=True)}
    assert (as_json["records"], as_csv["records"], as_dir["records"], as_dir["calibration_files"]) == (7, 6, 7, 6)
    doc = json.loads((tmp_path / "all.json").read_text())
    assert doc["format"] == "imucalib.store_export"
    assert {r["id"]: r["calibration"] for r in doc["records"]} == {k: r["calibration"] for k, r in expected.items()}
    with open(tmp_path / "all.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["device"] for r in rows] == ["A"] * 6
    for r in rows:
        cal = expected[int(r["id"])]["calibration"]
        if cal is None:
            assert r["status"] == "failed" and r["accelerometer.bias.x"] == ""
        else:
            assert float(r["accelerometer.bias.x"]) == cal["accelerometer"]["bias"][0]
    index = json.loads((tmp_path / "calibrations" / "index.json").read_text())["records"]
    for entry in index:
        if entry["file"] is None:
            assert expected[entry["id"]]["calibration"] is None
            continue
        cal = Calibration.load(tmp_path / "calibrations" / entry["file"])
        assert np.array_equal(cal.accelerometer.bias, expected[entry["id"]]["calibration"]["accelerometer"]["bias"])
    assert main(["store", "export", "--store", str(store), "-o", str(tmp_path / "x.json"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["records"] == 7


def test_what_is_not_a_store_is_refused(tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("hello, not a database\n" * 100)
    with pytest.raises(StoreError, match="notes.txt: not an imucalib store"):
        Store(text)
    assert text.read_text().startswith("hello")
    with pytest.raises(StoreError, match="no store there"):
        Store(tmp_path / "none.sqlite", create=False)
    assert not (tmp_path / "none.sqlite").exists()
    with pytest.raises(StoreError, match="is a directory"):
        Store(tmp_path)
    other = tmp_path / "other.db"
    with sqlite3.connect(other) as db:
        db.execute("CREATE TABLE parts (name TEXT)")
    db.close()
    with pytest.raises(StoreError, match="other.db: an SQLite file, but not an imucalib store"):
        Store(other)
    with sqlite3.connect(other) as db:  # left as it was: not switched to write-ahead logging
        assert db.execute("PRAGMA journal_mode").fetchone()[0] == "delete"
    db.close()


def test_parse_time():
    assert parse_time("2024-05-01") == ("2024-05-01", 1714521600.0)
    assert parse_time("2024-05-01T02:00+02:00") == ("2024-05-01T02:00:00+02:00", 1714521600.0)
    assert parse_time("2024-05-01T00:00:00Z")[1] == 1714521600.0
    assert parse_time("") == (None, None)
    with pytest.raises(ValueError, match="recorded_at '1 May' is not an ISO date"):
        parse_time("1 May", what="recorded_at")
