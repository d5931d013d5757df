"""The three controllers as discrete Drake systems, and a factory.

Every controller of an ``n``-joint nominal model has inputs ``q_measured`` (n) and
``desired`` (3n) and outputs ``voltage`` (n) and ``internals`` (columns named by
``internals_names(kind, n)``); see
``models.controllers.base`` for the timing.
"""

from __future__ import annotations

from functools import lru_cache

from posfb.models.controllers.base import SampledController
from posfb.models.controllers.lin_lc import LinLcController, lin_lc_internals
from posfb.models.controllers.pid import PidController, pid_internals
from posfb.models.controllers.proposed import ProposedController, proposed_internals
from posfb.models.design import ControllerConfig, Design, compute_design

#: The controllers of Sec. 4.2: computed torque + PID, Lin+LC, the paper's.
CONTROLLER_KINDS = ("pid", "lin_lc", "proposed")

_INTERNALS = {"pid": pid_internals, "lin_lc": lin_lc_internals, "proposed": proposed_internals}


def internals_names(kind: str, joints: int) -> tuple[str, ...]:
    """Column names of controller ``kind``'s ``internals`` output for ``joints`` joints."""
    return _INTERNALS[kind](joints)


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
    "ControllerConfig",
    "Design",
    "LinLcController",
    "PidController",
    "ProposedController",
    "SampledController",
    "RELEVANT_CHECKS",
    "cached_design",
    "failed_checks",
    "internals_names",
    "make_controller",
    "require_design",
]
