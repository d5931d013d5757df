"""Part (a): how accurate an identification of the paper's arm is.

Each planned excitation (``posfb identify plan``, seed ``p``) is played on the study
scenario's true arm by the spec's controller, logged at each encoder resolution and
identified from the log as ``posfb identify --log`` does; the truth is that arm's own
theta, computed from the plant (``models.theta_of_plant``). One record per (resolution,
plan), written as JSON as soon as it is done, so that a rerun continues where it
stopped; the logs are kept only for plan 0, whose model file and plant posterior
(``analysis.identification.study_out``) part (b) draws from.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np

from posfb.analysis.common.export import export_run
from posfb.analysis.common.outputs import atomic_file
from posfb.analysis.identification.identify import identify_log
from posfb.analysis.identification.plan import plan_for_scenario
from posfb.analysis.identification.study_out import plant_posterior, true_arm
from posfb.analysis.model_error.spec import ModelErrorSpec
from posfb.diagrams.resolve import LoadedScenario, run_scenario, scenario_from_file
from posfb.models.identification.checks import IDENTIFIABLE_RELATIVE_STD
from posfb.models.plant import apply_parameters
from posfb.models.theta_of_plant import identify

#: The plan whose identification part (b) draws from (and whose logs are kept).
POSTERIOR_PLAN = 0

T = TypeVar("T")


@dataclass(frozen=True)
class AccuracyRecord:
    """One identification: the resolution and plan, theta's ``names``, the ``estimate``,
    its stated ``std``, the ``truth``, the ``model`` the model file holds (the estimate
    bounded), the condition number and the warnings."""

    encoder_counts: int
    plan: int
    names: list[str]
    estimate: list[float]
    std: list[float]
    truth: list[float]
    model: list[float]
    condition_number: float
    warnings: list[str]

    def relative_error(self) -> np.ndarray:
        """``(estimate - truth) / truth`` per theta."""
        return (np.array(self.estimate) - self.truth) / np.abs(self.truth)

    def relative_std(self) -> np.ndarray:
        """The stated ``std / |estimate|`` per theta."""
        return np.array(self.std) / np.abs(self.estimate)

    def identifiable(self) -> np.ndarray:
        """The theta the identification states identifiable (relative standard error at
        most ``IDENTIFIABLE_RELATIVE_STD``: no warning)."""
        return self.relative_std() <= IDENTIFIABLE_RELATIVE_STD

    def z(self) -> np.ndarray:
        """The actual error in stated standard errors, ``(estimate - truth) / std``."""
        return (np.array(self.estimate) - self.truth) / np.array(self.std)


def record_path(folder: Path, counts: int, plan: int) -> Path:
    return folder / f"counts_{counts}_plan_{plan}.json"


def model_path(folder: Path, counts: int) -> Path:
    """The model file of plan ``POSTERIOR_PLAN`` at ``counts`` (``!Identified``)."""
    return folder / f"model_{counts}.yaml"


def posterior_path(folder: Path, counts: int) -> Path:
    """The plant posterior of plan ``POSTERIOR_PLAN`` at ``counts`` (JSON)."""
    return folder / f"posterior_{counts}.json"


def _scenario(spec: ModelErrorSpec, extra: list[str]) -> LoadedScenario:
    return scenario_from_file(spec.study.scenario, [*spec.study.settings, *extra])


def true_theta(loaded: LoadedScenario) -> np.ndarray:
    """theta of the scenario's true arm, computed from the plant."""
    truth = true_arm(loaded)
    apply_parameters(truth.arm, truth.context, truth.parameters)
    return identify(truth.arm, truth.context).theta


def require_recorded(path: Path) -> Path:
    """``path``, a file an earlier run of the study wrote (refused in one line if not)."""
    if not path.is_file():
        raise ValueError(
            f"{path} does not exist; run posfb model-error without --report-only first"
        )
    return path


def _read_plan(path: Path, duration: float) -> None:
    """``ValueError`` unless ``path`` is a whole plan of ``duration`` s (``plan.save``'s
    columns, finite, to its end)."""
    import pandas as pd

    try:
        table = pd.read_csv(path)
    except Exception as error:  # pandas raises many kinds; the file may be anything
        first = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ValueError(first) from None
    values = table.to_numpy(dtype=float, na_value=np.nan) if "time_s" in table else None
    if values is None or table.shape[1] < 2 or not np.all(np.isfinite(values)):
        raise ValueError("not a whole plan (time_s and finite positions)")
    if values[-1, 0] < duration * (1.0 - 1e-9):
        raise ValueError(f"it ends at {values[-1, 0]:g} s of {duration:g} s")


def _read_record(path: Path) -> AccuracyRecord:
    return AccuracyRecord(**json.loads(path.read_text()))


def read_posterior(path: Path) -> dict[str, object]:
    found = json.loads(path.read_text())
    if not (isinstance(found, dict) and set(found) == {"keys", "mean", "covariance"}):
        raise ValueError("not a posterior (keys, mean, covariance)")
    return found


def damage(path: Path, read: Callable[[Path], object]) -> str | None:
    """Why the file an earlier run wrote at ``path`` cannot be read back by ``read``
    (``None``: it can; a missing file is not damaged, only not written)."""
    if not path.is_file():
        return None
    try:
        read(path)
    except (OSError, ValueError, TypeError) as error:
        return str(error).splitlines()[0] if str(error) else type(error).__name__
    return None


def _redo(path: Path, why: str) -> None:
    """Say, in one line, that a damaged file is made again."""
    sys.stderr.write(f"posfb model-error: {path} is damaged ({why}); making it again\n")
    path.unlink(missing_ok=True)


def read_recorded(path: Path, read: Callable[[Path], T]) -> T:
    """``read(path)`` of a file an earlier run wrote; a damaged one is one line naming it
    (the study without ``--report-only`` makes it again)."""
    why = damage(require_recorded(path), read)
    if why is not None:
        raise ValueError(
            f"{path} is damaged ({why}); run posfb model-error without --report-only to make "
            "it again"
        )
    return read(path)


def _plan(spec: ModelErrorSpec, folder: Path, seed: int) -> Path:
    path = folder / f"plan_{seed}.csv"
    runs = spec.identification
    why = damage(path, lambda p: _read_plan(p, runs.duration))
    if why is not None:
        _redo(path, why)
    if not path.is_file():
        planned = plan_for_scenario(_scenario(spec, []), duration=runs.duration, seed=seed)
        planned.save(path)
    return path


def _identify(spec: ModelErrorSpec, folder: Path, logs: Path, counts: int, plan: int) -> None:
    runs = spec.identification
    loaded = _scenario(
        spec,
        [
            f"trajectory=!CsvFile {{path: {_plan(spec, folder, plan)}}}",
            f"timing.duration={runs.duration!r}",
            f"sensor.encoder_counts=[{counts}]",
            f"controller.kind={runs.controller}",
        ],
    )
    log = export_run(run_scenario(loaded), logs / f"counts_{counts}_plan_{plan}.csv")
    identification = identify_log(loaded, log)
    estimate = identification.estimate
    record = AccuracyRecord(
        encoder_counts=counts,
        plan=plan,
        names=list(estimate.names),
        estimate=[float(v) for v in estimate.values],
        std=[float(s) for s in estimate.std],
        truth=[float(t) for t in true_theta(loaded)],
        model=[float(v) for v in identification.model_values],
        condition_number=float(estimate.condition_number),
        warnings=list(identification.warnings),
    )
    if plan == POSTERIOR_PLAN:
        identification.save(model_path(folder, counts))
        posterior = plant_posterior(identification, loaded)
        with atomic_file(posterior_path(folder, counts)) as path:
            path.write_text(
                json.dumps(
                    {
                        "keys": list(posterior.keys),
                        "mean": posterior.mean.tolist(),
                        "covariance": posterior.covariance.tolist(),
                    }
                )
            )
    else:
        log.unlink()
    with atomic_file(record_path(folder, counts, plan)) as path:
        path.write_text(json.dumps(asdict(record), indent=1))


def run_identifications(spec: ModelErrorSpec, folder: Path, logs: Path) -> None:
    """Every (resolution, plan) not yet recorded in ``folder`` (module docstring)."""
    folder, logs = folder.resolve(), logs.resolve()  # the scenarios name them
    folder.mkdir(parents=True, exist_ok=True)
    logs.mkdir(parents=True, exist_ok=True)
    runs = spec.identification
    for counts in runs.encoder_counts:
        for plan in range(runs.plans):
            written = [(record_path(folder, counts, plan), _read_record)]
            if plan == POSTERIOR_PLAN:
                written.append((posterior_path(folder, counts), read_posterior))
            for path, read in written:
                why = damage(path, read)
                if why is not None:
                    _redo(path, why)
            if not all(path.is_file() for path, _ in written):
                _identify(spec, folder, logs, counts, plan)


def load_records(spec: ModelErrorSpec, folder: Path) -> dict[int, list[AccuracyRecord]]:
    """The records of every resolution, by plan (a missing one is refused in one line)."""
    records = {}
    for counts in spec.identification.encoder_counts:
        found = []
        for plan in range(spec.identification.plans):
            found.append(read_recorded(record_path(folder, counts, plan), _read_record))
        records[counts] = found
    return records
