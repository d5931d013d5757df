"""One place per controller: the registry of controller specs.

A spec holds everything posfb knows about a kind of controller: its ``kind`` (the
scenario's name for it), its ``label`` and plot ``style`` (legends, tables; a
``design_label`` where the label depends on the settings, ``label_for``), its
settings class (a member of the scenario's ``controller:`` union: ``!Proposed``,
``!LinLc``, ``!Pid``, ...), the design checks that concern it, what it refuses, and its
``law``: the update written once (``models.laws``), which the simulation evaluates
(``base.LawController``), ``posfb codegen`` prints as C, and from which the linear
feedback that margins, the map and tuning close is derived (``linearise``: the law on
the nominal linear part, Eq. 2 with ``h = 0``, the feed-forward terms cancelled by the
reference). A plug-in's spec has a ``factory`` too (it names the internals its instance
declares); a user's ``!Python`` plug-in written as a step has no law to give, and its
spec's ``law`` refuses it in one line. A controller whose linear feedback the Sec. 3
design already holds in closed form (Lin+LC, the paper's controller) names that loop,
``design_loop`` (a ``models.design.DESIGNED_LOOPS`` name): its feedback is read from the
design instead of derived (the same filter to round-off,
``tests/models/controllers/test_linearise.py``; a tuner asks for thousands), and the loop's
radius is the controller's in the design report, the stability map and a study's rho.
``tuning`` says what ``posfb tune`` may vary (``tunable``). Plots, exports, tables,
reports, Monte Carlo, replay and tuning read the spec. A new controller is one module with
a ``SPEC``, registered by one line in ``models.controllers.__init__`` or by the module
itself (``register``) before posfb reads a scenario
(``tests/models/controllers/test_new_controller.py``). A user's own controller
(``!Python {file, class}``) gets a spec made from its class (``UserPlugin.spec``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from posfb.models.controllers.base import SampledController
    from posfb.models.controllers.tunable import Tuning
    from posfb.models.design import ControllerConfig
    from posfb.models.laws.law import Law
    from posfb.models.laws.nominal import SymbolicModel


@dataclass(frozen=True)
class ControllerBuild:
    """What a law or factory builds a controller from: the design inputs (nominal model,
    ``T_s``, the Sec. 3 design's settings), the voltage limit per joint (V), the settings
    object of the scenario's ``controller:`` entry (``None`` for the flat form) and
    whether the law is wanted on the nominal model's ``linear_part`` (``linearise``)."""

    design: ControllerConfig
    voltage_limit: tuple[float, ...]
    settings: object | None = None
    linear_part: bool = False

    def symbolic_model(self) -> SymbolicModel:
        """The nominal model a law is written on (``models.laws.nominal``): the design's,
        or its linear part."""
        from posfb.models.laws.nominal import symbolic_model

        return symbolic_model(self.design.nominal, self.linear_part)


@dataclass(frozen=True)
class ControllerSpec:
    """A kind of controller (module docstring)."""

    kind: str
    label: str
    law: Callable[[ControllerBuild], Law] | None = None
    factory: Callable[[ControllerBuild], SampledController] | None = None
    style: Mapping[str, object] = field(default_factory=dict)
    settings: type | None = None
    checks: tuple[str, ...] = ()
    require: Callable[[ControllerConfig], None] | None = None
    internals: Callable[[int], tuple[str, ...]] | None = None
    internal_units: Mapping[str, str] = field(default_factory=dict)
    design_label: Callable[[ControllerConfig], str] | None = None
    design_loop: str | None = None
    tuning: Tuning | None = None

    def __post_init__(self) -> None:
        if self.law is None and self.factory is None:
            raise ValueError(f"controller {self.kind!r}: a spec needs a law or a factory")
        if self.design_loop is not None:
            from posfb.models.design import DESIGNED_LOOPS

            if self.design_loop not in DESIGNED_LOOPS:
                raise ValueError(
                    f"controller {self.kind!r}: design_loop = {self.design_loop!r}; one of "
                    f"{', '.join(DESIGNED_LOOPS)} is required"
                )

    def build(self, inputs: ControllerBuild) -> SampledController:
        """The controller's Drake system: ``factory(inputs)``, or the law's
        ``LawController`` with the internals' names (``internals``) and their unit
        columns (``internal_units``)."""
        if self.factory is not None:
            return self.factory(inputs)
        from posfb.models.controllers.base import LawController, unit_columns

        law = self.law(inputs)
        names = self.internals(law.joints) if self.internals is not None else ()
        columns = unit_columns(names, self.internal_units) if self.internal_units else names
        return LawController(law, inputs.design.sample_time, names, columns)

    def label_for(self, design: ControllerConfig) -> str:
        """The label of this controller built from ``design``: ``design_label(design)``
        where the spec has one (e.g. "(paper)" only for the paper's settings), else
        ``label``."""
        return self.label if self.design_label is None else self.design_label(design)

    def refuse(self, design: ControllerConfig) -> None:
        """Raise ``ValueError`` (one line) if the controller refuses ``design``."""
        if self.require is not None:
            self.require(design)


#: Every registered kind, in registration order (the order of tables and legends).
_REGISTRY: dict[str, ControllerSpec] = {}

#: Read-only view of the registry.
REGISTRY: Mapping[str, ControllerSpec] = MappingProxyType(_REGISTRY)

#: Line colours given to controllers in registration order (matplotlib's cycle); a figure
#: gives a line without a colour of its own the first one no registered kind holds
#: (``analysis.plots``).
PALETTE = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
           "tab:pink", "tab:olive", "tab:cyan")  # fmt: skip


def register(spec: ControllerSpec) -> ControllerSpec:
    """Add ``spec``; a kind registered twice is a bug."""
    if spec.kind in _REGISTRY:
        raise ValueError(f"controller kind {spec.kind!r} is registered twice")
    if "color" not in spec.style:
        colour = PALETTE[len(_REGISTRY) % len(PALETTE)]
        spec = replace(spec, style={**spec.style, "color": colour})
    _REGISTRY[spec.kind] = spec
    return spec


def registered_colours() -> tuple[str, ...]:
    """The line colour of every registered kind, in registration order."""
    return tuple(str(entry.style["color"]) for entry in _REGISTRY.values())


def kinds() -> tuple[str, ...]:
    """The registered kinds, in registration order."""
    return tuple(_REGISTRY)


def spec(kind: str) -> ControllerSpec:
    """The spec of registered ``kind``; ``ValueError`` names the allowed kinds."""
    try:
        return _REGISTRY[kind]
    except KeyError:
        raise ValueError(
            f"controller.kind = {kind!r}; one of {', '.join(_REGISTRY)} is required "
            "(or a !Python {file, class} entry for your own controller)"
        ) from None


def settings_kind(settings: object) -> str | None:
    """The registered kind whose settings class ``settings`` is, exactly (``Proposed``
    extends ``LinLc``; ``None``: none)."""
    for entry in _REGISTRY.values():
        if entry.settings is not None and type(settings) is entry.settings:
            return entry.kind
    return None
