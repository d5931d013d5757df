"""Coulomb friction smoothed by a tanh: posfb's default law (``!TanhCoulomb {}``)::

    f_j = -f_cj tanh(v_j / v_s)

``f_cj`` is joint j's Coulomb level (``ArmParameters.coulomb``, the URDF's
``<posfb:coulomb_friction>``), ``v_s`` the smoothing velocity
(``plant.friction_velocity``; ``models.plant`` explains its default). Viscous friction is
the URDF's joint damping (MultibodyPlant). The tanh regularisation of ``f_c sgn(v)`` is
the usual smooth approximation of the Coulomb law for ODE integration (e.g. Andersson,
Söderberg, Björklund 2007, "Friction models for sliding dry, boundary and mixed
lubricated contacts", Tribology International 40(4)).
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

from dataclasses import dataclass

from pydrake.symbolic import Variable, tanh
from pydrake.systems.primitives import SymbolicVectorSystem

from posfb.models.friction.common import friction_system, joint_variables
from posfb.models.friction.registry import FrictionLawSpec


@dataclass
class TanhCoulomb:
    """``f = -f_c tanh(v / v_s)`` (``models.friction.tanh_coulomb``); no settings."""


def coulomb_system(joints: int) -> SymbolicVectorSystem:
    """``-f_c tanh(v / v_s)`` per joint; parameters ``[f_c1..f_cn, v_s]``.

    Input: joint velocities. Its state integrates the energy friction
    dissipates (J, never decreasing)."""
    v = joint_variables("v", joints)
    levels = joint_variables("fc", joints)
    v_s = Variable("v_s")
    force = [-levels[j] * tanh(v[j] / v_s) for j in range(joints)]
    return friction_system("coulomb_friction", v, [*levels, v_s], force)


SPEC = FrictionLawSpec(
    kind="tanh_coulomb",
    label="Coulomb (tanh-smoothed)",
    settings=TanhCoulomb,
    system=coulomb_system,
)
