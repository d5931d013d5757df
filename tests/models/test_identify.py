"""Identification of theta_1..theta_11 (Sec. 4.1) from the URDF plant."""

from __future__ import annotations

import numpy as np
import pytest

from posfb.models.lumped import TABLE1
from posfb.models.plant import apply_parameters
from posfb.models.theta_of_plant import identify

# Reading note 9: theta7 and theta8 cannot both match a rigid arm closer than ~2 %.
TOLERANCE = {f"theta{i}": 0.02 for i in range(1, 12)} | {"theta7": 0.04, "theta8": 0.04}


@pytest.mark.parametrize("name", sorted(TOLERANCE))
def test_identified_theta_matches_table1(arm_diagram, name):
    _, arm, context = arm_diagram
    identified = identify(arm, context)
    paper = getattr(TABLE1, name)
    assert abs(getattr(identified, name) / paper - 1.0) <= TOLERANCE[name]


def test_table1_link_length_is_the_urdf_one(arm_diagram):
    _, arm, _ = arm_diagram
    assert TABLE1.l1 == pytest.approx(arm.layout.link_lengths[0], rel=1e-12)


def test_payload_raises_theta_as_a_tip_point_mass_predicts(arm_diagram):
    """A point mass m at distance l2 along link 2 adds m l2^2 to link 2's
    inertia about joint 2, m l1 l2 to the coupling, m l1^2 to joint 1 and
    m g l1 (+ m g l2) to the gravity terms: each divided by its motor constant."""
    _, arm, context = arm_diagram
    base = identify(arm, context)
    mass = 0.288
    params = arm.default_parameters
    apply_parameters(arm, context, params.with_payload(mass))
    loaded = identify(arm, context)
    k1, k2 = params.motor_constant
    l1, l2, g = arm.layout.link_lengths[0], arm.layout.tip_length, TABLE1.g
    expected = {
        "theta1": mass * l1**2 / k1,
        "theta2": mass * l2**2 / k1,
        "theta3": mass * l1 * l2 / k1,
        "theta4": mass * l1 * g / k1,
        "theta7": mass * l2**2 / k2,
        "theta8": mass * l1 * l2 / k2,
    }
    for name, rise in expected.items():
        assert getattr(loaded, name) - getattr(base, name) == pytest.approx(rise, rel=1e-9)
    for name in ("theta5", "theta6", "theta9", "theta10", "theta11"):
        assert getattr(loaded, name) == pytest.approx(getattr(base, name), rel=1e-12)


def test_payload_gravity_torque_rises_by_the_point_mass_moment(arm_diagram):
    _, arm, context = arm_diagram
    plant = arm.plant
    q = np.array([0.3, -0.7])
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, q)
    before = -plant.CalcGravityGeneralizedForces(plant_context)
    mass = 0.288
    apply_parameters(arm, context, arm.default_parameters.with_payload(mass))
    after = -plant.CalcGravityGeneralizedForces(plant_context)
    g, l1, l2 = TABLE1.g, arm.layout.link_lengths[0], arm.layout.tip_length
    tip_moment = mass * g * l2 * np.cos(q[0] + q[1])
    np.testing.assert_allclose(
        after - before, [mass * g * l1 * np.cos(q[0]) + tip_moment, tip_moment], rtol=1e-9
    )
