"""Faults outside posfb in a Monte-Carlo study, each one line and its own exit code, with
what finished kept: a store missing runs or its meta, a hand-damaged store, a full disk
(a real one: a small tmpfs, or a file-size limit), a worker killed by SIGKILL, and a
sample count no design can hold."""

from __future__ import annotations

import os
import signal
import sqlite3

import pytest

from helpers.montecarlo_helpers import (
    TINY_STUDY,
    SmallDisk,
    all_rows,
    made_up_evaluate,
    make_result,
    write_killer_study,
    write_study,
)
from posfb.analysis.cli import main
from posfb.analysis.common.errors import (
    EXIT_DAMAGED_STORE,
    EXIT_DISK_FULL,
    EXIT_WORKER_DIED,
    DamagedStoreError,
)
from posfb.analysis.montecarlo.scheduler import WORKER_DIED, run_study
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.uncertainty.study import MAX_SAMPLES, study_from_text


@pytest.fixture()
def study():
    return study_from_text(TINY_STUDY.replace("samples: 4", "samples: 3"))


def _stored(path, study) -> None:
    with ResultStore.create_or_resume(path, study, "v1") as store:
        for index in range(study.samples):
            store.write(make_result(index), "v1")


def _by_hand(path, *statements: str) -> None:
    """Edit the store as a user with the sqlite3 shell would (foreign keys off)."""
    connection = sqlite3.connect(path)
    with connection:
        for statement in statements:
            connection.execute(statement)
    connection.close()


def test_a_sample_missing_a_run_is_incomplete_and_its_run_is_rerun(tmp_path, study):
    path = tmp_path / "r.sqlite"
    _stored(path, study)
    _by_hand(path, "DELETE FROM runs WHERE sample = 1 AND controller = 'pid'")
    kept = [row for row in all_rows(path)[1] if row["sample"] != 1]
    with ResultStore.create_or_resume(path, study, "v2") as store:
        assert store.finished() == {0, 2}
        assert store.missing_runs() == {1: ("pid",)}
        assert [row["sample"] for row in store.sample_rows()] == [0, 2]  # readers skip it
        summary = run_study(study, store, "v2", progress=False, evaluate=made_up_evaluate)
        assert (summary.already_done, summary.written) == (2, 1)
        assert store.finished() == {0, 1, 2} and store.missing_runs() == {}
        runs = store.run_rows()
    assert sorted((r["sample"], r["controller"]) for r in runs) == sorted(
        (i, c) for i in range(3) for c in ("pid", "proposed")
    )
    assert [row for row in runs if row["sample"] != 1] == kept  # the others untouched


def test_runs_left_without_their_sample_row_are_replaced_on_resume(tmp_path, study):
    path = tmp_path / "r.sqlite"
    _stored(path, study)
    _by_hand(path, "DELETE FROM samples WHERE sample = 2")  # its runs stay behind
    with ResultStore.create_or_resume(path, study, "v2") as store:
        assert store.finished() == {0, 1}
        summary = run_study(study, store, "v2", progress=False, evaluate=made_up_evaluate)
        assert summary.written == 1 and store.finished() == {0, 1, 2}
        assert len(store.run_rows()) == 6


@pytest.mark.parametrize(
    ("damage", "missing"),
    [
        ("DROP TABLE meta", "missing the meta table"),
        ("DELETE FROM meta WHERE key = 'study'", "missing meta key 'study'"),
        ("DELETE FROM meta", "missing every meta key"),
        ("DROP TABLE runs", "missing the runs table"),
    ],
)
def test_a_store_missing_its_meta_or_a_table_is_refused_untouched(tmp_path, study, damage, missing):
    path = tmp_path / "r.sqlite"
    _stored(path, study)
    _by_hand(path, damage)
    before = path.read_bytes()
    for open_it in (
        lambda: ResultStore.create_or_resume(path, study, "v2"),
        lambda: ResultStore.open_existing(path),
    ):
        with pytest.raises(DamagedStoreError, match=f"{path}: a damaged posfb store \\({missing}"):
            open_it()
    assert path.read_bytes() == before


@pytest.mark.slow
def test_damaged_stores_are_one_line_and_their_own_exit_code_in_every_command(tmp_path, capsys):
    study = study_from_text(TINY_STUDY)
    path = tmp_path / "r.sqlite"
    _stored(path, study)
    _by_hand(path, "DROP TABLE meta")
    spec = write_study(tmp_path)
    commands = [
        ["montecarlo", "run", str(spec), "--db", str(path), "--no-progress"],
        ["montecarlo", "report", "--db", str(path), "--out", str(tmp_path / "report")],
        ["montecarlo", "export", "--db", str(path), "--out", str(tmp_path / "t.csv")],
        ["montecarlo", "replay", "--db", str(path), "--sample", "0", "--out", str(tmp_path / "p")],
    ]
    stores = tmp_path / "stores"
    stores.mkdir()
    (stores / "ideal.sqlite").write_bytes(path.read_bytes())
    commands.append(["realism", "--out", str(tmp_path / "real"), "--stores", str(stores),
                     "--report-only"])  # fmt: skip
    for command in commands:
        assert main(command) == EXIT_DAMAGED_STORE, command
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and "a damaged posfb store (missing the meta table)" in lines[0]


def test_a_malformed_store_is_a_damaged_store(tmp_path, study, capsys):
    path = tmp_path / "r.sqlite"
    _stored(path, study)
    data = bytearray(path.read_bytes())
    data[4096:] = b"\xff" * (len(data) - 4096)  # scribble over every page but the schema
    path.write_bytes(bytes(data))
    code = main(["montecarlo", "report", "--db", str(path), "--out", str(tmp_path / "report")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == EXIT_DAMAGED_STORE and len(lines) == 1, lines
    assert "a damaged posfb store" in lines[0] and "Traceback" not in lines[0]


@pytest.fixture()
def disk(tmp_path):
    disk = SmallDisk(tmp_path / "disk")
    yield disk
    disk.close()


def _one_line(result) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


@pytest.mark.slow
def test_a_full_disk_is_one_line_keeps_what_finished_and_resumes(tmp_path, disk):
    study = write_study(tmp_path, TINY_STUDY.replace("samples: 4", "samples: 2"))
    db = disk.folder / "s.sqlite"
    run = ["montecarlo", "run", str(study), "--db", str(db), "--no-progress"]
    assert disk.run(run, tmp_path).returncode == 0
    finished = all_rows(db)
    disk.fill()
    refused = disk.run([*run, "--samples", "4"], tmp_path)
    line = _one_line(refused)
    assert refused.returncode == EXIT_DISK_FULL and str(db) in line
    if disk.mounted:
        assert "no space left on device" in line
    fresh = disk.folder / "fresh.sqlite"  # a store created on the full disk
    created = disk.run(["montecarlo", "run", str(study), "--db", str(fresh), "--no-progress"],
                       tmp_path)  # fmt: skip
    assert created.returncode == EXIT_DISK_FULL and str(fresh) in _one_line(created)
    disk.free()
    assert all_rows(db) == finished  # what finished is kept, byte for byte in its rows
    report = disk.run(["montecarlo", "report", "--db", str(db), "--out", str(tmp_path / "r")],
                      tmp_path)  # fmt: skip
    assert report.returncode == 0, report.stderr
    resumed = disk.run([*run, "--samples", "4"], tmp_path)
    assert resumed.returncode == 0 and "4 of 4 samples (2 new" in resumed.stdout
    samples, _ = all_rows(db)
    assert [row["sample"] for row in samples] == [0, 1, 2, 3]
    assert disk.run(run, tmp_path).returncode == 0  # the store is usable
    again = disk.run(["montecarlo", "run", str(study), "--db", str(fresh), "--no-progress"],
                     tmp_path)  # fmt: skip
    assert again.returncode == 0 and "2 of 2 samples (2 new" in again.stdout


@pytest.mark.slow
def test_a_killed_worker_is_retried_once_then_its_sample_is_an_error(tmp_path, disk):
    from posfb.analysis.uncertainty.sampling import sample_scenario
    from posfb.analysis.uncertainty.study import load_study

    study, log = write_killer_study(tmp_path)
    samples = load_study(study).samples
    doomed = [
        index
        for index in range(samples)
        if sample_scenario(load_study(study), index)[1]["actuator.voltage_limit"] == 11.0
    ]
    assert len(doomed) == 1, "the study must draw the killing voltage on one sample"
    db = tmp_path / "killed.sqlite"
    run = ["montecarlo", "run", str(study), "--db", str(db), "--workers", "2", "--no-progress"]
    result = disk.run(run, tmp_path)
    assert result.returncode == EXIT_WORKER_DIED
    line = _one_line(result)
    assert f"a worker process died on sample {doomed[0]} and on the retry" in line
    assert len(log.read_text().split()) == 2  # the first try and one retry, two processes
    stored, runs = all_rows(db)
    assert [row["sample"] for row in stored] == list(range(samples))  # the run went on
    for row in runs:
        if row["sample"] == doomed[0]:
            assert (row["status"], row["message"]) == ("error", WORKER_DIED)
        else:
            assert row["status"] == "ok"
    assert disk.run(run, tmp_path).returncode == 0  # complete: the same command is a no-op


def test_a_sample_count_beyond_the_ceiling_is_refused_before_any_work():
    """A design built whole in memory is refused above the ceiling; random sampling,
    drawn on use, is not (``test_a_trillion_samples_keep_memory_flat`` runs 10^12)."""
    lhs = TINY_STUDY + "sampling: latin_hypercube\n"
    needle = f"samples = {10**12} with sampling: latin_hypercube; at most {MAX_SAMPLES:,}"
    with pytest.raises(ValueError, match=needle):
        study_from_text(lhs.replace("samples: 4", f"samples: {10**12}"))
    assert study_from_text(lhs.replace("samples: 4", f"samples: {MAX_SAMPLES}"))
    assert study_from_text(TINY_STUDY.replace("samples: 4", f"samples: {10**12}"))


@pytest.mark.slow
def test_a_sample_that_kills_its_dask_workers_is_an_error_and_the_run_goes_on(tmp_path):
    """On a Dask cluster (real worker processes under nannies), the sample whose plug-in
    SIGKILLs its worker is re-run by Dask itself (``allowed-failures``, here 1), then
    recorded as ``WORKER_DIED``; every other sample is stored ``ok``."""
    import dask
    from dask.distributed import LocalCluster

    from posfb.analysis.cli import main

    study, log = write_killer_study(tmp_path)
    db = tmp_path / "dask.sqlite"
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 1}),
        LocalCluster(
            n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1",
            dashboard_address=None,
        ) as cluster,
    ):  # fmt: skip
        args = ["montecarlo", "run", str(study), "--db", str(db), "--no-progress"]
        code = main([*args, "--dask-scheduler", cluster.scheduler_address])
    assert code == EXIT_WORKER_DIED
    assert len(log.read_text().split()) == 2  # the first try and Dask's one retry
    stored, runs = all_rows(db)
    died = {row["sample"] for row in runs if row["message"] == WORKER_DIED}
    assert len(died) == 1
    assert all(row["status"] == "ok" for row in runs if row["sample"] not in died)
    assert len(stored) == len({row["sample"] for row in runs})


def test_a_ctrl_c_while_the_last_sample_is_stored_is_not_dropped():
    """Issue 43: Ctrl-C while the caller stores the last sample (deferred: a store write
    is never cut) is raised when the scheduler resumes, not dropped with an exit 0."""
    from posfb.analysis.montecarlo import scheduler

    results = scheduler._local_results("unused", iter([(0, None)]), 1, made_up_evaluate)
    assert next(results).index == 0
    os.kill(os.getpid(), signal.SIGINT)  # the caller is storing it: Ctrl-C is deferred
    with pytest.raises(KeyboardInterrupt):
        next(results)
