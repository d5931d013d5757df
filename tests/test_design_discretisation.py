"""The sampled-data verdict at the paper's settings does not hinge on how the
controller's filters are discretised (ZOH is the shipped choice)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from posfb.models.design import ControllerConfig, compute_design
from posfb.models.design.augmented import augmented_system, nonlinear_input_matrix, solve_lqr
from posfb.models.design.closed_loop import sampled_data_closed_loop, spectral_radius
from posfb.models.design.realisation import DiscreteFilter, nonlinear_control_filter
from posfb.models.lumped import TABLE1, LumpedModel

SAMPLE_TIME = 0.01


def _continuous_proposed_filter():
    config = ControllerConfig()
    model = LumpedModel(TABLE1)
    augmented = augmented_system(model.M0(), model.B(), np.asarray(config.lqr.lambdas))
    lqr = solve_lqr(augmented, config.lqr.Q, np.asarray(config.lqr.R))
    nonlinear = config.nonlinear
    return model, nonlinear_control_filter(
        lqr.K1,
        lqr.K2,
        lqr.K3,
        augmented.A_eta,
        nonlinear_input_matrix(lqr.P, model.M0()),
        *(
            np.asarray(m, dtype=float)
            for m in (nonlinear.A_zeta, nonlinear.B_zeta, nonlinear.C_zeta)
        ),
    )


def _radius(method: str, alpha: float) -> float:
    model, continuous = _continuous_proposed_filter()
    if method == "foh":
        discrete = continuous.discretise(SAMPLE_TIME, "foh")
    else:
        A, B, C, D, _ = scipy.signal.cont2discrete(
            (continuous.A, continuous.B, continuous.C, continuous.D), SAMPLE_TIME, method=method
        )
        discrete = DiscreteFilter(A=A, B=B, C=C, D=D, initial=np.zeros_like(B))
    gain = np.hstack([np.eye(2), -alpha * np.eye(2)])
    loop = sampled_data_closed_loop(model.M0(), model.B(), discrete, gain, SAMPLE_TIME)
    return spectral_radius(loop)


@pytest.mark.parametrize("method", ["foh", "zoh", "bilinear", "backward_diff"])
def test_paper_alpha_star_is_unstable_at_100_hz_for_every_discretisation(method):
    assert _radius(method, alpha=4.0) > 1.0


@pytest.mark.parametrize("method", ["foh", "zoh", "bilinear"])
def test_second_study_alpha_star_is_stable_at_100_hz(method):
    assert _radius(method, alpha=2.75) < 1.0


def test_the_default_discretisation_is_scipys_zero_order_hold():
    # The design's default filters, against scipy's own ZOH of the same continuous filter.
    assert compute_design().sampled_data_spectral_radius == pytest.approx(
        _radius("zoh", alpha=4.0), rel=1e-9
    )
