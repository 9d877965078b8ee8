"""The CSV body parser: every engine gives the same arrays, chunk by chunk, in bounded memory; errors name the line."""

import tracemalloc
import warnings

import numpy as np
import pytest

from imucalib.io import ReaderError, csvparse, read
from imucalib.recording import ImucalibWarning

ENGINES = ["numpy", "python", pytest.param("pandas", marks=pytest.mark.skipif(
    not csvparse.pandas_available(), reason="pandas not installed (the pandas extra)"))]


@pytest.fixture(params=ENGINES)
def engine(request, monkeypatch):
    monkeypatch.setattr(csvparse, "ENGINE", request.param)
    monkeypatch.setattr(csvparse, "CHUNK_BYTES", 4096)  # many chunks, so that their seams are crossed
    return request.param


def _table(n=3000, seed=0):
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(n) * 0.005 + rng.uniform(0, 1e-4, n), 7)
    return t, rng.normal(0, 3, (n, 3)), rng.normal(0, 0.3, (n, 3))


def _text(t, a, g, sep=",", fmt=repr, header="t,ax,ay,az,gx,gy,gz", end="\n"):
    lines = [header] + [sep.join(fmt(float(v)) for v in (t[i], *a[i], *g[i])) for i in range(len(t))]
    return end.join(lines) + end


def _read_peak(path):
    """The recording read from ``path`` and the peak memory [bytes] traced while reading it."""
    tracemalloc.start()
    try:
        rec = read(path)
        return rec, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_engines_read_the_same_doubles(tmp_path, engine):
    t, a, g = _table()
    path = tmp_path / "d.csv"
    path.write_text(_text(t, a, g))
    rec = read(path)
    np.testing.assert_array_equal(rec.t, t)  # bit for bit: every engine rounds correctly
    np.testing.assert_array_equal(rec.acc, a)
    np.testing.assert_array_equal(rec.gyro, g)


@pytest.mark.parametrize("row", [1, 700, 2999])
def test_a_bad_cell_is_named_by_its_line_whatever_the_chunk(tmp_path, engine, row):
    t, a, g = _table()
    lines = _text(t, a, g).split("\n")
    cells = lines[row].split(",")
    cells[4] = "1.2.3"
    lines[row] = ",".join(cells)
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines))
    with pytest.raises(ReaderError, match=rf"bad.csv: line {row + 1}, gx: '1.2.3' is not a number"):
        read(path)


@pytest.mark.parametrize("fault,match", [
    (lambda ln: ln + ",7", r"line 1501: expected 7 values, found 8"),
    (lambda ln: ln.rsplit(",", 1)[0], r"line 1501: expected 7 values, found 6"),
    (lambda ln: "", r"line 1501 is empty; remove blank lines"),
    (lambda ln: "   ", r"line 1501 is empty; remove blank lines"),
    (lambda ln: ln.replace(",", ",,", 1).rsplit(",", 1)[0], r"line 1501, ax: '' is not a number"),
    (lambda ln: ln.rsplit(",", 1)[0] + ",inf", r"line 1501, gz: 'inf' is not finite"),
])
def test_row_faults_are_errors_at_their_line(tmp_path, engine, fault, match):
    t, a, g = _table()
    lines = _text(t, a, g).split("\n")
    lines[1500] = fault(lines[1500])
    path = tmp_path / "f.csv"
    path.write_text("\n".join(lines))
    with pytest.raises(ReaderError, match=match):
        read(path)


def test_quotes_comments_crlf_bom_and_trailing_blank_lines(tmp_path, engine):
    t, a, g = _table(n=800)
    lines = ['"t","ax","ay","az","gx","gy","gz"']
    for i in range(len(t)):
        cells = [repr(float(v)) for v in (t[i], *a[i], *g[i])]
        if i % 3 == 0:
            cells = [f'"{c}"' for c in cells]
        lines.append(",".join(cells))
        if i in (10, 400):
            lines.append("# the hand slipped here")
    path = tmp_path / "q.csv"
    path.write_bytes(b"\xef\xbb\xbf" + ("\r\n".join(lines) + "\r\n\r\n\n").encode())
    with pytest.warns(ImucalibWarning, match="skipped 2 comment lines"):
        rec = read(path)
    np.testing.assert_array_equal(rec.acc, a)
    np.testing.assert_array_equal(rec.t, t)


@pytest.mark.parametrize("sep", [";", "\t"])
def test_decimal_commas(tmp_path, engine, sep):
    t, a, g = _table(n=500)
    path = tmp_path / "dc.csv"
    path.write_text(_text(t, a, g, sep=sep, fmt=lambda v: f"{v:.9f}".replace(".", ","),
                          header=sep.join(["Time (s)", "ax", "ay", "az", "gx", "gy", "gz"])))
    rec = read(path)
    assert rec.metadata["separator"] == sep
    np.testing.assert_allclose(rec.acc, a, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.t, t, rtol=0, atol=1e-9)


def test_text_and_integer_columns(tmp_path, engine):
    n = 1000
    rng = np.random.default_rng(1)
    ns = 1700000000123456789 + np.arange(n, dtype=np.int64) * 1_000_000
    lines = ["timestamp_ns,ax,ay,az,gx,gy,gz,label,count"]
    for i in range(n):
        label = f"pose {i // 100}" if i != 555 else 'pose "x", moved'
        label = f'"{label.replace(chr(34), chr(34) * 2)}"' if "," in label else label
        lines.append(",".join([str(ns[i])] + [f"{v:.6f}" for v in rng.normal(size=6)] + [label, str(i)]))
    path = tmp_path / "tx.csv"
    path.write_text("\n".join(lines) + "\n")
    rec = read(path)
    assert rec.metadata["t0"] == int(ns[0])
    np.testing.assert_allclose(np.diff(rec.t), 1e-3, rtol=0, atol=1e-12)
    assert rec.extra["label"][555] == 'pose "x", moved' and rec.extra["label"][999] == "pose 9"
    np.testing.assert_array_equal(rec.extra["count"], np.arange(n))


def test_a_text_cell_in_a_sensor_column_is_an_error_not_a_text_column(tmp_path, engine):
    t, a, g = _table(n=2000)
    lines = _text(t, a, g).split("\n")
    lines[1800] = lines[1800].replace(",", ",oops", 1)
    (tmp_path / "x.csv").write_text("\n".join(lines))
    with pytest.raises(ReaderError, match=r"line 1801, ax: 'oops[-0-9.e]*' is not a number"):
        read(tmp_path / "x.csv")


def test_utf16_is_refused_in_plain_words(tmp_path):
    t, a, g = _table(n=10)
    (tmp_path / "u.csv").write_text(_text(t, a, g), encoding="utf-16")
    with pytest.raises(ReaderError, match=r"u.csv: the text is UTF-16 encoded.*save it as UTF-8"):
        read(tmp_path / "u.csv")


@pytest.mark.slow
def test_reading_streams_into_the_recording_arrays(tmp_path, monkeypatch):
    """Peak memory while reading ≈ the recording's own arrays, not copies of the table or of its text."""
    monkeypatch.setattr(csvparse, "ENGINE", "numpy")
    monkeypatch.setattr(csvparse, "CHUNK_BYTES", 1 << 20)
    t, a, g = _table(n=200_000)
    path = tmp_path / "big.csv"
    path.write_text(_text(t, a, g))
    size = path.stat().st_size
    arrays = 7 * 8 * len(t)  # t, acc, gyro in float64
    rec, peak = _read_peak(path)
    assert len(rec) == len(t)
    # the arrays, one chunk of text and what the C parser makes of it; the whole text alone is 2× the arrays
    assert size > 1.5 * arrays
    assert peak < arrays + 12 * (1 << 20), f"peak {peak / 1e6:.1f} MB for {arrays / 1e6:.1f} MB of samples"


def test_pandas_engine_is_used_only_for_large_files(tmp_path, monkeypatch):
    t, a, g = _table(n=100)
    path = tmp_path / "s.csv"
    path.write_text(_text(t, a, g))
    monkeypatch.setattr(csvparse, "ENGINE", "auto")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        layout = read(path).metadata["source_layout"]
    assert csvparse.engine_for(csvparse.Layout.from_dict(layout)) == "numpy"
    monkeypatch.setattr(csvparse, "PANDAS_MIN_BYTES", 10)
    expected = "pandas" if csvparse.pandas_available() else "numpy"
    assert csvparse.engine_for(csvparse.Layout.from_dict(layout)) == expected


@pytest.mark.parametrize("extra", ["every", "first"])
def test_whitespace_rows_with_an_extra_cell_are_errors(tmp_path, engine, extra):
    """A blank-separated table whose rows (all of a chunk, or its first) have a cell too many is refused."""
    t, a, g = _table(n=2000)
    lines = _text(t, a, g, sep=" ", header="t ax ay az gx gy gz").split("\n")
    rows = range(1, 2001) if extra == "every" else [1]
    for i in rows:
        lines[i] += " 7"
    (tmp_path / "w.txt").write_text("\n".join(lines))
    with pytest.raises(ReaderError, match=r"line 2: expected 7 values, found 8"):
        read(tmp_path / "w.txt")


# ------------------------------------------------------------------ gzip
def _gzip(path, out):
    import gzip
    import shutil

    with open(path, "rb") as f, gzip.open(out, "wb") as g:
        shutil.copyfileobj(f, g)
    return out


def test_gzip_copy_of_a_simulated_session_is_the_same_recording(tmp_path, engine):
    """A .csv.gz (and a whitespace-separated .txt.gz) of a simulated session reads to the recording its plain
    file gives: every sample bit for bit, the units, the columns; nothing of it lands on disk decompressed."""
    from imucalib.io import write_csv
    from imucalib.scenarios import session

    sim = session("handheld", rng=3, n_poses=8)
    write_csv(tmp_path / "s.csv", sim.recording)
    before = set(tmp_path.iterdir())
    for plain, packed in ((tmp_path / "s.csv", tmp_path / "s.csv.gz"), (tmp_path / "s.txt", tmp_path / "s.txt.gz")):
        if plain.suffix == ".txt":
            plain.write_text((tmp_path / "s.csv").read_text().replace(" [", "[").replace(",", " "))  # t[s] ax[…]
        _gzip(plain, packed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ImucalibWarning)
            a, b = read(plain), read(packed)
        assert len(a) == len(b) == len(sim.recording)
        np.testing.assert_array_equal(b.t, a.t)
        np.testing.assert_array_equal(b.acc, a.acc)
        np.testing.assert_array_equal(b.gyro, a.gyro)
        assert (b.acc_unit, b.gyro_unit) == (a.acc_unit, a.gyro_unit)
        for key in ("columns", "column_names", "header", "time_unit"):
            assert b.metadata.get(key) == a.metadata.get(key), key
        assert "source_layout" not in b.metadata  # apply writes a compressed source's rows from the values
    np.testing.assert_allclose(read(tmp_path / "s.csv.gz").acc, sim.recording.acc, rtol=1e-15)
    assert set(tmp_path.iterdir()) - before == {tmp_path / n for n in ("s.csv.gz", "s.txt", "s.txt.gz")}


@pytest.mark.slow
def test_gzip_streams_in_bounded_memory(tmp_path, monkeypatch):
    """A .csv.gz of 200 000 rows (26 MB of text, beyond the 1 MB head: its length and last line are found by
    decompressing it through once) peaks at the plain file's bound: the arrays and a chunk, never the text."""
    monkeypatch.setattr(csvparse, "ENGINE", "numpy")
    monkeypatch.setattr(csvparse, "CHUNK_BYTES", 1 << 20)
    t, a, g = _table(n=200_000)
    path = tmp_path / "big.csv"
    path.write_text(_text(t, a, g))
    packed = _gzip(path, tmp_path / "big.csv.gz")
    size = path.stat().st_size
    path.unlink()
    arrays = 7 * 8 * len(t)
    rec, peak = _read_peak(packed)
    np.testing.assert_array_equal(rec.t, t)
    np.testing.assert_array_equal(rec.gyro, g)
    assert size > 1.5 * arrays and packed.stat().st_size < size
    assert peak < arrays + 12 * (1 << 20), f"peak {peak / 1e6:.1f} MB for {arrays / 1e6:.1f} MB of samples"
