"""``apply`` while its input changes: the output holds exactly the rows read and calibrated, or nothing changes.

The input is written with six decimals, so that its own text (copied) and the
shortest text of the values read (written from the values) differ: each test
tells which of the two ``apply`` wrote. The input is changed at a chosen point,
deterministically: between the read and the copy, or once the copy has taken
its first block of rows; appended to, rewritten in place (its size and
modification time put back), cut short. A file that grew is copied up to the
end it had when read; one whose bytes are no longer those parsed is written
from the values read.
"""

from __future__ import annotations

import hashlib
import os
import warnings

import pytest

from imucalib.calibration import Calibration
from imucalib.cli import main
from imucalib.io import read, write_csv, writers
from synth import linear_truth, tedaldi_session

OLD = 1_000_000_000 * 10**9  # 2001: the input's modification time [ns]


@pytest.fixture
def files(tmp_path):
    """The input (own text), the calibration, and the two outputs ``apply`` may write: copied, from the values."""
    rec, truth, _ = tedaldi_session(linear_truth(), seed=3, poses=6, noise_acc=0.01, noise_gyro=0.001)
    data, cal = tmp_path / "in.csv", tmp_path / "c.json"
    rows = [f"{t:.6f},{a[0]:.6f},{a[1]:.6f},{a[2]:.6f},{g[0]:.6f},{g[1]:.6f},{g[2]:.6f}"
            for t, a, g in zip(rec.t, rec.acc, rec.gyro, strict=True)]
    data.write_text("t [s],ax,ay,az,gx,gy,gz\n"
                    + "\n".join(rows) + "\n")
    os.utime(data, ns=(OLD, OLD))
    truth.save(cal)
    reference = tmp_path / "reference.csv"
    assert main(["apply", str(cal), str(data), "-o", str(reference)]) == 0  # the input left alone
    read_rec = read(data)
    calibrated = Calibration.load(cal).apply(read_rec)
    read_rec.metadata.pop("source_layout")
    values = tmp_path / "values.csv"
    write_csv(values, read_rec, calibrated_acc=calibrated.acc, calibrated_gyro=calibrated.gyro)
    assert values.read_bytes() != reference.read_bytes()  # the tests can tell a copy from a write of the values
    assert reference.read_bytes().startswith(data.read_bytes().split(b"\n")[0])
    assert data.read_bytes().split(b"\n")[5] in reference.read_bytes()  # the input's own text, copied
    return data, cal, reference, values


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


def _before_the_copy(monkeypatch, change):
    """Run ``change()`` after the read and the calibration, just before the copy opens the input."""
    original = writers._copy_source
    calls = []

    def copy(*args, **kw):
        calls.append(1)
        change()
        return original(*args, **kw)

    monkeypatch.setattr(writers, "_copy_source", copy)
    return calls


def _append(data):
    with data.open("ab") as fh:
        fh.write(b"99.0,1,2,3,4,5,6\n" * 500)


def _rewrite_in_place(data):
    """Other digits in the middle of the rows, same size, the modification time put back (``touch -r``)."""
    st = data.stat()
    with data.open("r+b") as fh:
        fh.seek(st.st_size // 2)
        chunk = fh.read(4096)
        fh.seek(st.st_size // 2)
        fh.write(bytes(b if not 48 <= b <= 57 else 48 + (b - 47) % 10 for b in chunk))
    os.utime(data, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert (data.stat().st_size, data.stat().st_mtime_ns) == (st.st_size, st.st_mtime_ns)


def _cut_short(data):
    os.truncate(data, data.stat().st_size // 2)


@pytest.mark.parametrize("when", [_before_the_copy, _during_the_copy])
@pytest.mark.parametrize(("change", "written"), [(_append, "reference"), (_rewrite_in_place, "values"),
                                                 (_cut_short, "values")])
def test_apply_writes_the_rows_it_read_whatever_happens_to_the_input(monkeypatch, capsys, files, when, change,
                                                                     written):
    """Grown: the bytes read, copied up to the end as read. Rewritten or cut short: the values read."""
    data, cal, reference, values = files
    out = data.parent / "out.csv"
    out.write_text("previous\n")
    calls = when(monkeypatch, lambda: change(data))
    assert data.stat().st_size > 3 * 4096  # several blocks: the change lands in the middle of the copy
    assert main(["apply", str(cal), str(data), "-o", str(out)]) == 0, capsys.readouterr().err
    assert calls == [1]
    assert out.read_bytes() == {"reference": reference, "values": values}[written].read_bytes()
    assert not [p for p in data.parent.iterdir() if p.name.startswith(".")]


def test_a_file_replaced_by_another_is_copied_from_the_one_read(monkeypatch, capsys, files):
    """Renamed over while open: the open file is the one read, unchanged; its bytes are what is copied."""
    data, cal, reference, _ = files
    other = data.parent / "other.csv"
    other.write_bytes(data.read_bytes().replace(b"1", b"2"))
    out = data.parent / "out.csv"
    _during_the_copy(monkeypatch, lambda: os.replace(other, data))
    assert main(["apply", str(cal), str(data), "-o", str(out)]) == 0, capsys.readouterr().err
    assert out.read_bytes() == reference.read_bytes()


def test_a_failed_copy_leaves_the_existing_output_as_it_was(monkeypatch, capsys, files):
    data, cal, _, _ = files
    out = data.parent / "out.csv"
    out.write_text("previous\n")

    def fail():
        raise OSError(5, "Input/output error")

    _during_the_copy(monkeypatch, fail)
    assert main(["apply", str(cal), str(data), "-o", str(out)]) == 2
    assert "Input/output error" in capsys.readouterr().err
    assert out.read_text() == "previous\n"
    assert not [p for p in data.parent.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("tail", [b"\n\n", b"99.0,1,2,3,4,5,6\n" * 3, b"# a comment\n"])
def test_the_copy_never_reads_past_the_end_as_read(files, tail):
    """Bytes appended after the read are never taken, even by the trailing copy after the last row."""
    data, cal, reference, _ = files
    rec = read(data)
    calibrated = Calibration.load(cal).apply(rec)
    with data.open("ab") as fh:
        fh.write(tail)
    os.utime(data, ns=(OLD, OLD))
    assert writers._source_layout(rec) is not None  # grown: still copied, up to the end as read
    out = data.parent / "o.csv"
    write_csv(out, rec, calibrated_acc=calibrated.acc, calibrated_gyro=calibrated.gyro)
    assert out.read_bytes() == reference.read_bytes()


@pytest.mark.parametrize("text", [
    b"t,ax,ay,az,gx,gy,gz\n0,1,2,3,4,5,6\n0.01,1,2,3,4,5,6",                       # no final line end
    b"# logger v1\nrate: 100 Hz\nt,ax,ay,az,gx,gy,gz\r\n0,1,2,3,4,5,6\r\n0.01,1,2,3,4,5,6\r\n\r\n\n",
    b"\xef\xbb\xbft;ax;ay;az;gx;gy;gz\n0;1,5;2;3;4;5;6\n# pause\n0,01;1,5;2;3;4;5;6\n  \n",
])
def test_the_checksum_is_of_every_byte_up_to_the_size_read(tmp_path, text):
    """Computed apart: BLAKE2b of the whole file, whatever precedes, follows or interrupts the rows."""
    data = tmp_path / "in.csv"
    data.write_bytes(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the preamble and comment lines skipped
        rec = read(data)
    info = rec.metadata["source_layout"]
    assert info["size"] == len(text)
    assert info["digest"] == hashlib.blake2b(text, digest_size=16).hexdigest()

