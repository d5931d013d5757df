"""What a worker process does with one sample index.

Drake diagrams and Contexts do not pickle, so work crosses process (and
machine) boundaries as ``(study_text, index)`` and comes back as a plain
``SampleResult``. Each worker builds one ``ClosedLoopRunner`` per controller
the first time it sees a study and reuses them for every later sample (a
thread-local cache, so a Dask worker with several threads never shares a
runner between threads).

``montecarlo replay`` (``analysis.montecarlo.replay``) rebuilds a stored sample
with ``ClosedLoopEvaluator.evaluate``, the method ``__call__`` runs, and keeps
the closed-loop runs that a study throws away after taking their metrics.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import threading
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

from pydrake.systems.framework import Context

from posfb.analysis.common.configurations import scenario_configurations
from posfb.analysis.common.loop_effects import loop_effects
from posfb.analysis.common.metrics import RunMetrics, run_metrics, run_verdict
from posfb.analysis.montecarlo.records import ControllerRun, SampleResult, metric_columns
from posfb.analysis.uncertainty.coverage import Coverage, coverage, serial_coverage
from posfb.analysis.uncertainty.sampling import SampledPlant, sample_plant, sample_scenario
from posfb.analysis.uncertainty.study import Study, study_from_text
from posfb.diagrams.actuator import ActuatorState
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.resolve import LoadedScenario, resolve
from posfb.diagrams.runner import ClosedLoopResult, ClosedLoopRunner
from posfb.diagrams.scenario import (
    Scenario,
    with_controller,
)
from posfb.diagrams.sections import SensorState
from posfb.diagrams.structure import structure_key
from posfb.models.controllers import cached_design
from posfb.models.design import (
    ControllerConfig,
    LoopEffects,
    plant_spectral_radii,
)
from posfb.models.lumped import LumpedParameters
from posfb.models.nominal import nominal_model
from posfb.models.theta_of_plant import linear_part_model


def _metrics_dict(metrics: RunMetrics) -> dict[str, float | None]:
    values = (*metrics.rms_q, *metrics.rms_u, metrics.max_abs_q_err)
    values += (metrics.saturated_fraction, metrics.wall_time_s, *metrics.rms_q_measured)
    columns = metric_columns(len(metrics.rms_q))
    return {
        column: float(value) if math.isfinite(value) else None
        for column, value in zip(columns, values, strict=True)
    }


def _one_line(error: BaseException) -> str:
    text = str(error).strip()
    return f"{type(error).__name__}: {text.splitlines()[0] if text else ''}".rstrip(": ")


#: Diagrams a worker keeps, one per distinct structure (sample time, sensor delay,
#: noise or none, voltage limit, design, trajectory, controller, friction law kind, a
#: gear, a lag, a DAC or none, compute delay). Draws that only change Context values
#: (plant parameters, the friction law's and the gear's, encoder counts, offsets, noise
#: levels, electrical time constants, DAC bits) reuse one (``diagrams.structure``).
RUNNER_CACHE_SIZE = 16


def rigid_twin(scenario: Scenario) -> Scenario:
    """``scenario`` with a rigid gear read on the link (``models.gear``): the same arm
    with each motor's rotor inertia in its joint; ``scenario`` itself when rigid."""
    if not any(k > 0.0 for k in scenario.plant.gear_stiffness):
        return scenario
    twin = copy.deepcopy(scenario)
    twin.plant.gear_stiffness, twin.plant.gear_damping, twin.plant.backlash = [0.0], [0.0], [0.0]
    twin.sensor.location = "link"
    return twin


class ClosedLoopEvaluator:
    """Evaluates samples of one study: sample the scenario and the plant, identify its
    theta, place it against the Assumption-1 bounds, compute the sampled-data spectral
    radius of each designed loop on it, run every controller on it."""

    def __init__(self, study: Study) -> None:
        self.study = study
        self._runners: OrderedDict[str, ClosedLoopRunner] = OrderedDict()
        base = self._loaded(study.base_scenario())
        # The arm a sample is identified and placed on: rigid, as the paper's theta
        # lump the rotor inertia into the joint (a compliant gear moves it to the motor).
        self._reference = self.runner(rigid_twin(base.scenario), study.controllers[0])
        self.nominal_plant = resolve(base).true_parameters(self._reference.arm.default_parameters)

    @staticmethod
    def _loaded(scenario: Scenario) -> LoadedScenario:
        return LoadedScenario(scenario, Path.cwd())  # study paths are absolute

    def runner(self, scenario: Scenario, controller: str) -> ClosedLoopRunner:
        """The (cached) closed loop of ``controller`` for the structure of ``scenario``."""
        key = structure_key(scenario, controller)
        if key not in self._runners:
            config = resolve(self._loaded(with_controller(scenario, controller))).config
            self._runners[key] = ClosedLoopRunner(config)
            while len(self._runners) > RUNNER_CACHE_SIZE:
                self._runners.popitem(last=False)
        self._runners.move_to_end(key)
        return self._runners[key]

    def __call__(self, index: int) -> SampleResult:
        """Sample ``index`` with every controller of the study (what the store keeps)."""
        return self.evaluate(index)[0]

    def evaluate(
        self, index: int, controllers: Sequence[str] | None = None, failed: str | None = None
    ) -> tuple[SampleResult, dict[str, ClosedLoopResult]]:
        """Sample ``index``: the ``SampleResult`` with one run per controller of
        ``controllers`` (default: the study's, in its order) and each run's
        ``ClosedLoopResult`` by controller (none for a run that raised). The one code
        path of both a study's samples (``__call__``) and ``montecarlo replay``. With
        ``failed``, no controller runs: each run is recorded as ``error`` with that
        message (the sample's draw, theta and radii are still computed)."""
        scenario, drawn = sample_scenario(self.study, index)
        config = resolve(self._loaded(scenario)).config
        plant = sample_plant(self.study, self.nominal_plant, index)
        sensor = config.sensor_state
        if plant.encoder_counts is not None:
            sensor = dataclasses.replace(
                sensor, encoder_counts=(plant.encoder_counts,) * config.joints
            )
        context = self._reference.new_context(plant.parameters)
        chosen = self.study.controllers if controllers is None else controllers
        runners = {c: self._runner_or_error(scenario, c) for c in chosen}
        configs = {c: r.config for c, r in runners.items() if isinstance(r, ClosedLoopRunner)}
        theta, where, linear_plant = self._place(self._designed(config, configs), context)
        radii = self._radii(configs, linear_plant, loop_effects(config, plant.parameters))
        parameters = {
            key: list(value) if isinstance(value, tuple) else value
            for key, value in asdict(plant.parameters).items()
        }
        runs, results = [], {}
        for controller in chosen:
            if failed is not None:
                runs.append(ControllerRun(controller, "error", failed, {}, radii.get(controller)))
                continue
            run, result = self._run(
                controller,
                runners[controller],
                plant,
                sensor,
                radii.get(controller),
                config.plant.friction,
                config.plant.gear,
                config.actuator_state,
            )
            runs.append(run)
            if result is not None:
                results[controller] = result
        sample = SampleResult(
            index=index,
            parameters={**parameters, **drawn},
            encoder_counts=sensor.encoder_counts[0],
            theta=theta,
            bound_ratios=where.ratios,
            inside_bounds=where.inside,
            runs=tuple(runs),
        )
        return sample, results

    @staticmethod
    def _designed(
        config: ClosedLoopConfig, configs: dict[str, ClosedLoopConfig]
    ) -> ControllerConfig:
        """The Sec. 3 design a sample is placed against (its Assumption-1 bounds): the
        base scenario's entry's, or, when that entry is a plug-in's (no Sec. 3 design),
        that of the study's first controller that has one."""
        if config.controller_settings is None:
            return config.design
        designed = [c.design for c in configs.values() if c.controller_settings is None]
        return designed[0] if designed else config.design

    def _place(
        self, design: ControllerConfig, context: Context
    ) -> tuple[dict[str, float], Coverage, object]:
        """The sampled plant in ``context`` against the design: its theta (Table 1's,
        identified, for a theta nominal model; empty otherwise), where it lies against
        the Assumption-1 bounds, and its linear part as the sampled-data check takes it
        (the identified theta, or the sampled arm's own Drake model)."""
        bounds = cached_design(design).bounds
        true = linear_part_model(self._reference.arm, context, design.nominal)
        if isinstance(true, LumpedParameters):
            where = coverage(true, design.nominal, bounds)
            return {key: float(value) for key, value in true.as_dict().items()}, where, true
        return {}, serial_coverage(true, nominal_model(design.nominal), bounds), true

    @staticmethod
    def _radii(
        configs: dict[str, ClosedLoopConfig], linear_plant: object, effects: LoopEffects
    ) -> dict[str, float]:
        """The sampled-data spectral radius of each controller's designed loop (its own
        design) closed around the sampled plant's linear part with the sample's linear
        ``effects`` (``analysis.common.loop_effects``), the worst of its ``M0*`` and its
        ``M*(q)`` frozen at the configurations of the sample's path
        (``analysis.common.configurations``); none for a controller without one (PID, the
        plug-ins)."""
        radii, by_design = {}, {}
        for name, config in configs.items():
            loop = config.spec.design_loop  # None: PID, the plug-ins
            if loop is None:
                continue
            if config.design not in by_design:
                angles = tuple(c.q for c in scenario_configurations(config).configurations)
                by_design[config.design] = plant_spectral_radii(
                    cached_design(config.design), linear_plant, effects, angles
                )
            radii[name] = by_design[config.design][loop]
        return radii

    def _runner_or_error(self, scenario: Scenario, controller: str) -> ClosedLoopRunner | Exception:
        """``runner(scenario, controller)``, or the exception that building it raised (the
        sample records it as that controller's ``error`` run)."""
        try:
            return self.runner(scenario, controller)
        except Exception as error:  # recorded by _run, never stops the study
            return error

    @staticmethod
    def _run(
        controller: str,
        runner: ClosedLoopRunner | Exception,
        plant: SampledPlant,
        sensor: SensorState,
        radius: float | None,
        friction: object,
        gear: object = None,
        actuator: ActuatorState | None = None,
    ) -> tuple[ControllerRun, ClosedLoopResult | None]:
        """One controller on ``plant`` with the sample's ``friction`` law settings,
        ``gear`` and ``actuator`` values (set in the Context: the cached diagram may have
        been built with another sample's) and
        its run; an exception (building its runner or running it) is recorded as
        ``error`` (and there is no run)."""
        try:
            if isinstance(runner, Exception):
                raise runner
            result = runner.run(
                plant.parameters, sensor, friction=friction, gear=gear, actuator=actuator
            )
        except Exception as error:  # recorded, never stops the study
            return ControllerRun(controller, "error", _one_line(error), {}, radius), None
        metrics, verdict = _metrics_dict(run_metrics(result)), run_verdict(result)
        run = ControllerRun(controller, verdict.status, verdict.message, metrics, radius)
        return run, result


_local = threading.local()


def _evaluator(study_text: str) -> ClosedLoopEvaluator:
    """This thread's evaluator of the study given as canonical YAML."""
    if getattr(_local, "study_text", None) != study_text:
        # One study per worker thread at a time: a new study replaces the last one's diagrams.
        _local.evaluator = ClosedLoopEvaluator(study_from_text(study_text))
        _local.study_text = study_text
    return _local.evaluator


def evaluate(study_text: str, index: int, controllers: Sequence[str] | None = None) -> SampleResult:
    """Sample ``index`` of the study given as canonical YAML (the unit of work sent to
    worker processes and Dask workers), with every controller of the study or only
    ``controllers`` (the runs a stored sample lacks)."""
    return _evaluator(study_text).evaluate(index, controllers)[0]


def record_failure(
    study_text: str, index: int, controllers: Sequence[str] | None, message: str
) -> SampleResult:
    """Sample ``index`` drawn without running a controller: each run of ``controllers``
    (default: the study's) recorded as ``error`` with ``message`` (a sample whose worker
    process died, ``scheduler.WORKER_DIED``)."""
    return _evaluator(study_text).evaluate(index, controllers, failed=message)[0]
