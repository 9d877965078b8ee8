"""The fixed-layout fast path of the text parser gives the numbers of a correctly rounding parser, bit for bit."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from imucalib.io import read
from imucalib.io.fixedcells import fixed_chunk as _fixed_chunk

XSENS = Path(__file__).resolve().parents[2] / "shared" / "data" / "xsens_imu_tk"

FORMATS = [" %15.7e", " %14.6E", " %22.14e", " %+.5e", " %8.1e", " %12.4f", " %9.3f", " %.0f", " %10d", " %18.10f"]


def _table(rng: np.random.Generator, fmt: str, rows: int, end: str) -> bytes:
    exponent = int(rng.integers(-25, 25)) if "e" in fmt.lower() else int(rng.integers(-3, 4))
    values = rng.normal(size=(rows, 3)) * 10.0**exponent
    if "d" in fmt or fmt == " %.0f":
        values = np.round(values)
    return end.join("".join(fmt % v for v in row) for row in values).encode() + end.encode()


def test_same_bits_as_loadtxt_wherever_it_accepts() -> None:
    rng = np.random.default_rng(7)
    accepted = 0
    for trial in range(600):
        fmt = FORMATS[trial % len(FORMATS)]
        data = _table(rng, fmt, int(rng.integers(1, 60)), "\r\n" if trial % 5 == 0 else "\n")
        if trial % 2:
            data = data.rstrip()  # the body ends at its last non-blank character
        got = _fixed_chunk(data, 3)
        if got is None:
            continue
        accepted += 1
        ref = np.loadtxt(io.BytesIO(data), ndmin=2)
        assert got.shape == ref.shape
        assert np.array_equal(got.view(np.int64), ref.view(np.int64)), data[:200]
    assert accepted > 100  # the generated layouts are mostly fixed: the fast path must take them


@pytest.mark.parametrize("data", [
    b"1 2 3\n4 5 x\n",            # not a number
    b"1.5 2 3\n1.5 2 3 \n",       # lines of different lengths
    b"nan 1 2\nnan 1 2\n",        # not finite: the general parser names it
    b"1 2 3\n1 2\t3\n",           # another blank in one line
    b"1-2 3 4\n1+2 3 4\n",        # a sign inside a number
    b"12345678901234567 1 2\n",   # more digits than float64 holds exactly
    b"1e-30 1 2\n",               # beyond the exact powers of ten
    b"1 2 3\n\n4 5 6\n",          # a blank line
    b" 12.5 1 2\n112.5 1 2\n",    # a number's width varies
])
def test_other_layouts_go_to_the_general_parser(data: bytes) -> None:
    assert _fixed_chunk(data, 3) is None


def test_signs_zero_and_bare_points() -> None:
    got = _fixed_chunk(b"-0.0 1.e5 .5\n 0.0 2.e5 .6\n", 3)
    ref = np.loadtxt(io.BytesIO(b"-0.0 1.e5 .5\n 0.0 2.e5 .6\n"), ndmin=2)
    assert np.array_equal(got.view(np.int64), ref.view(np.int64))
    assert np.signbit(got[0, 0]) and not np.signbit(got[1, 0])


@pytest.mark.skipif(not XSENS.is_dir(), reason=f"{XSENS} not present (needs ../shared/data)")
def test_imutk_files_read_as_loadtxt_reads_them() -> None:
    files = [XSENS / "xsens_acc.mat", XSENS / "xsens_gyro.mat"]
    for path in files:
        assert _fixed_chunk(path.read_bytes().rstrip(), 4) is not None  # the fast path takes these files
    rec = read([str(f) for f in files], reader="imutk")
    acc, gyro = (np.loadtxt(f) for f in files)  # same times in both files: no resampling
    assert np.array_equal(rec.t, acc[:, 0])
    assert np.array_equal(rec.acc, acc[:, 1:])
    assert np.array_equal(rec.gyro, gyro[:, 1:])
