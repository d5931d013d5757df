"""The worst plant of a study's parameter box for a design (``posfb design --worst-case
--study STUDY``): the plant with the largest spectral radius ``rho`` of the sampled loop,
and the one with the smallest disk margin.

The plants are those ``posfb tune`` checks a design on (``analysis.uncertainty.plants``:
the study's ``parameters:`` around the scenario's arm; a study of another arm is refused).
The box leaves out the Coulomb levels, which do not enter the linear part.
The loop is the scenario's controller as designed, closed around each plant's linear part
with its linear effects (``analysis.uncertainty.loops``), at the plant's ``M0*`` and
with its own ``M*(q)`` frozen at the configurations the path visits
(``models.design.configurations``): a plant's ``rho`` is the worst over ``M0*`` and every
configuration, its disk margin the worst over ``M0*`` and the *active* configurations
(where the nominal plant's loop has its largest radius, and the path's lightest and
heaviest; ``design --margins``' three), and the figure names where it is worst. The
search's objective judges ``M0*`` and the active configurations only (a radius at every
configuration per evaluation would cost the set's size over again); the plants it
finds are then judged as the sampled ones are. Two steps:

1. ``plants`` i.i.d. draws (seed ``seed``); the worst of them by each figure;
2. a search of the box, each varied parameter between its distribution's ends (a
   Gaussian without bounds between its 0.1 % and 99.9 % quantiles), with scipy's
   ``differential_evolution`` (``generations`` generations of ``POPULATION_PER_AXIS``
   members per axis, Latin-hypercube start, no gradient polish, seeded) started from the
   worst sampled plant, which the population keeps: the found plant is never better
   than the worst sampled one.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize

from posfb.analysis.uncertainty.loops import BoxAxis, StudyLoops
from posfb.analysis.uncertainty.plants import plant_family
from posfb.analysis.uncertainty.sampling import sample_plant
from posfb.analysis.uncertainty.study import Study
from posfb.diagrams.resolve import LoadedScenario
from posfb.models.design.configurations import Configuration, distinct
from posfb.models.design.margins import STUDY_GRID_POINTS, SampledFeedback
from posfb.models.plant import ArmParameters

#: The drawn parameters that do not enter the loop's linear part (not searched).
NONLINEAR_PARAMETERS = ("coulomb",)

#: The search's population per box axis (scipy's ``popsize``).
POPULATION_PER_AXIS = 5

#: Defaults: sampled plants, generations of the search, seed.
DEFAULT_PLANTS = 100
DEFAULT_GENERATIONS = 15
DEFAULT_SEED = 0

#: The most generations of the search: each evaluates ``POPULATION_PER_AXIS`` plants per
#: box axis (a six-joint study: about 60, 0.1-1 s), so 1 000 are minutes to hours; the
#: sampled plants' ceiling is ``tune``'s (``analysis.design.settings.MAX_DESIGN_PLANTS``).
MAX_GENERATIONS = 1_000


def check_search_size(plants: int, generations: int) -> None:
    """``ValueError`` naming the count and its ceiling unless ``1 <= plants <=
    MAX_DESIGN_PLANTS`` and ``1 <= generations <= MAX_GENERATIONS`` (before any work)."""
    from posfb.analysis.design.settings import MAX_DESIGN_PLANTS

    for name, value, ceiling in (("plants", plants, MAX_DESIGN_PLANTS),
                                 ("generations", generations, MAX_GENERATIONS)):  # fmt: skip
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= ceiling:
            raise ValueError(
                f"{name} = {value!r}; an integer from 1 to {ceiling:,} is required "
                f"({'MAX_DESIGN_PLANTS' if name == 'plants' else 'MAX_GENERATIONS'})"
            )


@dataclass(frozen=True)
class Plant:
    """One plant: where it comes from (``sampled N`` or ``search``), its loop's
    ``radius`` and ``disk_margin`` (0 when unstable), the configurations where each is
    worst (``radius_at``, ``disk_at``: ``M0*`` or a configuration of the path) and the
    box's parameter values."""

    source: str
    radius: float
    disk_margin: float
    values: tuple[float, ...]
    radius_at: str = "M0*"
    disk_at: str = "M0*"


@dataclass(frozen=True)
class WorstCase:
    """The worst plants by ``rho`` and by disk margin, sampled and searched, the box's
    ``axes`` and the nominal arm's values on them."""

    controller: str
    axes: tuple[BoxAxis, ...]
    nominal: Plant
    sampled_radius: Plant
    searched_radius: Plant
    sampled_disk: Plant
    searched_disk: Plant
    plants: int
    evaluations: int
    configurations: int = 0
    active: tuple[str, ...] = ()


def _value(axis: BoxAxis, parameters: ArmParameters) -> float:
    scalar = axis.scalar
    if scalar.key == "payload_mass":
        return float(parameters.payload_mass)
    return float(getattr(parameters, scalar.key)[scalar.joint])


def _where(configurations: Sequence[Configuration], index: int) -> str:
    """``M0*`` for index 0 of ``StudyLoops.loops_at``'s list, else the configuration."""
    return "M0*" if index == 0 else configurations[index - 1].describe()


def _disk(loop: SampledFeedback) -> float:
    """The loop's disk margin (the worse break's; 0 when unstable)."""
    return loop.robustness(STUDY_GRID_POINTS, delay=False)[1]


def active_configurations(loops: StudyLoops) -> tuple[Configuration, ...]:
    """The configurations the search and the disk margins judge (module docstring)."""
    configurations = loops.configurations()
    radii = [loop.radius() for loop in loops.loops_at(loops.nominal_parameters,
                                                      configurations)[1:]]  # fmt: skip
    worst = configurations[int(np.argmax(radii))]
    extremes = [c for c in configurations if c.role in ("lightest", "heaviest")]
    return distinct([worst, *extremes])


def worst_case(
    loaded: LoadedScenario,
    study: Study,
    controller: str,
    plants: int = DEFAULT_PLANTS,
    generations: int = DEFAULT_GENERATIONS,
    seed: int = DEFAULT_SEED,
    progress: Callable[[str], None] | None = None,
) -> WorstCase:
    """The ``WorstCase`` of the scenario ``loaded``'s ``controller`` over ``study``'s box
    (module docstring). ``ValueError`` (one line): a study of another arm, one with a
    ``posterior:`` (no box), one that varies no arm parameter, or a controller without a
    linear design, sizes beyond their ceilings (``check_search_size``). ``progress`` gets
    a line at each step and generation (it does not change the result)."""
    say = progress or (lambda text: None)
    check_search_size(plants, generations)
    if study.posterior is not None:
        raise ValueError("the study draws the arm from a posterior:, which has no parameter "
                         "box; a study with parameters: ranges is required")  # fmt: skip
    family = replace(plant_family(study, loaded), seed=seed, samples=max(plants, 1))
    loops = StudyLoops(family, controller)
    axes = tuple(a for a in loops.box() if a.scalar.key not in NONLINEAR_PARAMETERS)
    if not axes:
        raise ValueError("the study varies no arm parameter (parameters:); nothing to search")
    count = 0
    everywhere = loops.configurations()
    active = active_configurations(loops)

    # the active configurations' places in loops_at(..., everywhere)'s list (0: M0*)
    at_active = [0, *(everywhere.index(c) + 1 for c in active)]

    def describe(source: str, parameters: ArmParameters) -> Plant:
        nonlocal count
        count += 1
        judged = loops.loops_at(parameters, everywhere)
        radii = [loop.radius() for loop in judged]
        disks = [_disk(judged[i]) for i in at_active]
        worst_radius, worst_disk = int(np.argmax(radii)), int(np.argmin(disks))
        return Plant(source, radii[worst_radius], disks[worst_disk],
                     tuple(_value(a, parameters) for a in axes),
                     _where(everywhere, worst_radius), _where(active, worst_disk))  # fmt: skip

    drawn = [sample_plant(family, loops.nominal_parameters, i).parameters for i in range(plants)]
    sampled = []
    for i, p in enumerate(drawn):
        say(f"sampled plant {i + 1} of {plants}")
        sampled.append(describe(f"sampled {i}", p))
    by_radius = max(range(plants), key=lambda i: sampled[i].radius)
    by_disk = min(range(plants), key=lambda i: sampled[i].disk_margin)
    bounds = [(a.low, a.high) for a in axes]

    def search(objective, start: ArmParameters, figure: str) -> np.ndarray:
        nonlocal count
        generation = iter(range(1, generations + 1))

        def step(*_: object, **__: object) -> None:  # scipy's old and new callback forms
            say(f"{figure} search, generation {next(generation)} of {generations}")

        say(f"{figure} search, first generation")
        found = scipy.optimize.differential_evolution(
            objective, bounds, x0=loops.unit_of(axes, start), maxiter=generations,
            popsize=POPULATION_PER_AXIS, init="latinhypercube", polish=False, seed=seed, tol=0.0,
            callback=step,
        )  # fmt: skip
        count += found.nfev
        return found.x

    def negative_radius(u: np.ndarray) -> float:
        return -max(loop.radius() for loop in loops.loops_at(loops.parameters_at(axes, u), active))

    def disk(u: np.ndarray) -> float:
        return min(_disk(loop) for loop in loops.loops_at(loops.parameters_at(axes, u), active))

    worst_radius = loops.parameters_at(axes, search(negative_radius, drawn[by_radius], "radius"))
    worst_disk = loops.parameters_at(axes, search(disk, drawn[by_disk], "disk margin"))
    return WorstCase(
        controller=controller,
        axes=axes,
        nominal=describe("nominal", loops.nominal_parameters),
        sampled_radius=sampled[by_radius],
        searched_radius=_at_least(describe("search", worst_radius), sampled[by_radius], "radius"),
        sampled_disk=sampled[by_disk],
        searched_disk=_at_least(describe("search", worst_disk), sampled[by_disk], "disk"),
        plants=plants,
        evaluations=count,
        configurations=len(everywhere),
        active=tuple(c.describe() for c in active),
    )


def _at_least(found: Plant, sampled: Plant, figure: str) -> Plant:
    """``found``, or ``sampled`` where the search ended on a better plant (the sampled one
    is inside the box and the population keeps its start, so this only guards the
    round trip through the box's probabilities)."""
    worse = found.radius >= sampled.radius if figure == "radius" else (
        found.disk_margin <= sampled.disk_margin)  # fmt: skip
    return found if worse else sampled


def worst_case_to_dict(found: WorstCase) -> dict[str, object]:
    """``--json``'s object."""

    def plant(p: Plant) -> dict[str, object]:
        return {"source": p.source, "spectral_radius": p.radius, "disk_margin": p.disk_margin,
                "spectral_radius_at": p.radius_at, "disk_margin_at": p.disk_at,
                "parameters": {a.scalar.column: v for a, v in zip(found.axes, p.values,
                                                                  strict=True)}}  # fmt: skip

    return {
        "controller": found.controller,
        "plants": found.plants,
        "evaluations": found.evaluations,
        "configurations": {"count": found.configurations, "active": list(found.active)},
        "nominal": plant(found.nominal),
        "largest_radius": {
            "sampled": plant(found.sampled_radius),
            "searched": plant(found.searched_radius),
        },  # fmt: skip
        "smallest_disk_margin": {
            "sampled": plant(found.sampled_disk),
            "searched": plant(found.searched_disk),
        },  # fmt: skip
    }


def format_worst_case(found: WorstCase, label: str) -> str:
    """The two worst plants in words, their parameters beside the nominal and the worst
    sampled ones."""
    columns = (found.nominal, found.sampled_radius, found.searched_radius, found.sampled_disk,
               found.searched_disk)  # fmt: skip
    lines = [
        f"Worst plants of the study's box for {label} ({found.plants} sampled plants, then "
        f"a search; {found.evaluations} plants evaluated). A plant's rho is the worst over "
        f"its M0* and its M*(q) frozen at the path's {found.configurations} configurations; "
        f"its disk margin the worst over M0* and {len(found.active)} of them (the search "
        "judges those): " + "; ".join(found.active) + ".",
        f"  largest rho: {found.searched_radius.radius:.4f} at "
        f"{found.searched_radius.radius_at} ({found.searched_radius.source}; the worst "
        f"sampled {found.sampled_radius.radius:.4f}, nominal {found.nominal.radius:.4f})",
        f"  smallest disk margin: {found.searched_disk.disk_margin:.4f} at "
        f"{found.searched_disk.disk_at} ({found.searched_disk.source}; the worst sampled "
        f"{found.sampled_disk.disk_margin:.4f}, nominal {found.nominal.disk_margin:.4f})",
        "",
        "| parameter | nominal | worst sampled rho | largest rho | worst sampled disk | "
        "smallest disk |",
        "|---|---:|---:|---:|---:|---:|",
        "| rho | " + " | ".join(f"{p.radius:.4f}" for p in columns) + " |",
        "| disk margin | " + " | ".join(f"{p.disk_margin:.4f}" for p in columns) + " |",
    ]
    for k, axis in enumerate(found.axes):
        lines.append(f"| {axis.scalar.column} | " + " | ".join(f"{p.values[k]:.6g}"
                                                              for p in columns) + " |")  # fmt: skip
    unstable = [name for name, plant in (("the nominal plant", found.nominal),
                                         ("the worst sampled plant", found.sampled_radius))
                if plant.radius >= 1.0]  # fmt: skip
    if unstable:
        lines.append(
            f"note: {' and '.join(unstable)} already {'has' if len(unstable) == 1 else 'have'} "
            "rho >= 1: the loop is unstable there, a disk margin of 0 says only that, and "
            "the search's worst is no sharper a verdict (a shorter sample time or a new "
            "design first)"
        )
    return "\n".join(lines)
