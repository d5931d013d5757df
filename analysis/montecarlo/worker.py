"""What a worker process does with one sample index.

Drake diagrams and Contexts do not pickle, so work crosses process (and
machine) boundaries as ``(study_text, index)`` and comes back as a plain
``SampleResult``. Each worker builds one ``ClosedLoopRunner`` per controller
the first time it sees a study and reuses them for every later sample (a
thread-local cache, so a Dask worker with several threads never shares a
runner between threads).
"""

from __future__ import annotations

import math
import threading
from dataclasses import asdict

from posfb.analysis.metrics import RunMetrics, run_metrics
from posfb.analysis.montecarlo.config import Study, study_from_text
from posfb.analysis.montecarlo.coverage import coverage
from posfb.analysis.montecarlo.records import METRIC_COLUMNS, ControllerRun, SampleResult
from posfb.analysis.montecarlo.sampling import SampledPlant, sample_plant
from posfb.diagrams.closed_loop import ClosedLoopConfig, ClosedLoopRunner
from posfb.models.design.bounds import resolve_bounds
from posfb.models.identify import identify


def _metrics_dict(metrics: RunMetrics) -> dict[str, float | None]:
    values = (*metrics.rms_q, *metrics.rms_u, metrics.max_abs_q_err)
    values += (metrics.saturated_fraction, metrics.wall_time_s)
    return {
        column: float(value) if math.isfinite(value) else None
        for column, value in zip(METRIC_COLUMNS, values, strict=True)
    }


def _one_line(error: BaseException) -> str:
    text = str(error).strip()
    return f"{type(error).__name__}: {text.splitlines()[0] if text else ''}".rstrip(": ")


class ClosedLoopEvaluator:
    """Evaluates samples of one study: sample the plant, identify its theta, place it
    against the Assumption-1 bounds, run every controller on it."""

    def __init__(self, study: Study) -> None:
        self.study = study
        self.runners = {
            controller: ClosedLoopRunner(
                ClosedLoopConfig(
                    controller=controller,
                    design=study.controller_config(),
                    duration=study.duration,
                    divergence_bound=study.divergence_bound,
                )
            )
            for controller in study.controllers
        }
        reference = self.runners[study.controllers[0]]
        self._reference = reference
        self.nominal_plant = reference.arm.default_parameters
        design = reference.config.design
        self.nominal_model = design.nominal
        self.bounds = resolve_bounds(design.bounds, design.nominal)

    def __call__(self, index: int) -> SampleResult:
        plant = sample_plant(self.study, self.nominal_plant, index)
        context = self._reference.new_context(plant.parameters, plant.encoder_counts)
        theta = identify(self._reference.arm, context)
        where = coverage(theta, self.nominal_model, self.bounds)
        parameters = {
            key: list(value) if isinstance(value, tuple) else value
            for key, value in asdict(plant.parameters).items()
        }
        return SampleResult(
            index=index,
            parameters=parameters,
            encoder_counts=plant.encoder_counts,
            theta={key: float(value) for key, value in theta.as_dict().items()},
            bound_ratios=where.ratios,
            inside_bounds=where.inside,
            runs=tuple(self._run(controller, plant) for controller in self.study.controllers),
        )

    def _run(self, controller: str, plant: SampledPlant) -> ControllerRun:
        """One controller on ``plant``; an exception is recorded as ``error``."""
        try:
            result = self.runners[controller].run(plant.parameters, plant.encoder_counts)
        except Exception as error:  # recorded, never stops the study
            return ControllerRun(controller, "error", _one_line(error), {})
        return ControllerRun(
            controller, result.status, result.message, _metrics_dict(run_metrics(result))
        )


_local = threading.local()


def evaluate(study_text: str, index: int) -> SampleResult:
    """Sample ``index`` of the study given as canonical YAML (the unit of work sent to
    worker processes and Dask workers)."""
    if getattr(_local, "study_text", None) != study_text:
        # One study per worker thread at a time: a new study replaces the last one's diagrams.
        _local.evaluator = ClosedLoopEvaluator(study_from_text(study_text))
        _local.study_text = study_text
    return _local.evaluator(index)
