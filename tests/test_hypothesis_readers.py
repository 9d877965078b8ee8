"""Property tests of the readers: any mutation of a valid file is read correctly or refused in plain words.

Mutations of a valid CSV (and of an imu_tk pair): truncations, flipped bytes,
swapped and dropped lines, NaN/inf/empty/text cells, odd delimiters, a BOM,
CRLF line ends, UTF-16, extra cells. The property: ``read`` returns a
recording whose readings are finite and whose time increases strictly, or
raises a ValueError subclass whose message names the file and holds no
numpy text. RuntimeWarnings are errors in this suite (pyproject), so none
may escape either.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is not installed")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from imucalib.io import read  # noqa: E402
from imucalib.recording import ImucalibWarning, Recording  # noqa: E402

SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _valid_rows(n: int = 40) -> list[list[str]]:
    rng = np.random.default_rng(0)
    t = np.arange(n) * 0.01
    acc = rng.normal([0.1, -0.2, 9.8], 0.05, (n, 3))
    gyro = rng.normal(0, 0.01, (n, 3))
    return [[f"{v:.6g}" for v in (t[k], *acc[k], *gyro[k])] for k in range(n)]


HEADER = ["t [s]", "ax [m/s^2]", "ay [m/s^2]", "az [m/s^2]", "gx [rad/s]", "gy [rad/s]", "gz [rad/s]"]
CELLS = st.sampled_from(["nan", "NaN", "inf", "-inf", "", "abc", "1e400", "0x10", "1,5", "--1", " ", "1e15",
                         "9e15", "1.0.0", "+", "\"1\"", "1;2"])


@st.composite
def mutated_csv(draw) -> tuple[bytes, str]:
    rows = [list(r) for r in _valid_rows()]
    sep = draw(st.sampled_from([",", ";", "\t", " "]))
    lines = [HEADER if sep != " " else [h.split()[0] for h in HEADER], *rows]
    for _ in range(draw(st.integers(0, 3))):
        kind = draw(st.sampled_from(["cell", "swap", "drop", "extra", "short", "dup", "delim"]))
        i = draw(st.integers(1, len(lines) - 1))
        j = draw(st.integers(0, 6))
        if kind == "cell" and j < len(lines[i]):
            lines[i][j] = draw(CELLS)
        elif kind == "swap":
            k = draw(st.integers(1, len(lines) - 1))
            lines[i], lines[k] = lines[k], lines[i]
        elif kind == "drop" and len(lines) > 3:
            del lines[i]
        elif kind == "extra":
            lines[i] = [*lines[i], draw(CELLS)]
        elif kind == "short":
            lines[i] = lines[i][:j]
        elif kind == "dup":
            lines.insert(i, list(lines[i]))
        elif kind == "delim":
            lines[i] = [draw(st.sampled_from([",", ";", "|", "\t", "  "])).join(lines[i])]
    eol = draw(st.sampled_from(["\n", "\r\n"]))
    text = eol.join(sep.join(c for c in line) for line in lines) + eol
    encoding = draw(st.sampled_from(["utf-8", "utf-8", "utf-8", "utf-8-sig", "utf-16"]))
    data = bytearray(text.encode(encoding))
    for _ in range(draw(st.integers(0, 2))):
        if not data:
            break
        if draw(st.booleans()):
            pos = draw(st.integers(0, len(data) - 1))
            data[pos] = draw(st.integers(0, 255))
        else:
            data = data[:draw(st.integers(0, len(data)))]
    return bytes(data), f"sep={sep!r} eol={eol!r} {encoding}"


def _check(result_or_error, path) -> None:
    if isinstance(result_or_error, Recording):
        rec = result_or_error
        assert np.all(np.isfinite(rec.acc)) and np.all(np.isfinite(rec.gyro))
        assert np.all(np.diff(rec.t) > 0)
        return
    exc = result_or_error
    assert isinstance(exc, ValueError), repr(exc)
    text = str(exc)
    assert str(path) in text or path.name in text or text.startswith("--columns"), text
    for word in ("np.", "numpy", "dtype", "Traceback", "could not convert", "unmatched data"):
        assert word not in text, text


def _read(paths, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        try:
            return read(paths, **options)
        except ValueError as exc:
            return exc


@SETTINGS
@given(mutated_csv())
def test_a_mutated_csv_is_read_or_refused_in_plain_words(tmp_path, case):
    data, _ = case
    path = tmp_path / "m.csv"
    path.write_bytes(data)
    _check(_read(path), path)


@SETTINGS
@given(mutated_csv(), st.sampled_from([None, "-,1,2,3,4,5,6", "0,1,2,3,4,5,6", "0,1,1,3,4,5,6"]))
def test_a_mutated_csv_with_columns_and_units_is_read_or_refused(tmp_path, case, columns):
    data, _ = case
    path = tmp_path / "c.csv"
    path.write_bytes(data)
    options = {"columns": columns.split(",") if columns else None, "acc_unit": "m/s^2", "gyro_unit": "rad/s"}
    if columns and columns.startswith("-"):
        options["rate"] = 100.0
    _check(_read(path, **options), path)


@SETTINGS
@given(st.data())
def test_a_mutated_imutk_pair_is_read_or_refused(tmp_path, data):
    rows = _valid_rows()
    acc = "\n".join(" ".join([r[0], *r[1:4]]) for r in rows) + "\n"
    (tmp_path / "acc.txt").write_text(acc)
    raw, _ = data.draw(mutated_csv())
    gyro = tmp_path / "gyro.txt"  # a mutated table, its first four columns as imu_tk writes them
    text = raw.decode("utf-8", errors="replace").replace(",", " ")
    gyro.write_bytes(raw if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else text.encode("utf-8"))
    result = _read([tmp_path / "acc.txt", gyro], reader="imutk")
    if isinstance(result, ValueError):
        assert "gyro.txt" in str(result) or "acc.txt" in str(result), str(result)
    _check(result, gyro if not isinstance(result, ValueError) or "gyro.txt" in str(result)
           else tmp_path / "acc.txt")
