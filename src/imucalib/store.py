"""The calibration store: every calibration of every device, in one SQLite file.

One record per calibration made by :func:`imucalib.batch.run_batch` (or added
with :meth:`Store.add`): the device, when it was recorded and at what
temperature, the method and model, the verdict, the calibration file's JSON,
the source files with their SHA-256 hashes, and for a row that failed its
error. Records are found again by device and time or temperature
(:meth:`Store.get`: the accepted calibration closest to a date, as a
production line looks a board up by its serial number) and written out as
files (:meth:`Store.export`).

The file is an SQLite database (the standard library's :mod:`sqlite3`) in
write-ahead-log mode: each record is written in its own transaction, so a
run killed at any point (SIGKILL) leaves the store as of its last complete
record (after a power loss, of one of its last ones: the next run redoes the
others), readable while a batch writes to it. Keep it on a local disk (WAL
needs shared memory, which network file systems do not give). This is the one file
the package writes without :mod:`imucalib.io.atomic` (a database is updated
in place by its own journal); exports go through it as every other output.

Identity: a record's key is its device, its ``recorded_at``, its settings
(method, model, reading options, gravity, temperature) and the hash of its
source files' contents. A batch skips a row whose key is already stored, so a
batch run again after being killed does the remaining rows only, and a row
whose files changed is calibrated anew (a new record beside the old one).

Times are ISO 8601 dates or date-times (``2024-05-01``, ``2024-05-01T14:30``,
``2024-05-01T14:30:00+02:00``); one without a zone is taken as UTC when times
are compared.

In a program, the calibration of a device as it was on a date, from a store a batch filled (:class:`Store`
has an example that runs)::

    from imucalib.store import Store

    with Store("fleet.sqlite", readonly=True) as store:
        cal, record = store.get("IMU-0042", at="2024-06-01")
        cal.save("imu-0042.json")
"""

from __future__ import annotations

import contextlib
import csv
import errno
import functools
import hashlib
import json
import os
import re
import sqlite3
import stat
from collections.abc import Iterable, Iterator, Sequence
from datetime import UTC, date, datetime
from pathlib import Path
from typing import Any

from .calibration import Calibration
from .io.atomic import atomic_create, atomic_write
from .io.jsontext import dumps, jsonable, loads

__all__ = ["SCHEMA_VERSION", "STATUSES", "SUMMARY_COLUMNS", "Store", "StoreError", "canonical_json",
           "check_store_path", "instant_key", "parse_time", "record_key", "spreadsheet_text"]

#: ``PRAGMA user_version`` of the store's schema
SCHEMA_VERSION = 1
#: a record's status: a calibration was made (``ok``, its verdict accepted or suspect), or not (``failed``:
#: an error, or a rejected verdict)
STATUSES = ("ok", "failed")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS calibrations (
    id INTEGER PRIMARY KEY,
    record_key TEXT NOT NULL UNIQUE,
    device TEXT NOT NULL,
    recorded_at TEXT,
    recorded_ts REAL,
    temperature_c REAL,
    method TEXT NOT NULL,
    model TEXT,
    status TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
    verdict TEXT,
    calibration TEXT,
    files TEXT NOT NULL,
    source_sha256 TEXT NOT NULL,
    settings TEXT NOT NULL,
    error TEXT,
    notes TEXT NOT NULL DEFAULT '[]',
    seconds REAL,
    created TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS calibrations_device ON calibrations (device, recorded_ts);
"""

#: the columns of a record's summary (everything but the calibration JSON), in :meth:`Store.records` order
SUMMARY_COLUMNS = ("id", "device", "recorded_at", "temperature_c", "method", "model", "status", "verdict",
                   "error", "files", "source_sha256", "settings", "notes", "seconds", "created")
_JSON_COLUMNS = ("files", "settings", "notes")


class StoreError(ValueError):
    """A store that cannot be opened or read, or a calibration it does not hold; the message names the file.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.store import Store, StoreError
    >>> path = Path(tempfile.mkdtemp()) / "fleet.sqlite"
    >>> try:
    ...     Store(path, create=False)
    ... except StoreError as exc:
    ...     print(exc)
    /.../fleet.sqlite: no store there (a batch creates it: imucalib batch MANIFEST --store ...)
    """


def parse_time(text: str | datetime | date | None, *, what: str = "time") -> tuple[str | None, float | None]:
    """An ISO 8601 date or date-time as (normalised text, seconds since 1970-01-01 UTC).

    A date alone stays a date (``"2024-05-01"``, its midnight for comparisons); a date-time is written
    back by :meth:`datetime.isoformat`. A time without a zone is taken as UTC. ``None`` or an empty text
    gives ``(None, None)``.

    Raises
    ------
    ValueError
        ``text`` is not an ISO date or date-time; the message names ``what``.
    """
    if text is None or (isinstance(text, str) and not text.strip()):
        return None, None
    if isinstance(text, datetime):
        moment = text
        normalised = moment.isoformat()
    elif isinstance(text, date):
        moment = datetime(text.year, text.month, text.day)
        normalised = text.isoformat()
    else:
        s = text.strip()
        try:
            if re.fullmatch(r"\d{4}-\d{2}-\d{2}", s):
                day = date.fromisoformat(s)
                moment, normalised = datetime(day.year, day.month, day.day), day.isoformat()
            else:
                moment = datetime.fromisoformat(s)
                normalised = moment.isoformat()
        except ValueError:
            raise ValueError(f"{what} {s!r} is not an ISO date or time (e.g. 2024-05-01 or "
                             "2024-05-01T14:30:00, optionally with a zone such as +02:00 or Z)") from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=UTC)
    return normalised, moment.timestamp()


def instant_key(text: str | datetime | date | None) -> str:
    """One text per instant, for a record's identity: ``2024-05-01``, ``2024-05-01T00:00`` and
    ``2024-05-01T02:00+02:00`` are the same moment (a time without a zone is UTC) and give ``"2024-05-01"``;
    another moment gives its UTC date-time without a zone (``2024-05-01T14:30:00``); None gives ``""``."""
    _, ts = parse_time(text)
    if ts is None:
        return ""
    moment = datetime.fromtimestamp(ts, UTC).replace(tzinfo=None)
    return moment.date().isoformat() if moment.time() == datetime.min.time() else moment.isoformat()


def canonical_json(obj: Any) -> str:
    """``obj`` as compact strict JSON with sorted keys: equal settings give equal text."""
    return json.dumps(jsonable(obj), sort_keys=True, separators=(",", ":"), allow_nan=False, ensure_ascii=False)


def record_key(device: str, recorded_at: str | None, settings: str, source_sha256: str) -> str:
    """The identity of a record: SHA-256 of its device, time, settings (canonical JSON) and source hash."""
    text = json.dumps([device, recorded_at or "", settings, source_sha256], ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _safe_name(text: str) -> str:
    """``text`` made a file name: anything but letters, digits, ``.``, ``_`` and ``-`` becomes ``_``."""
    name = re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "device"
    return name[:100]


def check_store_path(path: str | Path) -> None:
    """Refuse a store path that is a symbolic link loop, a FIFO, a socket or a device (a StoreError naming it)."""
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise StoreError(f"{path}: a symbolic link loop (the link leads back to itself through other links); "
                             "the store is a file: point the link at it or give another name") from None
        return  # a store that does not exist yet, or an error sqlite reports when it opens it
    for test, kind in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device")):
        if test(mode):
            raise StoreError(f"{path}: {kind}, not a store file; the store is an SQLite file (e.g. fleet.sqlite)")


def _sql_errors(method):
    """A :class:`Store` method whose database errors (disk full, a read-only file) become :class:`StoreError`."""
    @functools.wraps(method)
    def wrapped(self, *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except sqlite3.Error as exc:
            raise StoreError(f"{self.path}: {_sql_cause(exc, self.path)}") from None

    return wrapped


#: free space below which SQLite's "disk I/O error" is a full disk [bytes]: a write of a page, its journal and
#: its shared-memory index
_NEARLY_FULL = 1 << 20


def _sql_cause(exc: sqlite3.Error, path: str | Path) -> str:
    """SQLite's error in words: a full disk (SQLITE_FULL, or an I/O error with the disk out of space) said so."""
    text = str(exc)
    full = "full" in text
    if not full and "disk I/O error" in text:
        with contextlib.suppress(OSError):
            fs = os.statvfs(os.path.dirname(os.path.abspath(path)))
            full = fs.f_bavail * fs.f_frsize < _NEARLY_FULL
    if full:
        return (f"the disk holding it is full ({text}): nothing of this write was kept, the records before it are "
                "intact; free space on that disk, then run again")
    return text


class Store:
    """A calibration store in the SQLite file ``path``.

    Use it as a context manager, or call :meth:`close`.

    Parameters
    ----------
    path : str or Path
        The store file. Its directory must exist.
    create : bool
        Create the store when the file does not exist (default). With False, a missing file is an error
        (commands that only read a store).
    readonly : bool
        Open the file for reading only (``store list``, ``get``, ``export``): nothing is written, not even
        the write-ahead-log setting, so a store in a folder one cannot write to (or on read-only media) is
        read. When SQLite cannot open it read-only there (a write-ahead-log store needs its ``-shm`` file,
        which a read-only folder cannot hold), it is opened as immutable: as it is on disk, which is what a
        folder that nobody can write to holds. Implies ``create=False``.

    Examples
    --------
    A store filled by a batch (:func:`imucalib.batch.run_batch`), then read: the calibration to use for a
    device:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from imucalib.batch import run_batch
    >>> from imucalib.sessions import write_session
    >>> from imucalib.scenarios import session
    >>> from imucalib.store import Store
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = write_session(session("handheld", rng=1, rest=10, n_poses=14), folder / "imu1")
    >>> manifest = chr(10).join(["device,files,reader", "imu1,imu1,session"])
    >>> _ = (folder / "manifest.csv").write_text(manifest)
    >>> _ = run_batch(folder / "manifest.csv", folder / "fleet.sqlite", workers=1)
    >>> with Store(folder / "fleet.sqlite", readonly=True) as store:
    ...     cal, record = store.get("imu1")
    ...     store.devices(), cal.method, cal.fit.verdict.level
    (['imu1'], 'tedaldi2014', 'accepted')
    """

    def __init__(self, path: str | Path, *, create: bool = True, readonly: bool = False) -> None:
        self.path = Path(path)
        self.readonly = readonly
        create = create and not readonly
        check_store_path(self.path)
        if self.path.is_dir():
            raise StoreError(f"{self.path}: is a directory; the store is one file (e.g. fleet.sqlite)")
        if not create and not self.path.is_file():
            raise StoreError(f"{self.path}: no store there (a batch creates it: imucalib batch MANIFEST "
                             f"--store {self.path})")
        try:
            self._db = self._connect_readonly() if readonly else \
                sqlite3.connect(self.path, timeout=60.0, isolation_level=None)
        except sqlite3.Error as exc:
            raise StoreError(f"{self.path}: cannot open the store ({exc})") from None
        try:  # look before changing anything: another program's database is left as it is
            version = self._db.execute("PRAGMA user_version").fetchone()[0]
            tables = {r[0] for r in self._db.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        except sqlite3.DatabaseError as exc:
            self._db.close()
            raise StoreError(f"{self.path}: not an imucalib store ({exc})") from None
        if "calibrations" in tables:
            if version != SCHEMA_VERSION:
                self._db.close()
                raise StoreError(f"{self.path}: store schema version {version} is not supported (this "
                                 f"imucalib reads version {SCHEMA_VERSION})")
        elif tables or not create:
            self._db.close()
            raise StoreError(f"{self.path}: an SQLite file, but not an imucalib store (no calibrations table)")
        if readonly:
            return
        try:
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            if "calibrations" not in tables:
                self._db.executescript(f"BEGIN; {_SCHEMA} PRAGMA user_version = {SCHEMA_VERSION}; COMMIT;")
        except sqlite3.Error as exc:
            self._db.close()
            raise StoreError(f"{self.path}: cannot use the store ({_sql_cause(exc, self.path)})") from None

    def _connect_readonly(self) -> sqlite3.Connection:
        """A read-only connection (``mode=ro``), else an immutable one where the folder cannot be written."""
        uri = self.path.absolute().as_uri()
        db = sqlite3.connect(f"{uri}?mode=ro", uri=True, timeout=60.0, isolation_level=None)
        try:
            db.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()
            return db
        except sqlite3.OperationalError:
            db.close()
            if os.access(self.path.absolute().parent, os.W_OK):
                raise
        # a write-ahead-log store in a folder that cannot hold its -shm file: nobody can be writing to it
        return sqlite3.connect(f"{uri}?immutable=1", uri=True, timeout=60.0, isolation_level=None)

    # ------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """Close the database (idempotent)."""
        if self._db is not None:
            self._db.close()
            self._db = None

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @_sql_errors
    def __len__(self) -> int:
        return int(self._db.execute("SELECT COUNT(*) FROM calibrations").fetchone()[0])

    # --------------------------------------------------------------- writing
    @_sql_errors
    def add(self, record: dict[str, Any], *, replace: bool = False) -> int | None:
        """Write one record in its own transaction; its id, or None when its key is already stored.

        Parameters
        ----------
        record : dict
            ``device``, ``method``, ``status`` (``ok``/``failed``), ``files`` (a list of
            ``{"path", "sha256", "bytes"}``), ``source_sha256``, ``settings`` (a dict) required;
            ``recorded_at``, ``temperature_c``, ``model``, ``verdict``, ``calibration`` (a
            :class:`Calibration`, a dict or JSON text), ``error``, ``notes``, ``seconds``, ``created``
            optional.
        replace : bool
            Replace a record with the same key (``--force``) instead of keeping it.
        """
        if record.get("status") not in STATUSES:
            raise ValueError(f"a record's status is 'ok' or 'failed'; got {record.get('status')!r}")
        device = str(record["device"])
        recorded_at, ts = parse_time(record.get("recorded_at"), what="recorded_at")
        settings = record.get("settings") or {}
        settings = settings if isinstance(settings, str) else canonical_json(settings)
        cal = record.get("calibration")
        if isinstance(cal, Calibration):
            cal = cal.to_json()
        elif isinstance(cal, dict):
            cal = dumps(cal, indent=2)
        created = record.get("created") or datetime.now(UTC).replace(microsecond=0).isoformat()
        values = {
            "record_key": record_key(device, instant_key(recorded_at), settings, record["source_sha256"]),
            "device": device, "recorded_at": recorded_at, "recorded_ts": ts,
            "temperature_c": record.get("temperature_c"), "method": record["method"],
            "model": record.get("model"), "status": record["status"], "verdict": record.get("verdict"),
            "calibration": cal, "files": dumps(record["files"]), "source_sha256": record["source_sha256"],
            "settings": settings, "error": record.get("error"), "notes": dumps(list(record.get("notes") or [])),
            "seconds": record.get("seconds"), "created": created,
        }
        names = ", ".join(values)
        marks = ", ".join(f":{k}" for k in values)
        if replace:
            update = ", ".join(f"{k} = excluded.{k}" for k in values if k != "record_key")
            sql = f"INSERT INTO calibrations ({names}) VALUES ({marks}) ON CONFLICT(record_key) DO UPDATE SET {update}"
        else:
            sql = f"INSERT INTO calibrations ({names}) VALUES ({marks}) ON CONFLICT(record_key) DO NOTHING"
        with self._transaction():
            cur = self._db.execute(sql, values)
            if cur.rowcount == 0:
                return None
            row = self._db.execute("SELECT id FROM calibrations WHERE record_key = ?",
                                   (values["record_key"],)).fetchone()
        return int(row[0])

    @contextlib.contextmanager
    def _transaction(self) -> Iterator[None]:
        """BEGIN IMMEDIATE … COMMIT, or ROLLBACK when the block raises."""
        self._db.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self._db.execute("ROLLBACK")
            raise
        self._db.execute("COMMIT")

    # --------------------------------------------------------------- reading
    @_sql_errors
    def source_hashes(self) -> dict[tuple[str, str, str], set[str]]:
        """``(device, instant_key(recorded_at), settings JSON) → {source hashes}`` of every record (what a batch
        skips): one key per moment, however its time was written (:func:`instant_key`)."""
        out: dict[tuple[str, str, str], set[str]] = {}
        for device, at, settings, source in self._db.execute(
                "SELECT device, recorded_at, settings, source_sha256 FROM calibrations"):
            out.setdefault((device, instant_key(at), settings), set()).add(source)
        return out

    @_sql_errors
    def records(self, device: str | None = None, *, with_calibration: bool = False) -> list[dict[str, Any]]:
        """Every record (of ``device``), oldest recording first: dicts of :data:`SUMMARY_COLUMNS`.

        ``files``, ``settings`` and ``notes`` are decoded; with ``with_calibration`` each record also has
        ``calibration``, the calibration file's content as a dict (``None`` for a failed row).
        """
        cols = list(SUMMARY_COLUMNS) + (["calibration"] if with_calibration else [])
        sql = f"SELECT {', '.join(cols)} FROM calibrations"
        params: tuple = ()
        if device is not None:
            sql += " WHERE device = ?"
            params = (device,)
        sql += " ORDER BY device, recorded_ts IS NULL, recorded_ts, id"
        out = []
        for row in self._db.execute(sql, params):
            rec = dict(zip(cols, row, strict=True))
            try:  # nested at most MAX_DEPTH levels: a crafted store cannot exhaust the stack
                for k in _JSON_COLUMNS:
                    rec[k] = loads(rec[k]) if rec[k] is not None else None
                if with_calibration and rec["calibration"] is not None:
                    rec["calibration"] = loads(rec["calibration"])
            except ValueError as exc:
                raise StoreError(f"{self.path}: record {rec.get('id')} is damaged ({exc}); delete it or restore the "
                                 "store from a copy") from None
            out.append(rec)
        return out

    @_sql_errors
    def devices(self) -> list[str]:
        """The devices with at least one record, sorted."""
        return [r[0] for r in self._db.execute("SELECT DISTINCT device FROM calibrations ORDER BY device")]

    @_sql_errors
    def counts(self) -> dict[str, int]:
        """``{"records", "ok", "failed", "accepted", "suspect", "rejected", "devices"}``."""
        q = self._db.execute
        out = {"records": len(self)}
        for status in STATUSES:
            out[status] = int(q("SELECT COUNT(*) FROM calibrations WHERE status = ?", (status,)).fetchone()[0])
        for verdict in ("accepted", "suspect", "rejected"):
            out[verdict] = int(q("SELECT COUNT(*) FROM calibrations WHERE verdict = ?", (verdict,)).fetchone()[0])
        out["devices"] = int(q("SELECT COUNT(DISTINCT device) FROM calibrations").fetchone()[0])
        return out

    def get(self, device: str, *, at: str | datetime | date | None = None, temperature: float | None = None,
            verdicts: Sequence[str] = ("accepted",)) -> tuple[Calibration, dict[str, Any]]:
        """The calibration of ``device`` to use: accepted, closest in time (or in temperature when given).

        Parameters
        ----------
        device : str
            The device's name as in the manifest.
        at : str or datetime or date, optional
            The record recorded closest to this time; by default the latest recording.
        temperature : float, optional
            [°C] The record whose ``temperature_c`` is closest; ties go to the one closest to ``at`` (or
            the latest).
        verdicts : sequence of str
            The verdicts that may be used (default: accepted only; add ``"suspect"`` to allow those).

        Returns
        -------
        (Calibration, dict)
            The calibration and its record (as in :meth:`records`).

        Raises
        ------
        StoreError
            No record of ``device`` qualifies; the message says what the store holds for it.
        """
        _, at_ts = parse_time(at, what="--at")
        records = self.records(device, with_calibration=True)
        usable = [r for r in records if r["status"] == "ok" and r["verdict"] in verdicts
                  and r["calibration"] is not None]
        allowed = " or ".join(verdicts)
        if not usable:
            if not records:
                known = self.devices()
                hint = f"; it holds {', '.join(known[:10])}{' …' if len(known) > 10 else ''}" if known else \
                    "; it is empty"
                raise StoreError(f"{self.path}: no record of device {device!r}{hint}")
            tally = ", ".join(f"{n} {k}" for k, n in self._tally(records).items() if n)
            raise StoreError(f"{self.path}: device {device!r} has no {allowed} calibration ({tally})")
        candidates = [(r, parse_time(r["recorded_at"])[1]) for r in usable]
        if at_ts is not None:
            candidates = [(r, t) for r, t in candidates if t is not None]
            if not candidates:
                raise StoreError(f"{self.path}: no {allowed} calibration of {device!r} has a recorded_at time "
                                 "to compare with --at")

        def by_time(item) -> tuple:
            r, t = item
            if at_ts is None:  # the latest recording; undated ones after every dated one, newest record first
                return (t is None, -(t or 0.0), -r["id"])
            return (abs(t - at_ts), -t, -r["id"])

        if temperature is not None:
            warm = [(r, t) for r, t in candidates if r["temperature_c"] is not None]
            if not warm:
                raise StoreError(f"{self.path}: no {allowed} calibration of {device!r} has a temperature_c to "
                                 "compare with --temperature")
            best = min(warm, key=lambda item: (abs(item[0]["temperature_c"] - float(temperature)), by_time(item)))
        else:
            best = min(candidates, key=by_time)
        record = best[0]
        return Calibration.from_dict(record["calibration"]), record

    @staticmethod
    def _tally(records: Iterable[dict]) -> dict[str, int]:
        out = {"accepted": 0, "suspect": 0, "rejected": 0, "failed": 0}
        for r in records:
            key = r["verdict"] if r["verdict"] in out else "failed"
            out[key] += 1
        return out

    # -------------------------------------------------------------- exporting
    def export(self, path: str | Path, *, device: str | None = None) -> dict[str, Any]:
        """Write the records (of ``device``) out, in the form the name of ``path`` says.

        * ``NAME.json``: one JSON document, ``{"format": "imucalib.store_export", "format_version": 1,
          "records": [...]}``, each record with its calibration;
        * ``NAME.csv``: one line per record, its summary and every calibration parameter as a column
          (``accelerometer.scale.x``, …; empty for a failed row);
        * any other name: a new directory holding ``index.json`` (the records without their
          calibrations, each with ``file``) and one calibration file per record that has one,
          ``DEVICE/RECORDED_AT_ID.json``, usable as it is by ``imucalib apply``.

        Files are written through a temporary file moved into place; a directory appears complete or not
        at all, and never replaces an existing one.

        Returns
        -------
        dict
            ``{"path", "form", "records", "calibration_files"}``.
        """
        path = Path(path)
        if path.resolve() == self.path.resolve():
            raise StoreError(f"the export {path} is the store itself: choose another name")
        records = self.records(device, with_calibration=True)
        suffix = path.suffix.lower()
        if suffix == ".json":
            doc = {"format": "imucalib.store_export", "format_version": 1, "store": str(self.path),
                   "records": [_export_record(r) for r in records]}
            with atomic_write(path, "w", encoding="utf-8") as fh:
                fh.write(dumps(doc, indent=1) + "\n")
            return {"path": str(path), "form": "json", "records": len(records),
                    "calibration_files": 0}
        if suffix == ".csv":
            _write_csv(path, records)
            return {"path": str(path), "form": "csv", "records": len(records), "calibration_files": 0}
        written = 0
        with atomic_create(path) as inner:
            inner.mkdir()
            index = []
            for r in records:
                entry = _export_record(r)
                cal = entry.pop("calibration")
                entry["file"] = None
                if cal is not None:
                    when = (r["recorded_at"] or "undated").replace(":", "-")
                    rel = Path(_safe_name(r["device"])) / f"{_safe_name(when)}_{r['id']}.json"
                    (inner / rel.parent).mkdir(exist_ok=True)
                    (inner / rel).write_text(dumps(cal, indent=2) + "\n", encoding="utf-8")
                    entry["file"] = rel.as_posix()
                    written += 1
                index.append(entry)
            (inner / "index.json").write_text(
                dumps({"format": "imucalib.store_export", "format_version": 1, "store": str(self.path),
                       "records": index}, indent=1) + "\n", encoding="utf-8")
        return {"path": str(path), "form": "directory", "records": len(records), "calibration_files": written}


def _export_record(r: dict) -> dict:
    return {k: r[k] for k in (*SUMMARY_COLUMNS, "calibration")}


def _write_csv(path: Path, records: list[dict]) -> None:
    """One line per record: its summary, then every calibration parameter."""
    params = [Calibration.from_dict(r["calibration"]).parameters() if r["calibration"] else {} for r in records]
    names = sorted({k for p in params for k in p})
    head = ["id", "device", "recorded_at", "temperature_c", "method", "model", "status", "verdict", "error",
            "source_sha256", "files", "created"]
    with atomic_write(path, "w", encoding="utf-8", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(head + names)
        for r, p in zip(records, params, strict=True):
            cells = [r[k] for k in head]
            cells[head.index("files")] = ";".join(f["path"] for f in r["files"])
            w.writerow([spreadsheet_text(c) for c in cells] + [repr(float(p[n])) if n in p else "" for n in names])


#: what makes a spreadsheet read a cell as a formula (OWASP, CSV injection): = + - @, tab, carriage return,
#: and their full-width forms
_FORMULA_START = tuple("=+-@\t\r\uff1d\uff0b\uff0d\uff20")


def spreadsheet_text(cell) -> str | int | float:
    """A CSV cell a spreadsheet shows as text: text that starts like a formula gets a leading ``'`` (OWASP's
    CSV-injection rule), numbers stay numbers, None is empty."""
    if cell is None:
        return ""
    if isinstance(cell, int | float):
        return cell
    text = str(cell)
    return "'" + text if text.lstrip(" ").startswith(_FORMULA_START) else text
