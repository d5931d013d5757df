"""The paper's sampled-data loop at Sec. 4.2's settings rebuilt with scipy: the
continuous filters of Sec. 3 (``models.design``' realisation of Eq. 13 and 19) sampled by
``scipy.signal.cont2discrete`` (or posfb's first-order hold), closed around the nominal
linear part held over ``T_s``; an independent check of the design's radius, whose filters
posfb samples itself."""

from __future__ import annotations

import numpy as np
import scipy.signal

from posfb.models.design import ControllerConfig
from posfb.models.design.augmented import augmented_system, nonlinear_input_matrix, solve_lqr
from posfb.models.design.closed_loop import sampled_data_closed_loop, spectral_radius
from posfb.models.design.realisation import (
    ContinuousFilter,
    DiscreteFilter,
    nonlinear_control_filter,
)
from posfb.models.lumped import TABLE1, LumpedModel

#: The paper's sample time (s).
SAMPLE_TIME = 0.01


def continuous_proposed_filter() -> tuple[LumpedModel, ContinuousFilter]:
    """The paper's arm and its controller's continuous filter at the paper's settings."""
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


def sampled_radius(method: str, alpha: float) -> float:
    """The loop's spectral radius with the filter sampled by ``method`` (``foh``: posfb's;
    otherwise scipy's ``cont2discrete``) and the output gain at ``alpha``."""
    model, continuous = continuous_proposed_filter()
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
