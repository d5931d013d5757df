"""One place per friction law: the registry of friction-law specs.

A spec holds everything posfb knows about a law: its ``kind``, its ``label``, its
settings class (a member of the scenario's ``plant.friction:`` union: ``!TanhCoulomb``,
``!Stribeck``, ``!LuGre``), its per-joint parameters with their allowed ranges, and the
factory of its C++ block (``models.friction.block``). A new law is one module with a
``SPEC`` and one ``register`` line in ``models.friction.__init__``; nothing else spells
its name.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

from pydrake.systems.primitives import SymbolicVectorSystem

from posfb.models.validation import per_joint, require_finite, shown


@dataclass(frozen=True)
class LawParameter:
    """A per-joint parameter of a law: its settings field ``name``, the smallest allowed
    value ``low`` and whether ``low`` itself is allowed (``closed``)."""

    name: str
    low: float
    closed: bool

    def check(self, key: str, value: object) -> float:
        """``value`` as float if allowed; otherwise one line naming ``key`` and the range."""
        number = require_finite(key, value)
        if number < self.low or (number == self.low and not self.closed):
            relation = ">=" if self.closed else ">"
            raise ValueError(
                f"{key} = {shown(value)}; a finite value {relation} {self.low:g} is required"
            )
        return number


@dataclass(frozen=True)
class FrictionLawSpec:
    """A kind of friction law (module docstring).

    ``system(n)`` builds the law's ``SymbolicVectorSystem`` for ``n`` joints: input the
    joint velocities, output the friction torques ``f`` (N m) for the plant's applied
    generalized force, parameters ``[f_c1..f_cn, v_s, p_1 (n values), p_2 (n values),
    ...]`` in the order of ``parameters``, state ``[friction loss, law states...]`` with
    ``d(loss)/dt = -sum_j f_j v_j``. ``positive_coulomb``: the law needs ``f_c > 0`` at
    every joint (LuGre divides by ``g(v)``)."""

    kind: str
    label: str
    settings: type
    system: Callable[[int], SymbolicVectorSystem]
    parameters: tuple[LawParameter, ...] = ()
    positive_coulomb: bool = False


#: Every registered law, in registration order (the first is the default).
_REGISTRY: dict[str, FrictionLawSpec] = {}

#: Read-only view of the registry.
REGISTRY: Mapping[str, FrictionLawSpec] = MappingProxyType(_REGISTRY)


def register(spec: FrictionLawSpec) -> FrictionLawSpec:
    """Add ``spec``; a kind registered twice is a bug."""
    if spec.kind in _REGISTRY:
        raise ValueError(f"friction law {spec.kind!r} is registered twice")
    _REGISTRY[spec.kind] = spec
    return spec


def tag(settings: object) -> str:
    """The scenario tag of a settings object (``!Stribeck``)."""
    return f"!{type(settings).__name__}"


def law_spec(settings: object) -> FrictionLawSpec:
    """The spec whose settings class ``settings`` is; ``ValueError`` names the laws."""
    for entry in _REGISTRY.values():
        if type(settings) is entry.settings:
            return entry
    allowed = ", ".join(f"!{s.settings.__name__}" for s in _REGISTRY.values())
    raise ValueError(f"friction = {settings!r}; one of {allowed} is required")


def check_law(settings: object) -> FrictionLawSpec:
    """The spec of ``settings`` after checking every given value against its range
    (errors name ``friction.NAME[j]``); the number of values is checked by
    ``law_values``, which knows the joints."""
    spec = law_spec(settings)
    for parameter in spec.parameters:
        values = getattr(settings, parameter.name)
        if not values:
            raise ValueError(
                f"friction.{parameter.name} = []; one value for all joints or one per joint "
                "is required"
            )
        for j, value in enumerate(values):
            parameter.check(f"friction.{parameter.name}[{j}]", value)
    return spec


def law_values(settings: object, joints: int) -> tuple[float, ...]:
    """The law's parameters as its block takes them after ``[f_c, v_s]``: each parameter's
    ``joints`` values in the spec's order (one value is every joint's), checked."""
    spec = check_law(settings)
    values: list[float] = []
    for parameter in spec.parameters:
        name = f"friction.{parameter.name}"
        entries = per_joint(name, list(getattr(settings, parameter.name)), joints)
        values += [parameter.check(f"{name}[{j}]", v) for j, v in enumerate(entries)]
    return tuple(values)
