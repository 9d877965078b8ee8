"""Batch calibration: every recording of a manifest into a calibration store, on local processes or Dask.

A manifest is a CSV file with one recording per line. Columns (a header line names them; any order):

================= ===========================================================================
``device``        required: the device's name or serial number
``files``         required: the data files, ``;``-separated, relative to the manifest (or absolute; or
                  fsspec URLs such as ``s3://bucket/run.csv`` when URLs are allowed: ``allow_urls``)
``method``        calibration method (default ``tedaldi2014``, as ``imucalib calibrate``)
``model``         model variant
``reader``        input format (``csv``, ``imutk``, ``mat``, ``phone``, ``rosbag``, ``session``)
``columns``       column names or indices in the order t,ax,ay,az,gx,gy,gz (``,`` or ``;``-separated)
``acc_unit``      ``counts``, ``g``, ``m/s^2``
``gyro_unit``     ``counts``, ``deg/s``, ``rad/s``
``time_unit``     ``s``, ``ms``, ``us``, ``ns``
``rate``          sampling rate [Hz] when there is no time column
``topic``         ROS bags: the ``sensor_msgs/Imu`` topic
``variable``      MATLAB files: the matrix's name
``gravity``       local gravity [m/s²] (default 9.80665)
``recorded_at``   when the recording was made: an ISO date or date-time
``temperature_c`` the sensor's temperature [°C] during the recording
================= ===========================================================================

Empty cells take the default; lines that are empty or start with ``#`` are skipped. The whole manifest is
checked before anything runs, and every problem is reported with its line.

What a manifest can make the batch do, and whom to trust:

* A row names files the batch reads. A local path must be a regular file, or a ROS 2 bag or simulated
  session directory (only the files directly inside it are read): a FIFO, a device, a symbolic link loop
  or another directory is the row's error, found before anything is opened.
* A URL is read (through fsspec) only when it is allowed: ``allow_urls=True`` (``--allow-urls``) for any
  scheme, or a list of schemes (``--allow-urls s3,gcs``). Otherwise a URL row is an error of the manifest
  and nothing runs: a manifest from elsewhere cannot make the batch connect to a host it names (``ftp://``,
  ``http://``) or copy a folder (``file://``). A URL folder is read only when it is a ROS 2 bag or a
  simulated session, and then only the files directly inside it.
* A row's error is stored; it quotes at most :data:`EXCERPT_CHARS` characters of any quoted file content,
  so a row naming a file that is not a recording (``/etc/passwd``) does not copy its lines into the store.
* On Dask (``scheduler``), tasks and results travel pickled: whoever can reach the scheduler or its
  workers can run code in them, and in the process running the batch. Use only a scheduler of your own,
  on a network that only trusted hosts reach (``scheduler="local"`` listens on 127.0.0.1).

Each row is read with :func:`imucalib.read` and calibrated with
:func:`imucalib.methods.calibrate`, exactly as ``imucalib calibrate FILES --method …`` does, in a
worker (:func:`run_row`), which also hashes the files (SHA-256 of their contents). The process that runs
the batch writes each result into the store (:class:`imucalib.store.Store`) as it arrives, one transaction
per row. A row that fails (a file missing or unreadable, too few poses, a rejected verdict) is stored
with its error and never stops the batch. A row already in the store, same device, time, settings and
file contents, is skipped (``force`` redoes it, replacing the record): a batch killed half-way and run
again does the rest, and every row ends up in the store once.

Where the rows run (:func:`execute`, shared with :func:`imucalib.experiments.evaluate.montecarlo`):

* ``workers=1``: in this process;
* ``workers=N``: a pool of N processes that lives for the whole batch (started once, imports done once),
  rows handed out in small chunks;
* ``scheduler="local"``: a Dask ``LocalCluster`` of ``workers`` single-threaded processes on this machine
  (default: one per core);
* ``scheduler="tcp://HOST:8786"``: an existing Dask cluster, one task per row. The workers read the
  files themselves, so the paths must be valid on the workers (a shared file system) or be URLs.

The results do not depend on where the rows run: each row is calibrated by the same function from the same
bytes.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import logging
import os
import signal
import stat
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

from .batch_manifest import (
    MANIFEST_COLUMNS,
    ManifestError,
    Row,
    is_url,
    read_manifest,
    url_protocols,
    url_schemes,
)
from .io.atomic import refuse_overwriting_inputs
from .io.errors import ReaderError
from .io.inputs import check_input_path, check_text, path_kind
from .io.rosbag import is_rosbag
from .recording import ImucalibWarning
from .rowerrors import EXCERPT_CHARS, heads_of, row_message
from .store import Store, canonical_json, check_store_path, instant_key

__all__ = ["EXCERPT_CHARS", "MANIFEST_COLUMNS", "BatchError", "ManifestError", "Row", "dask_client", "execute",
           "is_url", "read_manifest", "run_batch", "run_row", "url_protocols", "url_schemes"]

_HASH_BLOCK = 1 << 20


class BatchError(ValueError):
    """A batch that could not go on (a worker process died, the Dask scheduler is out of reach).

    Examples
    --------
    A remote Dask cluster has workers of its own, so asking for a number of them is an error:

    >>> from imucalib.batch import BatchError, dask_client
    >>> try:
    ...     with dask_client("tcp://192.0.2.1:8786", workers=4):
    ...         pass
    ... except BatchError as exc:
    ...     print(exc)
    --workers applies to local processes and --scheduler local; the cluster at tcp://192.0.2.1:8786
    has its own workers
    """


# ------------------------------------------------------------------ one row
def _folder_files(path: Path) -> list[Path]:
    """The regular files directly inside ``path`` (no sub-folders, FIFOs or devices), in sorted order."""
    return sorted(p for p in path.iterdir() if p.is_file() and path_kind(p.stat().st_mode) is None)


def _check_local(path: Path) -> None:
    """A row's local input, looked at before it is opened: a regular file, a ROS 2 bag or a session folder."""
    st = check_input_path(path)
    if stat.S_ISDIR(st.st_mode) and not (is_rosbag(path) or (path / "session.json").is_file()):
        raise ReaderError(f"{path}: is a directory, not a data file (a ROS 2 bag directory holds metadata.yaml, "
                          "a simulated session session.json)")


def _check_content(path: Path, reader: str | None) -> None:
    """The checks a text reader makes of a regular file's first kilobytes (:func:`~.io.inputs.check_text`:
    binary, sparse, UTF-16 or compressed in another way), before the whole file is hashed: a 100 GB sparse file
    is refused in milliseconds, as ``imucalib calibrate`` refuses it."""
    from .io.readers import guess_reader  # imucalib.io.readers costs 24 ms at start-up

    if not path.is_file():
        return
    reader = reader or guess_reader([path])
    if reader in ("csv", "imutk", "phone"):
        check_text(path, gzip_ok=reader == "csv")


def _hash_path(path: Path) -> tuple[str, int]:
    """SHA-256 of a file's contents, or of a folder's (names and contents of the files directly inside it)."""
    h = hashlib.sha256()
    size = 0
    files = [path] if path.is_file() else _folder_files(path)
    for p in files:
        if p is not path:
            h.update(p.relative_to(path).as_posix().encode("utf-8") + b"\0")
        with open(p, "rb") as fh:
            while block := fh.read(_HASH_BLOCK):
                h.update(block)
                size += len(block)
    return h.hexdigest(), size


def _fetch(url: str, directory: Path) -> Path:
    """A local copy of the fsspec URL ``url`` in ``directory``, under its own name."""
    try:
        import fsspec  # optional: pip install imucalib[cluster]
    except ImportError:
        raise ValueError(f"{url}: reading URLs needs fsspec (pip install fsspec, or the cluster extra: "
                         'pip install "imucalib[cluster]")') from None
    fs, remote = fsspec.core.url_to_fs(url)
    name = Path(remote.rstrip("/")).name or "data"
    target = directory / f"{len(list(directory.iterdir()))}" / name
    target.parent.mkdir()
    if not fs.exists(remote):
        raise FileNotFoundError(f"{url}: file not found")
    if not fs.isdir(remote):
        fs.get(remote, str(target))
        return target
    # a folder: a ROS 2 bag or a simulated session, and then only the files directly inside it
    entries = fs.ls(remote, detail=True)
    names = {Path(str(e["name"]).rstrip("/")).name: e for e in entries}
    if "metadata.yaml" not in names and "session.json" not in names:
        raise ValueError(f"{url}: a folder, not a data file (a ROS 2 bag folder holds metadata.yaml, a "
                         "simulated session session.json); name the file")
    target.mkdir()
    for base, e in sorted(names.items()):
        if e.get("type") == "file":
            fs.get(str(e["name"]), str(target / base))
    return target


def run_row(task: dict) -> dict:
    """Hash, read and calibrate one manifest row; the result the batch stores. Never raises.

    Parameters
    ----------
    task : dict
        ``{"row": Row, "skip": [source hashes already stored for this row's device, time and settings]}``.

    Returns
    -------
    dict
        ``{"line", "status": "ok" | "failed" | "skipped", "verdict", "calibration" (JSON text or None),
        "error", "notes", "files": [{"path", "sha256", "bytes"}], "source_sha256", "seconds"}``. A row is
        ``skipped`` when its files' hash is in ``task["skip"]``; ``failed`` on any error, and when the
        calibration's verdict is ``rejected`` (its calibration is returned all the same).
    """
    from .methods import calibrate  # imucalib.methods costs 96 ms at start-up
    from .reading import read as read_data  # with the methods: read there where a row runs

    t0 = time.perf_counter()
    row: Row = task["row"]
    out: dict[str, Any] = {"line": row.line, "status": "failed", "verdict": None, "calibration": None,
                           "error": None, "notes": [], "files": [], "source_sha256": None, "seconds": None}
    replace: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="imucalib-batch-") if any(is_url(f) for f in row.files) \
            else contextlib.nullcontext() as tmp:
        local: list[Path | None] = []
        problems: list[str] = []
        digest = hashlib.sha256()
        for name in row.files:
            p: Path | None = None
            try:
                p = _fetch(name, Path(tmp)) if is_url(name) else Path(name)
                if is_url(name):
                    replace[str(p)] = name
                _check_local(p)
                _check_content(p, row.reader)  # what the reader refuses from its first bytes, before hashing it all
                sha, size = _hash_path(p)
            except Exception as exc:  # the row fails with this file's error; the batch goes on
                problems.append(row_message(exc, replace, row.files, heads_of([p])))
                local.append(None)
                out["files"].append({"path": name, "sha256": None, "bytes": None})
                digest.update(f"missing:{name}\n".encode())
                continue
            local.append(p)
            out["files"].append({"path": name, "sha256": sha, "bytes": size})
            digest.update(f"{sha}\n".encode())
        out["source_sha256"] = digest.hexdigest()
        if out["source_sha256"] in task.get("skip", ()):
            out["status"] = "skipped"
            return out
        try:
            if problems:
                raise FileNotFoundError("; ".join(problems))
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                data = read_data([str(p) for p in local], **row.reader_options())
                cal = calibrate(data, method=row.method, model=row.model, gravity=row.gravity)
            heads = heads_of(local)
            out["notes"] = [row_message(ValueError(str(w.message)), replace, row.files, heads) for w in caught
                            if issubclass(w.category, ImucalibWarning)]
            cal = cal.with_(device=row.device)
            verdict = cal.fit.verdict.level
            out["calibration"] = cal.to_json()
            out["verdict"] = verdict
            if verdict == "rejected":
                reasons = "; ".join(cal.fit.verdict.reasons or []) or "no reason recorded"
                out["error"] = f"the calibration is rejected: {reasons}"
            else:
                out["status"] = "ok"
        except Exception as exc:  # a failing row is stored with its error, never stops the batch
            out["error"] = row_message(exc, replace, row.files, heads_of(local))
    out["seconds"] = time.perf_counter() - t0
    return out


# ----------------------------------------------------------------- executing
def _watch_parent(parent: int) -> None:
    """End this worker when the process that started it is gone (killed with SIGKILL: no clean shutdown)."""
    while True:
        time.sleep(0.5)
        if os.getppid() != parent:
            os._exit(1)


def _init_worker() -> None:
    """A pool worker: leave Ctrl-C to the parent (which stops the pool) and die with it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True).start()


def _run_chunk(fn: Callable[[Any], Any], chunk: list[tuple[int, Any]]) -> list[tuple[int, Any]]:
    return [(i, fn(task)) for i, task in chunk]


def _auto_chunksize(n: int, workers: int) -> int:
    """Rows per hand-out: 1 for short batches (balance), up to 16 for long ones (fewer round trips)."""
    return max(1, min(16, n // (32 * workers)))


@contextlib.contextmanager
def dask_client(scheduler: str, workers: int | None = None) -> Iterator[Any]:
    """A Dask ``Client``: of a new ``LocalCluster`` (``scheduler="local"``, ``workers`` single-threaded
    processes, default one per core, listening on 127.0.0.1 only), or of the scheduler at an address."""
    try:
        from distributed import Client, LocalCluster  # optional: pip install imucalib[cluster]
    except ImportError:
        raise BatchError('--scheduler needs Dask distributed: pip install "imucalib[cluster]"') from None
    if scheduler == "local":
        import dask  # optional: pip install imucalib[cluster]

        n = workers if workers is not None else (os.cpu_count() or 1)
        # Dask's nannies start their workers with MALLOC_TRIM_THRESHOLD_=65536, which sends every array
        # above 128 kB back to the system when freed: the calibrations' temporaries then cost a fresh mmap
        # and page faults each time, 1.6-2 times slower. The one-thread BLAS settings are kept.
        with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}), \
                LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                             dashboard_address=None, silence_logs=logging.ERROR) as cluster, \
                Client(cluster) as client:
            yield client
        return
    if workers is not None:
        raise BatchError(f"--workers applies to local processes and --scheduler local; the cluster at "
                         f"{scheduler} has its own workers")
    try:
        client = Client(scheduler)  # waits distributed.comm.timeouts.connect (Dask's configuration)
    except (OSError, TimeoutError, ValueError) as exc:
        raise BatchError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
    with client:
        yield client


def execute(fn: Callable[[Any], Any], tasks: Sequence[Any], *, workers: int | None = None,
            scheduler: str | None = None, chunksize: int | None = None,
            progress: Callable[[int, int], None] | None = None) -> Iterator[tuple[int, Any]]:
    """``fn(task)`` for every task, locally or on Dask; yields ``(index, result)`` as each one completes.

    Parameters
    ----------
    fn : callable
        A module-level function (it is pickled by name for other processes).
    tasks : sequence
        Its arguments, one per call.
    workers : int, optional
        Without ``scheduler``: the number of processes (default 1: this process); a pool of them lives for
        the whole run. With ``scheduler="local"``: the number of LocalCluster workers (default: one per
        core).
    scheduler : str, optional
        ``"local"`` or the address of a Dask scheduler (``tcp://HOST:8786``): one Dask task per call.
    chunksize : int, optional
        Local pool only: tasks per hand-out (default: 1 for up to 64 tasks per worker, up to 16 beyond).
    progress : callable, optional
        ``progress(done, total)`` after each result.

    Yields
    ------
    index : int
        The task's position in ``tasks``.
    result : object
        ``fn(tasks[index])``, in the order the results complete.

    Raises
    ------
    BatchError
        A worker process died (the results yielded so far stand), or the scheduler cannot be reached.

    Examples
    --------
    >>> from imucalib.batch import execute
    >>> sorted(execute(abs, [-3, 2, -1]))  # one process: this one
    [(0, 3), (1, 2), (2, 1)]
    """
    tasks = list(tasks)
    n = len(tasks)
    done = 0

    def tick() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, n)

    if scheduler is not None:
        yield from _on_dask(fn, tasks, scheduler, workers, tick)
        return
    workers = 1 if workers is None else int(workers)
    if workers < 1:
        raise ValueError(f"workers must be ≥ 1; got {workers}")
    workers = min(workers, max(n, 1))
    if workers == 1:
        for i, task in enumerate(tasks):
            result = fn(task)
            tick()
            yield i, result
        return
    yield from _in_pool(fn, tasks, workers, chunksize or _auto_chunksize(n, workers), tick)


def _on_dask(fn: Callable[[Any], Any], tasks: list, scheduler: str, workers: int | None,
             tick: Callable[[], None]) -> Iterator[tuple[int, Any]]:
    """:func:`execute` on Dask: one task per call, ``(index, result)`` as each completes."""
    with dask_client(scheduler, workers) as client:
        from distributed import as_completed  # optional: pip install imucalib[cluster]

        futures = {client.submit(fn, task, pure=False): i for i, task in enumerate(tasks)}
        for fut in as_completed(futures):
            result = fut.result()
            i = futures[fut]
            fut.release()
            tick()
            yield i, result


def _in_pool(fn: Callable[[Any], Any], tasks: list, workers: int, size: int,
             tick: Callable[[], None]) -> Iterator[tuple[int, Any]]:
    """:func:`execute` in a pool of ``workers`` local processes, ``size`` tasks per hand-out."""
    n = len(tasks)
    items = list(enumerate(tasks))
    chunks = [items[k:k + size] for k in range(0, n, size)]
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_init_worker)
    try:
        pending = {pool.submit(_run_chunk, fn, chunk) for chunk in chunks}
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                try:
                    results = fut.result()
                except BrokenProcessPool:
                    raise BatchError("a worker process died (killed, or out of memory); what finished "
                                     "before is kept: run again to do the rest") from None
                for i, result in results:
                    tick()
                    yield i, result
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


# -------------------------------------------------------------------- batch
def _link_loop(path: str) -> bool:
    try:
        os.stat(path)
    except OSError as exc:
        return exc.errno == errno.ELOOP
    return False


def _size(row: Row) -> int:
    """Bytes of a row's local files (0 for URLs and what is missing): the order rows are handed out in."""
    total = 0
    for f in row.files:
        if not is_url(f):
            with contextlib.suppress(OSError):
                total += os.path.getsize(f)
    return total


def run_batch(manifest: str | Path, store: str | Path, *, workers: int | None = None, scheduler: str | None = None,
              force: bool = False, chunksize: int | None = None, allow_urls: bool | str | Sequence[str] = False,
              progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Calibrate every row of ``manifest`` into the store ``store`` (created if missing).

    Parameters
    ----------
    manifest : str or Path
        The manifest CSV (see the module docstring).
    store : str or Path
        The store file (:class:`imucalib.store.Store`).
    workers, scheduler, chunksize :
        Where the rows run (:func:`execute`).
    force : bool
        Calibrate rows already in the store again, replacing their records.
    allow_urls : bool, str or sequence of str
        URLs in the manifest: refused (default), any scheme (True), or the schemes listed
        (:func:`read_manifest`).
    progress : callable, optional
        ``progress(done, total)`` after each row.

    Returns
    -------
    dict
        ``{"manifest", "store", "rows", "calibrated", "failed", "skipped", "verdicts": {"accepted",
        "suspect", "rejected"}, "errors": [{"line", "device", "error"}], "seconds", "workers",
        "scheduler"}``: ``calibrated`` counts the rows stored with a calibration that is not rejected,
        ``failed`` those stored with an error (a rejected verdict included), ``skipped`` those already in
        the store (or twice in the manifest).

    Examples
    --------
    A manifest of one simulated device, calibrated into a new store:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.batch import run_batch
    >>> from imucalib.sessions import write_session
    >>> from imucalib.scenarios import session
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = write_session(session("handheld", rng=1, rest=10, n_poses=14), folder / "imu1")
    >>> manifest = chr(10).join(["device,files,reader", "imu1,imu1,session"])
    >>> _ = (folder / "manifest.csv").write_text(manifest)
    >>> summary = run_batch(folder / "manifest.csv", folder / "fleet.sqlite", workers=1)
    >>> summary["rows"], summary["calibrated"], summary["verdicts"]
    (1, 1, {'accepted': 1, 'suspect': 0, 'rejected': 0})
    """
    t0 = time.perf_counter()
    rows = read_manifest(manifest, allow_urls=allow_urls)
    check_store_path(store)
    # a row's file that is a symbolic link loop cannot be the store; the row fails with it when it runs
    refuse_overwriting_inputs([store], [manifest, *(f for r in rows for f in r.files
                                                    if not is_url(f) and not _link_loop(f))])
    summary: dict[str, Any] = {"manifest": str(manifest), "store": str(store), "rows": len(rows), "calibrated": 0,
                               "failed": 0, "skipped": 0, "verdicts": {"accepted": 0, "suspect": 0, "rejected": 0},
                               "errors": [], "seconds": None, "workers": workers, "scheduler": scheduler}
    with Store(store) as st:
        stored = {} if force else st.source_hashes()
        # the largest recordings first: the last ones to finish are then short, and the workers end together
        order = sorted(range(len(rows)), key=lambda k: -_size(rows[k]))
        tasks = [{"row": rows[k], "skip": sorted(stored.get(
            (rows[k].device, instant_key(rows[k].recorded_at), canonical_json(rows[k].settings())), ()))}
            for k in order]
        for i, res in execute(run_row, tasks, workers=workers, scheduler=scheduler, chunksize=chunksize,
                              progress=progress):
            row = rows[order[i]]
            if res["status"] == "skipped":
                summary["skipped"] += 1
                continue
            record = {"device": row.device, "recorded_at": row.recorded_at, "temperature_c": row.temperature_c,
                      "method": row.method, "model": row.model, "settings": row.settings(), **{
                          k: res[k] for k in ("status", "verdict", "calibration", "files", "source_sha256",
                                              "error", "notes", "seconds")}}
            if st.add(record, replace=force) is None:  # the same row twice in the manifest
                summary["skipped"] += 1
                continue
            if res["verdict"] in summary["verdicts"]:
                summary["verdicts"][res["verdict"]] += 1
            if res["status"] == "ok":
                summary["calibrated"] += 1
            else:
                summary["failed"] += 1
                summary["errors"].append({"line": row.line, "device": row.device, "error": res["error"]})
    summary["errors"].sort(key=lambda e: e["line"])
    summary["seconds"] = round(time.perf_counter() - t0, 3)
    return summary
