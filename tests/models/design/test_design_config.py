"""Bad design inputs are refused with a message naming the parameter."""

from __future__ import annotations

import numpy as np
import pytest

from posfb.models.controllers import make_controller
from posfb.models.design import (
    ControllerConfig,
    LqrWeights,
    NonlinearTorqueConfig,
    PidGains,
    UncertaintyBounds,
    diagonal,
)
from posfb.models.design.loop_context import LoopContext


@pytest.mark.parametrize(
    ("build", "name"),
    [
        (lambda: LqrWeights(Q1=diagonal((1.0, -1.0, 1.0, 1.0))), "Q1"),
        (
            lambda: LqrWeights(
                Q1=((1.0, 2.0, 0, 0), (0, 1.0, 0, 0), (0, 0, 1.0, 0), (0, 0, 0, 1.0))
            ),
            "Q1",
        ),
        (lambda: LqrWeights(Q2=diagonal((0.001, 0.0))), "Q2"),
        (lambda: LqrWeights(R=diagonal((0.0005, 0.0))), "R"),
        (lambda: LqrWeights(R=diagonal((0.0005, -1.0))), "R"),
        (lambda: LqrWeights(lambdas=(10.0, 0.0)), "lambdas[1]"),
        (lambda: LqrWeights(lambdas=(-10.0, 10.0)), "lambdas[0]"),
        (lambda: LqrWeights(Q1=diagonal((1.0, 1.0, 1.0))), "Q1"),
        (lambda: LqrWeights(R=((1.0, 0.0),)), "R"),
        (lambda: LqrWeights(lambdas=(10.0, 10.0, 10.0)), "lambdas"),
        (lambda: NonlinearTorqueConfig(alpha_star=0.0), "alpha_star"),
        (lambda: NonlinearTorqueConfig(alpha_star=-4.0), "alpha_star"),
        (lambda: NonlinearTorqueConfig(K_alpha=0.0), "K_alpha"),
        (lambda: NonlinearTorqueConfig(alpha0=5.0), "alpha0"),
        (lambda: NonlinearTorqueConfig(alpha0=-1.0), "alpha0"),
        (lambda: NonlinearTorqueConfig(filter_a=0.0), "filter_a"),
        (lambda: NonlinearTorqueConfig(A_zeta=diagonal((-10.0, -10.0, -10.0))), "A_zeta"),
        (lambda: NonlinearTorqueConfig(C_zeta=((1.0, 0.0),)), "C_zeta"),
        (lambda: UncertaintyBounds(relative=-0.1), "relative"),
        (lambda: UncertaintyBounds(delta_G=float("nan")), "delta_G"),
        (lambda: PidGains(Kp=(800.0, 0.0)), "Kp[1]"),
        (lambda: PidGains(KI=(1.0,)), "KI"),
        (lambda: ControllerConfig(LoopContext(sample_time=0.0)), "sample_time"),
        (lambda: ControllerConfig(LoopContext(sample_time=-0.01)), "sample_time"),
        (lambda: ControllerConfig(LoopContext(sample_time=float("inf"))), "sample_time"),
    ],
)
def test_bad_parameter_is_refused_by_name(build, name):
    with pytest.raises(ValueError, match=name.replace("[", r"\[").replace("]", r"\]")):
        build()


def test_filter_pole_at_or_below_ln2_over_Ts_is_refused_by_the_proposed_controller():
    """``a = 100`` at 200 Hz: ``abar = 0.61 >= 1/2``. Only the controller that uses the
    bounds refuses it."""
    config = ControllerConfig(LoopContext(sample_time=0.005))
    with pytest.raises(ValueError, match="filter_a = 100 is not above ln 2 / T_s"):
        make_controller("proposed", config)
    make_controller("lin_lc", config)
    make_controller("pid", config)
    boundary = NonlinearTorqueConfig(filter_a=0.6931471805599453 / 0.005)
    with pytest.raises(ValueError, match="filter_a"):
        make_controller(
            "proposed", ControllerConfig(LoopContext(sample_time=0.005), nonlinear=boundary)
        )


def test_non_spr_filter_is_refused_by_the_proposed_controller():
    config = ControllerConfig(nonlinear=NonlinearTorqueConfig(B_zeta=diagonal((-10.0, 10.0))))
    with pytest.raises(ValueError, match="A_zeta, B_zeta, C_zeta: H\\(s\\) is not strictly"):
        make_controller("proposed", config)
    make_controller("lin_lc", config)


def test_unknown_controller_kind_is_refused():
    with pytest.raises(ValueError, match="kind = 'mpc'"):
        make_controller("mpc")


def test_configs_built_from_arrays_are_hashable_and_equal_to_the_defaults():
    """``make_controller`` caches designs by config, so configs must hash by value."""
    weights = LqrWeights(Q1=np.diag([32000.0, 12000.0, 10.0, 10.0]), lambdas=np.array([10, 10]))
    config = ControllerConfig(lqr=weights, pid=PidGains(Kp=np.array([800, 500])))
    assert config == ControllerConfig()
    assert hash(config) == hash(ControllerConfig())
