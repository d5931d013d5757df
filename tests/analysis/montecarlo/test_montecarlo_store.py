"""The SQLite store: one transaction per sample, resume, refusal of another study."""

from __future__ import annotations

import sqlite3
from dataclasses import replace

import pytest

from helpers.montecarlo_helpers import EARLIER_STORE, TINY_STUDY, make_result
from posfb.analysis.common.errors import UsageError
from posfb.analysis.montecarlo.records import STATUSES, ControllerRun
from posfb.analysis.montecarlo.results import load, status_counts
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.uncertainty.study import study_from_text


@pytest.fixture()
def study():
    return study_from_text(TINY_STUDY)


def test_a_sample_and_its_runs_round_trip(tmp_path, study):
    with ResultStore.create_or_resume(tmp_path / "r.sqlite", study, "v1") as store:
        store.write(make_result(2), "v1")
        assert store.finished() == {2}
        (sample,) = store.sample_rows()
        runs = store.run_rows()
    assert sample["parameters"]["link_mass"] == [5.0, 0.9]
    assert sample["payload_mass"] == pytest.approx(0.2)
    assert sample["inside_bounds"] is False and sample["code_version"] == "v1"
    assert [r["controller"] for r in runs] == ["pid", "proposed"]
    assert runs[0]["rms_q2"] == pytest.approx(0.003 * 2)


def test_a_sample_is_written_whole_or_not_at_all(tmp_path, study):
    with ResultStore.create_or_resume(tmp_path / "r.sqlite", study, "v1") as store:
        store.write(make_result(0), "v1")
        with pytest.raises(sqlite3.IntegrityError):
            store.write(make_result(0), "v1")  # already there: the whole sample is refused
        broken = replace(make_result(1), runs=(make_result(1).runs[0],) * 2)
        with pytest.raises(sqlite3.IntegrityError):
            store.write(broken, "v1")  # second run fails: the sample row is rolled back too
        assert store.finished() == {0}
        assert len(store.run_rows()) == 2


def test_resume_keeps_results_and_accepts_a_new_sample_count(tmp_path, study):
    path = tmp_path / "r.sqlite"
    with ResultStore.create_or_resume(path, study, "v1") as store:
        store.write(make_result(0), "v1")
    with ResultStore.create_or_resume(path, replace(study, samples=40), "v2") as store:
        assert store.finished() == {0}
        assert store.meta()["code_version"] == "v1"
        assert store.study() == study


def test_resume_under_another_study_is_refused_naming_the_difference(tmp_path, study):
    path = tmp_path / "r.sqlite"
    ResultStore.create_or_resume(path, study, "v1").close()
    with pytest.raises(UsageError, match="differs in seed"):
        ResultStore.create_or_resume(path, replace(study, seed=99), "v1")
    with pytest.raises(UsageError, match="controllers"):
        ResultStore.create_or_resume(path, replace(study, controllers=["pid"]), "v1")


def test_other_sqlite_files_are_refused(tmp_path, study):
    path = tmp_path / "other.sqlite"
    with sqlite3.connect(path) as connection:
        connection.execute("CREATE TABLE things (x)")
    with pytest.raises(UsageError, match="another application"):
        ResultStore.create_or_resume(path, study, "v1")
    with pytest.raises(UsageError, match="another application"):
        ResultStore.open_existing(path)
    with pytest.raises(FileNotFoundError):
        ResultStore.open_existing(tmp_path / "missing.sqlite")


def test_invalid_status_is_refused():
    with pytest.raises(ValueError, match="status"):
        ControllerRun("pid", "exploded", "", {})


def test_foreign_files_are_refused_and_left_byte_for_byte(tmp_path, study):
    text = tmp_path / "notes.sqlite"
    text.write_bytes(b"not a database\n")
    foreign = tmp_path / "foreign.sqlite"
    with sqlite3.connect(foreign) as connection:
        connection.execute("CREATE TABLE meta (key, value)")  # a look-alike, no posfb id
        connection.execute("CREATE TABLE other (x)")
    for path, needle in ((text, "not an SQLite file"), (foreign, "another application")):
        before = path.read_bytes()
        with pytest.raises(UsageError, match=needle):
            ResultStore.create_or_resume(path, study, "v1")
        assert path.read_bytes() == before
        assert not path.with_name(path.name + "-wal").exists()


def test_a_second_writer_is_refused_naming_the_first(tmp_path, study):
    path = tmp_path / "store.sqlite"
    first = ResultStore.create_or_resume(path, study, "v1")
    with pytest.raises(UsageError, match=r"another posfb run is writing it \(host .*, pid \d+"):
        ResultStore.create_or_resume(path, study, "v1")
    first.close()
    ResultStore.create_or_resume(path, study, "v1").close()  # the lock went with the first


def _as_version_2(path):
    """Turn a store into what posfb wrote before schema version 3 (no measured error)."""
    connection = sqlite3.connect(path)
    with connection:
        for column in ("rms_measured_q1", "rms_measured_q2"):
            connection.execute(f"ALTER TABLE runs DROP COLUMN {column}")
        connection.execute("UPDATE meta SET value = '2' WHERE key = 'schema_version'")
    connection.close()


def test_a_version_2_store_reads_and_resumes_with_its_samples_marked_unmeasured(tmp_path, study):
    path = tmp_path / "r.sqlite"
    with ResultStore.create_or_resume(path, study, "v1") as store:
        store.write(make_result(0), "v1")
    _as_version_2(path)
    with ResultStore.open_existing(path) as store:  # read as it is: the columns read None
        assert store.run_rows()[0]["rms_measured_q1"] is None
        assert store.unrecorded(0) == ("rms_measured_q1", "rms_measured_q2")
    with ResultStore.create_or_resume(path, study, "v2") as store:  # resumed: migrated
        store.write(make_result(1), "v2")
        assert store.meta()["schema_version"] == "3"
        runs = {row["sample"]: row for row in store.run_rows()}
        assert runs[0]["rms_measured_q1"] is None and runs[1]["rms_measured_q1"] is not None
        assert runs[0]["rms_q1"] == make_result(0).runs[0].metrics["rms_q1"]
        assert store.unrecorded(0) == ("rms_measured_q1", "rms_measured_q2")
        assert store.unrecorded(1) == ()
    with ResultStore.create_or_resume(path, study, "v3") as store:  # migrated once only
        assert store.unrecorded(1) == ()


def test_every_status_is_stored_and_read_back(tmp_path, study):
    with ResultStore.create_or_resume(tmp_path / "r.sqlite", study, "v1") as store:
        for index, status in enumerate(STATUSES):
            store.write(make_result(index, status=status), "v1")
        stored = {row["sample"]: row["status"] for row in store.run_rows()}
    assert {"saturated", "lost"} <= set(STATUSES)
    assert stored == dict(enumerate(STATUSES))


def test_a_store_written_before_the_new_statuses_reads_and_is_not_resumed(tmp_path):
    # Its CHECK constraint knows ok/diverged/error only; the new posfb reads it as it is
    # and never writes a new status into it: the study's base now holds the verdict's
    # bounds, so its identity differs and a resume is refused in one line.
    path = tmp_path / "earlier.sqlite"
    path.write_bytes(EARLIER_STORE.read_bytes())
    with sqlite3.connect(path) as connection:
        query = "SELECT sql FROM sqlite_master WHERE name = 'runs'"
        (schema,) = connection.execute(query).fetchone()
    assert "'saturated'" not in schema
    with ResultStore.open_existing(path) as store:
        study, samples = store.study(), len(store.finished())
        counts = status_counts(load(store))
    assert all(c == {**dict.fromkeys(STATUSES, 0), "ok": samples} for c in counts.values())
    with pytest.raises(UsageError, match="as an earlier posfb wrote it"):
        ResultStore.create_or_resume(path, study, "v2")


def test_a_store_of_an_edited_urdf_is_not_resumed(tmp_path):
    """The study keeps its URDF's path only; the store also keeps the arm's digest
    (``diagrams.arm``), so after the file is edited (a heavier link 2) a resume is
    refused naming the arm, while the unedited file resumes."""
    from posfb.models.plant import DEFAULT_URDF

    urdf = tmp_path / "arm.urdf"
    urdf.write_text(DEFAULT_URDF.read_text())
    text = TINY_STUDY + f"settings: [plant.urdf={urdf}]\n"
    path = tmp_path / "store.sqlite"
    ResultStore.create_or_resume(path, study_from_text(text), "v").close()
    ResultStore.create_or_resume(path, study_from_text(text), "v").close()
    edited = DEFAULT_URDF.read_text().replace('<mass value="0.873"/>', '<mass value="0.9"/>')
    assert edited != DEFAULT_URDF.read_text()
    urdf.write_text(edited)
    with pytest.raises(UsageError, match="holds results for another arm than the 2-joint arm"):
        ResultStore.create_or_resume(path, study_from_text(text), "v")
