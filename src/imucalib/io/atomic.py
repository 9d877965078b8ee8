"""Writing files safely: through a temporary file moved into place, never onto an input.

Every file the package writes is first written to a temporary file in the
target's own directory (a hidden name, ``.NAME.XXXXXXXX.tmp``), flushed to
the disk, then moved onto the target with :func:`os.replace`. Readers of the
target therefore see either the previous file or the complete new one, never
a part; a write that fails or is interrupted (an exception, Ctrl-C) removes
its temporary file and leaves the target as it was. A process killed outright
(SIGKILL, power loss) can leave a hidden ``.NAME.….tmp`` behind, but never a
half-written target, and such a leftover never blocks a later run.

What is at the target is never destroyed: a symbolic link is followed (the
file it names is replaced, the link stays, as the shell's ``>`` does), except
one of another user in a sticky world-writable folder such as ``/tmp``, which
is refused as the kernel's protected-symlinks rule refuses it; a
character device or FIFO (``/dev/null``, a named pipe) is written into as a
stream, never replaced by a regular file; a block device, a socket, ``-`` and
an existing file the user may not write (read-only for a non-root user) are
refused before anything is written. A replaced file keeps its permissions
and, where the system allows, its owner. Hard links to a replaced file keep
the previous contents (the name gets a new file).

Three forms, by what the writer needs:

* :func:`atomic_write` yields an open file object (text or binary);
* :func:`atomic_path` yields the path of the temporary file, for writers that
  take a path and overwrite it (``numpy.savetxt``, ``Figure.savefig``); the
  temporary name ends with the target's suffix, so writers that choose the
  format by it (a ``.png``, a ``.gz``) do the same;
* :func:`atomic_create` yields a path that does not exist yet, inside a hidden
  temporary directory next to the target, for writers that insist on creating
  the file or directory themselves (ROS bag writers). The result is renamed
  into place only when complete, and only if the target still does not exist:
  this form never replaces anything, so an existing directory is never
  deleted or merged into.

:func:`refuse_overwriting_inputs` refuses, before anything is read or written,
an output path that names one of the inputs (or another output).
"""

from __future__ import annotations

import contextlib
import errno
import gzip
import io
import os
import shutil
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO

__all__ = ["OutputIsInputError", "atomic_create", "atomic_path", "atomic_write", "move_into_place",
           "output_target", "refuse_overwriting_inputs",
           "temporary_prefix"]


class OutputIsInputError(ValueError):
    """An output path that names an input file (or another output)."""


def temporary_prefix(path: str | Path) -> str:
    """The start of the name of every temporary file written for ``path``: ``"." + name + "."``."""
    return f".{Path(path).name}."


def _target(path: str | Path) -> tuple[Path, bool]:
    """The file to write for ``path`` and whether it is a stream (a character device or FIFO) written into.

    A symbolic link is followed, as the shell's ``>`` follows it: the file it
    names is replaced and the link stays. Refused, with the reason: ``-``
    (standard output is not a file name here), a directory, a block device
    or socket, and an existing file the user may not write (``os.access``: a
    read-only file of a non-root user, as the shell refuses it).
    """
    if str(path) == "-":
        raise ValueError("-o -: standard output is not a file name here; give a file name (or /dev/stdout)")
    path = Path(path)
    if not path.name:
        raise ValueError(f"{str(path)!r}: not a file name")
    if path.is_symlink():
        _check_protected_symlink(path)
        real = Path(os.path.realpath(path))
        if real.is_symlink():  # realpath stops at a loop
            raise OSError(errno.ELOOP, f"{path}: a loop of symbolic links; give a file name")
        path = real
    try:
        st = path.stat()
    except FileNotFoundError:
        return path, False
    if stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(f"{path}: is a directory; give a file name")
    if stat.S_ISCHR(st.st_mode) or stat.S_ISFIFO(st.st_mode):
        return path, True
    if not stat.S_ISREG(st.st_mode):
        kind = "a block device" if stat.S_ISBLK(st.st_mode) else "a socket" if stat.S_ISSOCK(st.st_mode) else \
            "not a regular file"
        raise ValueError(f"{path}: is {kind}; it is never written to or replaced: give a file name")
    if not os.access(path, os.W_OK):
        raise PermissionError(errno.EACCES, f"{path}: the file is read-only for you; it is not replaced (make it "
                                            "writable, or give another name)")
    return path, False


def output_target(path: str | Path) -> tuple[Path, bool]:
    """The file an output named ``path`` goes to, and whether it is a stream written into (a FIFO or device).

    The checks every writer here makes, for writers that write the file
    themselves (a recording kept as it comes): a symbolic link followed;
    ``-``, a directory, a block device, a socket and a read-only file refused
    (``ValueError``, ``OSError``).
    """
    return _target(path)


def _check_protected_symlink(link: Path) -> None:
    """Refuse to follow ``link`` where the kernel's protected-symlinks rule would (Linux ``fs.protected_symlinks``):
    a symbolic link in a sticky, world-writable folder (``/tmp``) owned by neither the user nor the folder's
    owner. Following it by name and renaming onto its target would let anyone who can write in ``/tmp`` choose
    which of the user's files is replaced."""
    try:
        folder = os.stat(link.parent)
        owner = os.lstat(link).st_uid
    except OSError:
        return
    shared = folder.st_mode & stat.S_ISVTX and folder.st_mode & stat.S_IWOTH
    if shared and owner not in (os.geteuid(), folder.st_uid):
        raise PermissionError(errno.EACCES, f"{link}: a symbolic link of another user (uid {owner}) in the shared "
                                            f"folder {link.parent}; it is not followed (another user may have put "
                                            "it there to make you overwrite a file): give another name")


def _stream(target: Path, mode: str, text: dict) -> IO:
    """``target`` (a character device or FIFO) opened for writing into: never created, truncated or replaced."""
    fd = os.open(target, os.O_WRONLY | getattr(os, "O_NOCTTY", 0))
    try:
        return os.fdopen(fd, mode, **text)
    except BaseException:
        os.close(fd)
        raise


def _temporary(target: Path, **kw):
    """``tempfile``'s ``mkstemp`` or ``mkdtemp`` next to ``target``; a folder that cannot be written in, named."""
    make = kw.pop("make")
    try:
        return make(dir=target.parent, prefix=temporary_prefix(target), **kw)
    except PermissionError:
        raise PermissionError(errno.EACCES, f"{target.parent or '.'}: you cannot write in this folder (its "
                                            f"permissions); {target.name} is not written") from None


def _file_mode(target: Path) -> int:
    """Permissions for the new file: the target's if it exists, else what the umask gives a new file."""
    try:
        return stat.S_IMODE(target.stat().st_mode)
    except OSError:
        mask = os.umask(0)
        os.umask(mask)
        return 0o666 & ~mask


def _fsync_directory(directory: Path) -> None:
    """Make a rename in ``directory`` durable (best effort: not every system can open a directory)."""
    with contextlib.suppress(OSError):
        fd = os.open(directory, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _remove(path: Path) -> None:
    with contextlib.suppress(FileNotFoundError):
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()


def move_into_place(tmp: Path, target: Path) -> None:
    """Rename the finished file ``tmp`` onto ``target`` (same folder), keeping the target's mode and owner,
    and make the rename durable (the folder synced)."""
    os.chmod(tmp, _file_mode(target))
    with contextlib.suppress(OSError):  # the owner kept (root replacing a user's file), as the shell's > keeps it
        st = target.stat()
        if (st.st_uid, st.st_gid) != (os.getuid(), os.getgid()):
            os.chown(tmp, st.st_uid, st.st_gid)
    os.replace(tmp, target)
    _fsync_directory(target.parent)


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "w", *, encoding: str | None = "utf-8",
                 newline: str | None = None, gzip_by_name: bool = False) -> Iterator[IO]:
    """Open a temporary file next to ``path`` for writing; on success it replaces ``path``.

    Parameters
    ----------
    path : str or Path
        The target file. Its directory must exist.
    mode : {"w", "wb"}
        Text or binary.
    encoding : str, optional
        Text mode only (default UTF-8).
    newline : str, optional
        Text mode only, as for :func:`open`.
    gzip_by_name : bool
        When ``path`` ends in ``.gz``, what is written is gzip-compressed (RFC 1952), so that the name says
        what the file is (a reader decompresses it by its first bytes).

    Yields
    ------
    file object
        Write to it inside the ``with`` block. When the block ends normally the
        file is flushed, synced to the disk and moved onto ``path``; when it
        raises (any exception, KeyboardInterrupt included) the temporary file
        is removed and ``path`` is left as it was. A character device or FIFO
        at ``path`` is written into instead, once the block has ended normally
        (nothing when it raises), from a temporary file in the system's
        temporary folder.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb'; got {mode!r}")
    if gzip_by_name and str(path).lower().endswith(".gz"):
        with atomic_write(path, "wb") as raw, _gzip_writer(raw, Path(path), mode, encoding, newline) as fh:
            yield fh
        return
    target, stream = _target(path)
    text = {"encoding": encoding, "newline": newline} if mode == "w" else {}
    if stream:  # a device or FIFO: written in the temporary folder, then into it as the shell's > writes
        with atomic_path(target) as tmp, tmp.open(mode, **text) as fh:
            yield fh
        return
    fd, name = _temporary(target, make=tempfile.mkstemp, suffix=".tmp")
    try:
        fh = os.fdopen(fd, mode, **text)
    except BaseException:
        os.close(fd)
        _remove(Path(name))
        raise
    tmp = Path(name)
    try:
        with fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        move_into_place(tmp, target)
    except OSError as exc:
        _remove(tmp)
        raise _full_disk(exc, target) from None
    except BaseException:
        _remove(tmp)
        raise


@contextlib.contextmanager
def _gzip_writer(raw: IO, path: Path, mode: str, encoding: str | None, newline: str | None) -> Iterator[IO]:
    """A gzip stream into the open binary file ``raw`` (text or binary by ``mode``), finished on success."""
    gz = gzip.GzipFile(filename=path.name[:-3], mode="wb", fileobj=raw, mtime=0)
    fh = io.TextIOWrapper(gz, encoding=encoding, newline=newline) if mode == "w" else gz
    yield fh
    fh.close()  # writes the gzip trailer; raw stays open for atomic_write to sync and move into place


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """The path of a temporary file next to ``path`` to write by name; on success it replaces ``path``.

    The temporary file exists (empty) when the block starts, and its name ends
    with ``path``'s suffix (``.fig.png.k3j2_x.tmp.png``), so a writer choosing
    the format by the suffix chooses the target's. Failure and success as in
    :func:`atomic_write`.
    """
    target, stream = _target(path)
    if stream:  # a device or FIFO: the file is written in the temporary folder, then copied into it
        fd, name = tempfile.mkstemp(prefix=temporary_prefix(target), suffix=".tmp" + target.suffix)
    else:
        fd, name = _temporary(target, make=tempfile.mkstemp, suffix=".tmp" + target.suffix)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        if stream:
            with tmp.open("rb") as src:
                dst = _stream(target, "wb", {})
                try:
                    shutil.copyfileobj(src, dst)
                finally:
                    try:
                        dst.close()
                    except OSError as exc:  # /dev/full: the device named
                        raise OSError(exc.errno, f"{target}: {exc.strerror}") from None
            _remove(tmp)
            return
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        move_into_place(tmp, target)
    except OSError as exc:
        _remove(tmp)
        raise _full_disk(exc, target) from None
    except BaseException:
        _remove(tmp)
        raise


def _full_disk(exc: OSError, target: Path) -> OSError:
    """``exc``, or for a full disk (ENOSPC, EDQUOT) an error naming the file and saying that nothing changed."""
    if exc.errno not in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC)):
        return exc
    what = "the disk is full" if exc.errno == errno.ENOSPC else "your disk quota is used up"
    return OSError(exc.errno, f"{target}: {what} ({exc.strerror}); nothing was written, what was there is as it "
                              "was: free space there, or write elsewhere")


@contextlib.contextmanager
def atomic_create(path: str | Path) -> Iterator[Path]:
    """A path for a new file or directory that appears at ``path`` only when complete; never replaces.

    The block gets ``.NAME.XXXXXXXX.tmp/NAME``, a path that does not exist yet
    inside a hidden temporary directory next to ``path`` (same name, so a
    writer naming inner files after it names them as it would at ``path``).
    When the block ends normally what was written there is renamed to
    ``path``; the temporary directory is removed in every case.

    Raises
    ------
    FileExistsError
        ``path`` exists, when the block starts or when the result is moved
        into place (nothing existing is ever replaced or merged into).
    """
    target = Path(path)
    if not target.name:
        raise ValueError(f"{str(path)!r}: not a file name")
    if target.exists() or target.is_symlink():
        raise FileExistsError(f"{target}: exists; choose a new name (it is never overwritten)")
    holder = Path(_temporary(target, make=tempfile.mkdtemp, suffix=".tmp"))
    inner = holder / target.name
    try:
        yield inner
        if not (inner.exists() or inner.is_symlink()):
            raise FileNotFoundError(f"{target}: nothing was written")
        if target.exists() or target.is_symlink():
            raise FileExistsError(f"{target}: appeared while it was being written; the new one is discarded")
        if not inner.is_dir():
            os.chmod(inner, _file_mode(target))
        os.rename(inner, target)  # a directory onto a non-empty one fails; a file is checked above
        _fsync_directory(target.parent)
    finally:
        _remove(holder)


def _same(a: Path, b: Path) -> bool:
    if a.exists() and b.exists():
        try:
            return os.path.samefile(a, b)
        except OSError:
            pass
    return os.path.realpath(a) == os.path.realpath(b)  # realpath stops at a symbolic link loop, never raises


def refuse_overwriting_inputs(outputs: Iterable[str | Path | None], inputs: Iterable[str | Path | None]) -> None:
    """Raise :class:`OutputIsInputError` when an output names an input, or two outputs name one file.

    Call it before anything is read or written. Two paths are the same when
    :func:`os.path.samefile` says so (both exist: hard links and symbolic
    links count), else when they resolve to the same absolute path. ``None``
    entries (options not given) are skipped.
    """
    outs = [Path(p) for p in outputs if p is not None]
    ins = [Path(p) for p in inputs if p is not None]
    for k, out in enumerate(outs):
        for src in ins:
            if _same(out, src):
                raise OutputIsInputError(f"the output {out} is the input {src}; writing it would destroy the "
                                         "input: choose another output name")
        for other in outs[:k]:
            if _same(out, other):
                raise OutputIsInputError(f"two outputs name the same file ({other} and {out}): choose "
                                         "different names")
