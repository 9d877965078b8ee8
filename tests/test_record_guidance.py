"""Guided recording: what a person holding the sensor is told.

The rest starts again when the sensor moves; poses are named from a sphere
fit once there are four (not from raw counts with large offsets); a pose is
said while held and once done, with how far the suggested one is and
whether it was held already; the checklist fills as poses come; a silent
stream is said; the last word is the calibration's verdict.
"""

import io
import json
import os
import signal
import threading
import time

import numpy as np
import pytest

from imucalib.cli.record import PlainView, verdict_line
from imucalib.io import read, write_csv
from imucalib.methods import calibrate
from imucalib.record import Recorder, Source, record
from imucalib.record.guidance import FACES, angle_deg, held_before
from imucalib.scenarios.handheld import generate


def _csv(tmp_path, session, name="in.csv"):
    path = tmp_path / name
    write_csv(path, session["recording"])
    return path


def _record(data: bytes, out, **kw):
    events = []
    result = record(io.BytesIO(data), out, Recorder(events.append, **kw))
    return events, result


def _with_time(rows: list[bytes], t0: float, dt: float) -> list[bytes]:
    """Rows with their stamps replaced by ``t0, t0 + dt, …`` (the rest of each row unchanged)."""
    return [f"{t0 + k * dt:.6f}".encode() + r[r.index(b","):] for k, r in enumerate(rows)]


def test_the_initial_rest_starts_again_when_the_sensor_moves(tmp_path):
    s = generate(np.random.default_rng(7), n_poses=14, rest=8.0)
    data = _csv(tmp_path, s).read_bytes().splitlines(keepends=True)
    header, rows = data[0], data[1:]
    events, _ = _record(b"".join([header, *rows]), tmp_path / "plain.csv")
    first = [e for e in events if e["event"] == "pose"][0]
    turn = rows[first["stop"] + 20:first["stop"] + 170]  # 1.5 s of the turn after pose 1
    # 2 s still, then 1.5 s of turning, then the session as recorded (its 8 s rest, its poses)
    moved = [*rows[:200], *turn, *rows]
    sent = [header, *_with_time(moved, 0.0, 0.01)]
    events, result = _record(b"".join(sent), tmp_path / "s.csv")
    rests = [e for e in events if e["event"] == "rest"]
    done = [k for k, e in enumerate(rests) if e.get("remaining_s") == 0]
    restarts = [k for k, e in enumerate(rests) if e.get("restart")]
    assert len(done) == 1 and restarts and max(restarts) < done[0]
    assert all("starts again" in rests[k]["message"] for k in restarts)
    # the session begins after the movement: no turn in its rest, and calibrate takes it
    kept = (tmp_path / "s.csv").read_bytes().splitlines(keepends=True)
    assert kept[0] == header and kept[1:] == sent[len(sent) - (len(kept) - 1):]  # the stream's last rows
    assert len(rows) - 300 < len(kept) - 1 <= len(rows)  # none of the turn, most of the session's own rest
    assert abs(result.poses - 14) <= 1
    verdict = calibrate(read(tmp_path / "s.csv")).fit["verdict"]
    assert verdict in ("accepted", "suspect") and verdict == events[-1]["verdict"]


def test_poses_are_named_from_a_sphere_fit_not_from_offset_counts(tmp_path):
    s = generate(np.random.default_rng(5), n_poses=12, rest=8.0)
    rec, truth = s["recording"], s["truth"]
    one_g = float(np.median(np.linalg.norm(rec.acc[:400], axis=1)))
    offset = np.array([0.45, -0.4, 0.3]) * one_g  # raw offsets of 0.4–0.5 g
    shifted = rec.acc + np.round(offset)
    lines = ["t,ax,ay,az,gx,gy,gz"] + [",".join(f"{v:.9g}" for v in (t, *a, *g))
                                        for t, a, g in zip(rec.t, shifted, rec.gyro, strict=True)]
    events, _ = _record(("\n".join(lines) + "\n").encode(), tmp_path / "s.csv")
    poses = [e for e in events if e["event"] == "pose"]
    raw_err, fit_err = [], []
    for p in poses:
        true_up = truth.accelerometer_si(rec.acc[p["start"]:p["stop"]].mean(axis=0)[None, :])[0]
        raw = shifted[p["start"]:p["stop"]].mean(axis=0)
        raw_err.append(angle_deg(raw, true_up))
        if p["directions_from"] != "raw":
            fit_err.append(angle_deg(p["up"], true_up))
    assert [p["directions_from"] for p in poses[:2]] == ["raw", "raw"]
    assert poses[2]["directions_from"] != "raw"  # the rest and three poses: four for the sphere
    assert max(raw_err) > 25  # what raw counts would have said
    assert max(fit_err) < 8 and len(fit_err) == len(poses) - 2


def test_holding_done_next_already_held_and_the_checklist(tmp_path):
    s = generate(np.random.default_rng(3), n_poses=12, rest=8.0)
    data = _csv(tmp_path, s).read_bytes().splitlines(keepends=True)
    header, rows = data[0], data[1:]
    events, _ = _record(b"".join(data), tmp_path / "a.csv")
    poses = [e for e in events if e["event"] == "pose"]
    # the session again with pose 3 held once more at the end (its rows, then a second of stillness after)
    p3 = poses[2]
    again = rows[p3["start"]:p3["stop"]] + rows[p3["stop"] - 100:p3["stop"]]
    t_end = float(rows[-1].split(b",")[0])
    sent = [header, *rows, *_with_time(again, t_end + 0.01, 0.01)]
    events, _ = _record(b"".join(sent), tmp_path / "s.csv")
    poses = [e for e in events if e["event"] == "pose"]
    assert poses[-1]["already_held"] == 3
    # already_held says the first earlier direction within 15° (the initial rest is 0)
    ups = [None] + [p["up"] for p in poses]
    for k, p in enumerate(poses, start=1):
        earlier = [angle_deg(p["up"], u) for u in ups[1:k]]
        assert (p["already_held"] is not None and p["already_held"] > 0) == any(a <= 15 for a in earlier) \
            or p["already_held"] == 0
    # while a pose is held: said at half a second (keep still) and once held long enough
    kinds = [e["event"] for e in events]
    holds = [e for e in events if e["event"] == "holding"]
    assert holds and all(e["seconds"] >= 0.5 for e in holds)
    first_pose = kinds.index("pose")
    before = [e for e in events[:first_pose] if e["event"] == "holding"]
    assert [e["enough"] for e in before] == [False, True]
    # the angle to the suggestion is the angle between the held direction and the last suggested one
    last_next = None
    for e in events:
        if e["event"] == "next_pose":
            last_next = e
            assert e["turn_deg"] == pytest.approx(angle_deg(poses[e["after_pose"] - 1]["up"], e["up"]))
        if e["event"] == "holding" and last_next is not None:
            assert e["to_suggestion_deg"] == pytest.approx(angle_deg(e["up"], last_next["up"]))
    # the checklist: each face as the directions of the rest and the poses say (re-estimated with each model)
    for p in poses:
        cl = p["checklist"]
        for name, f in FACES:  # the rest and the poses, in the directions the recorder has now
            assert cl["faces"][name] == any(angle_deg(u, f) <= 20 for u in p["directions"])
        assert set(cl["missing"]) >= {name for name, ok in cl["faces"].items() if not ok}
    assert len(poses[-1]["checklist"]["missing"]) < len(poses[0]["checklist"]["missing"])
    assert held_before(poses[-1]["up"], np.array([poses[2]["up"]])) == 0


def test_a_silent_stream_is_said_and_ctrl_c_ends_it(tmp_path):
    s = generate(np.random.default_rng(7), n_poses=4, rest=8.0)
    data = _csv(tmp_path, s).read_bytes()

    class Silent(Source):
        def __init__(self):
            self.sent = False

        def read(self, timeout):
            if not self.sent:
                self.sent = True
                return data
            time.sleep(timeout)
            return None

    events = []
    timer = threading.Timer(1.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    start = time.monotonic()
    result = record(Silent(), tmp_path / "s.csv", Recorder(events.append), silence=0.4)
    timer.join()
    assert result.interrupted and time.monotonic() - start < 10
    silences = [e for e in events if e["event"] == "silence"]
    assert silences and silences[0]["seconds"] == 0.4 and "no data for 0.4 s" in silences[0]["message"]
    assert (tmp_path / "s.csv").read_bytes() == data


def test_the_last_word_is_the_verdict_and_what_to_redo(tmp_path):
    s = generate(np.random.default_rng(9), n_poses=6, rest=8.0)
    path = _csv(tmp_path, s)
    events, _ = _record(path.read_bytes(), tmp_path / "s.csv")
    end = events[-1]
    assert end["event"] == "end" and end["verdict"] != "accepted"
    try:
        offline = calibrate(read(tmp_path / "s.csv")).fit["verdict"]
    except ValueError:
        offline = None
    assert end["verdict"] == offline
    assert end["redo"] and any("add poses" in r for r in end["redo"])
    line = verdict_line(end)
    assert line.startswith(f"verdict: {end['verdict'] or 'none'}") and "redo:" in line


def test_the_bell_rings_at_each_pose_unless_switched_off():
    pose = {"event": "pose", "pose": 1, "seconds": 2.0, "t_start": 10.0, "words": "z down", "already_held": None,
            "directions_from": "sphere fit", "checklist": {"faces": {"z down": True}, "corners": 0,
                                                           "turned": {"x": False}, "missing": ["x up"]}}
    for bell in (True, False):
        out = io.StringIO()
        view = PlainView(out, bell=bell)
        view(pose)
        view({"event": "rest", "remaining_s": 3})
        assert out.getvalue().count("\a") == (1 if bell else 0)
        assert "pose 1 done" in out.getvalue() and "still missing: x up" in out.getvalue()
    assert json.loads(json.dumps(pose)) == pose
