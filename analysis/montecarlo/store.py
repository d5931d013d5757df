"""The results of a study in one SQLite file: durable, resumable, self-describing.

Schema (version 3)::

    meta(key PRIMARY KEY, value)      -- schema_version, study (canonical YAML),
                                      -- identity, code_version, created_at
    samples(sample PRIMARY KEY, encoder_counts, payload_mass,
            parameters JSON, theta JSON, bound_ratios JSON, inside_bounds,
            code_version, finished_at)
    runs(sample, controller, status, message,
         rms_q1 .. rms_qn, rms_u1 .. rms_un, max_abs_q_err, saturated_fraction,
         wall_time_s, rms_measured_q1 .. rms_measured_qn, sampled_data_spectral_radius,
         PRIMARY KEY (sample, controller))

with ``n`` the joints of the study's arm (``records.metric_columns``; two for the
paper's arm, as every earlier store).

Version 2 added ``sampled_data_spectral_radius`` (NULL for PID); a version-1 store
is read (the radius reads as missing) but not resumed. Version 3 added
``rms_measured_q1 .. n``, the RMS of the error the encoder reads
(``analysis.common.metrics``). A version-2 store is read (the measured error reads as
missing) and, when a run resumes it, migrated in place: the columns are added (NULL in
the rows already there) and ``meta.unmeasured_samples`` lists the samples stored before
(``ResultStore.unrecorded``: a replay does not compare what was never recorded).

The file carries SQLite's ``application_id`` ``APPLICATION_ID`` ("posf"). Before
anything is written, an existing file is looked at read-only: a file that is not
SQLite, or an SQLite file of someone else (another application id, or other
tables), is refused and left byte for byte as it was. One ``run`` at a time
writes a store: it holds an exclusive lock on ``<file>.lock`` (released by the
operating system even if the process is killed); a second ``run`` on the same
file refuses with one line naming the one that holds it.

A store is created in one transaction (its tables and its meta), and a sample's
``samples`` row and its ``runs`` rows are written in one transaction, so a sample is
either wholly present or absent: killing the writer loses only samples not yet
committed, and a resume reruns exactly those. A sample is complete only when it has a
run of every controller of the study (``finished``); the readers (``sample_rows``,
``run_rows``) see the complete samples only, and a resume re-runs the missing runs of
the others (``missing_runs``; the runs of a sample whose ``samples`` row is gone are
replaced with it). WAL journal, ``synchronous = FULL`` (a commit survives a crash of
the process and of the machine). The store refuses to add results of a study whose
identity (every key but ``samples``) differs from the one it holds.

Faults of the file are one line each: a store whose tables or meta (``META_KEYS``) are
missing, or that SQLite finds malformed, raises ``DamagedStoreError`` and is never
adopted; a write the disk refuses (no space left, a file-size limit, an I/O error)
raises ``DiskFullError``, leaving every committed sample in place. A file holding no
posfb table yet (what a creation on a full disk leaves) is an empty store: a run fills
it, a reader refuses it as holding no results.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import resource
import socket
import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import fields, is_dataclass
from datetime import UTC, datetime
from pathlib import Path

from posfb.analysis.common.errors import (
    DISK_FULL_ERRNOS,
    DamagedStoreError,
    DiskFullError,
    UsageError,
)
from posfb.analysis.montecarlo.records import (
    STATUSES,
    SampleResult,
    measured_columns,
    metric_columns,
)
from posfb.analysis.uncertainty.study import (
    SIZED_DESIGNS,
    Study,
    canonical_text,
    identity,
    study_arm,
    study_from_text,
    study_joints,
)

SCHEMA_VERSION = "3"

#: The meta key of a migrated version-2 store: the samples stored without the
#: measured error (JSON list of indices).
UNMEASURED_KEY = "unmeasured_samples"

#: Meta key of the digest of the arm the study describes (``diagrams.arm``): the study
#: keeps only its URDF's path, so an edited URDF would otherwise resume as the same
#: study. Stores written before it lack the key and are not checked for it.
ARM_KEY = "arm"

#: SQLite ``PRAGMA application_id`` of a posfb store: "posf" in ASCII.
APPLICATION_ID = 0x706F7366

#: The first bytes of every SQLite 3 database file.
SQLITE_HEADER = b"SQLite format 3\x00"

#: The per-run column of the sampled-data spectral radius (schema version 2).
RADIUS_COLUMN = "sampled_data_spectral_radius"

#: The tables of a posfb store.
TABLES = {"meta", "samples", "runs"}

#: The meta keys a store cannot be read or resumed without.
META_KEYS = ("schema_version", "study", "identity")

#: SQLite's primary result codes (``sqlite3.Error.sqlite_errorcode & 0xFF``) of a write
#: the disk refused (``SQLITE_IOERR``, ``SQLITE_FULL``) and of a damaged file
#: (``SQLITE_CORRUPT``, ``SQLITE_NOTADB``).
SQLITE_IOERR, SQLITE_FULL, SQLITE_CORRUPT, SQLITE_NOTADB = 10, 13, 11, 26

#: Free bytes below which a refused write is put down to a full disk.
LOW_SPACE_BYTES = 1 << 16


def _schema(joints: int) -> tuple[str, ...]:
    """The statements that create the tables of a store of an arm of ``joints`` joints."""
    return (
        "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
        """CREATE TABLE IF NOT EXISTS samples (
    sample INTEGER PRIMARY KEY,
    encoder_counts INTEGER NOT NULL,
    payload_mass REAL NOT NULL,
    parameters TEXT NOT NULL,
    theta TEXT NOT NULL,
    bound_ratios TEXT NOT NULL,
    inside_bounds INTEGER NOT NULL CHECK (inside_bounds IN (0, 1)),
    code_version TEXT NOT NULL,
    finished_at TEXT NOT NULL
)""",
        f"""CREATE TABLE IF NOT EXISTS runs (
    sample INTEGER NOT NULL REFERENCES samples (sample),
    controller TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ({", ".join(repr(s) for s in STATUSES)})),
    message TEXT NOT NULL,
    {", ".join(f"{column} REAL" for column in metric_columns(joints))},
    {RADIUS_COLUMN} REAL,
    PRIMARY KEY (sample, controller)
)""",
    )


def _inspect(path: Path) -> None:
    """Refuse ``path`` unless it is missing, empty, or a posfb store (an SQLite file with
    posfb's application id, or without one but with no table other than posfb's) that is
    not damaged (``_holds_anything``); never writes."""
    if path.is_dir():
        raise UsageError(f"--db {path}: is a folder; an SQLite file name is required")
    if not path.exists() or path.stat().st_size == 0:
        return
    with path.open("rb") as file:
        if file.read(len(SQLITE_HEADER)) != SQLITE_HEADER:
            raise UsageError(f"--db {path}: not an SQLite file (left unchanged); use another --db")
    try:
        with _faults(path):  # even a reader writes its -shm file: a full disk shows here
            connection = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
            try:
                application = connection.execute("PRAGMA application_id").fetchone()[0]
                tables = _tables(connection)
                if application in (0, APPLICATION_ID) and tables <= TABLES:
                    _holds_anything(connection, path)
            finally:
                connection.close()
    except sqlite3.DatabaseError as error:
        raise UsageError(f"--db {path}: unreadable SQLite file ({error}; left unchanged)") from None
    if application not in (0, APPLICATION_ID) or not tables <= TABLES:
        raise UsageError(
            f"--db {path}: an SQLite file of another application (left unchanged); use another --db"
        )


def _tables(connection: sqlite3.Connection) -> set[str]:
    """The names of the tables of the database open in ``connection``."""
    query = "SELECT name FROM sqlite_master WHERE type = 'table'"
    return {row[0] for row in connection.execute(query)}


def _holds_anything(connection: sqlite3.Connection, path: Path) -> bool:
    """Whether the store at ``path`` holds anything: ``False`` for one with no meta and
    no row yet (to create); raise ``DamagedStoreError`` naming what is missing from one
    that holds something but not every table (``TABLES``) or meta key (``META_KEYS``)."""
    tables = _tables(connection)
    meta = {}
    if "meta" in tables:
        meta = {row[0]: row[1] for row in connection.execute("SELECT key, value FROM meta")}
    rows = any(
        connection.execute(f"SELECT EXISTS (SELECT 1 FROM {table})").fetchone()[0]
        for table in ("samples", "runs")
        if table in tables
    )
    if not meta and not rows:
        return False
    missing = [f"the {table} table" for table in sorted(TABLES - tables)]
    if not missing and not meta:
        missing = ["every meta key (the study it holds)"]
    elif not missing:
        missing = [f"meta key {key!r}" for key in META_KEYS if key not in meta]
    if missing:
        raise DamagedStoreError(
            f"--db {path}: a damaged posfb store (missing {', '.join(missing)}); it can be "
            "neither read nor resumed and is left unchanged: use another --db"
        )
    return True


def _refused_write(path: Path, error: Exception) -> str:
    """Why the disk refused a write to the store at ``path``, in a few words."""
    number = error.errno if isinstance(error, OSError) else None
    code = (getattr(error, "sqlite_errorcode", None) or 0) & 0xFF
    if number == errno.ENOSPC or code == SQLITE_FULL:
        return "no space left on device"
    try:
        status = os.statvfs(path.parent)
        if status.f_bavail * status.f_frsize < LOW_SPACE_BYTES:
            return "no space left on device"
    except OSError:
        pass
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    if number == errno.EFBIG or (code == SQLITE_IOERR and limit != resource.RLIM_INFINITY):
        return f"the file-size limit (ulimit -f) of {limit} bytes is reached"
    return os.strerror(number) if number is not None else str(error)


@contextmanager
def _faults(path: Path) -> Iterator[None]:
    """SQLite's and the system's refusals about the store at ``path`` as one-line
    faults: a write the disk refused as ``DiskFullError``, a damaged file as
    ``DamagedStoreError``; anything else (a bug) propagates as it is."""
    try:
        yield
    except sqlite3.IntegrityError:
        raise
    except sqlite3.DatabaseError as error:
        code = (error.sqlite_errorcode or 0) & 0xFF
        if code in (SQLITE_FULL, SQLITE_IOERR):
            raise _disk_full(path, error) from None
        if code in (SQLITE_CORRUPT, SQLITE_NOTADB) or str(error).startswith("no such"):
            raise DamagedStoreError(
                f"--db {path}: a damaged posfb store ({error}); it can be neither read nor "
                "resumed: use another --db"
            ) from None
        raise
    except OSError as error:
        if error.errno in DISK_FULL_ERRNOS:
            raise _disk_full(path, error) from None
        raise


def _disk_full(path: Path, error: Exception) -> DiskFullError:
    return DiskFullError(
        f"--db {path}: the disk refused a write ({_refused_write(path, error)}); every "
        "sample stored before is kept (make room, then run the same command again)"
    )


def _connect(path: Path) -> sqlite3.Connection:
    connection = sqlite3.connect(path, isolation_level=None)  # explicit transactions
    connection.row_factory = sqlite3.Row
    connection.execute("PRAGMA journal_mode = WAL")
    connection.execute("PRAGMA synchronous = FULL")
    connection.execute("PRAGMA foreign_keys = ON")
    return connection


def _differences(stored: object, current: object, key: str) -> list[str]:
    """The dotted keys below ``key`` whose values differ (dataclasses and maps walked
    field by field, anything else compared by value)."""
    if stored == current:
        return []
    if is_dataclass(stored) and type(stored) is type(current):
        parts = [(f.name, getattr(stored, f.name), getattr(current, f.name))
                 for f in fields(stored)]  # fmt: skip
    elif isinstance(stored, dict) and isinstance(current, dict):
        parts = [(str(k), stored.get(k), current.get(k)) for k in {**stored, **current}]
    else:
        return [key]
    found = [d for name, a, b in parts for d in _differences(a, b, f"{key}.{name}")]
    return found or [key]


def _differing_keys(stored: Study, study: Study) -> list[str]:
    """The study keys (dotted inside ``base``) in which ``stored`` differs from ``study``."""
    sized = study.sampling in SIZED_DESIGNS
    return [
        difference
        for key in (f.name for f in fields(Study))
        if key != "samples" or sized
        for difference in _differences(getattr(stored, key), getattr(study, key), key)
    ]


class ResultStore:
    """One results file. Use ``create_or_resume`` to write, ``open_existing`` to read."""

    def __init__(
        self, path: Path, connection: sqlite3.Connection, lock: _WriterLock | None = None
    ) -> None:
        self.path = path
        self._connection = connection
        self._lock = lock
        self._metrics: tuple[str, ...] | None = None
        self._study: Study | None = None

    @classmethod
    def create_or_resume(cls, path: str | Path, study: Study, code_version: str) -> ResultStore:
        """Open ``path`` for ``study``, creating it (and its folder) if needed; refuse,
        untouched, a file that is not a posfb store, is damaged, holds another study, or
        is being written by another run."""
        path = Path(path)
        _inspect(path)
        with _faults(path):
            path.parent.mkdir(parents=True, exist_ok=True)
            lock = _WriterLock(path)
            try:
                connection = _connect(path)
            except BaseException:
                lock.release()
                raise
            store = cls(path, connection, lock)
            try:
                if not _holds_anything(connection, path):
                    store._create(study, code_version)
                else:
                    meta = store.meta()
                    store._check_resumable(meta, study)
                    if meta["schema_version"] == "2":
                        store._migrate_from_2(study_joints(study))
            except BaseException:
                store.close()
                raise
        return store

    @classmethod
    def open_existing(cls, path: str | Path) -> ResultStore:
        """Open an existing store for reading; refuse one that holds nothing or is
        damaged."""
        path = Path(path)
        if not path.is_file() and not path.is_dir():
            raise FileNotFoundError(f"--db {path}: results do not exist")
        _inspect(path)
        if path.stat().st_size == 0:
            raise UsageError(f"--db {path}: an empty file, not a posfb store")
        with _faults(path):
            connection = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
            connection.row_factory = sqlite3.Row
            try:
                if not _holds_anything(connection, path):
                    raise UsageError(
                        f"--db {path}: holds no results yet (a store whose first run wrote "
                        "nothing); run posfb montecarlo run into it first"
                    )
            except BaseException:
                connection.close()
                raise
        return cls(path, connection)

    def _create(self, study: Study, code_version: str) -> None:
        """The tables and the meta of a new store for ``study``, in one transaction."""
        values = {
            "schema_version": SCHEMA_VERSION,
            "study": canonical_text(study),
            "identity": identity(study),
            ARM_KEY: study_arm(study).digest,
            "code_version": code_version,
            "created_at": datetime.now(UTC).isoformat(timespec="seconds"),
        }
        with self._transaction() as connection:
            connection.execute(f"PRAGMA application_id = {APPLICATION_ID}")
            for statement in _schema(study_joints(study)):
                connection.execute(statement)
            connection.executemany("INSERT INTO meta VALUES (?, ?)", values.items())

    def _migrate_from_2(self, joints: int) -> None:
        """Add the version-3 columns to a version-2 store, in one transaction (module
        docstring)."""
        with self._transaction():
            for column in measured_columns(joints):
                self._connection.execute(f"ALTER TABLE runs ADD COLUMN {column} REAL")
            stored = [row[0] for row in self._connection.execute("SELECT sample FROM samples")]
            self._connection.execute(
                "INSERT INTO meta VALUES (?, ?)", (UNMEASURED_KEY, json.dumps(sorted(stored)))
            )
            self._connection.execute(
                "UPDATE meta SET value = ? WHERE key = 'schema_version'", (SCHEMA_VERSION,)
            )

    def unrecorded(self, sample: int) -> tuple[str, ...]:
        """The ``runs`` columns the store did not record for ``sample`` (they read as
        ``None``): the radius in a version-1 store, the measured error in a version-1
        or 2 store and for the samples a migrated store held before (module docstring)."""
        meta = self.meta()
        version, joints = meta.get("schema_version"), study_joints(self.study())
        unmeasured = json.loads(meta.get(UNMEASURED_KEY, "[]"))
        columns = (RADIUS_COLUMN,) if version == "1" else ()
        if version in ("1", "2") or sample in unmeasured:
            columns += measured_columns(joints)
        return columns

    def _check_resumable(self, meta: dict[str, str], study: Study) -> None:
        if meta.get("schema_version") not in (SCHEMA_VERSION, "2"):
            raise UsageError(
                f"{self.path} has schema version {meta.get('schema_version')!r}; "
                f"this posfb writes {SCHEMA_VERSION!r}"
            )
        arm = study_arm(study)
        if meta.get(ARM_KEY, arm.digest) != arm.digest:
            raise UsageError(
                f"{self.path} holds results for another arm than {arm} (stored digest "
                f"{meta[ARM_KEY][:12]}): its URDF changed since the store was written; run "
                "the study into another store"
            )
        if meta["identity"] != identity(study):
            keys = _differing_keys(self.study(), study)
            if keys:
                shown = ", ".join(keys[:4]) + (f" and {len(keys) - 4} more" if keys[4:] else "")
                raise UsageError(
                    f"{self.path} holds results of a different study (differs in {shown}); "
                    "run this one into another store"
                )
            raise UsageError(
                f"{self.path} holds this study as an earlier posfb wrote it (its settings "
                "read the same now, but it was stored before settings posfb has added since, "
                "so its runs were judged by that version); report it as it is, or run the "
                "study into another store"
            )

    def _transaction(self) -> _Transaction:
        return _Transaction(self._connection)

    def meta(self) -> dict[str, str]:
        with _faults(self.path):
            rows = self._connection.execute("SELECT * FROM meta").fetchall()
        return {row["key"]: row["value"] for row in rows}

    def study(self) -> Study:
        """The study these results belong to (with the sample count it was created with)."""
        if self._study is None:
            text = self.meta()["study"]
            self._study = study_from_text(text, source=f"study stored in {self.path}")
        return self._study

    def _complete(self) -> tuple[str, tuple[object, ...]]:
        """The query of the complete samples' indices (a run of every controller of the
        study) and its arguments."""
        controllers = tuple(self.study().controllers)
        query = (
            "SELECT s.sample FROM samples AS s WHERE (SELECT count(*) FROM runs AS r WHERE "
            f"r.sample = s.sample AND r.controller IN ({', '.join('?' * len(controllers))})) = ?"
        )
        return query, (*controllers, len(controllers))

    def finished(self) -> set[int]:
        """Indices of the complete samples: stored with a run of every controller."""
        query, arguments = self._complete()
        with _faults(self.path):
            return {row[0] for row in self._connection.execute(query, arguments)}

    def missing_runs(self) -> dict[int, tuple[str, ...]]:
        """The samples stored without a run of some controller of the study, each with
        those controllers (in the study's order): what a resume runs for them."""
        controllers = self.study().controllers
        connection = self._connection
        with _faults(self.path):
            stored = {row[0]: set() for row in connection.execute("SELECT sample FROM samples")}
            for sample, controller in connection.execute("SELECT sample, controller FROM runs"):
                stored.get(sample, set()).add(controller)
        return {
            sample: tuple(c for c in controllers if c not in present)
            for sample, present in stored.items()
            if not set(controllers) <= present
        }

    def write(self, result: SampleResult, code_version: str) -> None:
        """Store one finished sample and its runs in one transaction. For a sample stored
        already (with runs missing, ``missing_runs``) only the runs are added; runs left
        of a sample whose ``samples`` row is gone are replaced with it."""
        if self._metrics is None:
            self._metrics = metric_columns(study_joints(self.study()))
        metrics = self._metrics
        names = ("sample", "controller", "status", "message", *metrics, RADIUS_COLUMN)
        columns, marks = ", ".join(names), ", ".join("?" * len(names))
        with _faults(self.path), self._transaction() as connection:
            query = "SELECT EXISTS (SELECT 1 FROM samples WHERE sample = ?)"
            if not connection.execute(query, (result.index,)).fetchone()[0]:
                connection.execute("DELETE FROM runs WHERE sample = ?", (result.index,))
                connection.execute(
                    "INSERT INTO samples VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    (
                        result.index,
                        result.encoder_counts,
                        float(result.parameters["payload_mass"]),
                        json.dumps(result.parameters),
                        json.dumps(result.theta),
                        json.dumps(result.bound_ratios),
                        int(result.inside_bounds),
                        code_version,
                        datetime.now(UTC).isoformat(timespec="seconds"),
                    ),
                )
            connection.executemany(
                f"INSERT INTO runs ({columns}) VALUES ({marks})",
                [
                    (
                        result.index,
                        run.controller,
                        run.status,
                        run.message,
                        *(run.metrics.get(column) for column in metrics),
                        run.spectral_radius,
                    )
                    for run in result.runs
                ],
            )

    def sample_rows(self, sample: int | None = None) -> list[dict[str, object]]:
        """Every ``samples`` row of a complete sample (``finished``; JSON columns
        decoded), by sample index; only sample ``sample``'s where given."""
        query, arguments = _where("SELECT * FROM samples", self._complete(), sample)
        rows = []
        with _faults(self.path):
            found = self._connection.execute(f"{query} ORDER BY sample", arguments).fetchall()
        for row in found:
            record = dict(row)
            for key in ("parameters", "theta", "bound_ratios"):
                record[key] = json.loads(record[key])
            record["inside_bounds"] = bool(record["inside_bounds"])
            rows.append(record)
        return rows

    def run_rows(self, sample: int | None = None) -> list[dict[str, object]]:
        """Every ``runs`` row of a complete sample, by sample index and controller (the
        columns an older store lacks read as ``None``, ``unrecorded``); only sample
        ``sample``'s where given."""
        query, arguments = _where("SELECT * FROM runs", self._complete(), sample)
        joints = study_joints(self.study())
        missing = dict.fromkeys((*measured_columns(joints), RADIUS_COLUMN))
        with _faults(self.path):
            found = self._connection.execute(f"{query} ORDER BY sample, controller", arguments)
            return [{**missing, **dict(row)} for row in found.fetchall()]

    def close(self) -> None:
        self._connection.close()
        if self._lock is not None:
            self._lock.release()

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _where(
    select: str, complete: tuple[str, tuple[object, ...]], sample: int | None
) -> tuple[str, tuple[object, ...]]:
    """``select`` restricted to the complete samples (``ResultStore._complete``), and to
    sample ``sample`` where given."""
    query, arguments = complete
    if sample is None:
        return f"{select} WHERE sample IN ({query})", arguments
    return f"{select} WHERE sample IN ({query}) AND sample = ?", (*arguments, int(sample))


class _WriterLock:
    """An exclusive ``flock`` on ``<store>.lock`` for as long as one run writes the store;
    the file names the holder (host, pid, start time) for the refusal message."""

    def __init__(self, store: Path) -> None:
        self.path = store.with_name(store.name + ".lock")
        self._file = self.path.open("a+")
        try:
            fcntl.flock(self._file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._file.seek(0)
            holder = self._file.read().strip() or "another process"
            self._file.close()
            raise UsageError(
                f"--db {store}: another posfb run is writing it ({holder}); wait for it to "
                "finish or use another --db"
            ) from None
        try:
            self._file.seek(0)
            self._file.truncate()
            started = datetime.now(UTC).isoformat(timespec="seconds")
            self._file.write(f"host {socket.gethostname()}, pid {os.getpid()}, since {started}")
            self._file.flush()
        except OSError:  # a full disk: the caller reports it
            self.release()
            raise

    def release(self) -> None:
        if not self._file.closed:
            fcntl.flock(self._file, fcntl.LOCK_UN)
            with suppress(OSError):  # the holder's line could not be flushed (a full disk)
                self._file.close()


class _Transaction:
    """``BEGIN IMMEDIATE`` ... ``COMMIT`` (``ROLLBACK`` on an exception, unless SQLite
    rolled back itself, as on a full disk)."""

    def __init__(self, connection: sqlite3.Connection) -> None:
        self._connection = connection

    def __enter__(self) -> sqlite3.Connection:
        self._connection.execute("BEGIN IMMEDIATE")
        return self._connection

    def __exit__(self, kind: type | None, *rest: object) -> None:
        if kind is None:
            self._connection.execute("COMMIT")
        elif self._connection.in_transaction:
            self._connection.execute("ROLLBACK")
