"""The LuGre dynamic friction model (``!LuGre {static_ratio, stribeck_velocity,
sigma0, sigma1}``) of Canudas de Wit, Olsson, Åström and Lischinsky (1995), "A new
model for control of systems with friction", IEEE Trans. Automatic Control 40(3),
419-425 (their Eqs. 1-3 and 5), one bristle state ``z_j`` (rad) per joint::

    g_j(v)   = f_cj + (f_sj - f_cj) exp(-(v / v_stj)^2),   f_sj = static_ratio_j f_cj
    dz_j/dt  = v_j - sigma0_j |v_j| z_j / g_j(v_j)
    f_j      = -(sigma0_j z_j + sigma1_j dz_j/dt)

``sigma0 > 0`` is the bristle (presliding) stiffness (N m/rad), ``sigma1 >= 0`` the
bristle damping (N m s/rad); the viscous term ``sigma2 v`` of the paper is the URDF's
joint damping (MultibodyPlant), not repeated. ``g`` is ``models.friction.stribeck``'s
curve (no tanh: the bristle state makes the law smooth), so at a constant velocity
(``dz/dt = 0``, ``z = g(v) sgn(v) / sigma0``) the force is ``-g(v) sgn(v)``: the Stribeck
curve; at rest a small displacement ``dq`` gives ``f = -sigma0 dq`` (presliding). The law
needs ``f_c > 0`` at every joint (it divides by ``g``). ``z`` starts at 0 (a relaxed
bristle) with the arm at rest.

The block's loss state integrates ``-sum_j f_j v_j``: the work the joints do against
friction. For LuGre that is the energy dissipated plus the energy stored in the
bristles, ``sum_j sigma0_j z_j^2 / 2``, which presliding motion gives back, so it can
decrease for a moment; the energy balance of the arm holds with it as it stands. The
paper's literature values (a unit mass, SI units) are ``sigma0 = 1e5``, ``sigma1 =
sqrt(1e5)``, ``f_s / f_c = 1.5``, ``v_st = 0.001``; ``sigma0 ~ 1e4..1e5`` N m/rad makes the
integrator's job stiff (user guide, ``docs/guide/nonidealities.md``).
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

from dataclasses import dataclass, field

from pydrake.symbolic import Variable, abs
from pydrake.systems.primitives import SymbolicVectorSystem

from posfb.models.friction.common import friction_system, joint_variables
from posfb.models.friction.registry import FrictionLawSpec, LawParameter
from posfb.models.friction.stribeck import STATIC_RATIO, STRIBECK_VELOCITY, stribeck_level


@dataclass
class LuGre:
    """LuGre (``models.friction.lugre``): per joint (one value = every joint),
    ``static_ratio = f_s / f_c`` (>= 1), ``stribeck_velocity`` (rad/s, > 0), ``sigma0``
    (N m/rad, > 0) and ``sigma1`` (N m s/rad, >= 0). Defaults: Canudas de Wit et al.
    (1995)'s example values."""

    static_ratio: list[float] = field(default_factory=lambda: [1.5])
    stribeck_velocity: list[float] = field(default_factory=lambda: [0.001])
    sigma0: list[float] = field(default_factory=lambda: [1e5])
    sigma1: list[float] = field(default_factory=lambda: [316.22776601683796])


def lugre_system(joints: int) -> SymbolicVectorSystem:
    """LuGre per joint; parameters ``[f_c, v_s, static_ratio, stribeck_velocity, sigma0,
    sigma1]`` (``v_s`` unused); state ``[friction loss, z_1..z_n]``."""
    v = joint_variables("v", joints)
    levels = joint_variables("fc", joints)
    v_s = Variable("v_s")
    ratio = joint_variables("static_ratio", joints)
    v_st = joint_variables("stribeck_velocity", joints)
    sigma0 = joint_variables("sigma0_", joints)
    sigma1 = joint_variables("sigma1_", joints)
    z = joint_variables("z", joints)
    rate = [
        v[j] - sigma0[j] * abs(v[j]) * z[j] / stribeck_level(levels[j], ratio[j], v_st[j], v[j])
        for j in range(joints)
    ]
    force = [-(sigma0[j] * z[j] + sigma1[j] * rate[j]) for j in range(joints)]
    parameters = [*levels, v_s, *ratio, *v_st, *sigma0, *sigma1]
    return friction_system("lugre_friction", v, parameters, force, z, rate)


SPEC = FrictionLawSpec(
    kind="lugre",
    label="LuGre",
    settings=LuGre,
    system=lugre_system,
    parameters=(
        STATIC_RATIO,
        STRIBECK_VELOCITY,
        LawParameter("sigma0", 0.0, closed=False),
        LawParameter("sigma1", 0.0, closed=True),
    ),
    positive_coulomb=True,
)
