"""``tune``: a robust design of the paper's controller and Lin+LC for a scenario's arm,
with a stated probabilistic guarantee (issue 20).

For each of ``TUNED_CONTROLLERS`` in turn:

1. draw ``plants`` design plants from the family (``analysis.tuning.plants``, seed
   ``seed``) and search the entry's settings (``analysis.tuning.problem``,
   ``analysis.tuning.search``) for the smallest predicted tracking error with
   ``rho <= 1 - margin`` on the nominal model and every design plant and within the
   voltage limit;
2. verify the chosen design's stability (``rho < 1``) on
   ``verification_plants(epsilon, beta / rounds)`` *fresh* plants (seed ``seed + 1 +
   round``, drawn after the design is fixed) and state the guarantee that applies
   (``analysis.tuning.guarantee``); when it does not reach ``epsilon``, search again on
   twice the design plants and verify on another fresh set, at most ``rounds`` times
   (each round at ``beta / rounds``: the union bound keeps ``1 - beta`` overall);
3. cross-check the prediction with short simulations (``CHECK_DURATION`` s, or the
   scenario's duration if shorter) of the entry before and after, on the scenario's arm.

The tuned scenario holds the tuned paper's controller as its ``controller`` and the tuned
Lin+LC as the named entry ``lin_lc``; every other setting is the scenario's. The result
is a pure function of the scenario, the family, the settings and the seed; the budget
only stops a search that would overrun it (``BudgetError``).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from posfb.analysis.montecarlo.config import Study
from posfb.analysis.tuning.guarantee import (
    Guarantee,
    scenario_confidence,
    verification_plants,
    verify,
)
from posfb.analysis.tuning.plants import linear_plants, plant_family
from posfb.analysis.tuning.problem import Evaluation, TuningProblem
from posfb.analysis.tuning.search import BudgetError, TuneError, search
from posfb.analysis.tuning.settings import TuneSettings
from posfb.diagrams.resolve import (
    LoadedScenario,
    ResolvedScenario,
    resolve,
    with_absolute_paths,
)
from posfb.diagrams.scenario import Scenario, controller_kind, dump_scenario, with_controller
from posfb.models.design.settings import LinearTorqueInputs

#: The controllers ``tune`` designs, in order (each has a Sec. 3 loop).
TUNED_CONTROLLERS = ("proposed", "lin_lc")

#: Seconds of the cross-check simulations (at most the scenario's duration).
CHECK_DURATION = 5.0

#: The settings each report shows beside their former value, per controller.
SHOWN_SETTINGS = {
    "proposed": ("alpha_star", "K_alpha", "filter_a", "Q1", "R", "lambdas"),
    "lin_lc": ("Q1", "R", "lambdas"),
}


@dataclass(frozen=True)
class SimulatedCheck:
    """RMS tracking error (rad, per joint) and saturated share of a short run."""

    rms_q: tuple[float, ...]
    saturated_fraction: float
    status: str


@dataclass(frozen=True)
class TunedController:
    """One controller's tuning: the entries before and after, their evaluations on the
    design plants, the verification, the cross-check runs and the search's size."""

    controller: str
    before: LinearTorqueInputs
    after: LinearTorqueInputs
    start: Evaluation
    best: Evaluation
    guarantee: Guarantee
    disturbance_std: tuple[float, ...]
    disturbance_bandwidth: float
    rounds: int
    design_plants: int
    verified_radii: tuple[float, ...]
    scenario_beta: float
    decisions: int
    simulated_before: SimulatedCheck
    simulated_after: SimulatedCheck
    generations: int
    evaluations: int


@dataclass
class TuneResult:
    """What ``tune`` found: the tuned scenario and, per controller, ``TunedController``."""

    source: str
    scenario: Scenario
    base_dir: Path
    settings: TuneSettings
    family: str
    check_duration: float = CHECK_DURATION
    controllers: dict[str, TunedController] = field(default_factory=dict)
    wall_time_s: float = 0.0

    @property
    def tuned(self) -> LoadedScenario:
        """The tuned scenario, ready for ``posfb.simulate`` and ``posfb.compare``."""
        return LoadedScenario(copy.deepcopy(self.scenario), self.base_dir, f"tuned {self.source}")

    def dump(self) -> str:
        """The tuned scenario as YAML, the report above it as comments."""
        from posfb.analysis.tuning.report import text_report

        header = "".join(f"# {line}".rstrip() + "\n" for line in text_report(self).splitlines())
        return header + dump_scenario(self.scenario)

    def save(self, path: str | Path) -> Path:
        """Write ``dump()`` to ``path`` (its folder is created)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(self.dump())
        return path


class InfeasibleError(TuneError):
    """No design in the search box meets the constraints on the design plants."""


class UnverifiedError(TuneError):
    """The designs found fail their verification on fresh plants in every round."""


def _entry(scenario: Scenario, controller: str) -> LinearTorqueInputs:
    return copy.deepcopy(with_controller(scenario, controller).controller)


def check_duration(scenario: Scenario) -> float:
    """``CHECK_DURATION`` (at most the scenario's duration) as a whole number of periods."""
    sample_time = scenario.timing.sample_time
    wanted = min(CHECK_DURATION, scenario.timing.duration)
    return max(1, round(wanted / sample_time)) * sample_time


def _simulate(loaded: LoadedScenario, entry: object) -> SimulatedCheck:
    """A ``check_duration`` run of ``entry`` on the scenario's arm; a setting the
    closed loop refuses is reported as the run's status."""
    from posfb.analysis.metrics import run_metrics
    from posfb.diagrams.closed_loop import ClosedLoopRunner

    scenario = copy.deepcopy(loaded.scenario)
    scenario.controller = entry
    scenario.timing.duration = check_duration(scenario)
    trial = LoadedScenario(scenario, loaded.base_dir, loaded.source)
    try:
        result = ClosedLoopRunner(resolve(trial).config).run()
    except ValueError as error:
        return SimulatedCheck((), math.nan, f"refused: {error}")
    metrics = run_metrics(result)
    return SimulatedCheck(metrics.rms_q, metrics.saturated_fraction, result.status)


def _tuned_scenario(
    loaded: LoadedScenario, entries: dict[str, object], out: Path | None
) -> Scenario:
    """The scenario with the tuned entries: the paper's controller as ``controller``, the
    others named; the scenario's own entry of another kind kept under its kind. Paths are
    made absolute unless the file is written beside the scenario."""
    same_folder = out is not None and out.resolve().parent == loaded.base_dir.resolve()
    scenario = copy.deepcopy(loaded.scenario) if same_folder else with_absolute_paths(loaded)
    own = controller_kind(scenario.controller)
    if own not in entries and own not in scenario.controllers:
        scenario.controllers[own] = scenario.controller
    scenario.controller = entries["proposed"]
    for name, entry in entries.items():
        if name != "proposed":
            scenario.controllers[name] = entry
    return scenario


def _tune_controller(
    loaded: LoadedScenario,
    resolved: ResolvedScenario,
    family: Study,
    controller: str,
    settings: TuneSettings,
    deadline: float,
) -> TunedController:
    """Search, then verify on fresh plants; up to ``settings.rounds`` rounds, each on
    twice the design plants of the last and verified on its own fresh set at
    ``beta / rounds`` (so that the statement of the round that passes holds at ``1 -
    beta`` overall, by the union bound)."""
    before = _entry(loaded.scenario, controller)
    checks = verification_plants(settings.epsilon, settings.beta / settings.rounds)
    for round_ in range(settings.rounds):
        count = settings.plants * 2**round_
        design_set = linear_plants(family, resolved, settings.seed, count, errors=True)
        problem = TuningProblem(
            resolved, controller, before, design_set, settings.margin
        )
        found = search(problem, settings.seed, settings.generations, deadline)
        if not found.best.feasible:
            raise InfeasibleError(
                f"no {controller} design meets rho <= {1 - settings.margin:g} on the nominal "
                f"model and {count} plants within the voltage limit (best: nominal rho "
                f"{found.best.nominal_radius:.4f}, worst plant rho "
                f"{found.best.worst_radius:.4f}, voltage {found.best.voltage_ratio:.2f} of the "
                "limit); a smaller --margin, fewer --plants or another sample time may admit one"
            )
        after = problem.settings(found.x)
        fresh_set = linear_plants(family, resolved, settings.seed + 1 + round_, checks)
        radii = tuple(problem.radii(problem.design(after), fresh_set))
        guarantee = verify([r < 1.0 for r in radii], settings.epsilon, settings.beta,
                           settings.rounds)  # fmt: skip
        if time.monotonic() > deadline:
            raise BudgetError(
                "no design within the budget: the search and its verification overran it; "
                "raise --budget, or lower --plants or --generations"
            )
        if guarantee.holds:
            break
    else:
        raise UnverifiedError(
            f"the {controller} design chosen on {count} plants is unstable on "
            f"{guarantee.failures} of {guarantee.plants} fresh ones in the last of "
            f"{settings.rounds} rounds: P(rho >= 1) <= {guarantee.epsilon_bound:.3g} only, "
            f"above epsilon = {settings.epsilon:g}; raise --margin or --plants"
        )
    return TunedController(
        controller=controller,
        before=before,
        after=after,
        start=found.start,
        best=found.best,
        guarantee=guarantee,
        disturbance_std=tuple(float(v) for v in problem.disturbance_std),
        disturbance_bandwidth=problem.disturbance_bandwidth,
        rounds=round_ + 1,
        design_plants=count,
        verified_radii=radii,
        scenario_beta=scenario_confidence(count, len(problem.knobs), settings.epsilon),
        decisions=len(problem.knobs),
        simulated_before=_simulate(loaded, before),
        simulated_after=_simulate(loaded, after),
        generations=found.generations,
        evaluations=found.evaluations,
    )


def tune(
    loaded: LoadedScenario,
    study: Study | None = None,
    settings: TuneSettings | None = None,
    out: Path | None = None,
    study_name: str | None = None,
) -> TuneResult:
    """Tune ``TUNED_CONTROLLERS`` for the scenario ``loaded`` on plants of ``study``
    (``None``: the default spread; ``study_name`` names it in the report). Raises
    ``InfeasibleError`` when no design meets the constraints, ``BudgetError`` when the
    search would overrun ``settings.budget``, ``UnverifiedError`` when no round's design
    passes its verification, ``ValueError`` for a study of another arm."""
    from threadpoolctl import threadpool_limits  # small matrices: one BLAS thread is faster

    settings = TuneSettings() if settings is None else settings
    began = time.monotonic()
    deadline = began + settings.budget
    resolved = resolve(loaded)
    family = plant_family(study, loaded)
    result = TuneResult(
        source=loaded.source,
        scenario=loaded.scenario,
        base_dir=loaded.base_dir,
        settings=settings,
        family="the default spread" if study is None else f"{study_name or 'the study'}",
        check_duration=check_duration(loaded.scenario),
    )
    tuned: dict[str, object] = {}
    with threadpool_limits(1):
        for controller in TUNED_CONTROLLERS:
            entry = _tune_controller(loaded, resolved, family, controller, settings, deadline)
            result.controllers[controller] = entry
            tuned[controller] = entry.after
    result.scenario = _tuned_scenario(loaded, tuned, out)
    result.wall_time_s = time.monotonic() - began
    return result
