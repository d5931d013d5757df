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
(``analysis.metrics``). A version-2 store is read (the measured error reads as
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

A sample's ``samples`` row and its ``runs`` rows are written in one
transaction, so a sample is either wholly present or absent: killing the
writer loses only samples not yet committed, and a resume reruns exactly
those. WAL journal, ``synchronous = FULL`` (a commit survives a crash of the
process and of the machine). The store refuses to add results of a study
whose identity (every key but ``samples``) differs from the one it holds.
"""

from __future__ import annotations

import fcntl
import json
import os
import socket
import sqlite3
from dataclasses import fields
from datetime import UTC, datetime
from pathlib import Path

from posfb.analysis.errors import UsageError
from posfb.analysis.montecarlo.config import (
    SIZED_DESIGNS,
    Study,
    canonical_text,
    identity,
    study_from_text,
    study_joints,
)
from posfb.analysis.montecarlo.records import (
    STATUSES,
    SampleResult,
    measured_columns,
    metric_columns,
)

SCHEMA_VERSION = "3"

#: The meta key of a migrated version-2 store: the samples stored without the
#: measured error (JSON list of indices).
UNMEASURED_KEY = "unmeasured_samples"

#: SQLite ``PRAGMA application_id`` of a posfb store: "posf" in ASCII.
APPLICATION_ID = 0x706F7366

#: The first bytes of every SQLite 3 database file.
SQLITE_HEADER = b"SQLite format 3\x00"

#: The per-run column of the sampled-data spectral radius (schema version 2).
RADIUS_COLUMN = "sampled_data_spectral_radius"

#: The tables of a posfb store.
TABLES = {"meta", "samples", "runs"}


def _schema(joints: int) -> str:
    """The tables of a store of an arm of ``joints`` joints."""
    return f"""
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS samples (
    sample INTEGER PRIMARY KEY,
    encoder_counts INTEGER NOT NULL,
    payload_mass REAL NOT NULL,
    parameters TEXT NOT NULL,
    theta TEXT NOT NULL,
    bound_ratios TEXT NOT NULL,
    inside_bounds INTEGER NOT NULL CHECK (inside_bounds IN (0, 1)),
    code_version TEXT NOT NULL,
    finished_at TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS runs (
    sample INTEGER NOT NULL REFERENCES samples (sample),
    controller TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ({", ".join(repr(s) for s in STATUSES)})),
    message TEXT NOT NULL,
    {", ".join(f"{column} REAL" for column in metric_columns(joints))},
    {RADIUS_COLUMN} REAL,
    PRIMARY KEY (sample, controller)
);
"""


def _inspect(path: Path) -> None:
    """Refuse ``path`` unless it is missing, empty, or a posfb store; never writes."""
    if path.is_dir():
        raise UsageError(f"--db {path}: is a folder; an SQLite file name is required")
    if not path.exists() or path.stat().st_size == 0:
        return
    with path.open("rb") as file:
        if file.read(len(SQLITE_HEADER)) != SQLITE_HEADER:
            raise UsageError(f"--db {path}: not an SQLite file (left unchanged); use another --db")
    try:
        connection = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
        try:
            application = connection.execute("PRAGMA application_id").fetchone()[0]
            tables = {
                row[0]
                for row in connection.execute("SELECT name FROM sqlite_master WHERE type = 'table'")
            }
        finally:
            connection.close()
    except sqlite3.DatabaseError as error:
        raise UsageError(f"--db {path}: unreadable SQLite file ({error}; left unchanged)") from None
    ours = application == APPLICATION_ID or (application == 0 and tables == TABLES)
    if not ours or not tables <= TABLES:
        raise UsageError(
            f"--db {path}: an SQLite file of another application (left unchanged); use "
            "another --db"
        )


def _connect(path: Path) -> sqlite3.Connection:
    connection = sqlite3.connect(path, isolation_level=None)  # explicit transactions
    connection.row_factory = sqlite3.Row
    connection.execute("PRAGMA journal_mode = WAL")
    connection.execute("PRAGMA synchronous = FULL")
    connection.execute("PRAGMA foreign_keys = ON")
    return connection


def _differing_keys(stored: Study, study: Study) -> list[str]:
    sized = study.sampling in SIZED_DESIGNS
    return [
        key
        for key in (f.name for f in fields(Study))
        if (key != "samples" or sized) and getattr(stored, key) != getattr(study, key)
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

    @classmethod
    def create_or_resume(cls, path: str | Path, study: Study, code_version: str) -> ResultStore:
        """Open ``path`` for ``study``, creating it (and its folder) if needed; refuse,
        untouched, a file that is not a posfb store, holds another study, or is being
        written by another run."""
        path = Path(path)
        _inspect(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = _WriterLock(path)
        try:
            connection = _connect(path)
        except BaseException:
            lock.release()
            raise
        store = cls(path, connection, lock)
        try:
            connection.execute(f"PRAGMA application_id = {APPLICATION_ID}")
            connection.executescript(_schema(study_joints(study)))
            meta = store.meta()
            if not meta:
                store._write_meta(study, code_version)
            else:
                store._check_resumable(meta, study)
                if meta["schema_version"] == "2":
                    store._migrate_from_2(study_joints(study))
        except BaseException:
            connection.close()
            raise
        return store

    @classmethod
    def open_existing(cls, path: str | Path) -> ResultStore:
        """Open an existing store for reading."""
        path = Path(path)
        if not path.is_file() and not path.is_dir():
            raise FileNotFoundError(f"--db {path}: results do not exist")
        _inspect(path)
        if path.stat().st_size == 0:
            raise UsageError(f"--db {path}: an empty file, not a posfb store")
        connection = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
        connection.row_factory = sqlite3.Row
        return cls(path, connection)

    def _write_meta(self, study: Study, code_version: str) -> None:
        values = {
            "schema_version": SCHEMA_VERSION,
            "study": canonical_text(study),
            "identity": identity(study),
            "code_version": code_version,
            "created_at": datetime.now(UTC).isoformat(timespec="seconds"),
        }
        with self._transaction():
            self._connection.executemany("INSERT INTO meta VALUES (?, ?)", values.items())

    def _migrate_from_2(self, joints: int) -> None:
        """Add the version-3 columns to a version-2 store, in one transaction (module
        docstring)."""
        with self._transaction():
            for column in measured_columns(joints):
                self._connection.execute(f"ALTER TABLE runs ADD COLUMN {column} REAL")
            self._connection.execute(
                "INSERT INTO meta VALUES (?, ?)",
                (UNMEASURED_KEY, json.dumps(sorted(self.finished()))),
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
        if meta["identity"] != identity(study):
            keys = _differing_keys(self.study(), study)
            raise UsageError(
                f"{self.path} holds results of a different study (differs in "
                f"{', '.join(keys) or 'its canonical form'}); use another --db to run this one"
            )

    def _transaction(self) -> _Transaction:
        return _Transaction(self._connection)

    def meta(self) -> dict[str, str]:
        return {row["key"]: row["value"] for row in self._connection.execute("SELECT * FROM meta")}

    def study(self) -> Study:
        """The study these results belong to (with the sample count it was created with)."""
        return study_from_text(self.meta()["study"], source=f"study stored in {self.path}")

    def finished(self) -> set[int]:
        """Indices of the samples already stored."""
        return {row[0] for row in self._connection.execute("SELECT sample FROM samples")}

    def write(self, result: SampleResult, code_version: str) -> None:
        """Store one finished sample and its runs in one transaction."""
        if self._metrics is None:
            self._metrics = metric_columns(study_joints(self.study()))
        metrics = self._metrics
        names = ("sample", "controller", "status", "message", *metrics, RADIUS_COLUMN)
        columns, marks = ", ".join(names), ", ".join("?" * len(names))
        with self._transaction():
            self._connection.execute(
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
            self._connection.executemany(
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
        """Every ``samples`` row (JSON columns decoded), by sample index; only sample
        ``sample``'s where given."""
        query, arguments = _where("SELECT * FROM samples", sample, "ORDER BY sample")
        rows = []
        for row in self._connection.execute(query, arguments):
            record = dict(row)
            for key in ("parameters", "theta", "bound_ratios"):
                record[key] = json.loads(record[key])
            record["inside_bounds"] = bool(record["inside_bounds"])
            rows.append(record)
        return rows

    def run_rows(self, sample: int | None = None) -> list[dict[str, object]]:
        """Every ``runs`` row, by sample index and controller (the columns an older
        store lacks read as ``None``, ``unrecorded``); only sample ``sample``'s where
        given."""
        query, arguments = _where("SELECT * FROM runs", sample, "ORDER BY sample, controller")
        joints = study_joints(self.study())
        missing = dict.fromkeys((*measured_columns(joints), RADIUS_COLUMN))
        return [{**missing, **dict(row)} for row in self._connection.execute(query, arguments)]

    def close(self) -> None:
        self._connection.close()
        if self._lock is not None:
            self._lock.release()

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _where(select: str, sample: int | None, order: str) -> tuple[str, tuple[int, ...]]:
    """``select`` restricted to one sample where given, then ``order``."""
    if sample is None:
        return f"{select} {order}", ()
    return f"{select} WHERE sample = ? {order}", (int(sample),)


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
        self._file.seek(0)
        self._file.truncate()
        started = datetime.now(UTC).isoformat(timespec="seconds")
        self._file.write(f"host {socket.gethostname()}, pid {os.getpid()}, since {started}")
        self._file.flush()

    def release(self) -> None:
        if not self._file.closed:
            fcntl.flock(self._file, fcntl.LOCK_UN)
            self._file.close()


class _Transaction:
    """``BEGIN IMMEDIATE`` ... ``COMMIT`` (``ROLLBACK`` on an exception)."""

    def __init__(self, connection: sqlite3.Connection) -> None:
        self._connection = connection

    def __enter__(self) -> sqlite3.Connection:
        self._connection.execute("BEGIN IMMEDIATE")
        return self._connection

    def __exit__(self, kind: type | None, *rest: object) -> None:
        self._connection.execute("COMMIT" if kind is None else "ROLLBACK")
