"""The results of a study in one SQLite file: durable, resumable, self-describing.

Schema (version 1)::

    meta(key PRIMARY KEY, value)      -- schema_version, study (canonical YAML),
                                      -- identity, code_version, created_at
    samples(sample PRIMARY KEY, encoder_counts, payload_mass,
            parameters JSON, theta JSON, bound_ratios JSON, inside_bounds,
            code_version, finished_at)
    runs(sample, controller, status, message,
         rms_q1, rms_q2, rms_u1, rms_u2, max_abs_q_err, saturated_fraction,
         wall_time_s, PRIMARY KEY (sample, controller))

A sample's ``samples`` row and its ``runs`` rows are written in one
transaction, so a sample is either wholly present or absent: killing the
writer loses only samples not yet committed, and a resume reruns exactly
those. WAL journal, ``synchronous = FULL`` (a commit survives a crash of the
process and of the machine). The store refuses to add results of a study
whose identity (every key but ``samples``) differs from the one it holds.
"""

from __future__ import annotations

import json
import sqlite3
from dataclasses import fields
from datetime import UTC, datetime
from pathlib import Path

from posfb.analysis.errors import UsageError
from posfb.analysis.montecarlo.config import Study, canonical_text, identity, study_from_text
from posfb.analysis.montecarlo.records import METRIC_COLUMNS, STATUSES, SampleResult

SCHEMA_VERSION = "1"

_SCHEMA = f"""
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
    {", ".join(f"{column} REAL" for column in METRIC_COLUMNS)},
    PRIMARY KEY (sample, controller)
);
"""


def _connect(path: Path) -> sqlite3.Connection:
    connection = sqlite3.connect(path, isolation_level=None)  # explicit transactions
    connection.row_factory = sqlite3.Row
    connection.execute("PRAGMA journal_mode = WAL")
    connection.execute("PRAGMA synchronous = FULL")
    connection.execute("PRAGMA foreign_keys = ON")
    return connection


def _differing_keys(stored: Study, study: Study) -> list[str]:
    return [
        key
        for key in (f.name for f in fields(Study))
        if key != "samples" and getattr(stored, key) != getattr(study, key)
    ]


class ResultStore:
    """One results file. Use ``create_or_resume`` to write, ``open_existing`` to read."""

    def __init__(self, path: Path, connection: sqlite3.Connection) -> None:
        self.path = path
        self._connection = connection

    @classmethod
    def create_or_resume(cls, path: str | Path, study: Study, code_version: str) -> ResultStore:
        """Open ``path`` for ``study``, creating it if needed; refuse a file that holds
        another study or is not a posfb results file."""
        path = Path(path)
        connection = _connect(path)
        store = cls(path, connection)
        try:
            tables = {row[0] for row in connection.execute("SELECT name FROM sqlite_master")}
            if tables and "meta" not in tables:
                raise UsageError(f"{path} is an SQLite file but not a posfb Monte-Carlo store")
            connection.executescript(_SCHEMA)
            meta = store.meta()
            if not meta:
                store._write_meta(study, code_version)
            else:
                store._check_resumable(meta, study)
        except BaseException:
            connection.close()
            raise
        return store

    @classmethod
    def open_existing(cls, path: str | Path) -> ResultStore:
        """Open an existing store for reading."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"results {path} do not exist")
        connection = _connect(path)
        tables = {row[0] for row in connection.execute("SELECT name FROM sqlite_master")}
        if not {"meta", "samples", "runs"} <= tables:
            connection.close()
            raise UsageError(f"{path} is not a posfb Monte-Carlo store")
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

    def _check_resumable(self, meta: dict[str, str], study: Study) -> None:
        if meta.get("schema_version") != SCHEMA_VERSION:
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
        columns = ", ".join(("sample", "controller", "status", "message", *METRIC_COLUMNS))
        marks = ", ".join("?" * (4 + len(METRIC_COLUMNS)))
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
                        *(run.metrics.get(column) for column in METRIC_COLUMNS),
                    )
                    for run in result.runs
                ],
            )

    def sample_rows(self) -> list[dict[str, object]]:
        """Every ``samples`` row (JSON columns decoded), by sample index."""
        rows = []
        for row in self._connection.execute("SELECT * FROM samples ORDER BY sample"):
            record = dict(row)
            for key in ("parameters", "theta", "bound_ratios"):
                record[key] = json.loads(record[key])
            record["inside_bounds"] = bool(record["inside_bounds"])
            rows.append(record)
        return rows

    def run_rows(self) -> list[dict[str, object]]:
        """Every ``runs`` row, by sample index and controller."""
        query = "SELECT * FROM runs ORDER BY sample, controller"
        return [dict(row) for row in self._connection.execute(query)]

    def close(self) -> None:
        self._connection.close()

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Transaction:
    """``BEGIN IMMEDIATE`` ... ``COMMIT`` (``ROLLBACK`` on an exception)."""

    def __init__(self, connection: sqlite3.Connection) -> None:
        self._connection = connection

    def __enter__(self) -> sqlite3.Connection:
        self._connection.execute("BEGIN IMMEDIATE")
        return self._connection

    def __exit__(self, kind: type | None, *rest: object) -> None:
        self._connection.execute("COMMIT" if kind is None else "ROLLBACK")
