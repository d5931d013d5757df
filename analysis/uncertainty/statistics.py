"""Numerical helpers for the Monte-Carlo report: intervals, rankings, Sobol indices, convergence.

Conventions shared by every function here:

* **Finite values only.** A non-finite response (NaN, +-inf) marks a run that produced no
  number (it failed or diverged). Statistics of a response describe the runs that did produce
  one; how many did not is a proportion, reported with ``proportion_interval``. Sobol' indices
  are the exception: their estimators need every run of the design, so they refuse such values.
* **Intervals are two-sided and equal-tailed.** ``confidence`` is the nominal coverage, a number
  in (0, 1); an ``Interval`` of NaNs means that nothing is known (no finite value).
* **Seeded.** Every random step draws from ``numpy.random.default_rng(seed)``, so the same input
  and seed give the same output, bit for bit.
* **Validated at the entry.** A bad argument raises ``ValueError`` whose message names the
  parameter, its value and what is allowed, e.g. ``confidence = 1.5; a number in (0, 1) is
  required``.

Methods (and their sources):

* ``quantile_interval``: Efron's percentile bootstrap (Efron 1979; Efron & Tibshirani 1993,
  ch. 13) through ``scipy.stats.bootstrap``. For tail quantiles of small samples it covers less
  than nominal: the bootstrap distribution of an extreme order statistic is discrete and rests
  on the few largest observations (for the 95th percentile of 100 lognormal values a nominal
  95 % interval covers about 90 % of the time in simulation; the median's covers about 95 %).
* ``proportion_interval``: the Wilson (1927) score interval, or the Clopper & Pearson (1934)
  "exact" interval, which covers at least the nominal level for every true proportion.
* ``spearman_ranking``: Spearman's rank correlation with its t-approximation p-value
  (``scipy.stats.spearmanr``) and a paired percentile bootstrap interval (rows resampled).
* ``sobol_indices``: first-order (Saltelli et al. 2010) and total-order (Jansen 1999) Sobol'
  indices from a Saltelli design, as SALib 1.6 implements them, with SALib's bootstrap
  half-widths (normal approximation, 100 resamples).
* ``ecdf`` and ``running_quantiles``: the empirical distribution and the convergence of sample
  quantiles with the number of runs, in sample order.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike


def _stats():
    """``scipy.stats``, imported on first use: it takes a third of a second, and commands
    that import this module without computing statistics (``scenario check``) skip it."""
    from scipy import stats

    return stats


#: Largest number of array elements one bootstrap batch holds (resamples x sample size).
_BATCH_ELEMENTS = 1 << 20

#: Fewest rows (finished runs) for which the report gives an interval or a p-value: with
#: fewer, a percentile-bootstrap interval is built from a handful of distinct resamples
#: and Spearman's t-approximation p-value is far off (5 identical ranks print rho = 1
#: [1, 1], p = 1e-24); the report then prints the estimate alone (this project's choice,
#: the smallest n for which critical values of Spearman's rho are usually tabulated by
#: their normal approximation, Zar 1972).
MIN_INFERENCE_ROWS = 10

#: Above this many rows ``spearman_ranking`` uses the Fisher-z (Bonett-Wright) interval.
BOOTSTRAP_ROWS = 2000

#: Largest dimension ``saltelli_unit_design`` accepts: the design draws a Sobol' sequence of
#: 2 d dimensions, and SciPy's direction numbers (Joe & Kuo 2008) stop at 21201.
_MAX_SALTELLI_DIMENSIONS = 21201 // 2

_PROPORTION_METHODS = {"wilson": "wilson", "clopper-pearson": "exact"}


@dataclass(frozen=True)
class Interval:
    """A point estimate with a two-sided confidence interval ``[low, high]``."""

    estimate: float
    low: float
    high: float
    confidence: float

    def text(self, digits: int = 3) -> str:
        """``"estimate [low, high]"``, each to ``digits`` significant digits (``g`` format);
        the estimate alone when there is no interval (``without_interval``)."""
        digits = _integer("digits", digits, minimum=1)
        if not (np.isfinite(self.low) and np.isfinite(self.high)):
            return f"{self.estimate:.{digits}g} (no CI, n < {MIN_INFERENCE_ROWS})"
        return f"{self.estimate:.{digits}g} [{self.low:.{digits}g}, {self.high:.{digits}g}]"

    def without_interval(self, count: int) -> Interval:
        """This estimate without its interval when it rests on fewer than
        ``MIN_INFERENCE_ROWS`` values (``count``); unchanged otherwise."""
        if count >= MIN_INFERENCE_ROWS:
            return self
        return Interval(self.estimate, math.nan, math.nan, self.confidence)


@dataclass(frozen=True)
class RankCorrelation:
    """Spearman's rho of one parameter with the response, over ``count`` rows."""

    parameter: str
    rho: float
    p_value: float
    low: float
    high: float
    count: int


@dataclass(frozen=True)
class SobolIndex:
    """First- and total-order Sobol' indices of one parameter, with bootstrap half-widths."""

    parameter: str
    first: float
    first_conf: float
    total: float
    total_conf: float


def quantile_interval(
    values: ArrayLike,
    q: float,
    confidence: float = 0.95,
    resamples: int = 2000,
    seed: int = 0,
) -> Interval:
    """The ``q`` quantile of the finite values with a percentile-bootstrap interval.

    The estimate is ``numpy.quantile`` (linear interpolation) of the finite values; the interval
    is Efron's percentile bootstrap (``scipy.stats.bootstrap``, ``method="percentile"``) with
    ``resamples`` resamples drawn from ``default_rng(seed)``. No finite value gives an interval
    of NaNs; a single one gives the degenerate interval ``[v, v]``.
    """
    q = _probability("q", q, closed=True)
    confidence = _probability("confidence", confidence, closed=False)
    resamples = _integer("resamples", resamples, minimum=1)
    seed = _integer("seed", seed, minimum=0)
    finite = _finite(_vector("values", values))
    if finite.size == 0:
        return Interval(np.nan, np.nan, np.nan, confidence)
    estimate = float(np.quantile(finite, q))
    if finite.size == 1:
        return Interval(estimate, estimate, estimate, confidence)

    def statistic(sample: np.ndarray, axis: int) -> np.ndarray:
        return np.quantile(sample, q, axis=axis)

    result = _stats().bootstrap(
        (finite,),
        statistic,
        n_resamples=resamples,
        batch=max(1, _BATCH_ELEMENTS // finite.size),
        vectorized=True,
        confidence_level=confidence,
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    interval = result.confidence_interval
    return Interval(estimate, float(interval.low), float(interval.high), confidence)


def median_interval(
    values: ArrayLike,
    confidence: float = 0.95,
    resamples: int = 2000,
    seed: int = 0,
) -> Interval:
    """``quantile_interval(values, 0.5, ...)``: the median with a percentile-bootstrap interval."""
    return quantile_interval(values, 0.5, confidence=confidence, resamples=resamples, seed=seed)


def proportion_interval(
    successes: int,
    trials: int,
    confidence: float = 0.95,
    method: str = "wilson",
) -> Interval:
    """The proportion ``successes / trials`` with a binomial confidence interval.

    ``method="wilson"`` is the Wilson (1927) score interval (no continuity correction): close to
    nominal coverage on average, sometimes a little below. ``method="clopper-pearson"`` is the
    Clopper & Pearson (1934) interval from the binomial tails, which covers at least
    ``confidence`` for every true proportion at the price of width. Both come from
    ``scipy.stats.binomtest(successes, trials).proportion_ci``. No trials give
    ``Interval(nan, 0, 1)``: nothing is known.
    """
    trials = _integer("trials", trials, minimum=0)
    successes = _integer("successes", successes, minimum=0)
    if successes > trials:
        raise ValueError(
            f"successes = {successes}; an integer in [0, trials = {trials}] is required"
        )
    confidence = _probability("confidence", confidence, closed=False)
    if method not in _PROPORTION_METHODS:
        allowed = " or ".join(repr(name) for name in _PROPORTION_METHODS)
        raise ValueError(f"method = {method!r}; {allowed} is required")
    if trials == 0:
        return Interval(np.nan, 0.0, 1.0, confidence)
    interval = _stats().binomtest(successes, trials).proportion_ci(
        confidence_level=confidence, method=_PROPORTION_METHODS[method]
    )
    return Interval(successes / trials, float(interval.low), float(interval.high), confidence)


def spearman_ranking(
    parameters: Mapping[str, ArrayLike],
    response: ArrayLike,
    confidence: float = 0.95,
    resamples: int = 1000,
    seed: int = 0,
) -> list[RankCorrelation]:
    """Spearman's rank correlation of each parameter with the response, strongest first.

    Each parameter is paired with the response over the rows where both are finite. ``rho`` and
    ``p_value`` (two-sided, t approximation) come from ``scipy.stats.spearmanr``; ``[low, high]``
    is a paired percentile bootstrap (rows resampled together, ``resamples`` times, from
    ``default_rng(seed)`` afresh for each parameter) up to ``BOOTSTRAP_ROWS`` rows, and above
    that the Fisher-z interval with Bonett & Wright's (2000) variance ``(1 + rho^2 / 2) / (n - 3)``
    (accurate at such sizes, where the bootstrap would cost minutes per study). A
    resample in which either column is constant has no rho and is left out of the percentiles.
    A parameter with fewer than 3 such rows, or for which the parameter or the response is
    constant over them, has no rank correlation and is left out. The list is sorted by
    ``|rho|`` descending, ties by name.
    """
    confidence = _probability("confidence", confidence, closed=False)
    resamples = _integer("resamples", resamples, minimum=1)
    seed = _integer("seed", seed, minimum=0)
    y = _vector("response", response)
    columns = {}
    for name, values in parameters.items():
        x = _vector(f"parameters[{name!r}]", values)
        if x.size != y.size:
            raise ValueError(
                f"parameters[{name!r}] has {x.size} values; "
                f"one per response value ({y.size}) is required"
            )
        columns[name] = x

    ranking = []
    for name, x in columns.items():
        rows = np.isfinite(x) & np.isfinite(y)
        xs, ys = x[rows], y[rows]
        if xs.size < 3 or np.ptp(xs) == 0 or np.ptp(ys) == 0:
            continue
        result = _stats().spearmanr(xs, ys)
        if xs.size <= BOOTSTRAP_ROWS:
            low, high = _bootstrap_spearman(xs, ys, confidence, resamples, seed)
        else:
            low, high = _fisher_spearman(float(result.statistic), xs.size, confidence)
        ranking.append(
            RankCorrelation(
                parameter=name,
                rho=float(result.statistic),
                p_value=float(result.pvalue),
                low=low,
                high=high,
                count=int(xs.size),
            )
        )
    return sorted(ranking, key=lambda item: (-abs(item.rho), item.parameter))


def saltelli_unit_design(dimensions: int, base_samples: int, seed: int) -> np.ndarray:
    """The Saltelli design for first- and total-order indices, in the unit cube ``[0, 1)^d``.

    ``SALib.sample.sobol.sample`` (``calc_second_order=False``, scrambled Sobol' sequence seeded
    with ``seed``): ``base_samples * (dimensions + 2)`` rows, in blocks of ``dimensions + 2`` --
    the point A, the ``dimensions`` points A with column j taken from B, then B (Saltelli 2002,
    2010). ``base_samples`` must be a power of 2, where the Sobol' sequence is balanced. The
    design is prefix stable: the first ``k * (dimensions + 2)`` rows for ``base_samples = 2 k``
    are the design for ``base_samples = k`` with the same seed, so a study can be extended.
    """
    dimensions = _integer("dimensions", dimensions, minimum=1)
    if dimensions > _MAX_SALTELLI_DIMENSIONS:
        raise ValueError(
            f"dimensions = {dimensions}; an integer in [1, {_MAX_SALTELLI_DIMENSIONS}] is required"
        )
    base_samples = _integer("base_samples", base_samples, minimum=1)
    if base_samples & (base_samples - 1):
        raise ValueError(f"base_samples = {base_samples}; a power of 2 is required")
    seed = _integer("seed", seed, minimum=0)
    from SALib.sample import sobol as sobol_sample  # imported on use: SALib is slow to import

    return sobol_sample.sample(
        _unit_problem([f"x{j}" for j in range(dimensions)]),
        base_samples,
        calc_second_order=False,
        scramble=True,
        seed=seed,
    )


def sobol_indices(
    names: Sequence[str],
    response: ArrayLike,
    confidence: float = 0.95,
    seed: int = 0,
) -> list[SobolIndex]:
    """First- and total-order Sobol' indices from the responses to a Saltelli design.

    ``response[i]`` is the response at row i of the design (``saltelli_unit_design`` with
    ``dimensions = len(names)``; only the row structure matters, not the bounds). The indices are
    ``SALib.analyze.sobol.analyze`` without second order: first order by the Saltelli et al.
    (2010) estimator, total order by Jansen's (1999), both over the variance of the normalised
    response. ``first_conf`` and ``total_conf`` are SALib's half-widths at ``confidence``:
    z times the standard deviation of 100 bootstrap estimates. SALib treats ``seed=0`` as "no
    seed" and then draws from NumPy's global state, so a generator built from ``seed`` is passed
    instead: every seed, 0 included, is reproducible. Every run must have a finite response and
    the response must vary. The list is sorted by total order descending, ties by name.
    """
    if isinstance(names, str):
        raise ValueError(f"names = {names!r}; a sequence of parameter names is required")
    names = list(names)
    if not names or len(set(names)) != len(names):
        raise ValueError(f"names = {names!r}; a non-empty sequence of distinct names is required")
    confidence = _probability("confidence", confidence, closed=False)
    seed = _integer("seed", seed, minimum=0)
    y = _vector("response", response)
    block = len(names) + 2
    if y.size == 0 or y.size % block:
        raise ValueError(
            f"response has {y.size} values; a positive multiple of len(names) + 2 = {block} "
            "is required (a Saltelli design without second order)"
        )
    bad = int(np.count_nonzero(~np.isfinite(y)))
    if bad:
        raise ValueError(f"response has {bad} non-finite values; Sobol indices need every run")
    if np.ptp(y) == 0:
        raise ValueError(
            f"response is constant ({y[0]:g}); Sobol indices need a response that varies"
        )
    from SALib.analyze import sobol as sobol_analyze  # imported on use, as above

    result = sobol_analyze.analyze(
        _unit_problem(names),
        y,
        calc_second_order=False,
        conf_level=confidence,
        print_to_console=False,
        seed=np.random.default_rng(seed),
    )
    indices = [
        SobolIndex(
            parameter=name,
            first=float(result["S1"][j]),
            first_conf=float(result["S1_conf"][j]),
            total=float(result["ST"][j]),
            total_conf=float(result["ST_conf"][j]),
        )
        for j, name in enumerate(names)
    ]
    return sorted(indices, key=lambda item: (-item.total, item.parameter))


def ecdf(values: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The empirical distribution: the sorted finite values and ``i / n`` for ``i = 1..n``."""
    finite = np.sort(_finite(_vector("values", values)))
    return finite, np.arange(1, finite.size + 1) / finite.size


def running_quantiles(
    values: ArrayLike,
    qs: Sequence[float],
    min_count: int = 5,
    points: int = 200,
) -> tuple[np.ndarray, np.ndarray]:
    """Sample quantiles of the first n finite values, in sample order, for a convergence figure.

    Non-finite values are skipped (they do not count towards n). The counts n run from
    ``min_count`` to the number N of finite values at up to ``points`` logarithmically spaced
    integers, N always included. Returns ``(n, quantiles)`` with ``quantiles[i, j] =
    numpy.quantile(first n[i] finite values, qs[j])``, of shape ``(len(n), len(qs))``; both are
    empty when N < ``min_count``.
    """
    qs = [_probability(f"qs[{j}]", q, closed=True) for j, q in enumerate(qs)]
    if not qs:
        raise ValueError("qs = []; at least one probability in [0, 1] is required")
    min_count = _integer("min_count", min_count, minimum=1)
    points = _integer("points", points, minimum=2)
    finite = _finite(_vector("values", values))
    if finite.size < min_count:
        return np.zeros(0, dtype=int), np.zeros((0, len(qs)))
    counts = np.unique(np.geomspace(min_count, finite.size, points).round().astype(int))
    quantiles = np.array([np.quantile(finite[:n], qs) for n in counts])
    return counts, quantiles


def _bootstrap_spearman(
    x: np.ndarray, y: np.ndarray, confidence: float, resamples: int, seed: int
) -> tuple[float, float]:
    """Percentile-bootstrap interval of Spearman's rho, resampling the (x, y) rows together."""
    rng = np.random.default_rng(seed)
    batch = max(1, _BATCH_ELEMENTS // x.size)
    rhos = np.empty(resamples)
    for start in range(0, resamples, batch):
        stop = min(start + batch, resamples)
        rows = rng.integers(0, x.size, size=(stop - start, x.size))
        rhos[start:stop] = _rank_correlation(x[rows], y[rows])
    rhos = rhos[np.isfinite(rhos)]
    if rhos.size == 0:
        return np.nan, np.nan
    tail = (1.0 - confidence) / 2.0
    low, high = np.quantile(rhos, [tail, 1.0 - tail])
    return float(low), float(high)


def _fisher_spearman(rho: float, rows: int, confidence: float) -> tuple[float, float]:
    """Fisher-z interval of Spearman's rho with Bonett & Wright's (2000) standard error."""
    z = float(np.arctanh(np.clip(rho, -1.0 + 1e-15, 1.0 - 1e-15)))
    half = _stats().norm.ppf(0.5 + confidence / 2.0) * np.sqrt((1.0 + rho * rho / 2.0) / (rows - 3))
    return float(np.tanh(z - half)), float(np.tanh(z + half))


def _rank_correlation(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Spearman's rho along the last axis (Pearson's r of mid-ranks); NaN where one is constant."""
    rx = _stats().rankdata(x, axis=-1)
    ry = _stats().rankdata(y, axis=-1)
    rx -= rx.mean(axis=-1, keepdims=True)
    ry -= ry.mean(axis=-1, keepdims=True)
    covariance = np.sum(rx * ry, axis=-1)
    scale = np.sqrt(np.sum(rx * rx, axis=-1) * np.sum(ry * ry, axis=-1))
    return np.divide(covariance, scale, out=np.full_like(scale, np.nan), where=scale > 0)


def _unit_problem(names: list[str]) -> dict[str, object]:
    """A SALib problem with every parameter on [0, 1]."""
    return {"num_vars": len(names), "names": names, "bounds": [[0.0, 1.0]] * len(names)}


def _vector(name: str, values: ArrayLike) -> np.ndarray:
    """``values`` as a one-dimensional float array, or ValueError naming ``name``."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(
            f"{name} could not be read as numbers ({error}); "
            "a one-dimensional array of numbers is required"
        ) from error
    if array.ndim != 1:
        raise ValueError(
            f"{name} has shape {array.shape}; a one-dimensional array of numbers is required"
        )
    return array


def _finite(values: np.ndarray) -> np.ndarray:
    """The finite entries of ``values``, in order."""
    return values[np.isfinite(values)]


def _integer(name: str, value: object, minimum: int) -> int:
    """``value`` as an int of at least ``minimum`` (booleans and floats refused)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} = {value!r}; an integer >= {minimum} is required")
    return int(value)


def _probability(name: str, value: object, closed: bool) -> float:
    """``value`` as a float in [0, 1] (``closed``) or (0, 1), or ValueError naming ``name``."""
    valid = (
        isinstance(value, numbers.Real)
        and not isinstance(value, bool)
        and (0.0 <= value <= 1.0 if closed else 0.0 < value < 1.0)
    )
    if not valid:
        allowed = "[0, 1]" if closed else "(0, 1)"
        raise ValueError(f"{name} = {value!r}; a number in {allowed} is required")
    return float(value)
