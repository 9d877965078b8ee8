"""Hostile and careless inputs: no traceback, no hang, bounded memory, and messages that name the right cause.

Commands that could block (a FIFO) or grow without bound (a 10⁷-column header) run in a child process
with a timeout, so a regression fails the test instead of hanging the suite.
"""

from __future__ import annotations

import gzip
import json
import os
import shutil
import socket
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib.batch import EXCERPT_CHARS, ManifestError, Row, read_manifest, run_batch, run_row
from imucalib.cli import main
from imucalib.fit.gyroscope import SIGNED_PERMUTATIONS, axes_disagreement
from imucalib.io import write_csv
from imucalib.methods import calibrate
from imucalib.recording import Recording
from imucalib.scenarios import session
from imucalib.segment import detect_intervals
from imucalib.store import Store, StoreError
from synth import tedaldi_session

SRC = Path(__file__).resolve().parent.parent / "src"
#: seconds a command may take on a hostile input before it counts as hanging
TIMEOUT = 20
#: the memory a command may peak at on a 88 MB one-line header [kB of RSS]: the interpreter, numpy and scipy
#: take about 80 MB; splitting the line into ten million cells took 1-1.9 GB
PEAK_RSS_KB = 250_000


def cli(*args, cwd=None, timeout=TIMEOUT) -> subprocess.CompletedProcess:
    """``imucalib ARGS`` in a child process (a hang is a test failure after ``timeout`` s, not a stuck suite)."""
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    return subprocess.run([sys.executable, "-m", "imucalib.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=cwd)


def here(capsys, *args) -> subprocess.CompletedProcess:
    """``imucalib ARGS`` in this process, as :func:`cli` reports it, for the commands that can neither block nor
    grow (a child costs ~0.4 processor seconds before the command runs)."""
    capsys.readouterr()
    try:
        code = main([str(a) for a in args])
    except SystemExit as exit_:  # argparse's --help and refusals: the exit status a child would end with
        assert isinstance(exit_.code, int | None), exit_.code
        code = exit_.code or 0
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(["imucalib", *map(str, args)], code, out, err)


def plain(err: str) -> bool:
    return "Traceback" not in err and err.count("\n") <= 2


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    rec, truth, _ = tedaldi_session(seed=12, noise_acc=0.003, noise_gyro=0.002)
    write_csv(d / "s.csv", rec)
    truth.save(d / "c.json")
    os.symlink("loop2", d / "loop1")
    os.symlink("loop1", d / "loop2")
    os.mkfifo(d / "fifo")
    return d


# ------------------------------------------------------------------ 4: tracebacks and hangs
@pytest.mark.parametrize("args, message", [
    (["calibrate", "s.csv", "-o", "loop1"], "loop1: the output is a symbolic link loop"),
    (["apply", "c.json", "loop1", "-o", "out.csv"], "loop1: a symbolic link loop"),
    (["apply", "loop1", "s.csv", "-o", "out.csv"], "loop1: a symbolic link loop"),
    (["calibrate", "loop1"], "loop1: a symbolic link loop"),
    (["calibrate", "fifo"], "fifo: a FIFO (named pipe), not a regular file"),
    (["apply", "c.json", "fifo", "-o", "out.csv"], "fifo: a FIFO (named pipe)"),
    (["apply", "fifo", "s.csv", "-o", "out.csv"], "fifo: a FIFO (named pipe)"),
    (["calibrate", "s.csv", "-o", "no/such/folder/c.json"], "the folder"),
])
def test_loops_fifos_and_missing_folders_are_plain_errors(files, args, message):
    r = cli(*args, cwd=files)
    assert r.returncode == 2, r.stderr
    assert message in r.stderr and plain(r.stderr), r.stderr
    assert not (files / "out.csv").exists()


def test_missing_output_folder_is_named_not_a_temporary_file(files, capsys, monkeypatch):
    monkeypatch.chdir(files)
    r = here(capsys, "calibrate", "s.csv", "-o", "nowhere/c.json")
    assert r.returncode == 2
    assert f"the folder {files / 'nowhere'} does not exist" in r.stderr and ".tmp" not in r.stderr, r.stderr


def test_a_symbolic_link_loop_is_not_called_missing(files):
    r = cli("calibrate", "loop1", cwd=files)
    assert "not found" not in r.stderr and "symbolic link loop" in r.stderr


def test_manifest_rows_that_are_loops_fifos_devices_or_folders_fail_quickly(files, tmp_path):
    big = tmp_path / "tree"  # a folder that is no recording, with a deep tree below it
    for k in range(30):
        (big / f"d{k}" / "sub").mkdir(parents=True)
        (big / f"d{k}" / "sub" / "x.bin").write_bytes(os.urandom(1 << 16))
    manifest = tmp_path / "m.csv"
    usr = "F,/usr\n" if Path("/usr").is_dir() else ""  # 36 s and 301 MB hashed before it was refused
    manifest.write_text(f"device,files\nA,{files / 'loop1'}\nB,{files / 'fifo'}\nC,/dev/zero\nD,{big}\n"
                        f"E,{files / 's.csv'}\n{usr}", encoding="utf-8")
    r = cli("batch", manifest, "--store", tmp_path / "s.sqlite", "--json")
    assert r.returncode == 3, r.stderr
    errors = {e["device"]: e["error"] for e in json.loads(r.stdout)["errors"]}
    assert "a symbolic link loop" in errors["A"]
    assert "a FIFO (named pipe)" in errors["B"]
    assert "a character device" in errors["C"] and "UTF-16" not in errors["C"]
    assert "is a directory, not a data file" in errors["D"]
    assert not usr or "is a directory, not a data file" in errors["F"]
    assert "E" not in errors  # the good row is calibrated beside them
    with Store(tmp_path / "s.sqlite", readonly=True) as st:
        rec = {r["device"]: r for r in st.records()}
    assert rec["D"]["files"][0]["sha256"] is None  # refused before anything in the tree was hashed


@pytest.mark.parametrize("store", ["fifo", "loop1"])
def test_a_store_or_manifest_that_is_a_fifo_or_a_loop_is_refused(files, tmp_path, store):
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"device,files\nA,{files / 's.csv'}\n", encoding="utf-8")
    for args in (["batch", manifest, "--store", files / store], ["store", "list", "--store", files / store],
                 ["batch", files / store, "--store", tmp_path / "s.sqlite"]):
        r = cli(*args)
        kind = "a FIFO (named pipe)" if store == "fifo" else "a symbolic link loop"
        assert r.returncode == 2 and f"{store}: {kind}" in r.stderr and plain(r.stderr), r.stderr
    with pytest.raises(ManifestError, match="a FIFO"):
        read_manifest(files / "fifo")  # the library refuses it too (reading it would block)


def _peak_rss_kb(*args) -> tuple[int, subprocess.CompletedProcess]:
    """The peak resident memory [kB] of ``imucalib ARGS`` in a grandchild, measured by its parent."""
    code = ("import resource, subprocess, sys\n"
            "r = subprocess.run([sys.executable, '-m', 'imucalib.cli', *sys.argv[1:]], capture_output=True, "
            "text=True)\n"
            "sys.stderr.write(r.stderr)\n"
            "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
            "sys.exit(r.returncode)\n")
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    r = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                       timeout=60, env=env)
    return int(r.stdout.strip().splitlines()[-1]), r


@pytest.mark.slow
@pytest.mark.parametrize("rows", ["", "\n1,2,3\n"])
def test_a_ten_million_column_header_is_refused_in_bounded_memory(tmp_path, rows):
    path = tmp_path / "wide.csv"
    names = ",".join(f"c{i:07d}" for i in range(10_000))  # 10,000 names, written 1,000 times (a 90 MB line)
    with open(path, "w", encoding="ascii") as f:
        f.write(",".join([names] * 1_000))
        f.write(rows)
    assert path.stat().st_size > 80e6
    peak, r = _peak_rss_kb("calibrate", path)
    assert r.returncode == 2 and plain(r.stderr), r.stderr
    assert "empty file" not in r.stderr and "is this a text table?" in r.stderr, r.stderr
    assert peak < PEAK_RSS_KB, f"peak RSS {peak} kB"


# ------------------------------------------------------------------ 6: manifests that reach out
@pytest.fixture
def listener():
    """A local TCP listener that must receive no connection: (port, a function giving the connections made)."""
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    srv.setblocking(False)

    def accepted() -> int:
        n = 0
        while True:
            try:
                conn, _ = srv.accept()
            except BlockingIOError:
                return n
            conn.close()
            n += 1

    yield srv.getsockname()[1], accepted
    srv.close()


def test_url_rows_are_refused_unless_allowed_and_nothing_connects(files, tmp_path, listener):
    port, accepted = listener
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"device,files\nA,ftp://127.0.0.1:{port}/run.csv\nB,http://127.0.0.1:{port}/run.csv\n"
                        f"C,{files / 's.csv'}\n", encoding="utf-8")
    with pytest.raises(ManifestError, match=r"line 2: ftp://.*a URL; a manifest's URLs are read only when allowed"
                       r"(.|\n)*line 3: http://"):
        run_batch(manifest, tmp_path / "s.sqlite")
    with pytest.raises(ManifestError, match=r"the URL scheme ftp is not among those allowed \(s3\)"):
        run_batch(manifest, tmp_path / "s.sqlite", allow_urls=["s3"])
    r = cli("batch", manifest, "--store", tmp_path / "t.sqlite")
    assert r.returncode == 2 and "--allow-urls" in r.stderr and plain(r.stderr.split("\n", 1)[-1]), r.stderr
    assert accepted() == 0
    assert not (tmp_path / "s.sqlite").exists() and not (tmp_path / "t.sqlite").exists()  # nothing ran
    assert [row.files for row in read_manifest(manifest, allow_urls="ftp,http")][0] == \
        (f"ftp://127.0.0.1:{port}/run.csv",)


def test_batch_help_says_urls_are_asked_for_and_whom_to_trust(capsys):
    r = here(capsys, "batch", "--help")
    text = " ".join(r.stdout.split())
    assert "--allow-urls" in text and "manifests you trust" in text and "pickled" in text


def test_a_file_url_to_a_folder_is_not_copied(tmp_path):
    pytest.importorskip("fsspec", reason="fsspec is not installed (it comes with the cluster extra)")
    tree = tmp_path / "tree"
    (tree / "sub").mkdir(parents=True)
    (tree / "sub" / "big.bin").write_bytes(b"\0" * (4 << 20))
    row = Row(line=2, device="A", files=(tree.as_uri(),))
    out = run_row({"row": row, "skip": []})
    assert out["status"] == "failed" and "a folder, not a data file" in out["error"], out["error"]
    assert out["files"][0]["bytes"] is None


hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is not installed")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_SECRET = st.text(alphabet=st.characters(min_codepoint=33, max_codepoint=126, exclude_characters=",;\t\"'#"),
                  min_size=EXCERPT_CHARS + 1, max_size=90)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(first=_SECRET, second=st.lists(_SECRET, min_size=0, max_size=3))
def test_stored_errors_quote_no_more_than_a_short_excerpt_of_a_file(tmp_path, first, second):
    """A row naming a file that is not a recording (/etc/passwd): no run of more than EXCERPT_CHARS
    characters of its content reaches the stored error."""
    path = tmp_path / "secret.txt"
    content = "\n".join([first, *second, "1 2 3"]) + "\n"
    path.write_text(content, encoding="ascii")
    out = run_row({"row": Row(line=2, device="A", files=(str(path),)), "skip": []})
    assert out["status"] == "failed"
    error = out["error"].replace(str(path), "")
    for line in content.splitlines():
        for i in range(len(line) - EXCERPT_CHARS):
            assert line[i:i + EXCERPT_CHARS + 1] not in error, (line, out["error"])


def test_etc_passwd_as_a_row_is_not_copied_into_the_store(tmp_path):
    if not Path("/etc/passwd").is_file():
        pytest.skip("no /etc/passwd on this system")
    first = Path("/etc/passwd").read_text(encoding="utf-8", errors="replace").splitlines()[0]
    out = run_row({"row": Row(line=2, device="A", files=("/etc/passwd",)), "skip": []})
    assert out["status"] == "failed" and first not in out["error"], out["error"]
    assert first[:EXCERPT_CHARS + 1] not in out["error"] or len(first) <= EXCERPT_CHARS


# ------------------------------------------------------------------ 7: the right cause
def test_dev_zero_and_sparse_files_are_binary_not_utf16(files, tmp_path):
    sparse = tmp_path / "sparse.csv"
    with open(sparse, "wb") as f:
        f.truncate(10 << 20)
    for path, words in (("/dev/zero", "character device"), (sparse, "NUL bytes")):
        r = cli("calibrate", path)
        assert r.returncode == 2 and words in r.stderr and "UTF-16" not in r.stderr and plain(r.stderr), r.stderr


@pytest.mark.parametrize("name", ["bzip2", "xz"])
def test_compressed_files_are_called_compressed(files, tmp_path, name, capsys):
    """Compressions the CSV reader does not decompress as it reads (gzip it does) are named, with the command."""
    import bz2
    import lzma

    path = tmp_path / f"s.csv.{'bz2' if name == 'bzip2' else 'xz'}"
    with (bz2.open if name == "bzip2" else lzma.open)(path, "wb") as f:
        f.write((files / "s.csv").read_bytes())
    r = here(capsys, "calibrate", path)
    assert r.returncode == 2 and f"{name}-compressed; decompress it first" in r.stderr and plain(r.stderr)


def test_gzip_cut_short_or_corrupt_is_exit_2(files, tmp_path, capsys):
    """A .csv.gz is read as it decompresses; one whose stream stops early (an interrupted copy) or whose bytes
    were damaged is an error naming the file and what is wrong with it, exit 2, no traceback."""
    raw = gzip.compress((files / "s.csv").read_bytes())
    (tmp_path / "cut.csv.gz").write_bytes(raw[: len(raw) * 2 // 3])
    damaged = bytearray(raw)
    damaged[len(raw) // 2] ^= 0xFF
    (tmp_path / "bad.csv.gz").write_bytes(bytes(damaged))
    r = here(capsys, "calibrate", tmp_path / "cut.csv.gz")
    assert r.returncode == 2 and "cut.csv.gz: the gzip-compressed file is cut short" in r.stderr, r.stderr
    assert plain(r.stderr)
    r = here(capsys, "calibrate", tmp_path / "bad.csv.gz")
    assert r.returncode == 2 and "bad.csv.gz: the gzip-compressed file is corrupt" in r.stderr, r.stderr
    assert plain(r.stderr)


def test_utf16_is_still_called_utf16(tmp_path, capsys):
    path = tmp_path / "u.csv"
    path.write_text("t,ax,ay,az,gx,gy,gz\n" + "0,1,2,3,4,5,6\n" * 50, encoding="utf-16-le")
    r = here(capsys, "calibrate", path)
    assert r.returncode == 2 and "the text is UTF-16 encoded" in r.stderr


def _read_only_folder(folder: Path):
    """Make ``folder`` unwritable for this process (chattr +i as root, chmod otherwise); the undo, or None."""
    if os.geteuid() != 0:
        folder.chmod(0o555)
        return lambda: folder.chmod(0o755)
    if shutil.which("chattr") is None:
        return None
    if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode != 0:
        return None
    return lambda: subprocess.run(["chattr", "-i", str(folder)], check=True)


def test_a_store_in_a_read_only_folder_is_listed(tmp_path, capsys):
    folder = tmp_path / "ro"
    folder.mkdir()
    with Store(folder / "s.sqlite") as st:
        st.add({"device": "A", "method": "tedaldi2014", "status": "failed", "files": [], "source_sha256": "0",
                "settings": {}, "error": "x"})
    assert sorted(p.name for p in folder.iterdir()) == ["s.sqlite"]  # the -wal and -shm files are gone
    undo = _read_only_folder(folder)
    if undo is None:
        pytest.skip("cannot make a folder read-only here (root without chattr)")
    try:
        with pytest.raises(OSError):
            (folder / "probe").write_text("x")
        r = here(capsys, "store", "list", "--store", folder / "s.sqlite", "--json")
        assert r.returncode == 0, r.stderr
        assert [rec["device"] for rec in json.loads(r.stdout)] == ["A"]
        with Store(folder / "s.sqlite", readonly=True) as st, pytest.raises(StoreError):
            st.add({"device": "B", "method": "tedaldi2014", "status": "failed", "files": [],
                    "source_sha256": "1", "settings": {}})
    finally:
        undo()


def _handheld(seed: int) -> Recording:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return session("handheld", rng=seed, rest=15.0, n_poses=20).recording


def _with_gyro(rec: Recording, perm, signs) -> Recording:
    return Recording(rec.t, rec.acc, rec.gyro[:, list(perm)] * np.array(signs), acc_unit=rec.acc_unit,
                     gyro_unit=rec.gyro_unit, metadata=rec.metadata)


def _fix_of(perm, signs) -> str:
    """The order that undoes ``gyro[:, perm] * signs``, written as the message writes it."""
    inv = [list(perm).index(i) for i in range(3)]
    return ", ".join(f"{'-' if signs[inv[i]] < 0 else ''}{'xyz'[inv[i]]}" for i in range(3))


def test_axes_disagreement_names_the_order_and_signs_that_undo_every_corruption():
    """All 47 orders and signs of one sensor's axes: the accelerometer's poses, the gyroscope's rotations."""
    rec = _handheld(11)
    intervals, _, rest, model = detect_intervals(rec, 9.80665, gyro_gate=False)
    bias = rec.gyro[rest.slice].mean(axis=0)
    assert axes_disagreement(rec, intervals, model, bias) is None  # the sensors agree as they are
    for perm, signs in SIGNED_PERMUTATIONS[1:]:
        bad = _with_gyro(rec, perm, signs)
        message = axes_disagreement(bad, intervals, model, bias[list(perm)] * np.array(signs))
        assert message is not None and f"read as ({_fix_of(perm, signs)})" in message, (perm, signs, message)


@pytest.mark.parametrize("seed, perm, signs", [(11, (0, 1, 2), (1, 1, -1)), (22, (1, 2, 0), (1, 1, -1)),
                                               (23, (0, 2, 1), (-1, 1, -1)), (26, (0, 1, 2), (-1, 1, 1))])
def test_swapped_or_reversed_gyroscope_axes_are_named_not_too_few_intervals(seed, perm, signs):
    rec = _handheld(seed)
    good = calibrate(rec, method="tedaldi2014")
    assert good.fit["verdict"] == "accepted"
    with pytest.raises(ValueError) as exc:
        calibrate(_with_gyro(rec, perm, signs), method="tedaldi2014")
    text = str(exc.value)
    assert "too few static intervals" not in text and "hold the sensor still" not in text
    assert "the accelerometer and the gyroscope disagree about the rotations" in text
    assert f"read as ({_fix_of(perm, signs)})" in text, text
    fixed = _with_gyro(_with_gyro(rec, perm, signs), *_undo(perm, signs))
    np.testing.assert_array_equal(fixed.gyro, rec.gyro)  # the order named is the one that undoes it


def _undo(perm, signs):
    inv = [list(perm).index(i) for i in range(3)]
    return inv, [signs[j] for j in inv]


def test_a_calibration_on_the_cli_with_a_reversed_axis_says_why(tmp_path, capsys):
    rec = _with_gyro(_handheld(11), (0, 1, 2), (1, 1, -1))
    write_csv(tmp_path / "flip.csv", rec)
    code = main(["calibrate", str(tmp_path / "flip.csv"), "-o", str(tmp_path / "c.json")])
    err = capsys.readouterr().err
    assert code == 2 and not (tmp_path / "c.json").exists()
    assert "disagree about the rotations" in err and "read as (x, y, -z)" in err and "the z column negated" in err


@pytest.mark.parametrize("seed, perm, signs", [(20, (2, 1, 0), (1, 1, 1)), (21, (1, 2, 0), (-1, -1, 1))])
def test_a_rejection_for_axes_near_90_degrees_names_the_swap(seed, perm, signs):
    cal = calibrate(_with_gyro(_handheld(seed), perm, signs), method="tedaldi2014")
    assert cal.fit["verdict"] == "rejected"
    reasons = " ".join(cal.fit["verdict_reasons"])
    assert f"the gyroscope's axes are swapped against the accelerometer's: the fit reads them as " \
           f"({_fix_of(perm, signs)})" in reasons, reasons


def test_real_data_with_two_gyroscope_columns_swapped_names_them(tmp_path, capsys):
    data = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"
    if not data.is_dir():
        pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): real-data test skipped")
    rows = np.loadtxt(data / "xsens_gyro.mat")
    np.savetxt(tmp_path / "gyro.txt", rows[:, [0, 2, 1, 3]], fmt="%.7e")
    code = main(["calibrate", str(data / "xsens_acc.mat"), str(tmp_path / "gyro.txt"), "--reader", "imutk"])
    out = capsys.readouterr().out
    assert code == 3 and "the fit reads them as (y, x, z)" in out, out


_TEXT = st.text(alphabet=st.characters(min_codepoint=32, max_codepoint=126), min_size=8, max_size=600)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=_TEXT, encoding=st.sampled_from(["utf-16", "utf-16-le", "utf-16-be"]),
       junk=st.binary(min_size=0, max_size=400), zeros=st.integers(8, 5000))
def test_utf16_text_is_utf16_and_nul_filled_data_is_binary(tmp_path, text, encoding, junk, zeros):
    """UTF-16 text (with or without a byte-order mark) is called UTF-16; NUL-filled data (a sparse file,
    zeros then anything) is called binary data with NUL bytes, never UTF-16."""
    from imucalib.io.errors import ReaderError
    from imucalib.io.inputs import check_text

    path = tmp_path / "x.csv"
    path.write_bytes(text.encode(encoding))
    with pytest.raises(ReaderError, match="the text is UTF-16 encoded"):
        check_text(path)
    path.write_bytes(b"\0" * zeros + junk)
    with pytest.raises(ReaderError) as exc:
        check_text(path)
    assert "UTF-16" not in str(exc.value) and "NUL bytes" in str(exc.value), str(exc.value)
