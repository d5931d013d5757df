"""The stability map of ``posfb design --map``: the sampled-data spectral radius ``rho``
of the designed loop on the NOMINAL model over a grid of two design keys, and at each
grid point the share of sampled plants on which the same loop is robustly stable
(``rho <= 1 - margin``).

A key is ``timing.sample_time`` or a real-valued key of the scenario's controller entry
(``controller.alpha_star``, ``controller.filter_a``, ``controller.lambdas[0]``, ...),
applied as ``--set KEY=VALUE`` applies it (``diagrams.scenario.apply_setting``); the
design inputs of each grid point are the controller entry's
(``diagrams.resolve.controller_inputs``), so the scenario's other settings stay fixed
(its duration is not required to be a multiple of the grid's sample times: the map
runs no simulation). The loop is the controller entry's (the proposed controller's at
``alpha = alpha*``, or Lin+LC's), designed on the nominal model and closed around each
plant's linear part ``M0, B`` with the scenario's linear effects (compute and sensor
delay, lag, compliant gear: ``analysis.common.loop_effects``; the nominal ``rho`` too)
(``models.design.held_design_radius``), at ``M0*`` and with ``M*(q)`` frozen at the
configurations the path visits (``models.design.configurations``): the nominal ``rho``
is the worst over ``M0*`` and every configuration of the set, a plant's the worst over
its own ``M0*`` and its ``M*(q)`` at the path's lightest and heaviest configurations
(every configuration for every plant would multiply the map's cost by the set's size;
these two bound the inertia the loop sees). A grid point whose design
the controller refuses (``a <= ln 2 / T_s``, a non-SPR ``H``, a failed LQR design; a
``T_s`` below the compute delay) or
whose value the scenario refuses is *refused*: neither stable nor unstable.

The grid (``make_axis``) is log-spaced and holds the scenario's own value of each key
exactly (the middle point of an odd count on a range symmetric about it in log, as
``T_s / 4 .. 4 T_s``; a range must hold the value). A marked design's
values inside the range are added to the grid (``with_marks``), so every point the
figure marks is a grid point: its cell is drawn (on log axes, cell edges at the
geometric midpoints between grid points) from the same arrays its printed verdict is
read from (``mark_verdicts``).

The plants are i.i.d. draws of the arm (``analysis.uncertainty.plants``: a study's
distributions, or the default spread). ``largest_robust_sample_time`` reads the map: the
largest grid ``T_s`` at which some value of the other key gives a robust loop (nominal
model and every plant), refined by bisection up to the next grid ``T_s``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from posfb.analysis.common.configurations import scenario_configurations
from posfb.analysis.common.errors import UsageError
from posfb.analysis.common.loop_effects import nominal_effects
from posfb.analysis.design.settings import TuneSettings
from posfb.analysis.uncertainty.plants import LinearPlant, draw_plants, plant_family
from posfb.diagrams.resolve import (
    LoadedScenario,
    controller_inputs,
    load_scenario,
    loop_context,
    make_nominal,
    resolve,
)
from posfb.diagrams.scenario import Scenario, apply_setting, scenario_description
from posfb.models.controllers import loop_kinds, require_design
from posfb.models.design import (
    DESIGNED_LOOPS,
    Design,
    cached_design,
    held_design_radius,
    with_effects,
)
from posfb.models.design.closed_loop import NO_EFFECTS, HeldPlant, LoopEffects, held_plant
from posfb.models.design.configurations import ConfigurationSet
from posfb.models.nominal import NominalModel, nominal_model

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.colors import Colormap
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from posfb.analysis.uncertainty.study import Study

#: The sample-time key: the only key outside the controller entry a map may vary.
SAMPLE_TIME = "timing.sample_time"

#: The default axes of the map.
DEFAULT_AXES = (SAMPLE_TIME, "controller.alpha_star")

#: Default grid points per axis, and the allowed range.
DEFAULT_POINTS = 25
POINTS_RANGE = (3, 201)

#: Default range of an axis as fractions of the scenario's value: ``T_s / 4 .. 4 T_s``
#: (the paper's arm keeps a robust design, at a small alpha*, up to about 3.5 T_s), any
#: other key ``value / 16 .. 2 value`` (alpha* = 4: 0.25 .. 8). The scenario's value is
#: a grid point either way (``make_axis``): at 25 points the T_s axis's middle one (one
#: ratio ``16 ** (1 / 24)`` between neighbours), another key's 20th (19 intervals below,
#: 5 above: ratios 1.157 and 1.149).
SAMPLE_TIME_RANGE = (0.25, 4.0)
OTHER_RANGE = (1.0 / 16.0, 2.0)

#: Bisection steps refining the largest robust ``T_s`` between two grid points.
BISECTION_STEPS = 7

#: The most loops a map may judge, grid points times plants (every grid point's design
#: around every plant), checked before the plants are drawn (``check_size``): the
#: largest grid (``POINTS_RANGE``'s 201 points a side, one more with a ``--mark``'s
#: value) at the default 50 plants. At 0.07 to 0.3 ms a loop (the shipped arms, measured
#: on the 2-core development machine) that is 2.4 to 10 minutes; a smaller grid may have
#: more plants (25 x 25 points: up to 3264), the plants' own ceiling aside
#: (``analysis.design.settings.MAX_DESIGN_PLANTS``).
MAX_MAP_LOOPS = (POINTS_RANGE[1] + 1) ** 2 * TuneSettings.plants

#: The figure's labels of the usual keys.
AXIS_LABELS = {
    SAMPLE_TIME: "sample time $T_s$ (s)",
    "controller.alpha_star": r"$\alpha^*$ (Eq. 21)",
    "controller.filter_a": r"filter pole $a$ of $G(s) = a/(s+a)$ (1/s)",
}


@dataclass(frozen=True)
class MapAxis:
    """One axis: the scenario ``key``, its grid ``values`` and the scenario's own value."""

    key: str
    values: np.ndarray
    scenario_value: float

    @property
    def label(self) -> str:
        """The figure's label of the key (the key itself when it has none)."""
        return AXIS_LABELS.get(self.key, self.key)

    @property
    def edges(self) -> np.ndarray:
        """The cell edges of the figure: the geometric midpoints between neighbouring
        grid values, the outer edges half a (log) step beyond the ends, so each grid
        value lies inside its own cell on a log axis."""
        values = self.values
        middle = np.sqrt(values[:-1] * values[1:])
        first = values[0] * np.sqrt(values[0] / values[1])
        last = values[-1] * np.sqrt(values[-1] / values[-2])
        return np.concatenate(([first], middle, [last]))

    def index(self, value: float) -> int | None:
        """The grid index of ``value`` (exactly equal), ``None`` when it is no grid point."""
        found = np.flatnonzero(self.values == value)
        return int(found[0]) if found.size else None


@dataclass(frozen=True, eq=False)
class MapSetup:
    """What every grid point shares: the scenario, its nominal model, the designed
    ``loop`` drawn (a ``models.design.DESIGNED_LOOPS`` name; ``controller``, the kind it
    belongs to), the plants (each with the scenario's linear effects,
    ``analysis.common.loop_effects``, and its ``M*(q)`` at the path's lightest
    and heaviest configurations), the margin, the nominal loop's effects and the
    nominal model's configuration set."""

    loaded: LoadedScenario
    nominal: NominalModel
    loop: str
    plants: tuple[LinearPlant, ...]
    margin: float
    arm: str
    effects: LoopEffects = NO_EFFECTS
    configurations: ConfigurationSet | None = None
    _held: dict[float, tuple[tuple[HeldPlant, ...], ...]] = field(default_factory=dict,
                                                                   repr=False)  # fmt: skip
    _nominal_held: dict[float, tuple[HeldPlant, ...]] = field(default_factory=dict, repr=False)

    @property
    def controller(self) -> str:
        """The kind the drawn loop belongs to (``models.controllers.loop_kinds``)."""
        return loop_kinds()[self.loop]

    @property
    def limit(self) -> float:
        """Robustly stable: ``rho <= 1 - margin``."""
        return 1.0 - self.margin

    def held_plants(self, sample_time: float) -> tuple[tuple[HeldPlant, ...], ...]:
        """Per plant, its linear part held over ``sample_time`` with its effects at its
        ``M0*`` and at each of its ``M_at``, computed once per sample time (every other key
        of a grid column shares them)."""
        if sample_time not in self._held:
            self._held[sample_time] = tuple(
                tuple(
                    held_plant(M, plant.B, sample_time, plant.effects)
                    for M in (plant.M0, *plant.M_at)
                )  # fmt: skip
                for plant in self.plants
            )
        return self._held[sample_time]

    def nominal_held(self, sample_time: float, B: np.ndarray) -> tuple[HeldPlant, ...]:
        """The nominal model's linear part (damping ``B``) held over ``sample_time`` with
        the nominal effects at every configuration of the set (none without one)."""
        if self.configurations is None:
            return ()
        if sample_time not in self._nominal_held:
            self._nominal_held[sample_time] = tuple(
                held_plant(M, B, sample_time, self.effects) for M in self.configurations.masses
            )
        return self._nominal_held[sample_time]


@dataclass(frozen=True)
class PointResult:
    """One point: ``refused``, else the nominal ``rho`` and each plant's."""

    refused: bool
    rho: float = math.nan
    plant_rho: tuple[float, ...] = ()

    def share(self, limit: float) -> float:
        """Share of the plants with ``rho <= limit`` (``nan`` when refused)."""
        if self.refused or not self.plant_rho:
            return math.nan
        return float(np.mean(np.asarray(self.plant_rho) <= limit))

    def robust(self, limit: float) -> bool:
        """``rho <= limit`` on the nominal model and on every plant."""
        return not self.refused and self.rho <= limit and all(r <= limit for r in self.plant_rho)


@dataclass(frozen=True, eq=False)
class StabilityMap:
    """The grid: arrays of shape ``(len(y.values), len(x.values))``; ``rho`` and ``share``
    are ``nan`` where ``refused``; ``worst`` is the largest plant ``rho``."""

    x: MapAxis
    y: MapAxis
    rho: np.ndarray
    share: np.ndarray
    worst: np.ndarray
    refused: np.ndarray
    robust: np.ndarray


@dataclass(frozen=True)
class RobustSampleTime:
    """The largest robust ``T_s``: on the grid (``None``: no robust grid point), refined
    by bisection towards the next grid ``T_s`` (``refined``), with the other key's grid
    values robust at ``grid`` and the one robust at ``refined``. ``at_edge``: the map's
    largest ``T_s`` is robust, so the true limit may lie beyond the map."""

    grid: float | None
    refined: float | None
    other_values: tuple[float, ...]
    other_at_refined: float | None
    at_edge: bool


# ---- keys and ranges ---------------------------------------------------------------------


def _number(value: object) -> float | None:
    """``value`` as a float: a real number, or a per-joint list of one repeated number."""
    if isinstance(value, list) and value and all(v == value[0] for v in value):
        value = value[0]
    if isinstance(value, float):
        return value
    return None


def key_value(loaded: LoadedScenario, key: str, option: str = "--map-axes") -> float:
    """The scenario's value of map key ``key``; an unknown key, a key outside the design
    (not ``timing.sample_time`` nor ``controller.*``) or a non-numeric one is refused."""
    try:
        value = loaded.get(key)
    except ValueError as error:
        reason = str(error).partition(": ")[2] or str(error)
        raise UsageError(f"{option} {key}: {reason}") from None
    if key != SAMPLE_TIME and not key.startswith("controller."):
        raise UsageError(
            f"{option} {key}: not a design key; {SAMPLE_TIME} or a numeric key of the "
            "controller entry (e.g. controller.alpha_star, controller.filter_a) is required"
        )
    number = _number(value)
    if number is None:
        raise UsageError(
            f"{option} {key} = {value!r} is not a number; a real-valued key is required "
            "(a per-joint list: index one joint, e.g. controller.lambdas[0])"
        )
    return number


def default_range(key: str, value: float) -> tuple[float, float]:
    """``SAMPLE_TIME_RANGE`` or ``OTHER_RANGE`` times the scenario's ``value`` (> 0: the
    grid is log-spaced)."""
    low, high = SAMPLE_TIME_RANGE if key == SAMPLE_TIME else OTHER_RANGE
    if value <= 0.0:
        raise UsageError(
            f"{key} = {value:g} in the scenario; the map's log-spaced grid needs a value > 0"
        )
    return low * value, high * value


def check_range(key: str, low: float, high: float, value: float) -> None:
    """Finite, ``0 < low < high`` (the grid is log-spaced), and holding the scenario's
    ``value`` (a grid point, ``make_axis``)."""
    if not (math.isfinite(low) and math.isfinite(high) and low < high):
        raise UsageError(f"--map-range {low:g} {high:g} for {key}: finite LOW < HIGH is required")
    if low <= 0.0:
        raise UsageError(
            f"--map-range {low:g} {high:g} for {key}: the grid is log-spaced; "
            "0 < LOW < HIGH is required"
        )
    if not low <= value <= high:
        raise UsageError(
            f"--map-range {low:g} {high:g} for {key}: the grid holds the scenario's value "
            f"{value:g}; LOW <= {value:g} <= HIGH is required (or --set {key}=... inside it)"
        )


def check_points(points: int) -> None:
    """A count in ``POINTS_RANGE``."""
    low, high = POINTS_RANGE
    if not low <= points <= high:
        raise UsageError(f"--map-points {points}; an integer from {low} to {high} is required")


def check_size(x: MapAxis, y: MapAxis, plants: int) -> None:
    """The grid of ``x`` and ``y`` times ``plants`` within ``MAX_MAP_LOOPS``, before any
    plant is drawn (``UsageError`` naming the options and the count they imply)."""
    loops = len(x.values) * len(y.values) * plants
    if loops > MAX_MAP_LOOPS:
        raise UsageError(
            f"--map-points {len(x.values)} x {len(y.values)} grid points with --plants {plants}: "
            f"{loops:,} loops to judge; at most {MAX_MAP_LOOPS:,} are allowed (MAX_MAP_LOOPS, "
            "0.07-0.3 ms a loop): fewer --map-points or --plants are required"
        )


def make_axis(key: str, low: float, high: float, points: int, value: float) -> MapAxis:
    """The log-spaced grid of ``points`` values from ``low`` to ``high`` holding the
    scenario's ``value`` exactly: its ``points - 1`` intervals split between
    ``low .. value`` and ``value .. high`` in proportion to their log lengths (rounded;
    at least one each side when ``value`` is inside), each side log-spaced. On a range
    symmetric about ``value`` in log (``T_s / 4 .. 4 T_s``) an odd count makes one ratio
    between neighbours and ``value`` the middle point; otherwise the two sides' ratios
    differ a little. A ``value`` at an end: one log-spaced run, ``value`` its end."""
    check_points(points)
    check_range(key, low, high, value)
    if value in (low, high):
        values = np.geomspace(low, high, points)
    else:
        share = math.log(value / low) / math.log(high / low)
        below = min(max(round(share * (points - 1)), 1), points - 2)
        values = np.concatenate(
            (np.geomspace(low, value, below + 1), np.geomspace(value, high, points - below)[1:])
        )
        values[below] = value
    values[0], values[-1] = low, high
    return MapAxis(key, values, value)


def _inside(axis: MapAxis, mark: Mapping[str, float]) -> bool:
    return bool(axis.values[0] <= mark[axis.key] <= axis.values[-1])


def with_marks(
    x: MapAxis, y: MapAxis, marks: Iterable[Mapping[str, float]]
) -> tuple[MapAxis, MapAxis]:
    """``x`` and ``y`` with the values of each mark inside both ranges added to their
    grids, so that the mark is a grid point (a mark outside the map is not drawn)."""
    inside = [mark for mark in marks if _inside(x, mark) and _inside(y, mark)]

    def extended(axis: MapAxis) -> MapAxis:
        extra = np.asarray([mark[axis.key] for mark in inside], dtype=float)
        return MapAxis(axis.key, np.unique(np.concatenate((axis.values, extra))),
                       axis.scenario_value)  # fmt: skip

    return extended(x), extended(y)


def _setting(key: str, value: float) -> str:
    return f"{key}={float(value)!r}"


def check_endpoints(loaded: LoadedScenario, axes: Sequence[MapAxis]) -> None:
    """Each axis's ends must be values the scenario takes (the other keys at the
    scenario's values); a refused design is allowed, a refused value is not."""
    nominal = make_nominal(
        loaded.scenario.nominal_model,
        loaded.base_dir,
        scenario_description(loaded.scenario, loaded.base_dir),
    )
    for axis in axes:
        for value in (axis.values[0], axis.values[-1]):
            try:
                setting = _setting(axis.key, value)
                scenario = apply_setting(loaded.scenario, setting, loaded.base_dir)
                controller_inputs(
                    scenario.controller, loop_context(scenario, nominal), loaded.base_dir
                )
            except ValueError as error:
                raise UsageError(f"--map-range for {axis.key}: {error}") from None


# ---- the setup and one point -------------------------------------------------------------


def map_loop(relevant: Sequence[str]) -> str:
    """The designed loop the map draws for a controller entry with design checks
    ``relevant``: the first of ``models.design.DESIGNED_LOOPS`` among them (the paper's
    controller's entry answers for its own loop and Lin+LC's: its own is drawn)."""
    return next(loop for loop in DESIGNED_LOOPS if loop in relevant)


def map_setup(
    loaded: LoadedScenario,
    relevant: Sequence[str],
    study: Study | None,
    plants: int,
    seed: int,
    margin: float,
) -> MapSetup:
    """The scenario's nominal model and ``plants`` draws (seed ``seed``) of its arm from
    ``study`` (the default spread when ``None``)."""
    resolved = resolve(loaded)
    try:
        family = plant_family(study, loaded)
    except ValueError as error:
        raise UsageError(f"--study: {error}") from None
    configurations = scenario_configurations(resolved.config)
    extremes = tuple(c.q for c in configurations.configurations
                     if c.role in ("lightest", "heaviest"))  # fmt: skip
    return MapSetup(
        loaded=loaded,
        nominal=make_nominal(
            loaded.scenario.nominal_model,
            loaded.base_dir,
            scenario_description(loaded.scenario, loaded.base_dir),
        ),
        loop=map_loop(relevant),
        plants=tuple(draw_plants(family, resolved, seed, plants, configurations=extremes)),
        margin=margin,
        arm=Path(resolved.config.plant.urdf).name,
        effects=nominal_effects(resolved),
        configurations=configurations,
    )


def _with(scenario: Scenario, setup: MapSetup, values: Mapping[str, float]) -> Scenario:
    for key, value in values.items():
        scenario = apply_setting(scenario, _setting(key, value), setup.loaded.base_dir)
    return scenario


def _design(setup: MapSetup, scenario: Scenario) -> Design | None:
    """The design of ``scenario``'s controller entry, ``None`` when refused."""
    try:
        context = loop_context(scenario, setup.nominal)
        _, config, _ = controller_inputs(scenario.controller, context, setup.loaded.base_dir)
        require_design(setup.controller, config)  # the controller's own refusals
    except ValueError:
        return None
    return cached_design(config)


def _evaluate(setup: MapSetup, scenario: Scenario) -> PointResult:
    design = _design(setup, scenario)
    if design is None or design.config.sample_time < setup.effects.compute_delay:
        return PointResult(refused=True)  # a compute delay longer than T_s is refused too
    design = with_effects(design, setup.effects)
    at_M0 = getattr(design, DESIGNED_LOOPS[setup.loop].radius)
    T = design.config.sample_time
    B = nominal_model(setup.nominal).B()
    rho = max([at_M0, *(held_design_radius(design, setup.loop, held)
                        for held in setup.nominal_held(T, B))])  # fmt: skip
    plant_rho = tuple(
        max(held_design_radius(design, setup.loop, held) for held in helds)
        for helds in setup.held_plants(T)
    )
    return PointResult(refused=False, rho=float(rho), plant_rho=plant_rho)


def evaluate_point(setup: MapSetup, values: Mapping[str, float]) -> PointResult:
    """The loop at the scenario with ``values`` (key -> value) applied."""
    try:
        scenario = _with(setup.loaded.scenario, setup, values)
    except ValueError:
        return PointResult(refused=True)
    return _evaluate(setup, scenario)


# ---- the grid ----------------------------------------------------------------------------


def compute_map(setup: MapSetup, x: MapAxis, y: MapAxis) -> StabilityMap:
    """Every grid point (BLAS on one thread: small matrices are much slower on more)."""
    from threadpoolctl import threadpool_limits

    shape = (len(y.values), len(x.values))
    rho, share, worst = (np.full(shape, np.nan) for _ in range(3))
    refused, robust = np.zeros(shape, dtype=bool), np.zeros(shape, dtype=bool)
    with threadpool_limits(1):
        for i, x_value in enumerate(x.values):
            try:
                column = _with(setup.loaded.scenario, setup, {x.key: x_value})
            except ValueError:
                refused[:, i] = True
                continue
            for j, y_value in enumerate(y.values):
                try:
                    point = _evaluate(setup, _with(column, setup, {y.key: y_value}))
                except ValueError:
                    point = PointResult(refused=True)
                refused[j, i] = point.refused
                if point.refused:
                    continue
                rho[j, i] = point.rho
                share[j, i] = point.share(setup.limit)
                worst[j, i] = max(point.plant_rho, default=np.nan)
                robust[j, i] = point.robust(setup.limit)
    return StabilityMap(x=x, y=y, rho=rho, share=share, worst=worst, refused=refused,
                        robust=robust)  # fmt: skip


def _sample_time_axis(smap: StabilityMap) -> tuple[MapAxis, MapAxis, np.ndarray] | None:
    """``(T_s axis, other axis, robust[T_s index, other index])``, ``None`` without T_s."""
    if smap.x.key == SAMPLE_TIME:
        return smap.x, smap.y, smap.robust.T
    if smap.y.key == SAMPLE_TIME:
        return smap.y, smap.x, smap.robust
    return None


def _bisect(setup: MapSetup, other: str, value: float, low: float, high: float) -> float:
    """The largest robust ``T_s`` found between robust ``low`` and non-robust ``high``."""
    for _ in range(BISECTION_STEPS):
        middle = 0.5 * (low + high)
        if evaluate_point(setup, {SAMPLE_TIME: middle, other: value}).robust(setup.limit):
            low = middle
        else:
            high = middle
    return low


def largest_robust_sample_time(setup: MapSetup, smap: StabilityMap) -> RobustSampleTime | None:
    """The largest grid ``T_s`` with a robust point (some value of the other key), and its
    refinement by bisection towards the next grid ``T_s`` for each such value; ``None``
    when neither axis is the sample time."""
    from threadpoolctl import threadpool_limits

    found = _sample_time_axis(smap)
    if found is None:
        return None
    times, other, robust = found
    rows = np.flatnonzero(robust.any(axis=1))
    if rows.size == 0:
        return RobustSampleTime(None, None, (), None, at_edge=False)
    row = int(rows[-1])
    values = tuple(float(v) for v in other.values[robust[row]])
    grid = float(times.values[row])
    if row == len(times.values) - 1:
        return RobustSampleTime(grid, grid, values, values[0], at_edge=True)
    best, best_value = grid, values[0]
    with threadpool_limits(1):
        for value in values:
            refined = _bisect(setup, other.key, value, grid, float(times.values[row + 1]))
            if refined > best:
                best, best_value = refined, value
    return RobustSampleTime(grid, best, values, best_value, at_edge=False)


# ---- output ------------------------------------------------------------------------------


def mark_values(path: str, keys: Sequence[str], scenario: LoadedScenario) -> dict[str, float]:
    """The values of ``keys`` in the scenario file ``path`` (``--mark``); a design of
    another arm than ``scenario``'s (``diagrams.arm``) is refused, naming both arms."""
    from posfb.diagrams.arm import arm_identity

    try:
        loaded = load_scenario(path)
        marked = arm_identity(loaded.scenario, loaded.base_dir)
    except (ValueError, FileNotFoundError) as error:
        raise UsageError(f"--mark {path}: {error}") from None
    own = arm_identity(scenario.scenario, scenario.base_dir)
    if marked != own:
        raise UsageError(
            f"--mark {path}: a design of {marked}, and the map is of {own}; a design of "
            "the scenario's arm is required"
        )
    return {key: key_value(loaded, key, option=f"--mark {path}:") for key in keys}


@dataclass(frozen=True)
class MarkVerdict:
    """A marked point's verdict. On the map (``index = (row, column)`` of the grid) it is
    read from the map's arrays at that index, the cell the figure draws under its marker;
    outside the map (``index`` ``None``, not drawn) it is evaluated on its own. ``share``
    and ``rho`` are ``nan`` when ``refused``."""

    values: Mapping[str, float]
    index: tuple[int, int] | None
    refused: bool
    rho: float
    share: float
    robust: bool


def mark_verdicts(
    setup: MapSetup, smap: StabilityMap, marks: Mapping[str, Mapping[str, float]]
) -> dict[str, MarkVerdict]:
    """Each mark's verdict (name -> ``MarkVerdict``), from the map's cell where the mark is
    a grid point (the scenario's always is, a marked design's inside the range is after
    ``with_marks``)."""
    verdicts = {}
    for name, values in marks.items():
        i, j = smap.x.index(values[smap.x.key]), smap.y.index(values[smap.y.key])
        if i is not None and j is not None:
            verdicts[name] = MarkVerdict(
                values=dict(values),
                index=(j, i),
                refused=bool(smap.refused[j, i]),
                rho=float(smap.rho[j, i]),
                share=float(smap.share[j, i]),
                robust=bool(smap.robust[j, i]),
            )
            continue
        point = evaluate_point(setup, values)
        verdicts[name] = MarkVerdict(
            values=dict(values),
            index=None,
            refused=point.refused,
            rho=point.rho,
            share=point.share(setup.limit),
            robust=point.robust(setup.limit),
        )
    return verdicts


def _nullable(array: np.ndarray) -> list:
    return [[None if not np.isfinite(v) else float(v) for v in row] for row in array]


def _point_dict(verdict: MarkVerdict) -> dict:
    return {
        "values": dict(verdict.values),
        "grid_index": None if verdict.index is None else list(verdict.index),
        "refused": verdict.refused,
        "rho_nominal": None if verdict.refused else verdict.rho,
        "share_stable": None if verdict.refused else verdict.share,
        "robust": verdict.robust,
    }


def map_to_dict(
    setup: MapSetup,
    smap: StabilityMap,
    robust: RobustSampleTime | None,
    verdicts: Mapping[str, MarkVerdict],
    seed: int,
    study: str | None,
) -> dict:
    """The JSON object (``stability_map.json``, ``--json``): ``rho_nominal[j][i]`` and
    ``share_stable[j][i]`` at ``x.values[i]``, ``y.values[j]``, ``null`` where refused;
    each point's ``grid_index`` ``[j, i]`` (``null`` outside the map)."""
    return {
        "arm": setup.arm,
        "controller": setup.controller,
        "plants": len(setup.plants),
        "seed": seed,
        "study": study,
        "margin": setup.margin,
        "x": {"key": smap.x.key, "values": smap.x.values.tolist(),
              "scenario_value": smap.x.scenario_value},
        "y": {"key": smap.y.key, "values": smap.y.values.tolist(),
              "scenario_value": smap.y.scenario_value},
        "rho_nominal": _nullable(smap.rho),
        "share_stable": _nullable(smap.share),
        "worst_plant_rho": _nullable(smap.worst),
        "refused": smap.refused.tolist(),
        "robust": smap.robust.tolist(),
        "points": {name: _point_dict(verdict) for name, verdict in verdicts.items()},
        "largest_robust_sample_time": None if robust is None else {
            "grid": robust.grid,
            "refined": robust.refined,
            "other_key": smap.y.key if smap.x.key == SAMPLE_TIME else smap.x.key,
            "other_values_at_grid": list(robust.other_values),
            "other_value_at_refined": robust.other_at_refined,
            "at_edge_of_map": robust.at_edge,
        },
    }  # fmt: skip


def _values_text(values: Mapping[str, float]) -> str:
    return ", ".join(f"{key} = {value:.6g}" for key, value in values.items())


def _point_text(name: str, verdict: MarkVerdict, plants: int, limit: float) -> str:
    where = "" if verdict.index is not None else ", outside the map"
    head = f"{name} ({_values_text(verdict.values)}{where})"
    if verdict.refused:
        return f"{head}: refused by the controller"
    stable = int(round(verdict.share * plants))
    return (
        f"{head}: nominal rho = {verdict.rho:.4f}, rho <= {limit:g} on {stable} of "
        f"{plants} plants; {'robust' if verdict.robust else 'not robust'}"
    )


def robust_text(smap: StabilityMap, robust: RobustSampleTime | None, limit: float) -> str:
    """The printed answer: the largest robust ``T_s`` and what it is conditional on."""
    if robust is None:
        return f"largest robust sample time: not computed ({SAMPLE_TIME} is not an axis)"
    other = smap.y if smap.x.key == SAMPLE_TIME else smap.x
    within = (
        f"within the map's grid of {other.key} ({other.values[0]:.6g} .. "
        f"{other.values[-1]:.6g}, {len(other.values)} points), the scenario's other "
        "settings fixed"
    )
    if robust.grid is None:
        return (
            f"largest sample time with a robust design (rho <= {limit:g} on the nominal "
            f"model and every plant): none on the map, {within}"
        )
    others = ", ".join(f"{v:.4g}" for v in robust.other_values)
    text = (
        f"largest sample time with a robust design (rho <= {limit:g} on the nominal model "
        f"and every plant): T_s = {robust.refined:.6g} s"
    )
    if robust.at_edge:
        text += " (the map's largest T_s: the limit may lie beyond the map)"
    else:
        text += (
            f" (bisection; largest on the grid {robust.grid:.6g} s, at {other.key} = {others};"
            f" refined at {other.key} = {robust.other_at_refined:.6g})"
        )
    return f"{text}, {within}"


def format_map(
    setup: MapSetup,
    smap: StabilityMap,
    robust: RobustSampleTime | None,
    verdicts: Mapping[str, MarkVerdict],
) -> str:
    """The readable summary of the map."""
    refused = int(smap.refused.sum())
    unstable = int(np.sum(~smap.refused & (smap.rho >= 1.0)))
    lines = [
        f"stability map of the {setup.controller} loop, arm {setup.arm}: nominal model and "
        f"{len(setup.plants)} sampled plants, robust when rho <= {setup.limit:g} "
        f"(margin {setup.margin:g})",
        f"  x: {smap.x.key} from {smap.x.values[0]:.6g} to {smap.x.values[-1]:.6g} "
        f"({len(smap.x.values)} points); y: {smap.y.key} from {smap.y.values[0]:.6g} to "
        f"{smap.y.values[-1]:.6g} ({len(smap.y.values)} points)",
        f"  grid points: {smap.rho.size}; refused by the controller {refused}; nominal "
        f"rho >= 1 at {unstable}; robust at {int(smap.robust.sum())}",
    ]
    plants = len(setup.plants)
    lines += [f"  {_point_text(name, v, plants, setup.limit)}" for name, v in verdicts.items()]
    lines.append(robust_text(smap, robust, setup.limit))
    return "\n".join(lines)


def plot_map(
    setup: MapSetup,
    smap: StabilityMap,
    verdicts: Mapping[str, MarkVerdict],
    robust: RobustSampleTime | None,
) -> Figure:
    """One panel on log axes: the share of plants robustly stable (colour: one cell per
    grid point, edges at the geometric midpoints; refused points hatched grey), the
    nominal ``rho = 1`` (solid) and ``rho = 1 - margin`` (dashed) contours, the marked
    points at their values (each a grid point, inside its cell) and the largest robust
    ``T_s``. The colour mesh is the panel's first collection, its array ``smap.share``."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    figure = Figure(figsize=(7.5, 6.5))
    axis = figure.subplots()
    axis.set_xscale("log")
    axis.set_yscale("log")
    x, y = smap.x.values, smap.y.values
    colours = _colour_map()
    mesh = axis.pcolormesh(smap.x.edges, smap.y.edges, np.ma.masked_invalid(smap.share),
                           cmap=colours, vmin=0.0, vmax=1.0, shading="flat")  # fmt: skip
    bar = figure.colorbar(mesh, ax=axis)
    bar.set_label(f"share of the {len(setup.plants)} plants with rho <= {setup.limit:g}")
    handles = []
    if smap.refused.any():
        _draw_refused(axis, smap)
        handles.append(Patch(facecolor="lightgrey", hatch="///", edgecolor="grey",
                             label="refused by the controller"))  # fmt: skip
    rho = np.ma.masked_invalid(smap.rho)
    for level, style, text in ((1.0, "-", "nominal rho = 1"),
                               (setup.limit, "--", f"nominal rho = {setup.limit:g}")):  # fmt: skip
        if rho.count() and rho.min() < level < rho.max():
            axis.contour(x, y, rho, levels=[level], colors="black", linestyles=style,
                         linewidths=1.4)  # fmt: skip
            handles.append(Line2D([], [], color="black", linestyle=style, label=text))
    handles += _draw_marks(axis, smap, verdicts)
    if robust is not None and robust.refined is not None:
        draw = axis.axvline if smap.x.key == SAMPLE_TIME else axis.axhline
        draw(robust.refined, color="tab:blue", linestyle=":", linewidth=1.4)
        handles.append(Line2D([], [], color="tab:blue", linestyle=":",
                              label=f"largest robust T_s = {robust.refined:.4g} s"))  # fmt: skip
    axis.set_xlim(smap.x.edges[0], smap.x.edges[-1])
    axis.set_ylim(smap.y.edges[0], smap.y.edges[-1])
    _log_ticks(axis)
    axis.set_xlabel(smap.x.label)
    axis.set_ylabel(smap.y.label)
    axis.set_title(
        f"{setup.arm}: sampled-data stability of the {setup.controller} loop\n"
        f"nominal model (contours) and {len(setup.plants)} sampled plants (colour)",
        fontsize="medium",
    )
    # below the panel: inside it the legend would cover cells and marks
    axis.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2,
                fontsize="small", frameon=False)  # fmt: skip
    return figure


def _draw_refused(axis: Axes, smap: StabilityMap) -> None:
    """The refused cells, grey and hatched."""
    from matplotlib.colors import ListedColormap

    cells = np.ma.masked_where(~smap.refused, np.ones(smap.refused.shape))
    axis.pcolor(smap.x.edges, smap.y.edges, cells, cmap=ListedColormap(["lightgrey"]),
                shading="flat", hatch="///", edgecolor="grey", linewidth=0.0)  # fmt: skip


def _log_ticks(axis: Axes) -> None:
    """Plain-number labels at 1, 2, 3 and 5 times the powers of ten (a map spans about
    one decade, where matplotlib's log axis would label one tick or none)."""
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    for which in (axis.xaxis, axis.yaxis):
        which.set_major_locator(LogLocator(subs=(1.0, 2.0, 3.0, 5.0)))
        which.set_major_formatter(FormatStrFormatter("%g"))
        which.set_minor_formatter(NullFormatter())


def _colour_map() -> Colormap:
    from matplotlib import colormaps

    return colormaps["RdYlGn"].with_extremes(bad="lightgrey")


#: Marker styles of the marked points, in order (the scenario's point first).
_MARKERS = (
    {"marker": "*", "markersize": 16, "color": "white", "markeredgecolor": "black"},
    {"marker": "D", "markersize": 9, "color": "tab:blue", "markeredgecolor": "black"},
)


def _draw_marks(
    axis: Axes, smap: StabilityMap, verdicts: Mapping[str, MarkVerdict]
) -> list[Line2D]:
    """Each mark on the map at its values (its grid point); one outside the map only in
    the legend."""
    from matplotlib.lines import Line2D

    handles = []
    for (name, verdict), style in zip(verdicts.items(), _MARKERS, strict=False):
        x, y = verdict.values[smap.x.key], verdict.values[smap.y.key]
        inside = verdict.index is not None
        if inside:
            axis.plot([x], [y], linestyle="none", label=name, **style)
        suffix = "" if inside else ", outside the map"
        label = f"{name} ({x:.4g}, {y:.4g}{suffix})"
        handles.append(Line2D([], [], linestyle="none", label=label, **style))
    return handles


def write_map(out: Path, figure: Figure, data: dict) -> list[Path]:
    """``stability_map.png``, ``.svg`` and ``.json`` in ``out`` (created)."""
    import json

    from posfb.analysis.common.plots import save_report_figure

    out.mkdir(parents=True, exist_ok=True)
    paths = save_report_figure(figure, out, "stability_map")
    path = out / "stability_map.json"
    path.write_text(json.dumps(data, allow_nan=False) + "\n")
    return [*paths, path]
