"""The sampled-data verdict at the paper's settings does not hinge on how the
controller's filters are discretised (ZOH is the shipped choice)."""

from __future__ import annotations

import pytest

from helpers.scipy_loop import sampled_radius
from posfb.models.design import compute_design


@pytest.mark.parametrize("method", ["foh", "zoh", "bilinear", "backward_diff"])
def test_paper_alpha_star_is_unstable_at_100_hz_for_every_discretisation(method):
    assert sampled_radius(method, alpha=4.0) > 1.0


@pytest.mark.parametrize("method", ["foh", "zoh", "bilinear"])
def test_second_study_alpha_star_is_stable_at_100_hz(method):
    assert sampled_radius(method, alpha=2.75) < 1.0


def test_the_default_discretisation_is_scipys_zero_order_hold():
    # The design's default filters, against scipy's own ZOH of the same continuous filter.
    assert compute_design().sampled_data_spectral_radius == pytest.approx(
        sampled_radius("zoh", alpha=4.0), rel=1e-9
    )
