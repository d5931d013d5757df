"""The settings of a robust tuning (``posfb tune``) and of the stability map, each default
written once here; the command line overrides them and every value is validated where
it enters (``TuneSettings.__post_init__``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

#: A loop counts as robustly stable when its spectral radius is at most ``1 - margin``.
DEFAULT_MARGIN = 0.02


@dataclass(frozen=True)
class TuneSettings:
    """``margin``: required ``rho <= 1 - margin`` on the nominal model and on every design
    plant. ``plants``: design plants drawn from the family (seed ``seed``).
    ``epsilon``, ``beta``: the verified probability of instability and the confidence
    level; each round's fresh verification plants (seed ``seed + 1 + round``) number
    ``ceil(ln(rounds/beta) / ln(1/(1 - epsilon)))`` (``analysis.tuning.guarantee``).
    ``rounds``: design-and-verify rounds at most, each on twice the design plants.
    ``budget``: wall-clock seconds the search may take. ``generations``: the optimiser's
    fixed schedule."""

    margin: float = DEFAULT_MARGIN
    plants: int = 50
    seed: int = 0
    epsilon: float = 0.05
    beta: float = 1e-3
    budget: float = 600.0
    generations: int = 30
    rounds: int = 2

    def __post_init__(self) -> None:
        checks = (
            ("margin", 0.0 <= self.margin < 1.0, "0 <= margin < 1"),
            ("plants", isinstance(self.plants, int) and self.plants >= 0, "an integer >= 0"),
            ("seed", isinstance(self.seed, int) and self.seed >= 0, "an integer >= 0"),
            ("epsilon", 0.0 < self.epsilon < 1.0, "0 < epsilon < 1"),
            ("beta", 0.0 < self.beta < 1.0, "0 < beta < 1"),
            ("budget", math.isfinite(self.budget) and self.budget > 0.0, "seconds > 0"),
            ("generations", isinstance(self.generations, int) and self.generations >= 1,
             "an integer >= 1"),
            ("rounds", isinstance(self.rounds, int) and self.rounds >= 1, "an integer >= 1"),
        )  # fmt: skip
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"{name} = {getattr(self, name)!r}; {allowed} is required")
