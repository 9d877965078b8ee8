"""``apply`` while its input changes: the output holds exactly the rows read and calibrated, or nothing changes.

The input is changed at a chosen point of the copy (after its first block of
rows), deterministically: appended to, rewritten in place, cut short. Its
modification time is set far in the past first, so that any write is seen
whatever the file system's timestamp resolution.
"""

from __future__ import annotations

import os

import pytest

from imucalib.cli import main
from imucalib.io import write_csv, writers
from synth import linear_truth, tedaldi_session

OLD = 1_000_000_000 * 10**9  # 2001: the input's modification time [ns]


@pytest.fixture
def files(tmp_path):
    rec, truth, _ = tedaldi_session(linear_truth(), seed=3, poses=6, noise_acc=0.01, noise_gyro=0.001)
    data, cal = tmp_path / "in.csv", tmp_path / "c.json"
    write_csv(data, rec)
    os.utime(data, ns=(OLD, OLD))
    truth.save(cal)
    reference = tmp_path / "reference.csv"
    assert main(["apply", str(cal), str(data), "-o", str(reference)]) == 0  # the input left alone
    return data, cal, reference


def _during_the_copy(monkeypatch, change):
    """Run ``change()`` once the copy has taken its first block of rows (blocks of 4 kB)."""
    monkeypatch.setattr(writers, "_COPY_BYTES", 4096)
    original = writers._body_chunks
    calls = []

    def chunks(*args, **kw):
        for k, data in enumerate(original(*args, **kw)):
            yield data
            if k == 0:
                calls.append(1)
                change()

    monkeypatch.setattr(writers, "_body_chunks", chunks)
    return calls


def _append(data):
    with data.open("ab") as fh:
        fh.write(b"99.0,1,2,3,4,5,6\n" * 500)


def _rewrite_in_place(data):
    size = data.stat().st_size
    with data.open("r+b") as fh:  # same size, other digits, in the middle of the rows
        fh.seek(size // 2)
        chunk = fh.read(4096)
        fh.seek(size // 2)
        fh.write(bytes(b if not 48 <= b <= 57 else 48 + (b - 47) % 10 for b in chunk))
    assert data.stat().st_size == size


def _cut_short(data):
    os.truncate(data, data.stat().st_size // 2)


@pytest.mark.parametrize("change", [_append, _rewrite_in_place, _cut_short])
def test_apply_writes_the_rows_it_read_whatever_happens_to_the_input(monkeypatch, capsys, files, change):
    data, cal, reference = files
    out = data.parent / "out.csv"
    out.write_text("previous\n")
    calls = _during_the_copy(monkeypatch, lambda: change(data))
    assert data.stat().st_size > 3 * 4096  # several blocks: the change lands in the middle of the copy
    assert main(["apply", str(cal), str(data), "-o", str(out)]) == 0, capsys.readouterr().err
    assert calls == [1]
    # the samples read, calibrated: the same bytes as the run on the untouched input (the values written
    # back with the shortest exact text are the text the input was written with)
    assert out.read_bytes() == reference.read_bytes()
    assert not [p for p in data.parent.iterdir() if p.name.startswith(".")]


def test_a_file_replaced_by_another_is_copied_from_the_one_read(monkeypatch, capsys, files):
    """Renamed over while open: the open file is the one read, unchanged; its bytes are what is copied."""
    data, cal, reference = files
    other = data.parent / "other.csv"
    other.write_bytes(data.read_bytes().replace(b"1", b"2"))
    out = data.parent / "out.csv"
    _during_the_copy(monkeypatch, lambda: os.replace(other, data))
    assert main(["apply", str(cal), str(data), "-o", str(out)]) == 0, capsys.readouterr().err
    assert out.read_bytes() == reference.read_bytes()


def test_a_failed_copy_leaves_the_existing_output_as_it_was(monkeypatch, capsys, files):
    data, cal, _ = files
    out = data.parent / "out.csv"
    out.write_text("previous\n")

    def fail():
        raise OSError(5, "Input/output error")

    _during_the_copy(monkeypatch, fail)
    assert main(["apply", str(cal), str(data), "-o", str(out)]) == 2
    assert "Input/output error" in capsys.readouterr().err
    assert out.read_text() == "previous\n"
    assert not [p for p in data.parent.iterdir() if p.name.startswith(".")]


def test_the_copy_never_reads_past_the_end_as_read(files):
    """Appended rows are never taken, even by the trailing copy after the last row."""
    data, cal, reference = files
    from imucalib.calibration import Calibration
    from imucalib.io import read

    rec = read(data)
    calibrated = Calibration.load(cal).apply(rec)
    with data.open("ab") as fh:
        fh.write(b"\n\n")  # blank lines: the same rows, another size
    os.utime(data, ns=(OLD, OLD))
    layout = writers._source_layout(rec)
    assert layout is None  # the size differs from the read's: not copied
    out = data.parent / "o.csv"
    write_csv(out, rec, calibrated_acc=calibrated.acc, calibrated_gyro=calibrated.gyro)
    assert out.read_bytes() == reference.read_bytes()
