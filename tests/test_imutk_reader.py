"""imu_tk's text files read a few megabytes at a time: the same numbers as the whole text, the same errors."""

import warnings

import numpy as np
import pytest

from imucalib.io import csvparse, imutk, read
from imucalib.io.errors import ReaderError


def _write(path, rows, *, bom=False, tail="\n"):
    text = "".join(f"  {r[0]:15.7e}{r[1]:15.7e}{r[2]:15.7e}{r[3]:15.7e}\n" for r in rows).rstrip("\n") + tail
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())


def _pair(tmp_path, n=3000, **kw):
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.009, 0.011, n))
    acc = np.column_stack([t, rng.normal(32768, 300, (n, 3))])
    gyro = np.column_stack([t, rng.normal(32768, 30, (n, 3))])
    _write(tmp_path / "acc.mat", acc, **kw)
    _write(tmp_path / "gyro.mat", gyro)
    return [tmp_path / "acc.mat", tmp_path / "gyro.mat"]


@pytest.mark.parametrize("kw", [{}, {"bom": True}, {"tail": "\n\n  \n"}, {"tail": ""}])
def test_chunks_give_the_whole_texts_numbers(tmp_path, monkeypatch, kw):
    paths = _pair(tmp_path, **kw)
    whole = [imutk.numeric_table(p, p.read_bytes().decode("utf-8-sig"), 4, ("time", "x", "y", "z"))
             for p in paths]
    monkeypatch.setattr(csvparse, "CHUNK_BYTES", 4096)  # many chunks
    for p, w in zip(paths, whole, strict=True):
        t, xyz = imutk.imutk_table(p)
        assert xyz.shape == (3000, 3) and xyz.flags.c_contiguous
        assert np.array_equal(t, w[:, 0]) and np.array_equal(xyz, w[:, 1:])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = read([str(p) for p in paths], reader="imutk")
    assert np.array_equal(rec.acc, whole[0][:, 1:]) and np.array_equal(rec.gyro, whole[1][:, 1:])


@pytest.mark.parametrize(("damage", "message"), [
    (lambda lines: lines[:5] + [""] + lines[5:], "line 6 is empty"),
    (lambda lines: lines[:7] + ["  1.0  2.0  x  4.0"] + lines[8:], "line 8"),
    (lambda lines: lines[:9] + ["  1.0  2.0  3.0"] + lines[10:], "line 10"),
])
def test_a_bad_line_is_named_as_before(tmp_path, monkeypatch, damage, message):
    paths = _pair(tmp_path, n=50)
    lines = paths[0].read_text().splitlines()
    paths[0].write_text("\n".join(damage(lines)) + "\n")
    monkeypatch.setattr(csvparse, "CHUNK_BYTES", 256)
    with pytest.raises(ReaderError, match=message):
        imutk.imutk_table(paths[0])
