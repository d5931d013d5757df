"""``tune``: a robust design of the tunable controllers (those whose spec says what tune
may vary, ``models.controllers.tunable``: the paper's controller and Lin+LC) for a
scenario's arm, with a stated probabilistic guarantee (issue 20).

For each of ``tuned_kinds`` (side by side, one process each, up to the cores available:
``TuneSettings.workers``; the same result as one after the other):

1. draw ``plants`` design plants from the family (``analysis.uncertainty.plants``, seed
   ``seed``) and search the entry's settings (``analysis.design.problem``,
   ``analysis.design.search``) for the smallest predicted tracking error with
   ``rho <= 1 - margin`` on the nominal model and every design plant and within the
   voltage limit;
2. verify the chosen design's stability (``rho < 1``) on
   ``verification_plants(epsilon, beta / rounds)`` *fresh* plants (seed ``seed + 1 +
   round``, drawn after the design is fixed) and state the guarantee that applies
   (``analysis.design.guarantee``); when it does not reach ``epsilon``, search again on
   twice the design plants and verify on another fresh set, at most ``rounds`` times
   (each round at ``beta / rounds``: the union bound keeps ``1 - beta`` overall);
3. cross-check the prediction with short simulations (``CHECK_DURATION`` s, or the
   scenario's duration if shorter) of the entry before and after, on the scenario's arm,
   each judged by ``analysis.common.metrics.run_verdict``;
4. judge the result against the start: a tuned entry whose predicted error is above the
   entry's own, or whose check run is worse (``worse_run``: a worse verdict, saturation
   included), makes the whole result *worse* (``TunedController.worse``), refused
   (``WorseError``) unless ``accept_worse``; and flag every tuned value within
   ``EDGE_SHARE`` of its search box's edge (``TunedController.at_edge``: the best design
   may lie outside the box).

A tuned entry is *certified* (its guarantee stated) only when its check run is ``ok``
(``TunedController.not_certified``): the guarantee is about the sampled linear loop, and
a run that saturates, loses its path or diverges is not that loop.

The tuned scenario holds the first tuned controller as its ``controller`` and the others
as named entries; every other setting is the scenario's. The result
is a pure function of the scenario, the family, the settings and the seed; the budget
only stops a tuning that would overrun it (``BudgetError``). It is a wall-clock bound on
all of the above, checked inside the work (``analysis.design.budget``): before each
plant drawn or judged, after each generation and every ``MONITOR_SAMPLES`` periods of a
check run; and each set of plants (design or verification) is refused before it is
drawn when drawing it and judging the first generation's designs on it (the
verification's one design) cannot fit in what is left, priced by the first
``PROBE_PLANTS`` plants (``_drawn``).
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path

import numpy as np

from posfb.analysis.common.configurations import scenario_configurations
from posfb.analysis.common.loop_effects import left_out
from posfb.analysis.common.metrics import RUN_STATUSES, run_metrics, run_verdict
from posfb.analysis.common.side_by_side import Call, available_cores, side_by_side
from posfb.analysis.design.budget import PROBE_PLANTS, REMEDY, Deadline, TuneError
from posfb.analysis.design.guarantee import (
    Guarantee,
    scenario_confidence,
    verification_plants,
    verify,
)
from posfb.analysis.design.problem import (
    Evaluation,
    Knob,
    TuningProblem,
    entry_feedback,
    judging_seconds,
    knobs,
    tuning,
)
from posfb.analysis.design.search import SearchResult, population, search
from posfb.analysis.design.settings import TuneSettings
from posfb.analysis.uncertainty.plants import LinearPlant, draw_plants, plant_family
from posfb.analysis.uncertainty.study import Study, canonical_text, study_from_text
from posfb.diagrams.resolve import (
    LoadedScenario,
    ResolvedScenario,
    resolve,
    with_absolute_paths,
)
from posfb.diagrams.scenario import (
    DEFAULT_KIND,
    Scenario,
    controller_kind,
    dump_scenario,
    with_controller,
)
from posfb.diagrams.yaml_schema import load_typed
from posfb.models.controllers import REGISTRY, PluginError
from posfb.models.controllers.tunable import Tuning
from posfb.models.design.margins import LoopMargins

#: Seconds of the cross-check simulations (at most the scenario's duration).
CHECK_DURATION = 5.0

#: The most refinement searches one round runs over the path's configurations: each adds
#: the pairs (plant, configuration) the last best design breaks to the search's active set
#: (``_search_over_configurations``) and searches again from that design.
MAX_REFINEMENTS = 3

#: A refinement search's share of the schedule's generations.
REFINEMENT_SHARE = 1.0 / 6.0

#: A tuned value within this share of an edge of its search box is flagged.
EDGE_SHARE = 0.02

def tuned_kinds(resolved: ResolvedScenario) -> tuple[str, ...]:
    """The controllers ``tune`` designs, in order: the scenario's own when its spec says
    what tune may vary (``ControllerSpec.tuning``; a ``!Python`` plug-in's, its class's
    ``tunable``), else the scenario's default kind; then the other registered kinds whose
    spec says it, in registration order."""
    tunable = [kind for kind, entry in REGISTRY.items() if entry.tuning is not None]
    own = resolved.config.controller
    lead = own if resolved.config.spec.tuning is not None else DEFAULT_KIND
    return tuple(dict.fromkeys([lead, *tunable] if lead in (own, *tunable) else tunable))


@dataclass(frozen=True)
class SimulatedCheck:
    """A short run's RMS tracking error (rad, per joint), saturated share and verdict
    (``analysis.common.metrics.run_verdict``: ``status`` and the ``message`` that says why
    it is not ``ok``); ``status`` ``refused`` (no ``rms_q``) where the closed loop refused
    the entry, ``message`` saying why."""

    rms_q: tuple[float, ...]
    saturated_fraction: float
    status: str
    message: str = ""

    def sentence(self) -> str:
        """The verdict in words: the status, with its message when it is not ``ok``."""
        return self.status if not self.message else f"{self.status} ({self.message})"


@dataclass(frozen=True)
class EdgeValue:
    """A tuned decision variable ``key`` (``analysis.design.problem.Knob``) whose
    ``value`` lies within ``EDGE_SHARE`` of the ``side`` (``lower`` or ``upper``) edge
    ``edge`` of its search box."""

    controller: str
    key: str
    value: float
    edge: float
    side: str

    def sentence(self) -> str:
        """One line naming the value and the edge."""
        return (
            f"tuned {self.controller} {self.key} = {self.value:.4g} lies within "
            f"{100 * EDGE_SHARE:g} % of its search box's {self.side} edge {self.edge:g}; the "
            "best design may lie outside the box"
        )


def edge_values(
    controller: str, knobs: tuple[Knob, ...], values: np.ndarray
) -> tuple[EdgeValue, ...]:
    """The ``values`` (actual values, in ``knobs`` order) within ``EDGE_SHARE`` of an
    edge of their knob's box (``|value - edge| <= EDGE_SHARE * edge``)."""
    found = []
    for knob, value in zip(knobs, values, strict=True):
        for side, edge in (("lower", knob.low), ("upper", knob.high)):
            if abs(float(value) - edge) <= EDGE_SHARE * edge:
                found.append(EdgeValue(controller, knob.key, float(value), edge, side))
    return tuple(found)


def worse_run(before: SimulatedCheck, after: SimulatedCheck, allowance: float) -> bool:
    """Whether the check run ``after`` is worse than ``before``: it was refused where
    ``before`` ran, or its verdict is worse (``RUN_STATUSES``' order: ``saturated`` is
    worse than ``ok``), or, with the same verdict, its RMS error norm (over joints)
    exceeds ``before``'s by more than ``allowance`` (rad: the encoder's quantisation RMS,
    below which two runs' order is noise)."""
    if not after.rms_q:
        return bool(before.rms_q)
    if not before.rms_q:
        return False
    if before.status != after.status:
        return RUN_STATUSES.index(after.status) > RUN_STATUSES.index(before.status)
    return float(np.linalg.norm(after.rms_q)) > float(np.linalg.norm(before.rms_q)) + allowance


def _worse(
    start: Evaluation,
    best: Evaluation,
    before: SimulatedCheck,
    after: SimulatedCheck,
    allowance: float,
) -> tuple[str, ...]:
    """Why a tuned entry is worse than the entry it started from (empty: it is not). A
    larger predicted error counts only against a start that meets every constraint (or
    a tuned entry that does not): a start that is not robustly stable on the design
    plants and configurations, or that exceeds the voltage limit, has no predicted error
    worth keeping, and its check run is compared all the same."""
    reasons = []
    if best.predicted_rms > start.predicted_rms and (start.feasible or not best.feasible):
        reasons.append(
            f"predicted RMS error {start.predicted_rms:.4g} -> {best.predicted_rms:.4g} rad"
        )
    if worse_run(before, after, allowance):
        reasons.append(f"check run's RMS error norm and verdict {_norm(before)} -> {_norm(after)}")
    return tuple(reasons)


def _norm(check: SimulatedCheck) -> str:
    """A check run as its RMS error norm and verdict (its refusal when it did not run)."""
    if not check.rms_q:
        return check.sentence()
    return f"{float(np.linalg.norm(check.rms_q)):.3g} rad ({check.status})"


@dataclass(frozen=True)
class TunedController:
    """One controller's tuning: the entries before and after, their evaluations on the
    design plants, the verification, the cross-check runs and the search's size;
    ``worse``: why the tuned entry is worse than the start (empty: it is not);
    ``at_edge``: the tuned values at their search box's edge."""

    controller: str
    tuning: Tuning
    before: object
    after: object
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
    worse: tuple[str, ...] = ()
    at_edge: tuple[EdgeValue, ...] = ()
    margins_before: LoopMargins | None = None
    margins_after: LoopMargins | None = None

    @property
    def not_certified(self) -> str:
        """Why the tuned entry's guarantee is not stated, in one line (empty: it is): its
        check run is not ``ok`` (module docstring)."""
        check = self.simulated_after
        if check.status == "ok":
            return ""
        return (
            f"its check run is {check.sentence()}: the guarantee covers the linear sampled "
            f"loop, not a run that is {check.status}"
        )


@dataclass
class TuneResult:
    """What ``tune`` found: the tuned scenario and, per controller, ``TunedController``;
    ``left_out``: the scenario's nonlinear settings its sampled loops leave out
    (``analysis.common.loop_effects.left_out``; the linear effects are in them)."""

    source: str
    scenario: Scenario
    base_dir: Path
    settings: TuneSettings
    family: str
    check_duration: float = CHECK_DURATION
    controllers: dict[str, TunedController] = field(default_factory=dict)
    wall_time_s: float = 0.0
    left_out: list[str] = field(default_factory=list)

    @property
    def worse(self) -> str:
        """Why the tuned design is worse than the scenario's own, in one line (empty: it
        is not): per controller, its predicted error or its check run."""
        return "; ".join(
            f"{name}: {', '.join(entry.worse)}"
            for name, entry in self.controllers.items()
            if entry.worse
        )

    @property
    def not_certified(self) -> str:
        """Which tuned entries get no guarantee and why, in one line (empty: all do)."""
        return "; ".join(
            f"{name}: {entry.not_certified}"
            for name, entry in self.controllers.items()
            if entry.not_certified
        )

    @property
    def at_edge(self) -> tuple[EdgeValue, ...]:
        """Every tuned value within ``EDGE_SHARE`` of its search box's edge."""
        return tuple(edge for entry in self.controllers.values() for edge in entry.at_edge)

    @property
    def tuned(self) -> LoadedScenario:
        """The tuned scenario, ready for ``posfb.simulate`` and ``posfb.compare``."""
        return LoadedScenario(copy.deepcopy(self.scenario), self.base_dir, f"tuned {self.source}")

    def dump(self) -> str:
        """The tuned scenario as YAML, the report above it as comments."""
        from posfb.analysis.design.tune_report import text_report

        header = "".join(f"# {line}".rstrip() + "\n" for line in text_report(self).splitlines())
        return header + dump_scenario(self.scenario)

    def save(self, path: str | Path) -> Path:
        """Write ``dump()`` to ``path`` (its folder is created), atomically
        (``analysis.common.outputs.atomic_file``): an existing file is replaced, and a failed
        write leaves it as it was."""
        from posfb.analysis.common.outputs import atomic_file

        path = Path(path)
        with atomic_file(path) as temporary:
            temporary.write_text(self.dump())
        return path


class InfeasibleError(TuneError):
    """No design in the search box meets the constraints on the design plants."""


class UnverifiedError(TuneError):
    """The designs found fail their verification on fresh plants in every round."""


class WorseError(TuneError):
    """The tuned design is worse than the scenario's own (``TuneResult.worse``); the
    result is kept in ``result``, for a caller that wants to see it."""

    def __init__(self, result: TuneResult) -> None:
        super().__init__(
            f"the tuned design is worse than the scenario's own: {result.worse}; nothing "
            "is written unless accepted (--accept-worse, posfb.tune(..., accept_worse=True))"
        )
        self.result = result


def _entry(scenario: Scenario, controller: str) -> object:
    return copy.deepcopy(with_controller(scenario, controller).controller)


def check_duration(scenario: Scenario) -> float:
    """``CHECK_DURATION`` (at most the scenario's duration) as a whole number of periods."""
    sample_time = scenario.timing.sample_time
    wanted = min(CHECK_DURATION, scenario.timing.duration)
    return max(1, round(wanted / sample_time)) * sample_time


class _OutOfTime(Exception):  # noqa: N818 (not an error: a stop)
    """A check run stopped by the budget at simulated time ``args[0]`` (not a
    ``RuntimeError``, which the runner reports as the run's own divergence)."""


def _margins(loaded: LoadedScenario, entry: object) -> LoopMargins | None:
    """The margins of ``entry``'s nominal sampled loop on the scenario
    (``analysis.design.linear_loop``); ``None`` where the entry is refused."""
    from posfb.analysis.design.linear_loop import linear_design

    scenario = copy.deepcopy(loaded.scenario)
    scenario.controller = entry
    try:
        return linear_design(resolve(LoadedScenario(scenario, loaded.base_dir))).margins()
    except ValueError:
        return None


def _simulate(
    loaded: LoadedScenario, entry: object, deadline: Deadline, what: str
) -> SimulatedCheck:
    """A ``check_duration`` run of ``entry`` (``what``, for the budget's message) on the
    scenario's arm; a setting the closed loop refuses is reported as the run's status.
    ``BudgetError`` when ``deadline`` passes during the run (checked every
    ``MONITOR_SAMPLES`` periods, by the runner's progress callback)."""
    from posfb.diagrams.runner import ClosedLoopRunner

    scenario = copy.deepcopy(loaded.scenario)
    scenario.controller = entry
    scenario.timing.duration = check_duration(scenario)
    trial = LoadedScenario(scenario, loaded.base_dir, loaded.source)

    def stop_when_out_of_time(simulated: float) -> None:
        if deadline.passed():
            raise _OutOfTime(simulated)

    try:
        result = ClosedLoopRunner(resolve(trial).config).run(progress=stop_when_out_of_time)
    except ValueError as error:
        return SimulatedCheck((), math.nan, "refused", str(error))
    except _OutOfTime as stop:
        raise deadline.error(
            f"running the {scenario.timing.duration:g} s check run of {what} (stopped at "
            f"t = {stop.args[0]:g} s)"
        ) from None
    metrics, verdict = run_metrics(result), run_verdict(result)
    return SimulatedCheck(
        metrics.rms_q, metrics.saturated_fraction, verdict.status, verdict.message
    )


def _drawn(
    plants: Iterator[LinearPlant],
    count: int,
    designs: tuple[int, str],
    judging: Callable[[list[LinearPlant]], float],
    deadline: Deadline,
    what: str,
    remedy: str = REMEDY,
) -> list[LinearPlant]:
    """The ``count`` plants of ``plants`` (``what`` they are, and ``remedy``: what to
    change, for the messages), with the budget checked before each; after the first
    ``PROBE_PLANTS``, the rest is priced by the fastest of them and ``judging`` (seconds
    per plant and design, measured on them) and refused up front (``BudgetError``) when
    drawing the rest and judging the ``designs`` (how many, and what they are) on all
    ``count`` cannot fit in what is left of ``deadline``."""
    drawn: list[LinearPlant] = []
    seconds: list[float] = []
    deadline.check(f"drawing {what}: 0 of {count} drawn", remedy)
    began = time.monotonic()
    for plant in plants:
        now = time.monotonic()
        seconds.append(now - began)
        drawn.append(plant)
        if len(drawn) == min(count, PROBE_PLANTS):
            drawing, judge = min(seconds), judging(drawn)
            deadline.require(
                (count - len(drawn)) * drawing + designs[0] * count * judge,
                f"drawing {count} {what} at {1e3 * drawing:.2g} ms each and judging {designs[1]} "
                f"on each at {1e3 * judge:.2g} ms per plant and design",
                remedy,
            )
        if len(drawn) < count:
            deadline.check(f"drawing {what}: {len(drawn)} of {count} drawn", remedy)
        began = time.monotonic()
    return drawn


def _tuned_scenario(
    loaded: LoadedScenario, entries: dict[str, object], out: Path | None
) -> Scenario:
    """The scenario with the tuned entries: the first as ``controller``, the others named;
    the scenario's own entry of another kind kept under its kind. Paths are made absolute
    unless the file is written beside the scenario."""
    same_folder = out is not None and out.resolve().parent == loaded.base_dir.resolve()
    scenario = copy.deepcopy(loaded.scenario) if same_folder else with_absolute_paths(loaded)
    own = controller_kind(scenario.controller)
    if own not in entries and own not in scenario.controllers:
        scenario.controllers[own] = scenario.controller
    lead, *others = entries
    scenario.controller = entries[lead]
    for name in others:
        scenario.controllers[name] = entries[name]
    return scenario


@dataclass(frozen=True)
class _Progress:
    """The progress line of one controller's tuning: ``show(text)`` (``None``: silent),
    each line ending in the budget left."""

    show: Callable[[str], None] | None
    controller: str
    deadline: Deadline

    def say(self, doing: str) -> None:
        if self.show is not None:
            left = max(0.0, self.deadline.left())
            self.show(f"{self.controller}: {doing}; {left:.0f} s of the {self.deadline.budget:g} "
                      "s budget left")  # fmt: skip

    def search(self, stage: str, schedule: int) -> Callable[[int, Evaluation], None] | None:
        """The search's callback: ``stage``, the generation of ``schedule`` and the best
        design's predicted error."""
        if self.show is None:
            return None

        def report(done: int, best: Evaluation) -> None:
            found = (f"best predicted RMS {best.predicted_rms:.3g} rad" if best.feasible
                     else "no design meets the constraints yet")  # fmt: skip
            self.say(f"{stage}, generation {done}/{schedule}, {found}")

        return report


def _search_over_configurations(
    problem: TuningProblem, settings: TuneSettings, deadline: Deadline, progress: _Progress,
    stage: str,
) -> tuple[TuningProblem, SearchResult]:  # fmt: skip
    """The search on ``problem``'s active configurations (``analysis.design.problem``),
    repeated with the configurations its best design breaks added to the set, until the
    best design holds at all of them (or ``MAX_REFINEMENTS`` searches have run: its
    verification then judges it at all of them)."""
    problem = replace(problem, active=problem.initial_active())
    found = search(problem, settings.seed, settings.generations, deadline,
                   progress=progress.search(f"{stage} search", settings.generations))  # fmt: skip
    generations, evaluations = found.generations, found.evaluations
    for _ in range(MAX_REFINEMENTS):
        missing = problem.violated(problem.settings(found.x)) if found.best.feasible else ()
        if not missing:
            break
        problem = replace(problem, active=problem.active + missing)
        refinement = refinement_generations(settings.generations)
        found = search(problem, settings.seed, refinement, deadline, x0=found.x,
                       progress=progress.search(f"{stage} refinement with "
                                                f"{len(problem.active)} configurations",
                                                refinement))  # fmt: skip
        generations, evaluations = generations + found.generations, evaluations + found.evaluations
    return problem, replace(found, generations=generations, evaluations=evaluations)


def refinement_generations(generations: int) -> int:
    """The generations of a refinement search: ``REFINEMENT_SHARE`` of the schedule's (at
    least one); it starts from the last best design, which breaks the new pairs only
    slightly (it met the constraint at the others)."""
    return max(1, math.ceil(REFINEMENT_SHARE * generations))


def _require_plugin_feedback(resolved: ResolvedScenario, controller: str, entry: object) -> None:
    """Raise a plug-in's own ``PluginError`` for its starting ``entry`` (one written as a
    step has no linear feedback to judge; its code refuses its scenario's settings); a
    start that a design refuses is searched from all the same."""
    try:
        entry_feedback(resolved, controller, entry)
    except PluginError:
        raise
    except ValueError:
        pass


def _tune_controller(
    loaded: LoadedScenario,
    resolved: ResolvedScenario,
    family: Study,
    controller: str,
    settings: TuneSettings,
    deadline: Deadline,
    show: Callable[[str], None] | None = None,
) -> TunedController:
    """Search, then verify on fresh plants; up to ``settings.rounds`` rounds, each on
    twice the design plants of the last and verified on its own fresh set at
    ``beta / rounds`` (so that the statement of the round that passes holds at ``1 -
    beta`` overall, by the union bound); ``BudgetError`` when ``deadline`` passes, or
    would (``_drawn``), first. ``show`` gets a progress line at each step."""
    progress = _Progress(show, controller, deadline)
    before = _entry(loaded.scenario, controller)
    _require_plugin_feedback(resolved, controller, before)
    checks = verification_plants(settings.epsilon, settings.beta / settings.rounds)
    configurations = scenario_configurations(resolved.config)
    angles = tuple(c.q for c in configurations.configurations)
    members = population(len(knobs(controller, before, resolved)))
    for round_ in range(settings.rounds):
        count = settings.plants * 2**round_
        stage = f"round {round_ + 1}/{settings.rounds}"
        progress.say(f"{stage}, drawing {count} design plants")
        design_set = _drawn(
            draw_plants(
                family, resolved, settings.seed, count, errors=True, configurations=angles
            ),  # fmt: skip
            count,
            (members, f"the first generation's {members} designs"),
            partial(judging_seconds, resolved, controller, before),
            deadline,
            f"{controller} design plants (round {round_ + 1})",
        )
        problem, found = _search_over_configurations(
            TuningProblem(resolved, controller, before, design_set, settings.margin, deadline,
                          configurations),
            settings, deadline, progress, stage,
        )  # fmt: skip
        if not found.best.feasible:
            raise InfeasibleError(
                f"no {controller} design meets rho <= {1 - settings.margin:g} on the nominal "
                f"model and {count} plants within the voltage limit (best: nominal rho "
                f"{found.best.nominal_radius:.4f}, worst plant rho "
                f"{found.best.worst_radius:.4f}, voltage {found.best.voltage_ratio:.2f} of the "
                "limit); a smaller --margin, fewer --plants or another sample time may admit one"
            )
        after = problem.settings(found.x)
        progress.say(f"{stage}, verifying the design on {checks} fresh plants")
        fresh_set = _drawn(
            draw_plants(
                family, resolved, settings.seed + 1 + round_, checks, configurations=angles
            ),  # fmt: skip
            checks,
            (1, "the chosen design"),
            partial(judging_seconds, resolved, controller, after),
            deadline,
            f"fresh {controller} verification plants (round {round_ + 1})",
            "raise --budget, or --epsilon or --beta (fewer fresh plants)",
        )
        radii = tuple(problem.radii(problem.feedback(after), fresh_set, everywhere=True))
        guarantee = verify([r < 1.0 for r in radii], settings.epsilon, settings.beta,
                           settings.rounds)  # fmt: skip
        if guarantee.holds:
            break
    else:
        raise UnverifiedError(
            f"the {controller} design chosen on {count} plants is unstable on "
            f"{guarantee.failures} of {guarantee.plants} fresh ones in the last of "
            f"{settings.rounds} rounds: P(rho >= 1) <= {guarantee.epsilon_bound:.3g} only, "
            f"above epsilon = {settings.epsilon:g}; raise --margin or --plants"
        )
    progress.say("check runs of the entry before and after, on the scenario's arm")
    simulated_before = _simulate(loaded, before, deadline, f"the scenario's {controller} entry")
    simulated_after = _simulate(loaded, after, deadline, f"the tuned {controller} entry")
    allowance = float(np.linalg.norm(problem.noise_std))
    return TunedController(
        controller=controller,
        tuning=problem.tuning,
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
        simulated_before=simulated_before,
        simulated_after=simulated_after,
        generations=found.generations,
        evaluations=found.evaluations,
        worse=_worse(found.start, found.best, simulated_before, simulated_after, allowance),
        at_edge=edge_values(controller, problem.knobs, np.power(10.0, found.x)),
        margins_before=_margins(loaded, before),
        margins_after=_margins(loaded, after),
    )


def _tuned(
    loaded: LoadedScenario, resolved: ResolvedScenario, family: Study, settings: TuneSettings,
    deadline: Deadline, progress: Callable[[str], None] | None,
) -> list[TunedController]:  # fmt: skip
    """Each of ``tuned_kinds`` tuned (``_tune_controller``), in order: one after the other
    in this process, or side by side in ``settings.workers`` processes
    (``analysis.common.side_by_side``: the same work on the same inputs, so the same
    result; the first controller in order that fails raises, as in a loop)."""
    kinds = tuned_kinds(resolved)
    workers = min(len(kinds), available_cores() if settings.workers is None else settings.workers)
    if workers == 1:
        return [_tune_controller(loaded, resolved, family, controller, settings, deadline,
                                 progress) for controller in kinds]  # fmt: skip
    for controller in kinds:  # a plug-in's own error, with its frames, from this process
        _require_plugin_feedback(resolved, controller, _entry(loaded.scenario, controller))
    inputs = (dump_scenario(loaded.scenario), loaded.base_dir, loaded.source,
              canonical_text(family))  # fmt: skip
    calls = [Call(controller, _tune_in_process,
                  (*inputs, controller, settings, deadline, progress is not None))
             for controller in kinds]  # fmt: skip
    found = side_by_side(calls, workers, preload=[__name__], say=progress)
    return [replace(entry, tuning=tuning(entry.controller, resolved)) for entry in found]


def _tune_in_process(
    scenario_text: str, base_dir: Path, source: str, family_text: str, controller: str,
    settings: TuneSettings, deadline: Deadline, show_progress: bool,
    say: Callable[[str], None],
) -> TunedController:  # fmt: skip
    """``_tune_controller`` in a worker process, from the scenario and the family as
    text; its ``tuning`` (which holds functions) is left out, for the parent to put back."""
    from threadpoolctl import threadpool_limits

    loaded = LoadedScenario(load_typed(Scenario, scenario_text, source), base_dir, source)
    loaded = loaded.with_settings(())
    family = study_from_text(family_text, source="the tuning's plant family")
    with threadpool_limits(1):
        entry = _tune_controller(loaded, resolve(loaded), family, controller, settings,
                                 deadline, say if show_progress else None)  # fmt: skip
    return replace(entry, tuning=None)


def tune(
    loaded: LoadedScenario,
    study: Study | None = None,
    settings: TuneSettings | None = None,
    out: Path | None = None,
    study_name: str | None = None,
    accept_worse: bool = False,
    progress: Callable[[str], None] | None = None,
) -> TuneResult:
    """Tune ``tuned_kinds`` for the scenario ``loaded`` on plants of ``study``
    (``None``: the default spread; ``study_name`` names it in the report). Raises
    ``ValueError`` for a study of another arm (before any other work), ``InfeasibleError``
    when no design meets the constraints, ``BudgetError`` when the tuning runs out of
    ``settings.budget`` (a wall-clock bound, checked inside the work) or would (a set of
    plants priced before it is drawn), ``UnverifiedError`` when no round's design passes its
    verification, and ``WorseError`` when the tuned design is worse than the scenario's
    own (``TuneResult.worse``), unless ``accept_worse``. ``progress`` gets one line at each
    step and each generation of the search (the step, the best design so far, the budget
    left)."""
    from threadpoolctl import threadpool_limits  # small matrices: one BLAS thread is faster

    settings = TuneSettings() if settings is None else settings
    began = time.monotonic()
    deadline = Deadline.after(settings.budget)
    family = plant_family(study, loaded)
    resolved = resolve(loaded)
    result = TuneResult(
        source=loaded.source,
        scenario=loaded.scenario,
        base_dir=loaded.base_dir,
        settings=settings,
        family="the default spread" if study is None else f"{study_name or 'the study'}",
        check_duration=check_duration(loaded.scenario),
        left_out=left_out(resolved.config),
    )
    tuned: dict[str, object] = {}
    with threadpool_limits(1):
        for entry in _tuned(loaded, resolved, family, settings, deadline, progress):
            result.controllers[entry.controller] = entry
            tuned[entry.controller] = entry.after
    result.scenario = _tuned_scenario(loaded, tuned, out)
    result.wall_time_s = time.monotonic() - began
    if result.worse and not accept_worse:
        raise WorseError(result)
    return result
