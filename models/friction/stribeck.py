"""Coulomb friction with the Stribeck effect (``!Stribeck {static_ratio,
stribeck_velocity}``), the static part of Armstrong-Hélouvry, Dupont and Canudas de Wit
(1994), "A survey of models, analysis tools and compensation methods for the control of
machines with friction", Automatica 30(7), 1083-1138 (the exponential Stribeck curve
with exponent 2, their Eq. 4 family)::

    g_j(v)  = f_cj + (f_sj - f_cj) exp(-(v / v_stj)^2),   f_sj = static_ratio_j f_cj
    f_j     = -g_j(v_j) tanh(v_j / v_s)

``f_cj`` is joint j's Coulomb level (``ArmParameters.coulomb``), ``static_ratio >= 1``
sets the static (breakaway) level ``f_s``, ``stribeck_velocity`` ``v_st > 0`` (rad/s)
how fast the level falls from ``f_s`` to ``f_c``. The sign function is smoothed by the
same ``tanh(v / v_s)`` as the default law (``plant.friction_velocity``), so the law is
continuous and ``static_ratio = 1`` gives ``!TanhCoulomb`` exactly; for ``|v| >> v_st``
it tends to ``!TanhCoulomb`` too. Viscous friction stays the URDF's joint damping
(MultibodyPlant), not repeated here.
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

from dataclasses import dataclass, field

from pydrake.symbolic import Expression, Variable, exp, tanh
from pydrake.systems.primitives import SymbolicVectorSystem

from posfb.models.friction.common import friction_system, joint_variables
from posfb.models.friction.registry import FrictionLawSpec, LawParameter


@dataclass
class Stribeck:
    """Stribeck curve (``models.friction.stribeck``): per joint (one value = every
    joint), ``static_ratio = f_s / f_c`` (>= 1) and ``stribeck_velocity`` (rad/s, > 0)."""

    static_ratio: list[float] = field(default_factory=lambda: [1.5])
    stribeck_velocity: list[float] = field(default_factory=lambda: [0.05])


def stribeck_level(level: Expression, ratio: Expression, v_st: Expression, v: Expression):
    """``g(v) = f_c + (f_s - f_c) exp(-(v / v_st)^2)`` with ``f_s = ratio f_c``."""
    scaled = v / v_st
    return level + (ratio * level - level) * exp(-(scaled * scaled))


def stribeck_system(joints: int) -> SymbolicVectorSystem:
    """``-g(v) tanh(v / v_s)`` per joint; parameters ``[f_c, v_s, static_ratio,
    stribeck_velocity]``; state: the friction loss (J)."""
    v = joint_variables("v", joints)
    levels = joint_variables("fc", joints)
    v_s = Variable("v_s")
    ratio = joint_variables("static_ratio", joints)
    v_st = joint_variables("stribeck_velocity", joints)
    force = [
        -stribeck_level(levels[j], ratio[j], v_st[j], v[j]) * tanh(v[j] / v_s)
        for j in range(joints)
    ]
    return friction_system("stribeck_friction", v, [*levels, v_s, *ratio, *v_st], force)


#: ``static_ratio >= 1``, ``stribeck_velocity > 0``.
STATIC_RATIO = LawParameter("static_ratio", 1.0, closed=True)
STRIBECK_VELOCITY = LawParameter("stribeck_velocity", 0.0, closed=False)

SPEC = FrictionLawSpec(
    kind="stribeck",
    label="Stribeck",
    settings=Stribeck,
    system=stribeck_system,
    parameters=(STATIC_RATIO, STRIBECK_VELOCITY),
)
