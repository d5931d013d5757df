"""The regressor, the base parameters and the consistent model of any serial arm (issue 29):
``models.identification.serial_regressor`` and ``models.identification.consistent``.

The regressor is checked against Drake through posfb's nominal model (``SerialArmModel``:
the voltages of Eq. 2 times the motor constants) on the shipped arms, a generated planar
arm, and the same arms with random full inertias, centres of mass off every axis and a
massive payload welded at the tip; the base parameters against the count known for
planar chains; the consistent fit by round trips through ``K`` and through a written URDF.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.multibody.tree import RotationalInertia, SpatialInertia

from helpers.planar_arm import planar_arm_text, planar_arm_urdf
from posfb.models.identification.consistent import (
    ConsistentModel,
    consistent_link,
    fit_consistent,
    log_cholesky_coordinates,
    log_cholesky_parameters,
    pseudo_inertia,
    write_urdf,
)
from posfb.models.identification.serial_regressor import (
    BaseParameters,
    SerialRegressor,
    base_parameters,
    true_parameters,
)
from posfb.models.package_data import package_path
from posfb.models.plant import PlantConfig, arm_model, build_arm_diagram

SHIPPED = ("two_link_arm", "three_link_arm", "template_arm", "six_joint_arm")


def shipped(name: str) -> Path:
    return package_path("posfb.urdf", f"{name}.urdf")


@pytest.fixture(scope="module")
def urdfs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The shipped arms and a generated four-link planar arm, by name."""
    folder = tmp_path_factory.mktemp("arms")
    paths = {name: shipped(name) for name in SHIPPED}
    paths["planar_arm_4"] = planar_arm_urdf(4, folder)
    return paths


@pytest.fixture(scope="module")
def arms(urdfs: dict[str, Path]) -> dict[str, tuple]:
    """``(arm, context, regressor)`` per arm, built once."""
    built = {}
    for name, path in urdfs.items():
        _, arm, context = build_arm_diagram(PlantConfig(urdf=str(path)))
        built[name] = (arm, context, SerialRegressor.of_arm(arm, context))
    return built


@pytest.fixture(scope="module")
def bases(arms: dict[str, tuple]) -> dict[str, BaseParameters]:
    return {
        name: base_parameters(arms[name][2], samples=100)
        for name in ("two_link_arm", "three_link_arm", "template_arm", "planar_arm_4")
    }


def voltages(arm, context, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``u`` of ``SerialArmModel.inverse_dynamics`` (Eq. 2, V) at each sample."""
    model = arm_model(arm, context)
    return np.array([model.inverse_dynamics(*state) for state in zip(q, v, a, strict=True)])


def drake_torques(arm, context, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``kappa u``: the torques of Eq. 2 (N m)."""
    return arm_model(arm, context).motor_constant * voltages(arm, context, q, v, a)


def assert_relative(actual: np.ndarray, expected: np.ndarray, tolerance: float) -> None:
    """Each sample's torques agree to ``tolerance`` times that sample's largest."""
    scale = np.abs(expected).max(axis=-1, keepdims=True)
    assert np.all(np.abs(actual - expected) <= tolerance * scale), np.abs(actual - expected).max()


def randomise_inertias(arm, context, seed: int) -> None:
    """Give every link a random spatial inertia: a solid ellipsoid of random mass, semi-axes
    and orientation, its centre of mass off every axis (on the URDF's side of the joint,
    as ``ArmParameters`` reads it), and the payload (where the arm has one) a mass off
    its origin (a point mass)."""
    rng = np.random.default_rng(seed)
    plant = arm.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    for name, shape in zip(arm.layout.links, arm.layout.shapes, strict=True):
        mass = rng.uniform(0.5, 3.0)
        a, b, c = rng.uniform(0.02, 0.2, 3)
        rotation = RotationMatrix(RollPitchYaw(rng.uniform(-np.pi, np.pi, 3))).matrix()
        central = rotation @ np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) @ rotation.T
        central *= mass / 5.0
        com = 0.12 * shape.com_direction + rng.normal(0.0, 0.03, 3)
        inertia = RotationalInertia(*np.diag(central), central[0, 1], central[0, 2], central[1, 2])
        plant.GetBodyByName(name).SetSpatialInertiaInBodyFrame(
            plant_context, SpatialInertia.MakeFromCentralInertia(mass, com, inertia)
        )
    if arm.layout.payload is not None:
        point = SpatialInertia.MakeFromCentralInertia(
            0.7, rng.normal(0.0, 0.03, 3), RotationalInertia(0.0, 0.0, 0.0)
        )
        plant.GetBodyByName(arm.layout.payload).SetSpatialInertiaInBodyFrame(plant_context, point)


# --- the regressor -------------------------------------------------------------------------


@pytest.mark.parametrize("name", [*SHIPPED, "planar_arm_4"])
def test_regressor_times_the_true_parameters_is_drakes_torque(arms, name):
    arm, context, regressor = arms[name]
    q, v, a = regressor.sample_states(6, seed=11)
    Y = regressor.torque_columns(q, v, a)
    assert Y.shape == (6, arm.size, 13 * arm.size)
    assert len(regressor.parameter_names) == 13 * arm.size
    assert_relative(Y @ true_parameters(arm, context), drake_torques(arm, context, q, v, a), 1e-9)


@pytest.mark.parametrize("name", ["three_link_arm", "template_arm", "six_joint_arm"])
def test_regressor_holds_for_full_inertias_and_a_massive_payload(urdfs, name):
    _, arm, context = build_arm_diagram(PlantConfig(urdf=str(urdfs[name])))
    randomise_inertias(arm, context, seed=len(name))
    regressor = SerialRegressor.of_arm(arm, context)
    q, v, a = regressor.sample_states(6, seed=5)
    pi = true_parameters(arm, context)
    assert_relative(
        regressor.torque_columns(q, v, a) @ pi, drake_torques(arm, context, q, v, a), 1e-9
    )
    if arm.layout.payload is not None:  # folded into the last link: its mass is both
        payload = arm.plant.GetBodyByName(arm.layout.payload)
        last = arm.plant.GetBodyByName(arm.layout.links[-1])
        plant_context = arm.plant.GetMyContextFromRoot(context)
        both = payload.get_mass(plant_context) + last.get_mass(plant_context)
        assert pi[10 * (arm.size - 1)] == pytest.approx(both, rel=1e-12)


def test_one_state_is_one_sample_and_the_columns_split(arms):
    arm, context, regressor = arms["template_arm"]
    q, v, a = regressor.sample_states(3, seed=np.random.default_rng(2))
    batch = regressor.torque_columns(q, v, a)
    single = regressor.torque_columns(q[1], v[1], a[1])
    np.testing.assert_allclose(single[0], batch[1], rtol=0, atol=1e-12)
    n = arm.size
    np.testing.assert_array_equal(batch[..., : 10 * n], regressor.inertial_columns(q, v, a))
    np.testing.assert_array_equal(batch[..., 10 * n :], regressor.drive_columns(v, a))
    assert regressor.parameter_names[:3] == ("column.m", "column.mcx", "column.mcy")
    assert regressor.parameter_names[-3:] == (
        "elbow.rotor_inertia",
        "elbow.damping",
        "elbow.coulomb",
    )


# --- base parameters -----------------------------------------------------------------------


@pytest.mark.parametrize("name", ["two_link_arm", "three_link_arm", "template_arm", "planar_arm_4"])
def test_base_regressor_has_full_rank_and_reproduces_every_standard_vector(arms, bases, name):
    arm, context, regressor = arms[name]
    base = bases[name]
    q, v, a = regressor.sample_states(40, seed=99)  # states the reduction did not see
    Y = regressor.torque_columns(q, v, a)
    Y_base = base.columns(Y)
    assert Y_base.shape == (40, arm.size, base.size)
    assert np.linalg.matrix_rank(Y_base.reshape(-1, base.size)) == base.size
    rng = np.random.default_rng(4)
    for pi in (true_parameters(arm, context), rng.normal(size=13 * arm.size)):
        assert_relative(Y_base @ base.combine(pi), Y @ pi, 1e-9)
    np.testing.assert_array_equal(base.K[:, list(base.independent)], np.eye(base.size))


@pytest.mark.parametrize("name", ["two_link_arm", "three_link_arm", "planar_arm_4"])
def test_planar_chains_have_three_inertial_base_parameters_per_link(arms, bases, name):
    """A planar chain of n parallel revolute joints with gravity in the plane has 3 n base
    inertial parameters (Mayeda, Yoshida & Osuka 1990; Gautier & Khalil 1990): per link
    the moment about its axis and the two first moments in the plane, the outer links'
    masses regrouped into them. With the drives: the first rotor inertia regroups into
    link 1's moment (both multiply ``q''_1`` only), the other n - 1 and the 2 n friction
    terms stay: 6 n - 1."""
    n = arms[name][0].size
    base = bases[name]
    inertial = [i for i in base.independent if i < 10 * n]
    assert len(inertial) == 3 * n
    assert base.size == 6 * n - 1


def test_rotor_inertia_of_the_first_joint_regroups_into_the_first_link(bases):
    base = bases["three_link_arm"]
    names = base.standard_names
    rotor = names.index("joint1.rotor_inertia")
    assert rotor not in base.independent
    row = base.names.index("link1.Iyy")
    assert base.K[row, rotor] == pytest.approx(1.0, abs=1e-9)
    assert "link1.Iyy + 0.16 link2.m + 0.16 link3.m + joint1.rotor_inertia" in base.descriptions
    assert "link2.Iyy + 0.09 link3.m" in base.descriptions
    assert "joint2.rotor_inertia" in base.names  # moves q''_2 alone: identifiable
    spatial = bases["template_arm"]  # the yaw joint's rotor: with the moments about z
    assert spatial.standard_names.index("base_yaw.rotor_inertia") not in spatial.independent
    assert spatial.descriptions[0].startswith("column.Izz + upper_arm.Izz")
    assert spatial.descriptions[0].endswith("+ base_yaw.rotor_inertia")


# --- the consistent model ------------------------------------------------------------------


def test_log_cholesky_coordinates_give_consistent_links_and_invert():
    rng = np.random.default_rng(8)
    for theta in rng.normal(0.0, 1.0, (20, 10)):
        link = log_cholesky_parameters(theta)
        assert np.linalg.eigvalsh(pseudo_inertia(link))[0] > 0.0
        np.testing.assert_allclose(log_cholesky_coordinates(link), theta, atol=1e-9)
    rod = np.array([2.0, 0.4, 0.0, 0.0, 0.0, 0.107, 0.107, 0.0, 0.0, 0.0])  # a line
    with pytest.raises(ValueError, match="physically consistent link"):
        log_cholesky_coordinates(rod)
    values = np.linalg.eigvalsh(pseudo_inertia(consistent_link(rod)))
    assert values[0] >= 0.99e-6 * values[-1]


def perturbed_prior(pi: np.ndarray, n: int, seed: int) -> np.ndarray:
    """A consistent prior off the truth: each link's log-Cholesky coordinates moved by
    0.1 (masses, sizes and shapes by about 10 %, the centres of mass by about 0.1 m),
    each drive parameter scaled by 0.7 to 1.3."""
    rng = np.random.default_rng(seed)
    links = [
        log_cholesky_parameters(
            log_cholesky_coordinates(pi[10 * i : 10 * i + 10]) + rng.normal(0.0, 0.1, 10)
        )
        for i in range(n)
    ]
    return np.concatenate([*links, pi[10 * n :] * rng.uniform(0.7, 1.3, 3 * n)])


def fit_truth(arm, context, base: BaseParameters, seed: int) -> tuple[ConsistentModel, np.ndarray]:
    pi = true_parameters(arm, context)
    beta = base.combine(pi)
    sigma = 1e-3 * (np.abs(beta) + 1e-3 * np.abs(beta).max())
    model = fit_consistent(base, beta, sigma**2, perturbed_prior(pi, arm.size, seed), 1e-8)
    return model, beta


@pytest.mark.parametrize("name", ["three_link_arm", "planar_arm_4"])
def test_fit_reproduces_the_base_parameters_with_a_consistent_arm(arms, bases, name):
    arm, context, _ = arms[name]
    model, beta = fit_truth(arm, context, bases[name], seed=3)
    assert model.converged
    np.testing.assert_allclose(model.beta, beta, rtol=1e-6, atol=1e-9 * np.abs(beta).max())
    assert np.abs(model.standard_errors).max() < 1e-3
    for i, link in enumerate(model.links):
        assert link.mass > 0.0
        assert np.linalg.eigvalsh(pseudo_inertia(model.standard[10 * i : 10 * i + 10]))[0] > 0.0
        moments = np.linalg.eigvalsh(link.inertia)
        assert moments[0] > 0.0 and moments[2] < moments[0] + moments[1]
    assert all(d.rotor_inertia > 0 and d.damping > 0 and d.coulomb > 0 for d in model.drives)


def test_an_estimate_no_arm_has_is_fitted_by_a_consistent_one(arms, bases):
    """A base parameter pushed below what any density allows (the last link's moment
    about its axis negative) is fitted by a consistent arm that misses it by many
    standard errors, the others kept."""
    arm, context, _ = arms["three_link_arm"]
    base = bases["three_link_arm"]
    pi = true_parameters(arm, context)
    beta = base.combine(pi)
    bad = base.names.index("link3.Iyy")
    beta_hat = beta.copy()
    beta_hat[bad] = -beta[bad]
    sigma = 0.01 * (np.abs(beta) + 1e-3 * np.abs(beta).max())
    model = fit_consistent(base, beta_hat, np.diag(sigma**2), pi, 1e-4)
    assert model.converged
    assert model.links[-1].mass > 0.0 and model.beta[bad] > 0.0
    assert model.standard_errors[bad] > 10.0
    assert np.abs(np.delete(model.standard_errors, bad)).max() < model.standard_errors[bad]
    assert model.mahalanobis >= np.abs(model.standard_errors).max()


@pytest.mark.parametrize("name", ["three_link_arm", "planar_arm_4"])
def test_written_urdf_loads_and_has_the_fitted_dynamics(arms, bases, urdfs, tmp_path, name):
    arm, context, regressor = arms[name]
    base = bases[name]
    model, beta = fit_truth(arm, context, base, seed=6)
    out = write_urdf(urdfs[name], model, tmp_path / "fitted.urdf")
    _, fitted, fitted_context = build_arm_diagram(PlantConfig(urdf=str(out)))  # checks the URDF
    np.testing.assert_allclose(
        true_parameters(fitted, fitted_context), model.standard, rtol=1e-12, atol=1e-15
    )
    np.testing.assert_allclose(
        base.combine(true_parameters(fitted, fitted_context)), model.beta, rtol=1e-12, atol=1e-15
    )
    assert fitted.default_parameters.motor_constant == arm.default_parameters.motor_constant
    q, v, a = regressor.sample_states(8, seed=21)
    assert_relative(
        voltages(fitted, fitted_context, q, v, a), voltages(arm, context, q, v, a), 1e-6
    )
    assert fitted.layout.payload == "payload"
    assert fitted.default_parameters.payload_mass == 0.0


def test_a_massive_welded_payload_is_folded_and_zeroed(tmp_path):
    """A payload with mass welded at the tip is part of the last link's parameters, so
    the written URDF carries it there and gives the payload link mass 0."""
    text = planar_arm_text(2).replace(
        '<origin xyz="0 0 0" rpy="0 0 0"/>\n      <mass value="0"/>',
        '<origin xyz="0.02 0 0.01" rpy="0 0 0"/>\n      <mass value="0.4"/>',
    )
    nominal = tmp_path / "loaded.urdf"
    nominal.write_text(text)
    _, arm, context = build_arm_diagram(PlantConfig(urdf=str(nominal)))
    regressor = SerialRegressor.of_arm(arm, context)
    base = base_parameters(regressor, samples=60)
    pi = true_parameters(arm, context)
    model = fit_consistent(base, base.combine(pi), np.full(base.size, 1e-8), pi, 1e-8)
    _, fitted, fitted_context = build_arm_diagram(
        PlantConfig(urdf=str(write_urdf(nominal, model, tmp_path / "fitted.urdf")))
    )
    assert fitted.default_parameters.payload_mass == 0.0
    assert fitted.default_parameters.link_mass[-1] == pytest.approx(
        arm.default_parameters.link_mass[-1] + 0.4, rel=1e-9
    )
    q, v, a = regressor.sample_states(5, seed=1)
    assert_relative(
        drake_torques(fitted, fitted_context, q, v, a), drake_torques(arm, context, q, v, a), 1e-6
    )


# --- bad inputs ----------------------------------------------------------------------------


def test_bad_inputs_are_refused_naming_the_parameter(arms, bases, urdfs, tmp_path):
    arm, context, regressor = arms["three_link_arm"]
    base = bases["three_link_arm"]
    q, v, a = regressor.sample_states(2, seed=0)
    with pytest.raises(ValueError, match=r"^q has shape \(2, 2\)"):
        regressor.inertial_columns(q[:, :2], v, a)
    with pytest.raises(ValueError, match="^the states have shapes"):
        regressor.torque_columns(q, v, a[:1])
    with pytest.raises(ValueError, match="^v = .*non-finite"):
        regressor.drive_columns(np.full((1, 3), np.nan), a[:1])
    with pytest.raises(ValueError, match="^samples = 0"):
        regressor.sample_states(0)
    with pytest.raises(ValueError, match="^seed = -1"):
        regressor.sample_states(3, seed=-1)
    with pytest.raises(ValueError, match="^root_context = "):
        SerialRegressor.of_arm(arm, arm.plant.CreateDefaultContext())
    with pytest.raises(ValueError, match="^arm = 'arm'"):
        true_parameters("arm", context)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="^tolerance = 2"):
        base_parameters(regressor, tolerance=2)
    with pytest.raises(ValueError, match=r"^Y_full has shape \(3, 4\)"):
        base.columns(np.zeros((3, 4)))
    with pytest.raises(ValueError, match=r"^standard has shape \(5,\)"):
        base.combine(np.zeros(5))
    pi = true_parameters(arm, context)
    beta = base.combine(pi)
    ones = np.ones(base.size)
    with pytest.raises(ValueError, match="^beta_hat = "):
        fit_consistent(base, beta[:-1], ones, pi)
    with pytest.raises(ValueError, match="^beta_cov has eigenvalues down to -1"):
        fit_consistent(base, beta, -ones, pi)
    with pytest.raises(ValueError, match="^beta_cov is not symmetric"):
        fit_consistent(base, beta, np.triu(np.ones((base.size, base.size))), pi)
    # Round-off asymmetry (issue 42: 1e-11 and 2e-4 of sigma_i sigma_j on published arms
    # with pinv) is within SYMMETRY_TOLERANCE's margin below 2e-4, above 1e-11.
    rng = np.random.default_rng(4)
    factor = rng.normal(size=(base.size, base.size))
    covariance = factor @ factor.T + np.eye(base.size)
    sigma = np.sqrt(np.diag(covariance))
    skew = np.triu(rng.uniform(-1, 1, covariance.shape), 1) * np.outer(sigma, sigma)
    fit_consistent(base, beta, covariance + 1e-11 * skew, pi)
    with pytest.raises(ValueError, match="^beta_cov is not symmetric: entries"):
        fit_consistent(base, beta, covariance + 2e-4 * skew, pi)
    with pytest.raises(ValueError, match=r"^prior has shape \(3,\)"):
        fit_consistent(base, beta, ones, pi[:3])
    with pytest.raises(ValueError, match="^regularisation = 0"):
        fit_consistent(base, beta, ones, pi, 0.0)
    with pytest.raises(ValueError, match="^base = "):
        fit_consistent(None, beta, ones, pi)  # type: ignore[arg-type]
    model = fit_consistent(base, beta, ones, pi)
    with pytest.raises(ValueError, match="^nominal_urdf = .* has the arm joints and links"):
        write_urdf(urdfs["planar_arm_4"], model, tmp_path / "out.urdf")
    with pytest.raises(ValueError, match="^out = .*folder does not exist"):
        write_urdf(urdfs["three_link_arm"], model, tmp_path / "missing" / "out.urdf")
    with pytest.raises(ValueError, match="^link = "):
        pseudo_inertia(np.zeros(3))
    with pytest.raises(ValueError, match="^theta = .* overflows"):
        log_cholesky_parameters(np.full(10, 400.0))
    with pytest.raises(ValueError, match="^margin = 0"):
        consistent_link(pi[:10], margin=0)
