"""The robust tuning problem: which settings of a controller entry are searched, what is
minimised, and what is required.

**Decision variables**: the controller's own (``ControllerSpec.tuning``,
``models.controllers.tunable``: for Lin+LC and the paper's controller the Sec. 3.2
weights' multipliers, the paper's adding ``alpha_star``), searched on a log scale. The
loop a candidate is judged by is the controller's linear feedback
(``models.controllers.linear_feedback``: derived from its law, or the Sec. 3 design's
filter) closed around the held plant.

**Objective** (``predicted_rms``): the predicted RMS tracking error of the nominal
sampled-data loop, ``sqrt(sum_j var(q~_j))`` in its stationary state
(``models.design.closed_loop.stationary_deviations``: the H2 norms of the loop weighted
by the intensities of its two inputs), driven by

* the model error ``h`` of Eq. 2 that the family implies, held over each period: per
  joint, the RMS over the design plants and the trajectory of the plant's inverse
  dynamics minus the nominal model's (``analysis.uncertainty.plants``), as a first-order
  Gauss-Markov sequence whose bandwidth is that error's (``torque_bandwidth``); a
  family without spread (or no design plants) has none;
* the encoder's quantisation, white, standard deviation ``(2 pi / counts) / sqrt(12)``
  per joint (and the sensor's noise, when it has some).

**Constraints**: ``rho <= 1 - margin`` on the nominal model and on every design plant
(``analysis.uncertainty.plants``), each at its ``M0*`` and with its ``M*(q)`` frozen at the
configurations of the scenario's path (``models.design.configurations``), and the voltage
limit along the trajectory: per joint, the nominal inverse dynamics' peak voltage plus
three standard deviations of the feedback voltage the two inputs cause stays within the
limit.

The configurations are judged by an **active set** (so that a search costs about the same
whatever their number): a design is judged at the ``active`` pairs only, each a plant
(``NOMINAL``: the nominal model; otherwise an index into ``plants``) and a configuration
(at first the nominal model at the path's lightest and heaviest and where the entry's own
loop is worst), the discretised plant at every configuration made once; ``violated``
judges a chosen design at all of them, on every plant, and ``analysis.design.tune`` adds
each plant's worst configuration that breaks the constraint and searches again.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from posfb.analysis.common.loop_effects import nominal_effects
from posfb.analysis.design.budget import Deadline
from posfb.analysis.uncertainty.plants import LinearPlant, error_instants
from posfb.diagrams.resolve import ResolvedScenario
from posfb.diagrams.scenario import Python
from posfb.models.controllers import ControllerConfig, entry_build, linear_feedback, spec
from posfb.models.controllers.registry import ControllerSpec
from posfb.models.controllers.tunable import Knob, Tuning
from posfb.models.design.closed_loop import (
    HeldPlant,
    held_loop,
    held_plant,
    held_transitions,
    spectral_radii,
    stationary_deviations,
)
from posfb.models.design.configurations import ConfigurationSet
from posfb.models.design.realisation import DiscreteFilter
from posfb.models.nominal import nominal_model, trajectory_voltages

#: The plant index of the nominal model in an active pair (``TuningProblem.active``).
NOMINAL = -1

#: Standard deviations of the feedback voltage kept below the limit with the peak.
VOLTAGE_SIGMAS = 3.0


def scenario_spec(resolved: ResolvedScenario | None, controller: str) -> ControllerSpec:
    """The spec of ``controller`` in ``resolved``: the scenario's own entry's when it is of
    that kind (a ``!Python`` plug-in's, made from its class), else the registered kind's."""
    if resolved is not None and controller == resolved.config.controller:
        return resolved.config.spec
    return spec(controller)


def tuning(controller: str, resolved: ResolvedScenario | None = None) -> Tuning:
    """What tune may vary of ``controller`` (``scenario_spec``); ``ValueError`` (one line)
    for one that says nothing (``ControllerSpec.tuning``)."""
    entry = scenario_spec(resolved, controller)
    if entry.tuning is None:
        raise ValueError(f"controller {controller!r} says nothing tune may vary (its spec has "
                         "no tuning)")  # fmt: skip
    return entry.tuning


def knobs(
    controller: str, entry: object, resolved: ResolvedScenario | None = None
) -> tuple[Knob, ...]:
    """The decision variables of ``controller``'s settings ``entry``."""
    return tuning(controller, resolved).knobs(entry)


def entry_feedback(resolved: ResolvedScenario, controller: str, entry: object) -> DiscreteFilter:
    """The linear feedback of ``controller`` with the settings ``entry`` on the scenario's
    nominal model at its sample time (a ``!Python`` entry: the scenario's own plug-in class
    with the entry's settings); ``ValueError`` (one line) for settings the controller
    refuses."""
    config = resolved.config
    if isinstance(entry, Python):
        plugin = replace(config.controller_settings, settings=json.loads(entry.settings))
        design = ControllerConfig.without_design(config.context)
        return linear_feedback(controller, design, settings=plugin)
    build = entry_build(entry, config.context)
    return linear_feedback(controller, build.design, settings=build.settings)


def feedback_radius(feedback: DiscreteFilter, plant: HeldPlant) -> float:
    """The spectral radius of ``feedback`` closed around the held ``plant``."""
    return float(feedback_radii(feedback, [plant])[0])


def feedback_radii(feedback: DiscreteFilter, plants: Sequence[HeldPlant]) -> np.ndarray:
    """The spectral radius of ``feedback`` closed around each of ``plants`` (held alike:
    one size of loop), in one batched eigenvalue call (a tuner asks for hundreds per
    candidate)."""
    if not plants:
        return np.zeros(0)
    return spectral_radii(held_transitions(plants, feedback, np.eye(plants[0].Gamma.shape[1])))


def torque_bandwidth(series: list[np.ndarray], step: float) -> float:
    """How fast torques vary (rad/s): the largest over joints of ``RMS(dv/dt) / RMS(v -
    mean v)`` (``omega`` for a sinusoid of frequency ``omega``), pooled over ``series``
    (each one row per instant, ``step`` seconds apart); 0 for torques that do not vary."""
    rates = np.vstack([np.diff(s, axis=0) / step for s in series])
    spread = np.vstack([s - s.mean(axis=0) for s in series])
    rate_rms = np.sqrt(np.mean(np.square(rates), axis=0))
    spread_rms = np.sqrt(np.mean(np.square(spread), axis=0))
    varying = spread_rms > 0.0
    return float(np.max(rate_rms[varying] / spread_rms[varying])) if np.any(varying) else 0.0


@dataclass(frozen=True)
class Evaluation:
    """One design judged: ``predicted_rms`` (rad; ``inf`` when the nominal loop is
    unstable), ``nominal_radius``, ``worst_radius`` over the design plants (``nan``
    with none), ``voltage`` per joint (peak feed-forward + ``VOLTAGE_SIGMAS`` sigma of
    the feedback, V), ``voltage_ratio`` (largest ``voltage / limit``) and whether every
    constraint holds (``feasible``); ``refused``: the design's own refusal, if any."""

    predicted_rms: float
    nominal_radius: float
    worst_radius: float
    voltage: tuple[float, ...]
    voltage_ratio: float
    feasible: bool
    refused: str = ""


def judging_seconds(
    resolved: ResolvedScenario,
    controller: str,
    entry: object,
    plants: list[LinearPlant],
) -> float:
    """Seconds to judge ``entry``'s loop (``controller``) around one plant: the fastest
    over ``plants`` (the price of each further plant); 0 when the entry is refused (its
    cost is then not known)."""
    try:
        feedback = entry_feedback(resolved, controller, entry)
    except ValueError:
        return 0.0
    times = []
    for plant in plants:
        began = time.perf_counter()
        feedback_radius(feedback, plant.held)
        times.append(time.perf_counter() - began)
    return min(times, default=0.0)


@dataclass
class TuningProblem:
    """The tuning of ``controller`` (a registered kind with a ``tuning``) starting from the
    scenario's ``entry``, checked on ``plants`` with ``margin``; ``deadline`` (``None``:
    none) is checked before each plant a design is judged on (``radii``);
    ``configurations``: the path's (each plant's ``held_at`` holds its loop at them),
    judged at the ``active`` ones during the search (module docstring)."""

    resolved: ResolvedScenario
    controller: str
    entry: object
    plants: list[LinearPlant]
    margin: float
    deadline: Deadline | None = None
    configurations: ConfigurationSet | None = None
    active: tuple[tuple[int, int], ...] = ()

    def __post_init__(self) -> None:
        config = self.resolved.config
        self.context = config.context
        self.tuning = tuning(self.controller, self.resolved)
        self.knobs = self.tuning.knobs(self.entry)
        model = nominal_model(self.context.nominal)
        self.effects = nominal_effects(self.resolved)
        sample_time = self.context.sample_time
        self.nominal_held = held_plant(model.M0(), model.B(), sample_time, self.effects)
        masses = () if self.configurations is None else self.configurations.masses
        self.nominal_held_at = tuple(
            held_plant(M, model.B(), sample_time, self.effects) for M in masses
        )
        times = np.arange(config.samples + 1) * config.sample_time
        needed = trajectory_voltages(model, config.trajectory, times)
        self.peak_voltage = np.max(np.abs(needed), axis=0)
        self.voltage_limit = np.asarray(config.voltage_limit, dtype=float)
        errors = [p.torque_error for p in self.plants if len(p.torque_error) > 1]
        if errors:
            self.disturbance_std = np.sqrt(np.mean(np.square(np.vstack(errors)), axis=0))
            step = float(np.diff(error_instants(self.resolved))[0])
            self.disturbance_bandwidth = torque_bandwidth(errors, step)
        else:
            self.disturbance_std, self.disturbance_bandwidth = np.zeros(len(needed[0])), 0.0
        self.disturbance_pole = math.exp(-self.disturbance_bandwidth * config.sample_time)
        counts = np.asarray(config.sensor_state.encoder_counts, dtype=float)
        step = np.divide(2.0 * math.pi, counts, out=np.zeros_like(counts), where=counts > 0)
        noise = np.asarray(config.sensor_state.noise_std, dtype=float)
        self.noise_std = np.sqrt(step**2 / 12.0 + noise**2)

    def settings(self, x: np.ndarray) -> object:
        """The entry at the point ``x`` (log10 of each knob's value)."""
        return self.tuning.apply(self.entry, np.power(10.0, x), self.context.sample_time)

    def bounds(self) -> list[tuple[float, float]]:
        """The search box in log10."""
        return [(math.log10(k.low), math.log10(k.high)) for k in self.knobs]

    def start(self) -> np.ndarray:
        """The entry's own point (log10), clipped into the box."""
        low, high = np.array(self.bounds()).T
        return np.clip([math.log10(k.start) for k in self.knobs], low, high)

    def feedback(self, entry: object) -> DiscreteFilter:
        """The linear feedback of ``entry`` on the scenario's nominal model; ``ValueError``
        (one line) for settings the controller refuses."""
        return entry_feedback(self.resolved, self.controller, entry)

    def evaluate(self, entry: object) -> Evaluation:
        """``entry`` judged on the nominal loop and the design plants."""
        try:
            feedback = self.feedback(entry)  # the controller's own refusals
        except ValueError as error:
            return Evaluation(math.inf, math.inf, math.inf, (), math.inf, False, str(error))
        active = [self.nominal_held_at[c] for owner, c in self.active if owner == NOMINAL]
        nominal_radius = float(feedback_radii(feedback, [self.nominal_held, *active]).max())
        worst = max(self.radii(feedback, self.plants), default=math.nan)
        if nominal_radius >= 1.0:
            return Evaluation(math.inf, nominal_radius, worst, (), math.inf, False)
        loop = held_loop(self.nominal_held, feedback, np.eye(len(self.voltage_limit)))
        q_std, u_std = stationary_deviations(
            loop, self.disturbance_std, self.noise_std, self.disturbance_pole
        )
        voltage = self.peak_voltage + VOLTAGE_SIGMAS * u_std
        ratio = float(np.max(voltage / self.voltage_limit))
        stable = max(nominal_radius, worst if self.plants else 0.0) <= 1.0 - self.margin
        return Evaluation(
            predicted_rms=float(np.sqrt(np.sum(q_std**2))),
            nominal_radius=nominal_radius,
            worst_radius=worst,
            voltage=tuple(float(v) for v in voltage),
            voltage_ratio=ratio,
            feasible=bool(stable and ratio <= 1.0),
        )

    def radii(
        self, feedback: DiscreteFilter, plants: list[LinearPlant], everywhere: bool = False
    ) -> list[float]:
        """The spectral radius of the controller's loop around each of ``plants``, the
        worst of its ``M0*`` and its ``active`` configurations (``everywhere``: all of
        them) (``BudgetError`` once ``deadline`` has passed)."""
        held, starts = [], []
        for index, plant in enumerate(plants):
            if self.deadline is not None and self.deadline.passed():
                raise self.deadline.error(
                    f"judging a {self.controller} design on plant {index + 1} of {len(plants)}"
                )
            frozen = plant.held_at if everywhere else [
                plant.held_at[c] for owner, c in self.active if owner == index]  # fmt: skip
            starts.append(len(held))
            held += [plant.held, *frozen]
        if not held:
            return []
        return [float(r) for r in np.maximum.reduceat(feedback_radii(feedback, held), starts)]

    def violated(self, entry: object) -> tuple[tuple[int, int], ...]:
        """The pairs (plant, configuration) where ``entry``'s loop breaks ``rho <= 1 -
        margin``, judged at every configuration of the nominal model and every design
        plant: for each, its worst configuration when that one breaks it and is not
        active yet."""
        if self.configurations is None:
            return ()
        feedback = self.feedback(entry)
        limit = 1.0 - self.margin
        owners = [(NOMINAL, self.nominal_held_at)] + [
            (index, plant.held_at) for index, plant in enumerate(self.plants)]  # fmt: skip
        found = []
        for owner, held_at in owners:
            radii = feedback_radii(feedback, held_at)
            pair = (owner, int(np.argmax(radii)))
            if radii[pair[1]] > limit and pair not in self.active:
                found.append(pair)
        return tuple(found)

    def initial_active(self) -> tuple[tuple[int, int], ...]:
        """The pairs the search starts with: the nominal model at the path's lightest and
        heaviest configurations and at the one where the entry's own loop is worst."""
        if self.configurations is None:
            return ()
        extremes = [i for i, c in enumerate(self.configurations.configurations)
                    if c.role in ("lightest", "heaviest")]  # fmt: skip
        try:
            feedback = self.feedback(self.entry)
            extremes.append(int(np.argmax(feedback_radii(feedback, self.nominal_held_at))))
        except ValueError:
            pass  # an entry the design refuses: its search starts from the extremes
        return tuple((NOMINAL, c) for c in dict.fromkeys(extremes))

    def violations(self, evaluation: Evaluation) -> np.ndarray:
        """How far ``evaluation`` is from each constraint (``<= 0``: met): the nominal and
        the worst plant radius against ``1 - margin``, the voltage ratio against 1."""
        worst = evaluation.worst_radius if self.plants else evaluation.nominal_radius
        limit = 1.0 - self.margin
        return np.array(
            [evaluation.nominal_radius - limit, worst - limit, evaluation.voltage_ratio - 1.0]
        )


#: An evaluation of a point in log10 space, cached by the search.
Evaluator = Callable[[np.ndarray], Evaluation]
