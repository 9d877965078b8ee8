"""``-o`` never destroys what is at the path: devices and FIFOs are written into, refusals are plain errors.

The real ``/dev/null`` is only ever reached through a symbolic link, and only
after checking that the writer treats the link's target as a stream (written
into), never as a file to replace.
"""

from __future__ import annotations

import os
import socket
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from imucalib.cli import main
from imucalib.io import atomic
from imucalib.io.atomic import atomic_path, atomic_write
from synth import linear_truth


def run(capsys, *args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def cal(tmp_path):
    path = tmp_path / "c.json"
    linear_truth().save(path)
    return path


def _char_device(path: Path) -> bool:
    return stat.S_ISCHR(os.stat(path).st_mode)


def test_a_fifo_output_is_written_into_and_stays_a_fifo(capsys, cal, tmp_path):
    fifo = tmp_path / "pipe.h"
    os.mkfifo(fifo)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # a reader waiting: the writer's open does not block
    try:
        code, out, err = run(capsys, "export", cal, "-o", fifo)
        data = os.read(reader, 1 << 16)
    finally:
        os.close(reader)
    assert code == 0, err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert data.startswith(b"/* imucalib calibration")
    assert data.rstrip().endswith(b"#endif /* IMUCALIB_CALIBRATION_H */")
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.skipif(not os.path.exists("/dev/null") or not _char_device("/dev/null"), reason="no /dev/null device")
def test_a_link_to_dev_null_is_written_into_never_replaced(capsys, cal, tmp_path):
    link = tmp_path / "discard.h"
    link.symlink_to("/dev/null")
    before = os.stat("/dev/null")
    # the guard before any write: the writer must take /dev/null for a stream, else stop here
    assert atomic._target(link) == (Path("/dev/null"), True)
    code, out, err = run(capsys, "export", cal, "-o", link)
    assert code == 0, err
    with atomic_path(link) as tmp:  # the by-name form too: written elsewhere, then copied in
        tmp.write_bytes(b"figure")
        assert tmp.parent != Path("/dev")
    after = os.stat("/dev/null")
    assert link.is_symlink() and os.readlink(link) == "/dev/null"
    assert _char_device("/dev/null") and (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)


def test_dash_a_socket_and_a_directory_are_refused_in_words(capsys, cal, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "export", cal, "--format", "c", "-o", "-")
    assert code == 2 and "-o -: standard output is not a file name here" in err
    assert not (tmp_path / "-").exists()
    sock_path = tempfile.mktemp(prefix="imucalib-", suffix=".sock", dir="/tmp")  # short: AF_UNIX path limit
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.bind(sock_path)
        try:
            code, _, err = run(capsys, "export", cal, "--format", "c", "-o", sock_path)
            assert code == 2 and "is a socket; it is never written to or replaced" in err
            assert stat.S_ISSOCK(os.lstat(sock_path).st_mode)
        finally:
            os.unlink(sock_path)
    (tmp_path / "d.h").mkdir()
    code, _, err = run(capsys, "export", cal, "-o", tmp_path / "d.h")
    assert code == 2 and "is a directory" in err and "Traceback" not in err


def test_a_symbolic_link_is_followed_and_kept(cal, tmp_path):
    real = tmp_path / "real.h"
    real.write_text("old\n")
    link = tmp_path / "link.h"
    link.symlink_to(real.name)
    with atomic_write(link) as fh:
        fh.write("new\n")
    assert link.is_symlink() and real.read_text() == "new\n"
    loop = tmp_path / "loop.h"
    loop.symlink_to(loop.name)
    with pytest.raises(OSError, match="loop of symbolic links"):
        with atomic_write(loop) as fh:
            fh.write("x")
    assert loop.is_symlink()


def _as_nobody(script: str, cwd: Path) -> subprocess.CompletedProcess:
    """``script`` run by the user ``nobody``: the modules imported as root first (root's home is closed to it)."""
    import pwd

    user = pwd.getpwnam("nobody")
    # every module of the package (the command line imports them lazily) and what argparse loads on first use
    prelude = ("import os, sys, encodings.utf_8_sig, locale, importlib, pkgutil\nimport imucalib\n"
               "for m in pkgutil.walk_packages(imucalib.__path__, 'imucalib.'):\n"
               "    if not m.name.endswith('__main__'):\n"
               "        importlib.import_module(m.name)\n"
               "imucalib.cli.build_parser().parse_args(['export', 'c.json'])\n"
               f"os.setgroups([])\nos.setgid({user.pw_gid})\nos.setuid({user.pw_uid})\n")
    return subprocess.run([sys.executable, "-c", prelude + script], cwd=cwd, capture_output=True, text=True,
                          timeout=120, env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})


def test_a_file_the_user_cannot_write_is_refused(capsys, cal, tmp_path):
    if os.geteuid() != 0:  # a non-root user: chmod 444 is enough
        target = tmp_path / "ro.h"
        target.write_text("mine\n")
        target.chmod(0o444)
        code, _, err = run(capsys, "export", cal, "-o", target)
        assert code == 2 and "read-only for you" in err and target.read_text() == "mine\n"
        return
    try:
        import pwd

        pwd.getpwnam("nobody")
    except (ImportError, KeyError):
        pytest.skip("running as root without a 'nobody' user: a read-only file cannot be tried as a non-root user")
    folder = Path(tempfile.mkdtemp(prefix="imucalib-ro-"))  # pytest's tmp_path is closed to other users
    try:
        folder.chmod(0o777)
        target = folder / "ro.h"
        target.write_text("theirs\n")
        target.chmod(0o444)
        calibration = folder / "c.json"
        calibration.write_bytes(cal.read_bytes())
        calibration.chmod(0o444)
        uid = __import__("pwd").getpwnam("nobody").pw_uid
        os.chown(target, uid, -1)
        res = _as_nobody("from imucalib.cli import main\nsys.exit(main(['export', 'c.json', '-o', 'ro.h']))", folder)
        if "Permission denied" in res.stderr and "imucalib" not in res.stderr:
            pytest.skip(f"the user nobody cannot run this interpreter: {res.stderr[-200:]}")
        assert res.returncode == 2, res.stderr
        assert "ro.h: the file is read-only for you; it is not replaced" in res.stderr
        assert target.read_text() == "theirs\n" and stat.S_IMODE(target.stat().st_mode) == 0o444
        # a file it may write is replaced, keeping its owner and mode
        target.chmod(0o644)
        res = _as_nobody("from imucalib.cli import main\nsys.exit(main(['export', 'c.json', '-o', 'ro.h']))", folder)
        assert res.returncode == 0, res.stderr
        assert target.read_text().startswith("/* imucalib") and target.stat().st_uid == uid
    finally:
        for p in folder.iterdir():
            p.unlink()
        folder.rmdir()


def test_root_replacing_a_user_s_file_keeps_its_owner(cal, tmp_path):
    if os.geteuid() != 0:
        pytest.skip("only root can write a file another user owns")
    target = tmp_path / "theirs.h"
    target.write_text("x\n")
    os.chown(target, 65534, 65534)
    with atomic_write(target) as fh:
        fh.write("y\n")
    assert target.read_text() == "y\n" and (target.stat().st_uid, target.stat().st_gid) == (65534, 65534)


def test_simulate_refuses_a_folder_holding_its_files_unless_forced(capsys, tmp_path):
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "recording.csv").write_text("my own recording\n")
    (folder / "notes.txt").write_text("kept\n")
    code, _, err = run(capsys, "simulate", "--scenario", "wang2019", "--dwell", "5", "-o", folder)
    assert code == 0, err  # a wang2019 session writes positions.csv, turns.csv: nothing of the user's
    code, _, err = run(capsys, "simulate", "--scenario", "handheld", "-o", folder)
    assert code == 2 and "holds recording.csv, truth.json, session.json, which this session would overwrite" in err
    assert (folder / "recording.csv").read_text() == "my own recording\n"
    code, _, err = run(capsys, "simulate", "--scenario", "handheld", "-o", folder, "--force")
    assert code == 0, err
    assert (folder / "recording.csv").read_text().startswith("t,") and (folder / "notes.txt").read_text() == "kept\n"
    (tmp_path / "file").write_text("x")
    code, _, err = run(capsys, "simulate", "-o", tmp_path / "file")
    assert code == 2 and "is a file; a session is written into a folder" in err


@pytest.mark.skipif(not os.path.exists("/dev/full") or not _char_device("/dev/full"), reason="no /dev/full device")
def test_a_full_device_is_a_plain_error_naming_it(capsys, cal, tmp_path):
    link = tmp_path / "full.h"
    link.symlink_to("/dev/full")
    assert atomic._target(link) == (Path("/dev/full"), True)  # the guard: written into, never replaced
    code, out, err = run(capsys, "export", cal, "-o", link)
    assert code == 2 and "/dev/full: No space left on device" in err and "Traceback" not in err
    assert _char_device("/dev/full") and os.readlink(link) == "/dev/full"


def test_a_failed_write_sends_nothing_into_a_fifo(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    try:
        with pytest.raises(RuntimeError, match="half-way"):
            with atomic_write(fifo) as fh:
                fh.write("first half\n")
                raise RuntimeError("half-way")
        assert os.read(reader, 1 << 16) == b""  # no writer ever opened it: nothing, not half a file
        with atomic_write(fifo) as fh:
            fh.write("whole\n")
        assert os.read(reader, 1 << 16) == b"whole\n"
    finally:
        os.close(reader)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
