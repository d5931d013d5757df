"""The lumped model of Sec. 4.1 against the plant it was identified from."""

from __future__ import annotations

import numpy as np
import pytest

from posfb.models.lumped import TABLE1, LumpedModel, LumpedParameters
from posfb.models.plant import set_coulomb
from posfb.models.theta_of_plant import identify


def test_identified_model_reproduces_plant_acceleration(arm_diagram):
    """Forward dynamics of the identified lumped model and of the URDF plant
    (motor stage included, friction off) agree on random (q, qdot, u)."""
    diagram, arm, context = arm_diagram
    set_coulomb(arm, context, (0.0, 0.0))
    model = LumpedModel(identify(arm, context))
    plant_context = arm.plant.GetMyMutableContextFromRoot(context)
    rng = np.random.default_rng(7)
    for _ in range(25):
        q, qdot = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3.0, 3.0, 2)
        u = rng.uniform(-24.0, 24.0, 2)
        arm.plant.SetPositions(plant_context, q)
        arm.plant.SetVelocities(plant_context, qdot)
        diagram.get_input_port(0).FixValue(context, u)
        plant_qddot = arm.plant.EvalTimeDerivatives(plant_context).CopyToVector()[2:]
        model_qddot = model.forward_dynamics(q, qdot, u, friction=False)
        np.testing.assert_allclose(model_qddot, plant_qddot, rtol=1e-9, atol=1e-12)


def test_inverse_and_forward_dynamics_are_inverse():
    model = LumpedModel(TABLE1)
    rng = np.random.default_rng(3)
    for _ in range(10):
        q, qdot, qddot = rng.normal(size=(3, 2))
        u = model.inverse_dynamics(q, qdot, qddot)
        np.testing.assert_allclose(model.forward_dynamics(q, qdot, u), qddot, atol=1e-10)


def test_m0_m1_split_is_the_constant_and_cos_parts():
    model = LumpedModel(TABLE1)
    q_perpendicular = np.array([0.4, np.pi / 2])
    np.testing.assert_allclose(model.M(q_perpendicular), model.M0(), atol=1e-15)
    np.testing.assert_allclose(model.M1(q_perpendicular), 0.0, atol=1e-15)


def test_plant_mass_matrix_is_symmetric_positive_definite(arm_diagram):
    _, arm, context = arm_diagram
    plant_context = arm.plant.GetMyMutableContextFromRoot(context)
    for q1 in np.linspace(-np.pi, np.pi, 7):
        for q2 in np.linspace(-np.pi, np.pi, 13):
            arm.plant.SetPositions(plant_context, [q1, q2])
            mass = arm.plant.CalcMassMatrix(plant_context)
            np.testing.assert_allclose(mass, mass.T, atol=1e-14)
            assert np.linalg.eigvalsh(mass).min() > 0.0


@pytest.mark.parametrize("name", ["theta1", "theta5", "l1"])
def test_lumped_parameters_refuse_bad_values(name):
    with pytest.raises(ValueError, match=name):
        LumpedParameters(**{name: -1.0})
    with pytest.raises(ValueError, match=name):
        LumpedParameters(**{name: float("nan")})
