"""The wall-clock budget of ``posfb tune`` (``TuneSettings.budget``), checked inside the
work: before each plant drawn, each plant a design is judged on, each generation of the
search and each stretch of a check run, so that a tuning that runs out stops within
one such step of its budget. Where a step's cost can be measured first (drawing and
judging the first ``PROBE_PLANTS`` plants), the whole of it is estimated and refused up
front when it cannot fit in what is left. Either way the answer is ``BudgetError`` and
no design, never a time-dependent one."""

from __future__ import annotations

import time
from dataclasses import dataclass

#: Plants whose drawing and judging is timed before a set of plants is drawn whole: the
#: fastest of them (the first one also pays the set-up) prices every other plant.
PROBE_PLANTS = 5

#: What to change when the budget is too small for the plants asked for.
REMEDY = "raise --budget, or lower --plants or --generations"


class TuneError(RuntimeError):
    """No tuned design: none meets the constraints, or the search would overrun its
    budget (the message says which, in one line)."""


class BudgetError(TuneError):
    """The tuning did not fit in its wall-clock budget, or would not (an estimate made
    before the work)."""


@dataclass(frozen=True)
class Deadline:
    """The end of a budget of ``budget`` seconds: ``time.monotonic()`` value ``at``."""

    budget: float
    at: float

    @classmethod
    def after(cls, budget: float) -> Deadline:
        """The deadline ``budget`` seconds from now."""
        return cls(budget, time.monotonic() + budget)

    def left(self) -> float:
        """Seconds left (negative once passed)."""
        return self.at - time.monotonic()

    def passed(self) -> bool:
        """Whether the budget has run out."""
        return time.monotonic() > self.at

    def error(self, doing: str, remedy: str = REMEDY) -> BudgetError:
        """The one-line ``BudgetError`` of a budget that ran out while ``doing``."""
        return BudgetError(
            f"no design within the budget: the budget's {self.budget:g} s ran out while "
            f"{doing}; {remedy}"
        )

    def check(self, doing: str, remedy: str = REMEDY) -> None:
        """Raise ``error(doing)`` when the budget has run out."""
        if self.passed():
            raise self.error(doing, remedy)

    def require(self, seconds: float, work: str, remedy: str = REMEDY) -> None:
        """Refuse ``work`` up front (``BudgetError``) when its estimated ``seconds`` are
        more than is left."""
        left = self.left()
        if seconds > left:
            raise BudgetError(
                f"no design within the budget: {work} would take about {seconds:.3g} s, more "
                f"than the {max(left, 0.0):.3g} s left of the budget's {self.budget:g} s; {remedy}"
            )
