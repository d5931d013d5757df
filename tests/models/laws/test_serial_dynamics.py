"""A URDF arm's model as CasADi expressions (``models.laws.serial_dynamics`` and
``models.laws.nominal.UrdfModel``, which the generated C prints) against Drake's own
evaluation (``models.serial_model.SerialArmModel``: ``CalcMassMatrix``,
``CalcBiasTerm``, ``CalcGravityGeneralizedForces``), and Eq. 18's norms against numpy's
(the spectral norm, LAPACK's SVD)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from helpers.paths import REPO
from helpers.spatial_arm import spatial_arm_urdf
from posfb.models.design.config import M1_NORMS
from posfb.models.laws.nominal import UrdfModel
from posfb.models.laws.serial_dynamics import SerialArmDynamics
from posfb.models.laws.spectral_norm import NORMS, frobenius_norm, spectral_norm
from posfb.models.serial_model import SerialArmModel

URDF = REPO / "urdf"


def _terms(arm: SerialArmModel) -> ca.Function:
    """``(q, v, a) -> (Eq. 2's voltage, Eq. 4, G*, ||M1*||, M*)`` of the expressions (``M*``
    by composite rigid bodies, each row divided by its motor constant)."""
    model, joints = UrdfModel(arm), arm.size
    q, v, a = (ca.SX.sym(name, joints) for name in "qva")
    mass = SerialArmDynamics(arm.plant, arm.context, arm.joints).mass_matrix(q)
    terms = [model.inverse_dynamics(q, v, a), model.linearization(q, v, a), model.gravity(q),
             model.M1_norm(q), ca.vec(ca.DM(1.0 / arm.motor_constant) * mass)]  # fmt: skip
    return ca.Function("terms", [q, v, a], terms)


def _drake_terms(model: SerialArmModel, q, v, a) -> list[np.ndarray]:
    """The same five terms from Drake's numbers (``CalcMassMatrix`` for ``M*``, and
    numpy's 2-norm)."""
    M1 = model.M(q) - model.M0()
    return [
        model.inverse_dynamics(q, v, a),
        M1 @ a + model.coriolis(q, v) + model.G(q) + model.F(v),
        model.G(q),
        np.array([np.linalg.norm(M1, 2)]),
        model.M(q).ravel(order="F"),  # ca.vec is column-major
    ]


def _assert_equal_to_drake(model: SerialArmModel, seed: int) -> None:
    n = model.size
    terms = _terms(model)
    rng = np.random.default_rng(seed)
    for _ in range(15):
        state = rng.normal(size=(3, n)) * 2.0
        got = [np.asarray(value).ravel() for value in terms(*state)]
        for value, expected in zip(got, _drake_terms(model, *state), strict=True):
            scale = max(float(np.max(np.abs(expected))), 1e-300)
            assert np.max(np.abs(value - expected)) <= 1e-12 * scale


@pytest.mark.parametrize("name", ["two_link_arm", "three_link_arm", "six_joint_arm"])
def test_shipped_arms_equal_drake(name):
    _assert_equal_to_drake(SerialArmModel(URDF / f"{name}.urdf"), seed=1)


@pytest.mark.parametrize(("joints", "seed"), [(2, 11), (4, 12), (7, 13)])
def test_random_spatial_arms_equal_drake(tmp_path, joints, seed):
    """Tilted joint frames, skew axes, full inertias about rotated frames, and welded
    mount, flange and tool bodies (``tests.helpers.spatial_arm``)."""
    _assert_equal_to_drake(SerialArmModel(spatial_arm_urdf(joints, tmp_path, seed)), seed)


def test_parameters_come_from_the_context(tmp_path):
    """A sampled plant (``SerialArmModel.of_plant``): masses, inertias and rotor inertias
    changed in a Context, not in the file, reach the expressions."""
    nominal = SerialArmModel(spatial_arm_urdf(3, tmp_path, 5))
    plant, context = nominal.plant, nominal.plant.CreateDefaultContext()
    for name in ("link2", "tool"):
        body = plant.GetBodyByName(name)
        body.SetSpatialInertiaInBodyFrame(
            context, body.default_spatial_inertia().Shift([0.03, -0.02, 0.05]))  # fmt: skip
        body.SetMass(context, 1.7 * body.default_mass())
    actuator = plant.GetJointActuatorByName("motor3")
    actuator.SetRotorInertia(context, 4.0 * actuator.default_rotor_inertia())
    coulomb = nominal.coulomb_levels() * nominal.motor_constant  # N m, as of_plant takes them
    sampled = SerialArmModel.of_plant(plant, context, nominal.joints, nominal.motor_constant,
                                      coulomb)  # fmt: skip
    assert not np.allclose(sampled.M(np.ones(3)), nominal.M(np.ones(3)))
    _assert_equal_to_drake(sampled, seed=5)


def test_a_joint_that_is_neither_revolute_nor_welded_is_refused():
    plant = MultibodyPlant(time_step=0.0)
    Parser(plant).AddModelsFromString("""<robot name="slider">
      <link name="base"/><link name="carriage"><inertial><mass value="1"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
      <joint name="slide" type="prismatic"><parent link="base"/><child link="carriage"/>
      <axis xyz="1 0 0"/></joint></robot>""", "urdf")  # fmt: skip
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base"))
    plant.Finalize()
    with pytest.raises(ValueError, match="joint 'slide' is a prismatic joint; a serial arm "
                                         "has revolute and weld joints only"):  # fmt: skip
        SerialArmDynamics(plant, plant.CreateDefaultContext(), ("slide",))


@pytest.mark.parametrize("rows", range(1, 9))
def test_spectral_norm_equals_lapack(rows):
    """Random, graded (columns over eight decades), nearly degenerate (the two largest
    singular values 1e-9 apart) and sparse symmetric matrices: to round-off."""
    A = ca.SX.sym("A", rows, rows)
    norm = ca.Function("norm", [A], [spectral_norm(A)])
    rng = np.random.default_rng(rows)
    for trial in range(80):
        matrix = rng.normal(size=(rows, rows))
        if trial % 4 == 1:
            matrix = matrix * np.logspace(0, -8, rows)[None, :]
        elif trial % 4 == 2:
            U, _, Vt = np.linalg.svd(matrix)
            singular = np.linspace(1.0, 0.1, rows)
            singular[1:2] = 1.0 - 1e-9
            matrix = U @ np.diag(singular) @ Vt
        elif trial % 4 == 3:
            matrix = (matrix + matrix.T) * (np.abs(matrix + matrix.T) > 1.0)
        expected = np.linalg.norm(matrix, 2)
        assert abs(float(norm(matrix)) - expected) <= 4e-15 * max(expected, 1e-300)


def test_the_frobenius_norm_bounds_the_spectral_norm():
    # ||A||_2 <= ||A||_F <= sqrt(n) ||A||_2 (the Frobenius norm is the root of the sum of
    # the squared singular values): Eq. 18 stays a bound with it
    A = ca.SX.sym("A", 6, 6)
    frobenius = ca.Function("frobenius", [A], [frobenius_norm(A)])
    rng = np.random.default_rng(0)
    for _ in range(50):
        matrix = rng.normal(size=(6, 6))
        value = float(frobenius(matrix))
        assert value == pytest.approx(np.linalg.norm(matrix, "fro"), rel=1e-15)
        spectral = np.linalg.norm(matrix, 2)
        assert spectral <= value <= np.sqrt(6) * spectral * (1 + 1e-15)


def test_every_norm_a_setting_names_has_an_expression():
    assert tuple(NORMS) == M1_NORMS


def test_the_frobenius_m1_norm_of_a_urdf_arm_is_drake_s():
    model = SerialArmModel(URDF / "six_joint_arm.urdf")
    q = ca.SX.sym("q", model.size)
    norm = ca.Function("norm", [q], [UrdfModel(model).M1_norm(q, "frobenius")])
    rng = np.random.default_rng(2)
    for _ in range(10):
        angles = rng.uniform(-np.pi, np.pi, model.size)
        expected = np.linalg.norm(model.M(angles) - model.M0(), "fro")
        assert float(norm(angles)) == pytest.approx(expected, rel=1e-12)
