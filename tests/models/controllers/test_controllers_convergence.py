"""The paper's central claim on a plant that *is* the nominal model: the proposed
controller drives the tracking error down, below Lin+LC, and what is left at the end
is a sampling effect that shrinks with ``T_s``.

Plant = the frictionless lumped model the controllers use (no quantisation, no
saturation), start at ``q_d(0) + (0.05, -0.05)`` rad at rest, 3 s of the Sec. 4.2
trajectory, ``a = 1/T_s`` (the paper's ``a T_s = 1``). Observed: the final error
halves when ``T_s`` halves (order 1: the voltage is held over each period, a
half-sample lag of the feedforward), about 1.5e-5 rad at 1 ms.
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers.lumped_plant import exact_model_config, simulate
from helpers.slow import heavy

SAMPLE_TIMES = (0.004, 0.002, 0.001)
INITIAL_ERROR = (0.05, -0.05)
DURATION = 3.0


def final_error(kind: str, sample_time: float) -> float:
    """Largest ``|q~_i|`` over the last second."""
    run = simulate(kind, exact_model_config(sample_time), DURATION, INITIAL_ERROR)
    return float(np.abs(run.error[:, run.times >= DURATION - 1.0]).max())


@pytest.fixture(scope="module")
@heavy
def proposed_errors() -> list[float]:
    return [final_error("proposed", T) for T in SAMPLE_TIMES]


def test_proposed_drives_the_error_down_below_lin_lc(proposed_errors):
    assert proposed_errors[-1] < 1e-3 * max(np.abs(INITIAL_ERROR))
    assert proposed_errors[-1] < 0.5 * final_error("lin_lc", SAMPLE_TIMES[-1])


def test_final_error_shrinks_with_the_sample_time_at_first_order(proposed_errors):
    errors = np.array(proposed_errors)
    orders = np.log2(errors[:-1] / errors[1:])
    print(f"final errors {errors.tolist()} at T_s {SAMPLE_TIMES}: observed orders {orders}")
    assert np.all(np.diff(errors) < 0.0)
    assert np.all((orders > 0.8) & (orders < 1.3)), orders
