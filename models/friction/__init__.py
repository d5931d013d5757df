"""Friction laws: one module per law behind one block (``models.friction.block``),
picked by the scenario's ``plant.friction`` (one tagged entry):

* ``!TanhCoulomb {}`` (the default, ``tanh_coulomb``): ``f = -f_c tanh(v / v_s)``.
* ``!Stribeck {static_ratio, stribeck_velocity}`` (``stribeck``).
* ``!LuGre {static_ratio, stribeck_velocity, sigma0, sigma1}`` (``lugre``).

Each module's docstring gives its equations and source. A new law is one module with a
``SPEC`` and one ``register`` line below.
"""

from __future__ import annotations

from posfb.models.friction import lugre, stribeck, tanh_coulomb
from posfb.models.friction.registry import (
    REGISTRY,
    FrictionLawSpec,
    check_law,
    law_spec,
    law_values,
    register,
    tag,
)

register(tanh_coulomb.SPEC)
register(stribeck.SPEC)
register(lugre.SPEC)

#: The default law's settings class (the first registered).
DEFAULT_LAW = next(iter(REGISTRY.values())).settings

#: The settings classes, in registration order (the scenario's ``plant.friction`` union).
LAW_SETTINGS = tuple(spec.settings for spec in REGISTRY.values())

__all__ = [
    "DEFAULT_LAW",
    "LAW_SETTINGS",
    "REGISTRY",
    "FrictionLawSpec",
    "check_law",
    "law_spec",
    "law_values",
    "register",
    "tag",
]
