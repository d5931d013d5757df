"""Tests of the Monte-Carlo report's statistics helpers (``analysis/uncertainty/statistics.py``).

Coverage tests are seeded simulations: they check that an interval method covers the true value
in a fraction of synthetic data sets that lies inside a binomial acceptance band around the
nominal level, so a systematic error (wrong tail, wrong level, unseeded draws) fails them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from posfb.analysis.uncertainty.statistics import (
    Interval,
    ecdf,
    median_interval,
    proportion_interval,
    quantile_interval,
    running_quantiles,
    saltelli_unit_design,
    sobol_indices,
    spearman_ranking,
)


def _binomial_sd(p: float, trials: int) -> float:
    """Standard deviation of a coverage fraction over ``trials`` independent data sets."""
    return math.sqrt(p * (1.0 - p) / trials)


# --- quantile intervals -------------------------------------------------------------------------


@pytest.mark.slow
def test_bootstrap_quantile_intervals_cover_the_true_quantiles() -> None:
    data_sets, size, nominal = 400, 100, 0.95
    true_median = 1.0  # lognormal(0, 1): median exp(0)
    true_p95 = math.exp(stats.norm.ppf(0.95))
    rng = np.random.default_rng(20240601)
    median_hits = p95_hits = 0
    for i in range(data_sets):
        values = rng.lognormal(size=size)
        median = median_interval(values, confidence=nominal, resamples=500, seed=i)
        p95 = quantile_interval(values, 0.95, confidence=nominal, resamples=500, seed=i)
        median_hits += median.low <= true_median <= median.high
        p95_hits += p95.low <= true_p95 <= p95.high
    sd = _binomial_sd(nominal, data_sets)
    # The median's percentile-bootstrap interval is close to nominal: 4 binomial sd either side.
    assert nominal - 4 * sd <= median_hits / data_sets <= nominal + 4 * sd
    # A tail quantile's percentile-bootstrap interval under-covers in small samples (its
    # bootstrap distribution rests on the few largest observations; the error shrinks like
    # 1/sqrt(n)). Allow 1/sqrt(n) below nominal, plus 3 binomial sd; above, the usual band.
    assert nominal - 1 / math.sqrt(size) - 3 * sd <= p95_hits / data_sets <= nominal + 4 * sd


def test_quantile_interval_estimate_ignores_non_finite_values_and_is_seeded() -> None:
    values = np.random.default_rng(3).normal(size=300)
    with_gaps = np.concatenate([values, [np.nan, np.inf, -np.inf]])
    first = quantile_interval(with_gaps, 0.9, resamples=300, seed=7)
    assert first.estimate == np.quantile(values, 0.9)
    assert first.low <= first.estimate <= first.high
    assert first.confidence == 0.95
    assert quantile_interval(with_gaps, 0.9, resamples=300, seed=7) == first
    assert quantile_interval(values, 0.9, resamples=300, seed=7) == first


def test_quantile_interval_degenerate_inputs() -> None:
    for values in ([], [np.nan, np.nan], np.array([np.inf])):
        interval = quantile_interval(values, 0.5)
        assert np.isnan([interval.estimate, interval.low, interval.high]).all()
    assert median_interval([np.nan, 2.5]) == Interval(2.5, 2.5, 2.5, 0.95)
    assert median_interval([4.0] * 10, confidence=0.9) == Interval(4.0, 4.0, 4.0, 0.9)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({"q": 1.5}, r"q = 1\.5; a number in \[0, 1\]"),
        ({"q": 0.5, "confidence": 1.5}, r"confidence = 1\.5; a number in \(0, 1\)"),
        ({"q": 0.5, "confidence": 0.0}, r"confidence = 0\.0"),
        ({"q": 0.5, "resamples": 0}, r"resamples = 0; an integer >= 1"),
        ({"q": 0.5, "resamples": 10.0}, r"resamples = 10\.0; an integer"),
        ({"q": 0.5, "seed": -1}, r"seed = -1; an integer >= 0"),
    ],
)
def test_quantile_interval_rejects_bad_arguments(arguments: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        quantile_interval([1.0, 2.0, 3.0], **arguments)


def test_quantile_interval_rejects_values_that_are_not_a_vector() -> None:
    with pytest.raises(ValueError, match=r"values has shape \(2, 2\)"):
        quantile_interval([[1.0, 2.0], [3.0, 4.0]], 0.5)
    with pytest.raises(ValueError, match="values could not be read as numbers"):
        quantile_interval(["a", "b"], 0.5)


def test_interval_text_uses_significant_digits() -> None:
    interval = Interval(0.012345, 0.010149, 0.015012, 0.95)
    assert interval.text() == "0.0123 [0.0101, 0.015]"
    assert interval.text(2) == "0.012 [0.01, 0.015]"
    with pytest.raises(ValueError, match="digits = 0"):
        interval.text(0)


# --- proportions --------------------------------------------------------------------------------


def test_proportion_intervals_cover_the_true_proportion() -> None:
    p, trials, draws, nominal = 0.1, 200, 2000, 0.95
    successes = np.random.default_rng(1927).binomial(trials, p, size=draws)
    sd = _binomial_sd(nominal, draws)
    for method in ("wilson", "clopper-pearson"):
        # One interval per possible count, then look the draws up.
        intervals = [proportion_interval(k, trials, method=method) for k in range(trials + 1)]
        covers = np.array([iv.low <= p <= iv.high for iv in intervals])
        coverage = covers[successes].mean()
        if method == "wilson":
            # Wilson's coverage oscillates about nominal with the count's lattice (Brown, Cai &
            # DasGupta 2001): allow 0.02 either side plus 3 binomial sd.
            assert nominal - 0.02 - 3 * sd <= coverage <= nominal + 0.02 + 3 * sd
        else:
            # Clopper-Pearson is conservative: at least nominal, less sampling tolerance.
            assert coverage >= nominal - 3 * sd


@pytest.mark.parametrize("p", [0.003, 0.05, 0.1, 0.37, 0.5, 0.9])
def test_clopper_pearson_exact_coverage_is_at_least_nominal(p: float) -> None:
    trials = 60
    counts = np.arange(trials + 1)
    intervals = [proportion_interval(int(k), trials, method="clopper-pearson") for k in counts]
    covers = np.array([iv.low <= p <= iv.high for iv in intervals])
    assert stats.binom.pmf(counts, trials, p)[covers].sum() >= 0.95 - 1e-9


def test_proportion_interval_estimate_and_edges() -> None:
    for method in ("wilson", "clopper-pearson"):
        middle = proportion_interval(7, 50, method=method)
        assert middle.estimate == 7 / 50
        assert 0.0 < middle.low < middle.estimate < middle.high < 1.0
        assert proportion_interval(0, 50, method=method).low == 0.0
        assert proportion_interval(50, 50, method=method).high == pytest.approx(1.0)
        wider = proportion_interval(7, 50, confidence=0.99, method=method)
        assert wider.low < middle.low and wider.high > middle.high
    nothing = proportion_interval(0, 0)
    assert math.isnan(nothing.estimate)
    assert (nothing.low, nothing.high) == (0.0, 1.0)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ((5, 4), r"successes = 5; an integer in \[0, trials = 4\]"),
        ((-1, 4), r"successes = -1; an integer >= 0"),
        ((1, 2.5), r"trials = 2\.5; an integer"),
        ((1.0, 2), r"successes = 1\.0; an integer"),
        ((True, 2), r"successes = True; an integer"),
    ],
)
def test_proportion_interval_rejects_bad_counts(arguments: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        proportion_interval(*arguments)


def test_proportion_interval_rejects_bad_options() -> None:
    with pytest.raises(ValueError, match=r"method = 'wald'; 'wilson' or 'clopper-pearson'"):
        proportion_interval(1, 2, method="wald")
    with pytest.raises(ValueError, match=r"confidence = 95"):
        proportion_interval(1, 2, confidence=95)


def test_proportion_interval_accepts_numpy_integers() -> None:
    counts = np.array([3, 10])
    assert proportion_interval(counts[0], counts[1]) == proportion_interval(3, 10)


# --- Spearman ranking ---------------------------------------------------------------------------


def _synthetic_study(rows: int = 500) -> tuple[dict[str, np.ndarray], np.ndarray]:
    rng = np.random.default_rng(11)
    parameters = {f"x{j}": rng.uniform(size=rows) for j in range(5)}
    response = np.exp(3 * parameters["x2"]) + rng.normal(scale=0.05, size=rows)
    return parameters, response


def test_spearman_ranking_finds_the_driving_parameter() -> None:
    parameters, response = _synthetic_study()
    parameters["constant"] = np.full(response.size, 2.0)
    ranking = spearman_ranking(parameters, response, resamples=300)
    assert [item.parameter for item in ranking][0] == "x2"
    assert {item.parameter for item in ranking} == {f"x{j}" for j in range(5)}
    top = ranking[0]
    assert top.rho > 0.9 and top.p_value < 1e-6
    assert top.low <= top.rho <= top.high
    assert top.count == response.size
    for item in ranking[1:]:
        assert abs(item.rho) < 0.2
        assert item.low <= item.high
    magnitudes = [abs(item.rho) for item in ranking]
    assert magnitudes == sorted(magnitudes, reverse=True)
    assert spearman_ranking(parameters, response, resamples=300) == ranking


def test_spearman_ranking_uses_rows_where_both_are_finite() -> None:
    parameters, response = _synthetic_study()
    response[:10] = np.nan
    parameters["x2"][10:15] = np.inf
    ranking = {item.parameter: item for item in spearman_ranking(parameters, response, 0.9, 200)}
    assert ranking["x2"].count == response.size - 15
    assert ranking["x0"].count == response.size - 10
    rows = np.isfinite(response) & np.isfinite(parameters["x2"])
    expected = stats.spearmanr(parameters["x2"][rows], response[rows])
    assert ranking["x2"].rho == pytest.approx(expected.statistic)
    assert ranking["x2"].p_value == pytest.approx(expected.pvalue)


def test_spearman_ranking_leaves_out_what_has_no_rank_correlation() -> None:
    response = np.array([1.0, 2.0, np.nan, np.nan, 5.0])
    parameters = {"two_rows": np.array([1.0, 2.0, 3.0, 4.0, np.nan]), "few": np.arange(5.0)}
    assert [item.parameter for item in spearman_ranking(parameters, response)] == ["few"]
    assert spearman_ranking({"x": np.arange(5.0)}, np.ones(5)) == []


def test_spearman_ranking_rejects_mismatched_lengths() -> None:
    parameters, response = _synthetic_study()
    parameters["x3"] = parameters["x3"][:-1]
    with pytest.raises(ValueError, match=r"parameters\['x3'\] has 499 values"):
        spearman_ranking(parameters, response)
    with pytest.raises(ValueError, match="confidence = 2"):
        spearman_ranking({}, response, confidence=2)


# --- Sobol indices ------------------------------------------------------------------------------


def _ishigami_indices(a: float = 7.0, b: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Analytic first- and total-order indices of the Ishigami function (Ishigami & Homma 1990)."""
    v1 = 0.5 * (1 + b * math.pi**4 / 5) ** 2
    v2 = a**2 / 8
    v13 = b**2 * math.pi**8 * (1 / 18 - 1 / 50)
    variance = v1 + v2 + v13
    first = np.array([v1, v2, 0.0]) / variance
    total = np.array([v1 + v13, v2, v13]) / variance
    return first, total


def test_ishigami_analytic_values_match_the_published_ones() -> None:
    first, total = _ishigami_indices()
    np.testing.assert_allclose(first, [0.3139, 0.4424, 0.0], atol=1e-4)
    np.testing.assert_allclose(total, [0.5576, 0.4424, 0.2437], atol=1e-4)


def test_sobol_indices_of_the_ishigami_function() -> None:
    design = saltelli_unit_design(3, 1024, seed=42)
    x = -math.pi + 2 * math.pi * design
    response = np.sin(x[:, 0]) + 7 * np.sin(x[:, 1]) ** 2 + 0.1 * x[:, 2] ** 4 * np.sin(x[:, 0])
    # Six intervals checked together: at 99 % each, all six hold with probability >= 94 %.
    indices = sobol_indices(["x1", "x2", "x3"], response, confidence=0.99, seed=0)
    assert [item.parameter for item in indices] == ["x1", "x2", "x3"]
    by_name = {item.parameter: item for item in indices}
    first, total = _ishigami_indices()
    for j, name in enumerate(["x1", "x2", "x3"]):
        item = by_name[name]
        assert abs(item.first - first[j]) <= item.first_conf
        assert abs(item.total - total[j]) <= item.total_conf
    assert by_name["x2"].first > by_name["x1"].first > by_name["x3"].first
    # SALib alone would treat seed 0 as "unseeded"; the half-widths must still be reproducible.
    assert sobol_indices(["x1", "x2", "x3"], response, confidence=0.99, seed=0) == indices


def test_sobol_indices_reject_bad_responses() -> None:
    with pytest.raises(ValueError, match=r"response has 9 values; a positive multiple of .* = 4"):
        sobol_indices(["a", "b"], np.arange(9.0))
    with pytest.raises(ValueError, match="response has 0 values"):
        sobol_indices(["a", "b"], [])
    response = np.arange(8.0)
    response[3] = np.nan
    with pytest.raises(
        ValueError, match="response has 1 non-finite values; Sobol indices need every run"
    ):
        sobol_indices(["a", "b"], response)
    with pytest.raises(ValueError, match="response is constant"):
        sobol_indices(["a", "b"], np.ones(8))
    with pytest.raises(ValueError, match="names = 'ab'"):
        sobol_indices("ab", np.arange(8.0))
    with pytest.raises(ValueError, match=r"names = \['a', 'a'\]; a non-empty sequence of distinct"):
        sobol_indices(["a", "a"], np.arange(8.0))


def test_saltelli_unit_design_shape_range_and_prefix_stability() -> None:
    small = saltelli_unit_design(3, 64, seed=5)
    large = saltelli_unit_design(3, 128, seed=5)
    assert small.shape == (64 * 5, 3)
    assert large.shape == (128 * 5, 3)
    assert ((large >= 0.0) & (large < 1.0)).all()
    np.testing.assert_array_equal(large[: small.shape[0]], small)
    # Each block is A, A with column j from B (j = 0..d-1), B.
    blocks = large.reshape(128, 5, 3)
    a, b = blocks[:, 0], blocks[:, 4]
    for j in range(3):
        expected = a.copy()
        expected[:, j] = b[:, j]
        np.testing.assert_array_equal(blocks[:, 1 + j], expected)
    assert not np.array_equal(saltelli_unit_design(3, 64, seed=6), small)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ((3, 100, 0), "base_samples = 100; a power of 2 is required"),
        ((3, 0, 0), "base_samples = 0; an integer >= 1"),
        ((0, 64, 0), "dimensions = 0; an integer >= 1"),
        ((20000, 64, 0), r"dimensions = 20000; an integer in \[1, 10600\]"),
        ((3, 64, -2), "seed = -2; an integer >= 0"),
    ],
)
def test_saltelli_unit_design_rejects_bad_arguments(arguments: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        saltelli_unit_design(*arguments)


# --- ECDF and running quantiles -----------------------------------------------------------------


def test_ecdf_is_sorted_and_ends_at_one() -> None:
    values = np.random.default_rng(5).normal(size=50)
    values[[3, 17]] = np.nan
    x, p = ecdf(values)
    assert x.shape == p.shape == (48,)
    assert (np.diff(x) >= 0).all() and (np.diff(p) > 0).all()
    assert p[0] == 1 / 48 and p[-1] == 1.0
    np.testing.assert_array_equal(np.sort(values[np.isfinite(values)]), x)
    empty_x, empty_p = ecdf([np.nan])
    assert empty_x.shape == empty_p.shape == (0,)


def test_running_quantiles_follow_the_sample_order() -> None:
    values = np.random.default_rng(8).lognormal(size=10_000)
    values[::97] = np.nan
    finite = values[np.isfinite(values)]
    qs = [0.05, 0.5, 0.95]
    counts, quantiles = running_quantiles(values, qs, min_count=10)
    assert quantiles.shape == (counts.size, len(qs))
    assert counts.size <= 200
    assert counts[0] == 10 and counts[-1] == finite.size
    assert (np.diff(counts) > 0).all()
    np.testing.assert_array_equal(quantiles[-1], np.quantile(finite, qs))
    middle = counts.size // 2
    np.testing.assert_array_equal(quantiles[middle], np.quantile(finite[: counts[middle]], qs))
    assert (np.diff(quantiles, axis=1) >= 0).all()


def test_running_quantiles_with_too_few_values_and_bad_arguments() -> None:
    counts, quantiles = running_quantiles([1.0, np.nan, 2.0], [0.5], min_count=5)
    assert counts.shape == (0,) and quantiles.shape == (0, 1)
    counts, quantiles = running_quantiles([1.0, 2.0, 3.0], [0.5], min_count=1, points=50)
    np.testing.assert_array_equal(counts, [1, 2, 3])
    np.testing.assert_array_equal(quantiles[:, 0], [1.0, 1.5, 2.0])
    with pytest.raises(ValueError, match=r"qs\[1\] = 1\.2; a number in \[0, 1\]"):
        running_quantiles([1.0], [0.5, 1.2])
    with pytest.raises(ValueError, match=r"qs = \[\]"):
        running_quantiles([1.0], [])
    with pytest.raises(ValueError, match="min_count = 0"):
        running_quantiles([1.0], [0.5], min_count=0)


def test_large_samples_get_a_fisher_interval_that_covers_the_population_rho():
    """Above BOOTSTRAP_ROWS rows the interval is Fisher-z with Bonett & Wright's variance:
    on bivariate normal data (population Spearman 6/pi asin(r/2)) it covers the truth at
    about its nominal rate (seeded, 200 data sets), in milliseconds."""
    from posfb.analysis.uncertainty.statistics import BOOTSTRAP_ROWS

    r, n = 0.6, BOOTSTRAP_ROWS + 500
    truth = 6 / np.pi * np.arcsin(r / 2)
    rng = np.random.default_rng(11)
    covered = 0
    for _ in range(200):
        x = rng.normal(size=n)
        y = r * x + np.sqrt(1 - r * r) * rng.normal(size=n)
        (entry,) = spearman_ranking({"x": x}, y)
        covered += entry.low <= truth <= entry.high
    assert 0.90 <= covered / 200 <= 0.99
