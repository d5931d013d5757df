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
from posfb.models.controllers.base import LawController, SampledController
from posfb.models.controllers.linearise import law_feedback
from posfb.models.controllers.plugin import Controller, ControllerSetup, PluginError, UserPlugin
from posfb.models.controllers.registry import (
    REGISTRY,
    ControllerBuild,
    ControllerSpec,
    kinds,
    register,
    spec,
)
from posfb.models.design import (
    DESIGNED_LOOPS,
    ControllerConfig,
    Design,
    cached_design,
    designed_feedback,
)
from posfb.models.design.loop_context import LoopContext
from posfb.models.design.realisation import DiscreteFilter
from posfb.models.laws.law import Law

for _module in (pid, lin_lc, proposed, pd_gravity, adrc):
    register(_module.SPEC)

#: The controllers of the paper's Sec. 4.2 (Tables 3-4): computed torque + PID,
#: Lin+LC, the paper's.
PAPER_CONTROLLERS = (pid.SPEC.kind, lin_lc.SPEC.kind, proposed.SPEC.kind)

#: The paper's controller (Eq. 3): a scenario's default, and the challenger of a study's
#: comparison with the paper's baseline.
PAPER_CONTROLLER = proposed.SPEC.kind

#: The paper's baseline (computed torque + PID, Eq. 26).
PAPER_BASELINE = pid.SPEC.kind


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
    holds Lin+LC's inputs, so it also answers for Lin+LC's sampled loop); none for a
    user's plug-in."""
    if kind not in REGISTRY or REGISTRY[kind].settings is None:
        return ()
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


def kind_of(settings: type) -> str:
    """The registered kind whose scenario entry is a ``settings`` object (its spec's
    ``settings`` class): how a caller that builds an entry names it."""
    for kind, entry in REGISTRY.items():
        if entry.settings is settings:
            return kind
    raise ValueError(f"settings class {settings.__name__}: no registered controller reads it")


def loop_kinds() -> dict[str, str]:
    """The kind each designed loop (``models.design.DESIGNED_LOOPS``) belongs to
    (``ControllerSpec.design_loop``; the first registered where two name one), in the
    order of ``DESIGNED_LOOPS``."""
    found: dict[str, str] = {}
    for kind, entry in REGISTRY.items():
        if entry.design_loop is not None:
            found.setdefault(entry.design_loop, kind)
    return {loop: found[loop] for loop in DESIGNED_LOOPS if loop in found}


def linear_kinds() -> tuple[str, ...]:
    """The registered kinds with a linear feedback: those written as a law."""
    return tuple(kind for kind, entry in REGISTRY.items() if entry.law is not None)


def controller_law(
    kind: str,
    config: ControllerConfig,
    *,
    voltage_limit: tuple[float, ...] = (),
    settings: object | None = None,
    linear_part: bool = False,
) -> Law:
    """Controller ``kind``'s update as a ``models.laws`` law (``ControllerSpec.law``), for
    the same inputs as ``make_controller`` (on the nominal model's linear part with
    ``linear_part``); ``ValueError`` (one line) for a controller written as a step or a
    design it refuses."""
    entry = controller_spec(kind, settings)
    if entry.law is None:
        raise ValueError(f"controller {kind!r} is written as a step (no law): posfb cannot "
                         "linearise it or print it as C")  # fmt: skip
    entry.refuse(config)
    return entry.law(ControllerBuild(config, tuple(voltage_limit), settings, linear_part))


def linear_feedback(
    kind: str,
    config: ControllerConfig,
    *,
    settings: object | None = None,
) -> DiscreteFilter:
    """Controller ``kind``'s feedback linearised on the nominal linear part: the filter from
    ``q~`` to the feedback voltage derived from its law (``linearise.law_feedback``), with
    no voltage limit (a linear loop does not saturate), or the design's closed form of it
    (``ControllerSpec.design_loop``); ``ValueError`` (one line) for a controller written as a
    step or a design it refuses."""
    entry = controller_spec(kind, settings)
    if entry.design_loop is not None:
        entry.refuse(config)
        return designed_feedback(cached_design(config), entry.design_loop)
    return law_feedback(controller_law(kind, config, settings=settings, linear_part=True))


def entry_build(entry: object, context: LoopContext) -> ControllerBuild:
    """What a scenario's settings ``entry`` builds its controller from in ``context``: an
    entry that gives design inputs (``config``: the paper's three,
    ``models.design.settings``) gives them and no settings; any other entry is the
    settings of a controller without a Sec. 3 design (``ControllerConfig.without_design``)."""
    if hasattr(entry, "config"):
        return ControllerBuild(entry.config(context), ())
    return ControllerBuild(ControllerConfig.without_design(context), (), entry)


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
    return controller_spec(kind, settings).build(build)


__all__ = [
    "PAPER_BASELINE",
    "PAPER_CONTROLLER",
    "PAPER_CONTROLLERS",
    "REGISTRY",
    "Controller",
    "ControllerBuild",
    "ControllerConfig",
    "ControllerSetup",
    "ControllerSpec",
    "Design",
    "LawController",
    "PluginError",
    "SampledController",
    "UserPlugin",
    "cached_design",
    "design_checks",
    "entry_build",
    "controller_spec",
    "failed_checks",
    "internals_names",
    "kind_of",
    "kinds",
    "controller_law",
    "linear_feedback",
    "linear_kinds",
    "loop_kinds",
    "spec",
    "make_controller",
    "require_design",
]
