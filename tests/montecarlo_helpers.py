"""Small studies and row comparisons shared by the Monte-Carlo tests."""

from __future__ import annotations

from pathlib import Path

from posfb.analysis.montecarlo.coverage import BOUND_NAMES
from posfb.analysis.montecarlo.records import ControllerRun, SampleResult, metric_columns
from posfb.analysis.montecarlo.store import ResultStore

#: A tiny study: two controllers, 1 s runs, parameters drawn the shipped study's way.
TINY_STUDY = """\
seed: 7
samples: 4
duration: 1.0
controllers: [proposed, pid]
encoder_counts: [20000, 4000]
parameters:
  link_mass: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  link_com: [!Uniform {min: -0.1, max: 0.1, relative: true}]
  damping: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  coulomb: [!Uniform {min: -0.2, max: 0.2, relative: true}, !Deterministic {}]
  motor_constant: [!Gaussian {mean: 0.0, stddev: 0.05, relative: true, min: -0.15, max: 0.15}]
  payload_mass: !Uniform {min: 0.0, max: 0.5}
"""


def write_study(folder: Path, text: str = TINY_STUDY, name: str = "study.yaml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def deterministic_rows(db: Path) -> tuple[list[dict], list[dict]]:
    """The store's rows without what legitimately differs between runs (wall time,
    when and by which code version a sample was written)."""
    with ResultStore.open_existing(db) as store:
        samples = [
            {k: v for k, v in row.items() if k not in ("finished_at", "code_version")}
            for row in store.sample_rows()
        ]
        runs = [{k: v for k, v in row.items() if k != "wall_time_s"} for row in store.run_rows()]
    return samples, runs


def all_rows(db: Path) -> tuple[list[dict], list[dict]]:
    """Every column of every row."""
    with ResultStore.open_existing(db) as store:
        return store.sample_rows(), store.run_rows()


def make_result(index: int, controllers=("proposed", "pid"), status="ok") -> SampleResult:
    """A finished sample with made-up numbers (no simulation)."""
    metrics = {column: 0.001 * (index + 1) * (k + 1) for k, column in enumerate(metric_columns(2))}
    return SampleResult(
        index=index,
        parameters={"link_mass": [5.0, 0.9], "payload_mass": 0.1 * index},
        encoder_counts=20000,
        theta={"theta1": 0.33, "l1": 0.25},
        bound_ratios={**dict.fromkeys(BOUND_NAMES, 0.2), "delta_M1": 1.5},
        inside_bounds=False,
        runs=tuple(
            ControllerRun(c, status, "" if status == "ok" else "stopped", metrics)
            for c in controllers
        ),
    )


def fake_evaluate(study_text: str, index: int) -> SampleResult:
    """A stand-in for ``worker.evaluate`` (no simulation) that fails on sample 2, as a
    bug in the worker code would."""
    if index == 2:
        raise RuntimeError("bug in the worker")
    return make_result(index)


def run_into_store(path: Path, study_text: str, workers: int = 1) -> Path:
    """Run the study ``study_text`` (the real closed loop) into a new store at ``path``."""
    from posfb.analysis.montecarlo.config import study_from_text
    from posfb.analysis.montecarlo.scheduler import run_study

    study = study_from_text(study_text)
    with ResultStore.create_or_resume(path, study, "test") as store:
        run_study(study, store, "test", workers=workers, progress=False)
    return path
