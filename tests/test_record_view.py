"""Guided recording in the browser: the live page, drawn by a real headless Chromium.

A session is followed by :class:`imucalib.record.view.LiveView`; the page is
loaded mid-session and at the end with ``chromium --headless --dump-dom``:
its sphere holds a dot for the rest and every pose held (as the events say),
the suggested pose and the current orientation; its checklist is the last
pose's; it asks for the state at least twice a second.
"""

import io
import shutil
import subprocess

import numpy as np
import pytest

from imucalib.io import write_csv
from imucalib.record import Recorder, record
from imucalib.record.view import LiveView
from imucalib.scenarios.handheld import generate

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _dom(url: str, profile, budget_ms: int = 2000) -> str:
    run = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                          "--no-first-run", f"--user-data-dir={profile}", f"--virtual-time-budget={budget_ms}",
                          "--dump-dom", url], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed")
def test_the_live_page_in_headless_chromium(tmp_path):
    s = generate(np.random.default_rng(7), n_poses=8, rest=8.0)
    write_csv(tmp_path / "in.csv", s["recording"])
    lines = (tmp_path / "in.csv").read_bytes().splitlines(keepends=True)
    view = LiveView()
    events = []

    def on_event(event):
        events.append(event)
        view(event)

    recorder = Recorder(on_event)
    view.recorder = recorder
    try:
        half = len(lines) // 2
        recorder.feed(lines[:half])  # mid-session: the page as it stands
        mid = _dom(view.url, tmp_path / "p1")
        poses_mid = [e for e in events if e["event"] == "pose"]
        before = view._state["updates"]
        rest = b"".join(lines[half:])
        recorder.sink = None
        record(io.BytesIO(rest), tmp_path / "s.csv", recorder)
        end = _dom(view.url, tmp_path / "p2", budget_ms=2000)
        served = view._state["updates"] - before
    finally:
        view.close()
    poses = [e for e in events if e["event"] == "pose"]
    assert 0 < len(poses_mid) < len(poses)
    assert mid.count('class="pose"') == len(poses_mid) + 1  # the rest and each pose held
    assert end.count('class="pose"') == len(poses) + 1
    assert end.count('class="current"') == 1 and end.count('class="suggestion"') == 1
    last = poses[-1]["checklist"]
    for item in last["missing"]:
        assert f'<li class="no">{item}</li>' in end
    for face, ok in last["faces"].items():
        assert f'<li class="{"ok" if ok else "no"}">{face}</li>' in end
    assert f"verdict: {events[-1]['verdict']}" in end
    assert served >= 4  # two seconds of the page: at least two requests a second
