"""The probabilistic statements a tuned design comes with.

**Verification of a fixed design** (Tempo, Bai and Dabbene, "Probabilistic robustness
analysis: explicit bounds for the minimum number of samples", Systems & Control Letters
30, 1997): a design fixed *before* the plants are drawn is checked on ``N`` i.i.d.
plants. If all pass and ``N >= ln(1/beta) / ln(1/(1 - epsilon))``
(``verification_plants``), then ``P(violation) <= epsilon`` with confidence at least
``1 - beta``: were the violation probability above ``epsilon``, all ``N`` would pass
with probability below ``(1 - epsilon)^N <= beta``. With ``k`` failures the same
reasoning gives the one-sided Clopper-Pearson bound ``epsilon_k``, the ``1 - beta``
quantile of ``Beta(k + 1, N - k)`` (``violation_bound``; for ``k = 0`` it is
``1 - beta^(1/N)``). posfb draws the verification plants with a seed of their own, so
the design cannot depend on them and the statement applies.

**A design chosen using the samples** (Calafiore and Campi, "The scenario approach to
robust control design", IEEE TAC 51(5), 2006): when the design is the solution of a
*convex* program with ``d`` decision variables constrained on ``N`` i.i.d. plants, its
violation probability exceeds ``epsilon`` with probability at most
``sum_{i<d} C(N, i) epsilon^i (1 - epsilon)^(N - i)`` (Campi and Garatti 2008's exact
form, ``scenario_confidence``). posfb's search over the spectral radius is not convex,
so this bound is reported for reference only and never claimed: the guarantee posfb
states is the verification one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def verification_bound(epsilon: float, beta: float, rounds: int = 1) -> float:
    """``ln(rounds/beta) / ln(1/(1 - epsilon))``, the real number ``verification_plants``
    rounds up at ``beta / rounds`` (``inf`` where it overflows; written with logarithms
    of each factor and ``log1p`` so that tiny ``beta`` and ``epsilon`` stay exact)."""
    return (math.log(rounds) - math.log(beta)) / -math.log1p(-epsilon)


def verification_plants(epsilon: float, beta: float) -> int:
    """The smallest ``N`` with ``(1 - epsilon)^N <= beta``:
    ``ceil(ln(1/beta) / ln(1/(1 - epsilon)))`` (Tempo, Bai and Dabbene 1997)."""
    return math.ceil(verification_bound(epsilon, beta))


def violation_bound(failures: int, plants: int, beta: float) -> float:
    """The smallest ``epsilon`` such that, had the violation probability been above it,
    ``failures`` or fewer of ``plants`` i.i.d. checks would have failed with probability
    at most ``beta``: the one-sided Clopper-Pearson upper bound."""
    if plants <= 0:
        return 1.0
    if failures >= plants:
        return 1.0
    import scipy.stats  # on use: start-up

    return float(scipy.stats.beta.ppf(1.0 - beta, failures + 1, plants - failures))


def scenario_confidence(plants: int, decisions: int, epsilon: float) -> float:
    """``beta`` of the scenario approach for a convex design with ``decisions`` variables
    chosen on ``plants`` samples: ``P(violation > epsilon) <= sum_{i<d} C(N, i)
    epsilon^i (1 - epsilon)^(N - i)`` (the binomial CDF at ``d - 1``)."""
    import scipy.stats  # on use: start-up

    return float(scipy.stats.binom.cdf(decisions - 1, plants, epsilon))


@dataclass(frozen=True)
class Guarantee:
    """The statement for ``failures`` failed of ``plants`` fresh i.i.d. plants:
    ``P(violation) <= epsilon_bound`` with confidence ``1 - beta``, where the check was
    the last of at most ``rounds`` design-and-verify rounds, each at ``beta / rounds``
    (union bound); ``holds``: the bound is at most the asked ``epsilon``."""

    epsilon: float
    beta: float
    rounds: int
    plants: int
    failures: int
    epsilon_bound: float

    @property
    def holds(self) -> bool:
        """Whether the verified bound is at most the asked ``epsilon``."""
        return self.epsilon_bound <= self.epsilon

    def sentence(self, what: str) -> str:
        """The guarantee in words (``what``: the violation), with its formula and source."""
        head = (
            f"{self.failures} of {self.plants} fresh i.i.d. plants: {what}, so "
            f"P({what}) <= {self.epsilon_bound:.4g} with confidence {1 - self.beta:.4g}"
        )
        split = (
            f", beta split over {self.rounds} rounds by the union bound" if self.rounds > 1 else ""
        )
        if self.failures == 0:
            needed = verification_bound(self.epsilon, self.beta, self.rounds)
            return (
                f"{head} (N = {self.plants} >= ln({self.rounds}/beta) / ln(1/(1 - epsilon)) "
                f"= {needed:.1f} for epsilon = {self.epsilon:g}, beta = {self.beta:g}{split}: "
                "Tempo, Bai and Dabbene 1997)"
            )
        return (
            f"{head} (one-sided Clopper-Pearson bound, Beta(k + 1, N - k) quantile at "
            f"1 - beta / {self.rounds}{split})"
        )


def verify(outcomes: list[bool], epsilon: float, beta: float, rounds: int = 1) -> Guarantee:
    """The guarantee that ``outcomes`` (``True``: the plant passed) support, checked in one
    of at most ``rounds`` rounds (each at ``beta / rounds``)."""
    failures = sum(not ok for ok in outcomes)
    return Guarantee(
        epsilon=epsilon,
        beta=beta,
        rounds=rounds,
        plants=len(outcomes),
        failures=failures,
        epsilon_bound=violation_bound(failures, len(outcomes), beta / rounds),
    )
