"""The robust tuning problem: which settings of a Sec. 3 controller entry are searched,
what is minimised, and what is required.

**Decision variables** (``knobs``), searched on a log scale:

* ``alpha_star`` (the proposed controller only): the steady-state gain of ``tau_NC``
  (Eq. 19-21), ``0.05 .. max(10, 2 alpha*)``;
* ``Q1`` position and velocity blocks, ``R`` and ``lambdas``: multipliers
  ``10^-2 .. 10^2`` (``lambdas``: ``10^-1 .. 10^1``) of the entry's own weights (Sec. 3.2),
  so that the search keeps their per-joint proportions and off-diagonal structure.

``K_alpha`` (how fast Eq. 21 raises ``alpha`` to ``alpha*``), ``H`` and ``Q2`` do not
enter the linear loop at ``alpha = alpha*`` and are kept; ``filter_a`` (Sec. 3.4) does
not either: the entry's value is kept when it is above ``ln 2 / T_s``, and replaced by
the rule of ``posfb scenario init`` otherwise (``models.design.initial.filter_pole``), so
a tuned scenario never holds an invalid pair.

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

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from posfb.analysis.common.loop_effects import nominal_effects
from posfb.analysis.design.budget import Deadline
from posfb.analysis.uncertainty.plants import LinearPlant, error_instants
from posfb.diagrams.resolve import ResolvedScenario
from posfb.models.controllers import require_design
from posfb.models.design import Design, cached_design, held_design_loop, held_design_radius
from posfb.models.design.bounds import bound_filter_constants
from posfb.models.design.closed_loop import HeldPlant, held_plant, stationary_deviations
from posfb.models.design.configurations import ConfigurationSet
from posfb.models.design.initial import filter_pole
from posfb.models.design.settings import LinearTorqueInputs, Proposed
from posfb.models.nominal import nominal_model, trajectory_voltages

#: The plant index of the nominal model in an active pair (``TuningProblem.active``).
NOMINAL = -1

#: Standard deviations of the feedback voltage kept below the limit with the peak.
VOLTAGE_SIGMAS = 3.0


@dataclass(frozen=True)
class Knob:
    """One decision variable: ``key`` as the report names it, searched in
    ``[log10(low), log10(high)]``; ``start`` is the entry's value (1 for a multiplier)."""

    key: str
    low: float
    high: float
    start: float


def knobs(entry: LinearTorqueInputs) -> tuple[Knob, ...]:
    """The decision variables of ``entry`` (``Proposed`` adds ``alpha_star``)."""
    weights = (
        Knob("Q1 position block x", 1e-2, 1e2, 1.0),
        Knob("Q1 velocity block x", 1e-2, 1e2, 1.0),
        Knob("R x", 1e-2, 1e2, 1.0),
        Knob("lambdas x", 1e-1, 1e1, 1.0),
    )
    if isinstance(entry, Proposed):
        top = max(10.0, 2.0 * entry.alpha_star)
        return (Knob("alpha_star", 0.05, top, entry.alpha_star), *weights)
    return weights


def _scaled_blocks(matrix: list[list[float]], scales: np.ndarray) -> list[list[float]]:
    """``S M S`` with ``S = diag(sqrt(scales))``: each diagonal block scaled by its factor,
    the matrix stays symmetric and keeps its definiteness."""
    root = np.sqrt(scales)
    return (np.asarray(matrix, dtype=float) * np.outer(root, root)).tolist()


def apply_knobs(entry: LinearTorqueInputs, values: np.ndarray, sample_time: float) -> object:
    """``entry`` with the decision variables ``values`` (in ``knobs(entry)`` order, actual
    values, not logarithms) and ``filter_a`` by its rule."""
    values = list(values)
    changes: dict[str, object] = {}
    if isinstance(entry, Proposed):
        changes["alpha_star"] = float(values.pop(0))
        valid = bound_filter_constants(entry.filter_a, sample_time).valid
        changes["filter_a"] = float(entry.filter_a) if valid else filter_pole(sample_time)
    position, velocity, r_scale, lambda_scale = values
    n = len(entry.R)
    changes["Q1"] = _scaled_blocks(entry.Q1, np.repeat([position, velocity], n))
    changes["R"] = (np.asarray(entry.R, dtype=float) * r_scale).tolist()
    changes["lambdas"] = [float(v) * lambda_scale for v in entry.lambdas]
    return replace(entry, **changes)


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
    entry: LinearTorqueInputs,
    plants: list[LinearPlant],
) -> float:
    """Seconds to judge ``entry``'s loop (``controller``) around one plant: the fastest
    over ``plants`` (the price of each further plant); 0 when the entry's design is
    refused (its cost is then not known)."""
    config = resolved.config
    try:
        design_config = entry.config(config.design.nominal, config.sample_time)
        require_design(controller, design_config)
    except ValueError:
        return 0.0
    design = cached_design(design_config)
    times = []
    for plant in plants:
        began = time.perf_counter()
        held_design_radius(design, controller, plant.held)
        times.append(time.perf_counter() - began)
    return min(times, default=0.0)


@dataclass
class TuningProblem:
    """The tuning of ``controller`` (``proposed`` or ``lin_lc``) starting from the
    scenario's ``entry``, checked on ``plants`` with ``margin``; ``deadline`` (``None``:
    none) is checked before each plant a design is judged on (``radii``);
    ``configurations``: the path's (each plant's ``held_at`` holds its loop at them),
    judged at the ``active`` ones during the search (module docstring)."""

    resolved: ResolvedScenario
    controller: str
    entry: LinearTorqueInputs
    plants: list[LinearPlant]
    margin: float
    deadline: Deadline | None = None
    configurations: ConfigurationSet | None = None
    active: tuple[tuple[int, int], ...] = ()

    def __post_init__(self) -> None:
        config = self.resolved.config
        self.sample_time = config.sample_time
        self.nominal = config.design.nominal
        self.knobs = knobs(self.entry)
        model = nominal_model(self.nominal)
        self.effects = nominal_effects(self.resolved)
        self.nominal_held = held_plant(model.M0(), model.B(), self.sample_time, self.effects)
        masses = () if self.configurations is None else self.configurations.masses
        self.nominal_held_at = tuple(
            held_plant(M, model.B(), self.sample_time, self.effects) for M in masses
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
        counts = np.asarray(config.encoder_counts, dtype=float)
        step = np.divide(2.0 * math.pi, counts, out=np.zeros_like(counts), where=counts > 0)
        noise = np.asarray(config.noise_std, dtype=float)
        self.noise_std = np.sqrt(step**2 / 12.0 + noise**2)

    def settings(self, x: np.ndarray) -> LinearTorqueInputs:
        """The entry at the point ``x`` (log10 of each knob's value)."""
        return apply_knobs(self.entry, np.power(10.0, x), self.sample_time)

    def bounds(self) -> list[tuple[float, float]]:
        """The search box in log10."""
        return [(math.log10(k.low), math.log10(k.high)) for k in self.knobs]

    def start(self) -> np.ndarray:
        """The entry's own point (log10), clipped into the box."""
        low, high = np.array(self.bounds()).T
        return np.clip([math.log10(k.start) for k in self.knobs], low, high)

    def design(self, entry: LinearTorqueInputs) -> Design:
        """The Sec. 3 design of ``entry`` on the scenario's nominal model."""
        return cached_design(entry.config(self.nominal, self.sample_time))

    def evaluate(self, entry: LinearTorqueInputs) -> Evaluation:
        """``entry`` judged on the nominal loop and the design plants."""
        try:
            config = entry.config(self.nominal, self.sample_time)
            require_design(self.controller, config)  # the controller's own refusals
        except ValueError as error:
            return Evaluation(math.inf, math.inf, math.inf, (), math.inf, False, str(error))
        design = cached_design(config)
        at_M0 = (
            (
                design.sampled_data_spectral_radius
                if self.controller == "proposed"
                else design.sampled_data_spectral_radius_lin_lc
            )
            if self.effects.ideal
            else held_design_radius(design, self.controller, self.nominal_held)
        )
        nominal_radius = max(
            [at_M0]
            + [
                self._radius(design, self.nominal_held_at[c])
                for owner, c in self.active
                if owner == NOMINAL
            ]  # fmt: skip
        )
        worst = max(self.radii(design, self.plants), default=math.nan)
        if nominal_radius >= 1.0:
            return Evaluation(math.inf, nominal_radius, worst, (), math.inf, False)
        loop = held_design_loop(design, self.controller, self.nominal_held)
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

    def _radius(self, design: Design, plant: HeldPlant) -> float:
        return held_design_radius(design, self.controller, plant)

    def radii(
        self, design: Design, plants: list[LinearPlant], everywhere: bool = False
    ) -> list[float]:
        """The spectral radius of the controller's loop around each of ``plants``, the
        worst of its ``M0*`` and its ``active`` configurations (``everywhere``: all of
        them) (``BudgetError`` once ``deadline`` has passed)."""
        found = []
        for index, plant in enumerate(plants):
            if self.deadline is not None and self.deadline.passed():
                raise self.deadline.error(
                    f"judging a {self.controller} design on plant {index + 1} of {len(plants)}"
                )
            frozen = plant.held_at if everywhere else [
                plant.held_at[c] for owner, c in self.active if owner == index]  # fmt: skip
            found.append(max(self._radius(design, h) for h in (plant.held, *frozen)))
        return found

    def violated(self, entry: LinearTorqueInputs) -> tuple[tuple[int, int], ...]:
        """The pairs (plant, configuration) where ``entry``'s loop breaks ``rho <= 1 -
        margin``, judged at every configuration of the nominal model and every design
        plant: for each, its worst configuration when that one breaks it and is not
        active yet."""
        if self.configurations is None:
            return ()
        design = self.design(entry)
        limit = 1.0 - self.margin
        owners = [(NOMINAL, self.nominal_held_at)] + [
            (index, plant.held_at) for index, plant in enumerate(self.plants)]  # fmt: skip
        found = []
        for owner, held_at in owners:
            radii = [self._radius(design, held) for held in held_at]
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
            design = self.design(self.entry)
            radii = [self._radius(design, held) for held in self.nominal_held_at]
            extremes.append(int(np.argmax(radii)))
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
