"""The three controllers as discrete Drake systems, and a factory.

Every controller has inputs ``q_measured`` (2) and ``desired`` (6) and outputs
``voltage`` (2) and ``internals`` (columns named by ``INTERNALS[kind]``); see
``models.controllers.base`` for the timing.
"""

from __future__ import annotations

from functools import lru_cache

from posfb.models.controllers.base import SampledController
from posfb.models.controllers.lin_lc import LIN_LC_INTERNALS, LinLcController
from posfb.models.controllers.pid import PID_INTERNALS, PidController
from posfb.models.controllers.proposed import PROPOSED_INTERNALS, ProposedController
from posfb.models.design import ControllerConfig, Design, compute_design

#: The controllers of Sec. 4.2: computed torque + PID, Lin+LC, the paper's.
CONTROLLER_KINDS = ("pid", "lin_lc", "proposed")

#: Column names of each kind's ``internals`` output.
INTERNALS = {"pid": PID_INTERNALS, "lin_lc": LIN_LC_INTERNALS, "proposed": PROPOSED_INTERNALS}

#: Designs are pure functions of the (frozen, hashable) config: reuse them.
cached_design = lru_cache(maxsize=32)(compute_design)


#: The design checks (``models.design.synthesis``) that concern each controller: PID has
#: no Sec. 3 design; Lin+LC uses the linear torque only.
RELEVANT_CHECKS = {
    "pid": (),
    "lin_lc": ("riccati", "lc_filter", "sampled_data_lin_lc"),
    "proposed": (
        "riccati", "lc_filter", "spr", "bound_filter", "continuous_with_nc", "sampled_data",
    ),
}  # fmt: skip


def failed_checks(kind: str, config: ControllerConfig) -> list[str]:
    """The details of the failed design checks that concern controller ``kind``."""
    relevant = RELEVANT_CHECKS[kind]
    return [c.detail for c in cached_design(config).checks if c.name in relevant and not c.passed]


def require_design(kind: str, config: ControllerConfig) -> None:
    """Raise ``ValueError`` (one line) if controller ``kind`` refuses ``config``'s design
    (``make_controller`` would refuse it the same way)."""
    if kind == "lin_lc":
        cached_design(config).require_linear_torque()
    elif kind == "proposed":
        cached_design(config).require_nonlinear_torque()


def make_controller(kind: str, config: ControllerConfig | None = None) -> SampledController:
    """The controller ``kind`` (one of ``CONTROLLER_KINDS``) for ``config`` (default: the
    paper's Sec. 4.2 settings)."""
    config = ControllerConfig() if config is None else config
    if kind == "pid":
        return PidController(config.nominal, config.pid, config.sample_time)
    if kind == "lin_lc":
        return LinLcController(cached_design(config))
    if kind == "proposed":
        return ProposedController(cached_design(config))
    raise ValueError(f"kind = {kind!r} is not a controller; one of {CONTROLLER_KINDS} is required")


__all__ = [
    "CONTROLLER_KINDS",
    "INTERNALS",
    "LIN_LC_INTERNALS",
    "PID_INTERNALS",
    "PROPOSED_INTERNALS",
    "ControllerConfig",
    "Design",
    "LinLcController",
    "PidController",
    "ProposedController",
    "SampledController",
    "RELEVANT_CHECKS",
    "cached_design",
    "failed_checks",
    "make_controller",
    "require_design",
]
