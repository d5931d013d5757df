"""``analysis.metrics``: the paper's RMS and the run metrics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from posfb.analysis.metrics import RunMetrics, compute_metrics, rms, run_metrics
from posfb.diagrams.resolve import load_scenario, run_scenario


def _paper_rms(samples: list[float]) -> float:
    """RMS(x) = sqrt((1/N0) sum_{k=1}^{N0} |x(k T_s)|^2), written out as in Sec. 4.2."""
    total = 0.0
    for k in range(1, len(samples) + 1):
        total += abs(samples[k - 1]) ** 2
    return math.sqrt(total / len(samples))


def test_rms_matches_the_paper_formula_on_a_hand_made_signal():
    T_s = 0.01
    samples = [0.003 * math.sin(2.0 * math.pi * 0.5 * k * T_s) + 0.001 for k in range(1, 2001)]
    assert rms(np.array(samples)) == pytest.approx(_paper_rms(samples), rel=1e-12)
    # a constant and a full-period sine have closed-form RMS values
    assert rms(np.full(7, -2.5)) == pytest.approx(2.5)
    assert rms(np.sin(2 * np.pi * np.arange(1, 101) / 100)) == pytest.approx(1 / math.sqrt(2))


def test_rms_of_a_matrix_is_per_column():
    x = np.array([[3.0, 1.0], [-4.0, 1.0]])
    np.testing.assert_allclose(rms(x), [math.sqrt(12.5), 1.0])


def test_rms_refuses_an_empty_signal():
    with pytest.raises(ValueError, match="at least one sample"):
        rms(np.array([]))


def test_compute_metrics_counts_saturated_samples_and_uses_applied_voltage():
    error = np.array([[0.001, -0.002], [0.0, 0.004]])
    commanded = np.array([[30.0, 0.0], [1.0, -2.0]])
    applied = np.clip(commanded, -24.0, 24.0)
    measured = np.array([[0.0, -0.003], [0.0, 0.004]])
    metrics = compute_metrics(error, applied, commanded, 24.0, 0.5, measured)
    assert metrics.saturated_fraction == 0.5
    assert metrics.rms_u[0] == pytest.approx(math.sqrt((24.0**2 + 1.0) / 2))
    assert metrics.max_abs_q_err == 0.004
    assert metrics.rms_q_measured == pytest.approx((0.0, 0.005 / math.sqrt(2)))  # 3-4-5
    data = metrics.as_dict()
    assert set(data) == {
        "rms_q", "rms_u", "max_abs_q_err", "saturated_fraction", "wall_time_s", "rms_q_measured"
    }  # fmt: skip
    assert isinstance(data["rms_q"], list) and len(data["rms_q"]) == 2
    assert isinstance(metrics, RunMetrics)


def _run(*settings: str):
    """A 1 s Lin+LC run of the default scenario with ``settings``."""
    return run_scenario(
        load_scenario(None, ["timing.duration=1", "controller.kind=lin_lc", *settings])
    )


def test_the_measured_error_of_an_ideal_encoder_is_the_true_error():
    result = _run("sensor.encoder_counts=0")
    metrics = run_metrics(result)
    assert metrics.rms_q_measured == metrics.rms_q


@pytest.mark.parametrize("counts", [4096, 20000])
def test_a_quantised_encoder_moves_the_measured_rms_by_at_most_half_a_count(counts):
    """|RMS(a) - RMS(b)| <= RMS(a - b) <= max |a - b| <= Delta / 2 (Minkowski, and the
    encoder rounds to the nearest count): a bound, not a measured number."""
    result = _run(f"sensor.encoder_counts={counts}")
    metrics = run_metrics(result)
    half_count = math.pi / counts
    for true, measured in zip(metrics.rms_q, metrics.rms_q_measured, strict=True):
        assert abs(measured - true) <= half_count * (1 + 1e-9)
    assert metrics.rms_q_measured != metrics.rms_q  # the quantisation does show
