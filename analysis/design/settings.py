"""The settings of a robust tuning (``posfb tune``) and of the stability map, each default
written once here; the command line overrides them and every value is validated where
it enters (``TuneSettings.__post_init__``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from posfb.analysis.design.guarantee import verification_bound

#: A loop counts as robustly stable when its spectral radius is at most ``1 - margin``.
DEFAULT_MARGIN = 0.02

#: The most design plants a round may use (``plants * 2^(rounds - 1)`` in the last), and
#: the most plants of a stability map: 200 times the default 50. Measured on the 2-core
#: development machine, one design plant takes 10-16 ms (the paper's arm) to 70 ms (the
#: six-joint arm) to draw, its model error along the trajectory included, and 0.07 to
#: 0.3 ms each time a design is judged on it: 10 000 of them take 2 to 12 minutes before
#: the search starts and 1 to 3 minutes for each of its generations (64 designs), hours
#: for the 30 of the default schedule; a larger count never ends in a usable budget.
MAX_DESIGN_PLANTS = 10_000

#: The most fresh plants one verification round may draw (``N`` of
#: ``analysis.design.guarantee.verification_plants`` at ``beta / rounds``). Each costs 3
#: to 34 ms to draw (its linear part only) and judge (the same machine), so 100 000 take
#: 5 minutes to an hour per round and controller; that admits epsilon down to about 1e-4
#: at beta = 1e-3 over 2 rounds (N = 76 000), while epsilon = 1e-12 would ask for 7.6e12.
MAX_VERIFICATION_PLANTS = 100_000


@dataclass(frozen=True)
class TuneSettings:
    """``margin``: required ``rho <= 1 - margin`` on the nominal model and on every design
    plant. ``plants``: design plants drawn from the family (seed ``seed``).
    ``epsilon``, ``beta``: the verified probability of instability and the confidence
    level; each round's fresh verification plants (seed ``seed + 1 + round``) number
    ``ceil(ln(rounds/beta) / ln(1/(1 - epsilon)))`` (``analysis.design.guarantee``).
    ``rounds``: design-and-verify rounds at most, each on twice the design plants.
    ``budget``: wall-clock seconds the whole tuning may take (drawing, search,
    verification and check runs, checked inside each: ``analysis.design.budget``).
    ``generations``: the optimiser's fixed schedule. The plants these imply are held to
    ``MAX_DESIGN_PLANTS`` and ``MAX_VERIFICATION_PLANTS`` here, before any work.
    ``workers``: processes that tune the controllers side by side (``None``: one per
    tuned controller, at most the cores available; 1: one after the other in this
    process); the result is the same whatever their number."""

    margin: float = DEFAULT_MARGIN
    plants: int = 50
    seed: int = 0
    epsilon: float = 0.05
    beta: float = 1e-3
    budget: float = 600.0
    generations: int = 30
    rounds: int = 2
    workers: int | None = None

    def __post_init__(self) -> None:
        checks = (
            ("margin", 0.0 <= self.margin < 1.0, "0 <= margin < 1"),
            ("plants", isinstance(self.plants, int) and self.plants >= 1, "an integer >= 1"),
            ("seed", isinstance(self.seed, int) and self.seed >= 0, "an integer >= 0"),
            ("epsilon", 0.0 < self.epsilon < 1.0, "0 < epsilon < 1"),
            ("beta", 0.0 < self.beta < 1.0, "0 < beta < 1"),
            ("budget", math.isfinite(self.budget) and self.budget > 0.0, "seconds > 0"),
            ("generations", isinstance(self.generations, int) and self.generations >= 1,
             "an integer >= 1"),
            ("rounds", isinstance(self.rounds, int) and self.rounds >= 1, "an integer >= 1"),
            ("workers", self.workers is None or (isinstance(self.workers, int)
                                                 and self.workers >= 1), "an integer >= 1"),
        )  # fmt: skip
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"{name} = {getattr(self, name)!r}; {allowed} is required")
        self._check_counts()

    def _check_counts(self) -> None:
        """The plants the settings imply, against ``MAX_DESIGN_PLANTS`` and
        ``MAX_VERIFICATION_PLANTS``, before any work (``ValueError`` naming the settings,
        the count they imply and the ceiling)."""
        doublings = self.rounds - 1  # an exponent beyond the ceiling's bits is not evaluated
        last = self.plants * 2**doublings if doublings < 64 else math.inf
        if last > MAX_DESIGN_PLANTS:
            count = f"{last:,}" if doublings < 64 else f"{self.plants} * 2^{doublings}"
            rounds = (
                f" with rounds = {self.rounds}: {count} design plants in the last round "
                "(plants * 2^(rounds - 1))"
                if self.rounds > 1
                else ""
            )
            raise ValueError(
                f"plants = {self.plants!r}{rounds}; at most {MAX_DESIGN_PLANTS:,} plants are "
                "allowed (MAX_DESIGN_PLANTS: each is drawn, then judged for every design tried)"
            )
        needed = verification_bound(self.epsilon, self.beta, self.rounds)
        if needed > MAX_VERIFICATION_PLANTS:
            raise ValueError(
                f"epsilon = {self.epsilon!r} with beta = {self.beta!r} and rounds = "
                f"{self.rounds} asks for N = ln(rounds/beta) / ln(1/(1 - epsilon)) = "
                f"{needed:.3g} fresh plants per verification round; at most "
                f"{MAX_VERIFICATION_PLANTS:,} are allowed (MAX_VERIFICATION_PLANTS): a larger "
                "epsilon or beta is required"
            )
