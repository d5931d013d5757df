"""The search of ``posfb tune``: scipy's differential evolution (Storn and Price 1997)
over the problem's log-scaled box, with the constraints handled by its feasibility
rules (Lampinen 2002: a feasible point beats an infeasible one, two infeasible ones are
ranked by how far they are from feasible), the scenario's own settings in the first
population, and a fixed schedule (``TuneSettings.generations``, population
``POPULATION`` per variable, no polishing). The result is a pure function of the
problem and the seed; the wall-clock budget (``analysis.design.budget``: checked after
each generation and, through the problem, before each plant a design is judged on) only
stops a search that would overrun it, and then nothing is returned (``BudgetError``),
never a time-dependent answer.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from posfb.analysis.design.budget import BudgetError, Deadline
from posfb.analysis.design.budget import TuneError as TuneError  # its home for callers
from posfb.analysis.design.problem import Evaluation, TuningProblem

#: Population members per decision variable.
POPULATION = 10

#: The objective given to a point whose nominal loop is unstable or refused (finite, so
#: that differential evolution can rank it; its constraints rank it anyway).
UNSTABLE_OBJECTIVE = 1e6


def population(decisions: int) -> int:
    """The members of each generation over ``decisions`` variables: ``POPULATION`` per
    variable, rounded up to a power of 2 (scipy's Sobol' initialisation does)."""
    return 2 ** math.ceil(math.log2(POPULATION * decisions))


@dataclass(frozen=True)
class SearchResult:
    """The entry's own evaluation (``start``), the best found (``best``, at ``x``, log10
    of each knob), the generations run and the evaluations made."""

    start: Evaluation
    best: Evaluation
    x: np.ndarray
    generations: int
    evaluations: int


def search(
    problem: TuningProblem, seed: int, generations: int, deadline: Deadline,
    x0: np.ndarray | None = None, progress: Callable[[int, Evaluation], None] | None = None,
) -> SearchResult:  # fmt: skip
    """Minimise ``problem``'s predicted error subject to its constraints; raise
    ``BudgetError`` when ``deadline`` passes first: after a generation, or inside one
    (``problem.deadline``, checked before each plant a design is judged on). ``x0``: the
    point put in the first population (default: the entry's own, ``problem.start()``);
    ``progress(generations done, best design's evaluation)`` after each generation."""
    import scipy.linalg  # on use: start-up
    import scipy.optimize

    cache: dict[bytes, Evaluation] = {}

    def evaluation(x: np.ndarray) -> Evaluation:
        key = np.asarray(x, dtype=float).tobytes()
        if key not in cache:
            cache[key] = problem.evaluate(problem.settings(np.asarray(x, dtype=float)))
        return cache[key]

    def objective(x: np.ndarray) -> float:
        value = evaluation(x).predicted_rms
        return value if np.isfinite(value) else UNSTABLE_OBJECTIVE

    def violations(x: np.ndarray) -> np.ndarray:
        return np.nan_to_num(problem.violations(evaluation(x)), nan=0.0, posinf=1e6)

    done = [0]

    def ran_out() -> BudgetError:
        return deadline.error(
            f"the search ran {done[0]} of its {generations} generations ({len(cache)} designs "
            f"judged on {len(problem.plants)} plants)"
        )

    def on_generation(intermediate_result: object) -> None:  # scipy passes it by this name
        done[0] += 1
        if progress is not None:
            progress(done[0], evaluation(intermediate_result.x))
        if deadline.passed():
            raise ran_out()

    start = problem.start()
    with warnings.catch_warnings():
        # The search visits ill-conditioned designs on purpose (its box is wide); their
        # Riccati and Lyapunov solutions are judged by the constraints, not reported.
        warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
        try:
            result = scipy.optimize.differential_evolution(
                objective,
                problem.bounds(),
                constraints=scipy.optimize.NonlinearConstraint(violations, -np.inf, 0.0),
                maxiter=generations,
                popsize=POPULATION,
                init="sobol",
                x0=start if x0 is None else np.asarray(x0, dtype=float),
                seed=seed,
                polish=False,
                tol=0.0,
                updating="deferred",
                callback=on_generation,
            )
        except BudgetError:  # after or inside a generation: say how far the search got
            raise ran_out() from None
    return SearchResult(
        start=evaluation(start),
        best=evaluation(result.x),
        x=np.asarray(result.x, dtype=float),
        generations=done[0],
        evaluations=len(cache),
    )
