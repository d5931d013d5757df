"""``posfb montecarlo run`` end to end on the real closed loop (1-2 s runs):
reproducible for any worker count and on Dask, durable under a real kill,
divergence recorded without stopping the study."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers.montecarlo_helpers import (
    TINY_STUDY,
    all_rows,
    deterministic_rows,
    fake_evaluate,
    write_study,
)
from helpers.paths import REPO
from helpers.slow import heavy
from posfb.analysis.cli import main
from posfb.analysis.montecarlo import scheduler
from posfb.analysis.montecarlo.scheduler import run_study
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.montecarlo.worker import ClosedLoopEvaluator
from posfb.analysis.uncertainty.study import study_from_text
from posfb.models.plant import build_arm_diagram

CLI = [sys.executable, "-m", "posfb.analysis.cli"]
ROOT = REPO


def _run(study_text: str, db: Path, workers: int) -> None:
    study = study_from_text(study_text)
    with ResultStore.create_or_resume(db, study, "test") as store:
        summary = run_study(study, store, "test", workers=workers, progress=False)
    assert summary.written == study.samples


@pytest.fixture(scope="module")
@heavy
def reference(tmp_path_factory) -> Path:
    """The tiny study run on one local worker."""
    db = tmp_path_factory.mktemp("reference") / "w1.sqlite"
    _run(TINY_STUDY, db, workers=1)
    return db


def test_one_and_two_workers_store_identical_rows(reference, tmp_path):
    _run(TINY_STUDY, tmp_path / "w2.sqlite", workers=2)
    assert deterministic_rows(tmp_path / "w2.sqlite") == deterministic_rows(reference)


def test_stored_samples_follow_the_study(reference):
    samples, runs = deterministic_rows(reference)
    nominal = build_arm_diagram()[1].default_parameters
    assert [s["sample"] for s in samples] == [0, 1, 2, 3]
    for sample in samples:
        mass = sample["parameters"]["link_mass"]
        assert all(0.8 * m0 <= m <= 1.2 * m0 for m, m0 in zip(mass, nominal.link_mass, strict=True))
        assert 0.0 <= sample["payload_mass"] <= 0.5
        assert sample["encoder_counts"] in (20000, 4000)
        assert set(sample["theta"]) == {f"theta{i}" for i in range(1, 12)} | {"l1"}
        assert len(sample["bound_ratios"]) == 6
    assert len(runs) == 8 and {r["status"] for r in runs} == {"ok"}
    assert all(0.0 < r["rms_q1"] < 0.05 and 0.0 < r["rms_q2"] < 0.2 for r in runs)


@pytest.mark.slow
def test_dask_cluster_stores_the_same_rows_as_the_local_pool(reference, tmp_path, capsys):
    from dask.distributed import LocalCluster

    study = write_study(tmp_path)
    db = tmp_path / "dask.sqlite"
    with LocalCluster(
        n_workers=2,
        processes=True,
        threads_per_worker=1,
        host="127.0.0.1",
        dashboard_address=None,
    ) as cluster:
        args = ["montecarlo", "run", str(study), "--db", str(db), "--no-progress"]
        code = main([*args, "--dask-scheduler", cluster.scheduler_address])
    assert code == 0, capsys.readouterr().err
    assert deterministic_rows(db) == deterministic_rows(reference)


def test_unreachable_dask_scheduler_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(scheduler, "DASK_CONNECT_TIMEOUT", "1s")
    study = write_study(tmp_path)
    args = ["montecarlo", "run", str(study), "--db", str(tmp_path / "r.sqlite"), "--no-progress"]
    assert main([*args, "--dask-scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Dask scheduler" in err[0]


def _count(db: Path) -> int:
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5) as connection:
            return connection.execute("SELECT count(*) FROM samples").fetchone()[0]
    except sqlite3.OperationalError:  # not created yet
        return 0


@pytest.mark.slow  # over 10 s on 2 cores (issue 45, item 4)
def test_killed_run_resumes_without_losing_or_repeating_samples(tmp_path, capsys):
    samples = 40
    study = write_study(tmp_path, TINY_STUDY.replace("samples: 4", f"samples: {samples}"))
    db = tmp_path / "killed.sqlite"
    command = ["montecarlo", "run", str(study), "--db", str(db), "--no-progress"]
    process = subprocess.Popen(
        [*CLI, *command, "--workers", "2"],
        cwd=ROOT,
        start_new_session=True,  # its own process group: the kill takes the workers too
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 90
        while _count(db) < 3 and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        before = all_rows(db)
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    finished_before = len(before[0])
    assert 3 <= finished_before < samples, "the run must be killed part-way"

    assert main([*command, "--workers", "2"]) == 0
    samples_rows, runs = all_rows(db)
    assert [row["sample"] for row in samples_rows] == list(range(samples))
    assert sorted((r["sample"], r["controller"]) for r in runs) == sorted(
        (i, c) for i in range(samples) for c in ("pid", "proposed")
    )
    for row in before[0]:  # nothing finished before the kill changed or was lost
        assert row in samples_rows
    for row in before[1]:
        assert row in runs

    assert main(command) == 0  # the same command again: nothing left to do
    assert "0 new" in capsys.readouterr().out
    assert all_rows(db) == (samples_rows, runs)


def test_resume_under_another_seed_is_refused(reference, tmp_path, capsys):
    study = write_study(tmp_path)
    code = main(["montecarlo", "run", str(study), "--db", str(reference), "--seed", "8"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "seed" in err[0]


DEAD_MOTORS = """\
seed: 3
samples: 3
duration: 2.0
controllers: [proposed, pid]
parameters:
  payload_mass: !Uniform {min: 0.0, max: 0.3}
# Sample 1's amplifiers deliver almost nothing: the arm cannot follow the
# trajectory and |q~| passes the 1 rad divergence bound within 2 s.
overrides: [{sample: 1, values: {motor_constant: [0.001, 0.001]}}]
"""


@pytest.mark.slow
def test_a_diverging_sample_is_recorded_and_the_others_complete(tmp_path):
    db = tmp_path / "diverge.sqlite"
    _run(DEAD_MOTORS, db, workers=1)
    _, runs = deterministic_rows(db)
    status = {(r["sample"], r["controller"]): r for r in runs}
    for controller in ("proposed", "pid"):
        assert status[(1, controller)]["status"] == "diverged"
        assert "divergence_bound" in status[(1, controller)]["message"]
        for sample in (0, 2):
            assert status[(sample, controller)]["status"] == "ok"
            assert status[(sample, controller)]["rms_q1"] < 0.05


def test_an_exception_in_a_run_is_recorded_as_error():
    evaluator = ClosedLoopEvaluator(study_from_text(TINY_STUDY))

    def explode(*args, **kwargs):
        raise ArithmeticError("controller state became complex\nsecond line")

    evaluator.runner(evaluator.study.base_scenario(), "pid").run = explode
    result = evaluator(0)
    runs = {run.controller: run for run in result.runs}
    assert runs["pid"].status == "error"
    assert runs["pid"].message == "ArithmeticError: controller state became complex"
    assert runs["proposed"].status == "ok"


def test_a_failing_worker_stops_the_run_and_keeps_what_finished(tmp_path):
    study = study_from_text(TINY_STUDY.replace("samples: 4", "samples: 6"))
    with ResultStore.create_or_resume(tmp_path / "r.sqlite", study, "test") as store:
        with pytest.raises(RuntimeError, match="bug in the worker"):
            run_study(study, store, "test", workers=1, progress=False, evaluate=fake_evaluate)
        assert {0, 1} <= store.finished() <= {0, 1, 3}


def test_a_study_alpha_star_reaches_the_runner_of_every_entry_that_has_one():
    study = study_from_text(
        "seed: 1\nsamples: 1\nduration: 0.5\ncontrollers: [proposed, lin_lc]\nalpha_star: 2.75\n"
        "entries:\n  proposed_again: !Proposed {}\n"
    )
    evaluator = ClosedLoopEvaluator(study)
    runner = evaluator.runner(study.base_scenario(), "proposed")
    assert runner.config.design.nonlinear.alpha_star == 2.75
    # A named entry holds its own settings: the study's alpha* sets the base's entry.
    again = evaluator.runner(study.base_scenario(), "proposed_again")
    assert again.config.design.nonlinear.alpha_star == 4.0


def test_a_study_runs_one_kind_twice_as_named_entries():
    # The paper's controller at alpha* = 4 and, as a named entry, at 2.75, in one study:
    # the entry's runs and per-sample radii equal those of a study of alpha* = 2.75 alone
    # (an independent evaluation of the same plants).
    base = "seed: 4\nsamples: 2\nduration: 1.0\nparameters:\n" \
        "  payload_mass: !Uniform {min: 0.0, max: 0.4}\n"  # fmt: skip
    both = study_from_text(base + "controllers: [proposed, proposed_275]\n"
                           "entries:\n  proposed_275: !Proposed {alpha_star: 2.75}\n")  # fmt: skip
    alone = study_from_text(base + "controllers: [proposed]\nalpha_star: 2.75\n")
    for index in range(2):
        runs = {run.controller: run for run in ClosedLoopEvaluator(both)(index).runs}
        (reference,) = ClosedLoopEvaluator(alone)(index).runs
        def timeless(metrics: dict) -> dict:
            return {key: value for key, value in metrics.items() if "wall" not in key}

        assert timeless(runs["proposed_275"].metrics) == timeless(reference.metrics)
        assert runs["proposed_275"].spectral_radius == reference.spectral_radius
        # Each entry has its own design: a larger alpha* gives a larger radius (Sec. 4).
        assert runs["proposed"].spectral_radius > reference.spectral_radius
