"""The controllers as discrete Drake systems, their registry, and a factory.

Every controller of an ``n``-joint nominal model has inputs ``q_measured`` (n) and
``desired`` (3n) and outputs ``voltage`` (n) and ``internals``; see
``models.controllers.base`` for the timing, ``models.controllers.registry`` for the
specs (one per kind: label, style, checks, factory) and ``models.controllers.plugin``
for the public ``Controller`` contract that the PD + gravity and ADRC baselines, and a
user's own controller, are written against.

Each controller module has a ``SPEC``; the loop below registers them, in the order of
tables and legends.
"""

from __future__ import annotations

from dataclasses import fields

from posfb.models.controllers import adrc, lin_lc, pd_gravity, pid, proposed
from posfb.models.controllers.base import SampledController
from posfb.models.controllers.lin_lc import LinLcController
from posfb.models.controllers.pid import PidController
from posfb.models.controllers.plugin import Controller, ControllerSetup, PluginError, UserPlugin
from posfb.models.controllers.proposed import ProposedController
from posfb.models.controllers.registry import (
    REGISTRY,
    ControllerBuild,
    ControllerSpec,
    kinds,
    register,
    spec,
)
from posfb.models.design import ControllerConfig, Design, cached_design
from posfb.models.design.realisation import DiscreteFilter
from posfb.models.laws.law import Law

for _module in (pid, lin_lc, proposed, pd_gravity, adrc):
    register(_module.SPEC)

#: The controllers of the paper's Sec. 4.2 (Tables 3-4): computed torque + PID,
#: Lin+LC, the paper's.
PAPER_CONTROLLERS = (pid.SPEC.kind, lin_lc.SPEC.kind, proposed.SPEC.kind)


def internals_names(kind: str, joints: int) -> tuple[str, ...]:
    """Names of registered controller ``kind``'s ``internals`` output for ``joints`` joints
    (a plug-in's names are known once it is built: ``SampledController.internals_names``)."""
    entry = spec(kind)
    if entry.internals is None:
        raise ValueError(f"controller {kind!r} names its internals when it is built")
    return entry.internals(joints)


def design_checks(kind: str) -> tuple[str, ...]:
    """Every design check that the entry of controller ``kind`` determines: its own, and
    those of each kind whose settings it holds all of (the paper's controller's entry
    holds Lin+LC's inputs, so it also answers for Lin+LC's sampled loop)."""
    own = {f.name for f in fields(spec(kind).settings)}
    found: list[str] = []
    for entry in REGISTRY.values():
        if {f.name for f in fields(entry.settings)} <= own:
            found += [name for name in entry.checks if name not in found]
    return tuple(found)


def failed_checks(kind: str, config: ControllerConfig) -> list[str]:
    """The details of the failed design checks that concern controller ``kind``."""
    relevant = spec(kind).checks if kind in REGISTRY else ()
    if not relevant:
        return []
    return [c.detail for c in cached_design(config).checks if c.name in relevant and not c.passed]


def require_design(kind: str, config: ControllerConfig) -> None:
    """Raise ``ValueError`` (one line) if controller ``kind`` refuses ``config``'s design
    (``make_controller`` would refuse it the same way)."""
    if kind in REGISTRY:
        spec(kind).refuse(config)


def controller_spec(kind: str, settings: object | None = None) -> ControllerSpec:
    """The spec of a scenario's controller: a user plug-in's own (``settings``), or the
    registered ``kind``'s."""
    return settings.spec if isinstance(settings, UserPlugin) else spec(kind)


def linear_kinds() -> tuple[str, ...]:
    """The registered kinds with a linear feedback (``ControllerSpec.linear``)."""
    return tuple(kind for kind, entry in REGISTRY.items() if entry.linear is not None)


def _built(
    part: str,
    missing: str,
    kind: str,
    config: ControllerConfig,
    voltage_limit: tuple[float, ...],
    settings: object | None,
) -> object:
    """``ControllerSpec.<part>`` of controller ``kind`` applied to ``make_controller``'s
    inputs; ``ValueError`` with ``missing`` (one line) for a controller without one, or
    the design's own refusal."""
    entry = controller_spec(kind, settings)
    build = getattr(entry, part)
    if build is None:
        raise ValueError(f"controller {kind!r} {missing}")
    entry.refuse(config)
    return build(ControllerBuild(config, tuple(voltage_limit), settings))


def linear_feedback(
    kind: str,
    config: ControllerConfig,
    *,
    voltage_limit: tuple[float, ...] = (),
    settings: object | None = None,
) -> DiscreteFilter:
    """Controller ``kind``'s feedback linearised on the nominal linear part
    (``ControllerSpec.linear``: a filter from ``q~`` to the feedback voltage) for the same
    inputs as ``make_controller``; ``ValueError`` (one line) for a controller without one
    (a plug-in of the user's) or a design it refuses."""
    missing = ("has no linear design (posfb cannot linearise a plug-in's step); the margins "
               f"are computed for {', '.join(linear_kinds())}")  # fmt: skip
    return _built("linear", missing, kind, config, voltage_limit, settings)


def controller_law(
    kind: str,
    config: ControllerConfig,
    *,
    voltage_limit: tuple[float, ...] = (),
    settings: object | None = None,
) -> Law:
    """Controller ``kind``'s update as a ``models.laws`` law (``ControllerSpec.law``), for
    the same inputs as ``make_controller``; ``ValueError`` (one line) for a controller
    without one."""
    having = ", ".join(k for k, e in REGISTRY.items() if e.law is not None)
    missing = f"has no generated code yet (posfb codegen covers {having})"
    return _built("law", missing, kind, config, voltage_limit, settings)


def make_controller(
    kind: str,
    config: ControllerConfig | None = None,
    *,
    voltage_limit: tuple[float, ...] = (),
    settings: object | None = None,
) -> SampledController:
    """The controller ``kind`` for ``config`` (default: the paper's Sec. 4.2 settings),
    the ``voltage_limit`` per joint (V; plug-ins read it) and the scenario entry's
    ``settings`` (a plug-in kind's settings object, or a user plug-in,
    ``models.controllers.plugin.UserPlugin``)."""
    config = ControllerConfig() if config is None else config
    build = ControllerBuild(config, tuple(voltage_limit), settings)
    return controller_spec(kind, settings).factory(build)


__all__ = [
    "PAPER_CONTROLLERS",
    "REGISTRY",
    "Controller",
    "ControllerBuild",
    "ControllerConfig",
    "ControllerSetup",
    "ControllerSpec",
    "Design",
    "LinLcController",
    "PidController",
    "PluginError",
    "ProposedController",
    "SampledController",
    "UserPlugin",
    "cached_design",
    "design_checks",
    "controller_spec",
    "failed_checks",
    "internals_names",
    "kinds",
    "controller_law",
    "linear_feedback",
    "linear_kinds",
    "spec",
    "make_controller",
    "require_design",
]
