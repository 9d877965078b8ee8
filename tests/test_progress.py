"""Progress output: plain lines when piped, a tqdm bar on a terminal, nothing when disabled, never stdout."""

import io

import pytest

from imucalib.progress import Progress


class FakeClock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_piped_progress_prints_a_line_every_interval_and_a_last_line(monkeypatch):
    clock = FakeClock()
    monkeypatch.setattr("imucalib.progress.time.perf_counter", clock)
    out = io.StringIO()
    bar = Progress("montecarlo", total=10, stream=out, interval=5.0, unit="run")
    for _ in range(10):
        clock.t += 2.0          # 2 s a step: a line at 6 s (first step past 5 s), 12 s, 18 s, and the end
        bar.update()
    lines = out.getvalue().splitlines()
    assert lines[0] == "montecarlo: 3/10 runs, 6 s, about 14 s left"
    assert lines[-1] == "montecarlo: 10/10 runs, 20 s"
    assert len(lines) == 4
    assert "\r" not in out.getvalue()


def test_callback_form_sets_the_count_and_total():
    out = io.StringIO()
    bar = Progress("reading", stream=out, interval=0.0, unit="message")
    bar(5, 20)
    bar(20, 20)
    assert bar.done == 20 and bar.total == 20
    assert out.getvalue().splitlines()[-1].startswith("reading: 20/20 messages")


def test_disabled_progress_writes_nothing(capsys):
    out = io.StringIO()
    with Progress("x", total=3, enabled=False, stream=out) as bar:
        for _ in range(3):
            bar.update()
    assert out.getvalue() == ""
    assert capsys.readouterr().out == ""


def test_terminal_progress_draws_a_tqdm_bar():
    pytest.importorskip("tqdm", reason="the progress extra (tqdm) is not installed")
    out = io.StringIO()
    with Progress("files", total=4, stream=out, bar=True, unit="file") as bar:
        for _ in range(4):
            bar.update()
    text = out.getvalue()
    assert "files" in text and "4/4" in text
