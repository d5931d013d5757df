"""theta_1..theta_11 of Sec. 4.1 computed from a plant and its Context.

Each row of the lumped model is the joint's physical row divided by its motor
constant ``kappa_j`` (reading note 9), so with ``M(q)`` the plant's mass matrix
(rotor inertia included), ``G(q)`` its gravity torque and ``h = m2 l1 lc2``::

    M11(q2) = kappa1 (theta1 + theta2 + 2 theta3 cos q2)
    M12(q2) = kappa1 (theta2 + theta3 cos q2) = kappa2 (theta7 + theta8 cos q2)
    M22     = kappa2 (theta7 + theta9)
    G1(q1 = 0, q2 = pi/2) = kappa1 theta4
    b_j = kappa_j (theta5 | theta10),   f_cj = kappa_j (theta6 | theta11)

The mass matrix is evaluated at ``q2 = 0`` and ``q2 = pi/2`` to separate the
constant and ``cos q2`` parts; nothing is fitted, so the identified lumped
model reproduces the plant's dynamics exactly (up to round-off).
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
from pydrake.systems.framework import Context

from posfb.models.lumped import LumpedParameters
from posfb.models.nominal import NominalModel
from posfb.models.plant import (
    PAYLOAD_BODY,
    Arm,
    PlantConfig,
    apply_parameters,
    arm_model,
    build_arm_diagram,
    read_parameters,
    require_payload_mass,
)
from posfb.models.serial_model import SerialArmModel
from posfb.models.urdf_check import check_arm_urdf


def identify(arm: Arm, root_context: Context) -> LumpedParameters:
    """The lumped parameters of the plant in ``root_context`` (a diagram Context); the
    theta model is the two-link arm's, so other arms are refused."""
    if arm.size != 2:
        raise ValueError(
            f"{arm.config.urdf} has {arm.size} joints; the theta model of Table 1 is "
            "identified for two-joint arms only (use a URDF nominal model instead)"
        )
    plant = arm.plant
    scratch = root_context.Clone()  # evaluate at chosen q without touching the caller's state
    plant_context = plant.GetMyContextFromRoot(scratch)
    physical = read_parameters(arm, root_context)
    kappa1, kappa2 = physical.motor_constant

    def mass_matrix(q2: float) -> np.ndarray:
        plant.SetPositions(plant_context, [0.0, q2])
        plant.SetVelocities(plant_context, [0.0, 0.0])
        return plant.CalcMassMatrix(plant_context)

    straight, bent = mass_matrix(0.0), mass_matrix(np.pi / 2)
    plant.SetPositions(plant_context, [0.0, np.pi / 2])
    # Drake returns the generalized force *of* gravity; the model's G is its negative.
    gravity = -plant.CalcGravityGeneralizedForces(plant_context)
    g = float(np.linalg.norm(plant.gravity_field().gravity_vector()))

    theta2 = bent[0, 1] / kappa1
    theta3 = (straight[0, 1] - bent[0, 1]) / kappa1
    theta7 = bent[1, 0] / kappa2
    theta8 = (straight[1, 0] - bent[1, 0]) / kappa2
    damping = [plant.GetJointByName(j).GetDamping(plant_context) for j in arm.layout.joints]
    return LumpedParameters(
        theta1=bent[0, 0] / kappa1 - theta2,
        theta2=theta2,
        theta3=theta3,
        theta4=gravity[0] / kappa1,
        theta5=damping[0] / kappa1,
        theta6=physical.coulomb[0] / kappa1,
        theta7=theta7,
        theta8=theta8,
        theta9=bent[1, 1] / kappa2 - theta7,
        theta10=damping[1] / kappa2,
        theta11=physical.coulomb[1] / kappa2,
        l1=arm.layout.link_lengths[0],
        g=g,
    )


@functools.lru_cache(maxsize=16)
def identify_urdf(urdf: str | Path, payload_mass: float = 0.0) -> LumpedParameters:
    """theta of the URDF arm with ``payload_mass`` kg at the link-2 tip (refused, naming
    ``payload_mass``, outside its allowed range; cached per file and payload)."""
    require_payload_mass(payload_mass)
    check_arm_urdf(Path(urdf), payload_link=PAYLOAD_BODY)
    _, arm, context = build_arm_diagram(PlantConfig(urdf=str(urdf)))
    apply_parameters(arm, context, arm.default_parameters.with_payload(payload_mass))
    return identify(arm, context)


def linear_part_model(
    arm: Arm, root_context: Context, nominal: NominalModel
) -> LumpedParameters | SerialArmModel:
    """The plant in ``root_context`` as the sampled-data check takes its linear part
    ``M0, B`` (``models.design.plant_spectral_radii``), in the form of the design's
    ``nominal`` model: its identified theta for a theta model (Table 1's), the arm's own
    Drake model (``models.plant.arm_model``) for a URDF nominal model."""
    if isinstance(nominal, LumpedParameters):
        return identify(arm, root_context)
    return arm_model(arm, root_context)
