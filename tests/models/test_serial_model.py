"""``models.serial_model``: the nominal model of any serial URDF arm, computed by Drake,
against the Table 1 model on the paper's arm and against an independent planar
recursive Newton-Euler on the shipped three-link arm; bad arms refused in one line."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from helpers.paths import REPO
from posfb.models.lumped import LumpedModel
from posfb.models.serial_model import SerialArmModel
from posfb.models.theta_of_plant import identify_urdf

URDF = REPO / "urdf"
GRAVITY = 9.81

#: The three-link arm as typed from its URDF comments (not parsed): per link its
#: length, mass, centre of mass along the link, inertia about the joint axis through
#: the centre of mass, and per joint rotor inertia, gear ratio, damping, Coulomb
#: level and motor constant.
LENGTH = np.array([0.40, 0.30, 0.20])
MASS = np.array([3.0, 1.5, 0.5])
COM = np.array([0.20, 0.15, 0.10])
INERTIA = np.array([0.04, 0.01125, 0.0016667])
ROTOR = np.array([0.00017, 0.00006, 0.00002])
GEAR = np.array([100.0, 50.0, 20.0])
DAMPING = np.array([15.0, 4.0, 1.0])
COULOMB = np.array([8.0, 2.5, 0.8])
KAPPA = np.array([6.0, 3.0, 1.2])


def _perp(r: np.ndarray) -> np.ndarray:
    """``r`` turned +90 deg in the arm's (x, z) plane: the direction a positive angle moves."""
    return np.array([-r[1], r[0]])


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def planar_newton_euler(q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Joint voltages of the planar three-link arm by recursive Newton-Euler, written
    from the link data above without Drake: forward pass of link velocities and
    accelerations (gravity as an upward base acceleration), backward pass of forces
    and moments, then the motor stage (reflected rotor inertia, damping, Coulomb)
    divided by the motor constants."""
    n = len(q)
    phi, omega, alpha = np.cumsum(q), np.cumsum(v), np.cumsum(a)
    joint_acceleration = np.array([0.0, GRAVITY])
    com_acceleration, direction = [], []
    for i in range(n):
        e = np.array([np.cos(phi[i]), np.sin(phi[i])])
        direction.append(e)
        c = COM[i] * e
        com_acceleration.append(joint_acceleration + alpha[i] * _perp(c) - omega[i] ** 2 * c)
        r = LENGTH[i] * e
        joint_acceleration = joint_acceleration + alpha[i] * _perp(r) - omega[i] ** 2 * r
    torque = np.zeros(n)
    force_from_next, moment_from_next = np.zeros(2), 0.0
    for i in reversed(range(n)):
        inertial_force = MASS[i] * com_acceleration[i]
        force = inertial_force + force_from_next
        moment = (
            INERTIA[i] * alpha[i]
            + moment_from_next
            + _cross(COM[i] * direction[i], inertial_force)
            + _cross(LENGTH[i] * direction[i], force_from_next)
        )
        torque[i] = moment
        force_from_next, moment_from_next = force, moment
    torque += ROTOR * GEAR**2 * a + DAMPING * v + COULOMB * np.sign(v)
    return torque / KAPPA


def _assert_inverse_dynamics(model, reference, states: int, speed: float, seed: int) -> None:
    """``model``'s inverse dynamics equal ``reference(q, v, a)`` to 1e-9 relative at
    ``states`` random states (velocities up to ``speed``, accelerations up to 3x it)."""
    rng = np.random.default_rng(seed)
    n = model.size
    for _ in range(states):
        q, v = rng.uniform(-np.pi, np.pi, n), rng.uniform(-speed, speed, n)
        a = rng.uniform(-3 * speed, 3 * speed, n)
        expected = reference(q, v, a)
        got = model.inverse_dynamics(q, v, a)
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


@pytest.fixture(scope="module")
def three_link():
    return SerialArmModel(URDF / "three_link_arm.urdf")


def test_the_paper_arm_equals_the_table_1_model_of_its_identified_theta():
    model = SerialArmModel(URDF / "two_link_arm.urdf")
    lumped = LumpedModel(identify_urdf(str(URDF / "two_link_arm.urdf")))
    rng = np.random.default_rng(1)
    for _ in range(20):
        q, v, a = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2), rng.uniform(-9, 9, 2)
        np.testing.assert_allclose(model.M(q), lumped.M(q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(model.coriolis(q, v), lumped.C(q, v) @ v, atol=1e-12)
        np.testing.assert_allclose(model.G(q), lumped.G(q), atol=1e-12)
        np.testing.assert_allclose(
            model.inverse_dynamics(q, v, a), lumped.inverse_dynamics(q, v, a, friction=True),
            atol=1e-12,
        )  # fmt: skip
    np.testing.assert_allclose(model.M0(), lumped.M0(), atol=1e-14)
    np.testing.assert_allclose(model.B(), lumped.B(), atol=1e-14)
    np.testing.assert_allclose(model.coulomb_levels(), lumped.coulomb_levels(), atol=1e-14)


def test_three_link_dynamics_agree_with_an_independent_newton_euler(three_link):
    assert three_link.joints == ("joint1", "joint2", "joint3")
    _assert_inverse_dynamics(three_link, planar_newton_euler, states=50, speed=3, seed=2)


def test_m0_is_the_exact_mean_of_the_mass_matrix_over_joint_turns(three_link):
    coarse, fine = three_link.mean_mass_matrix(3), three_link.mean_mass_matrix(6)
    np.testing.assert_allclose(coarse, fine, rtol=0, atol=1e-14)
    np.testing.assert_allclose(three_link.M0(), fine, atol=1e-14)
    # The mean of M over q3 at random q2 by fine quadrature gives the same matrix.
    rng = np.random.default_rng(3)
    angles = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    brute = np.mean(
        [three_link.M(np.array([rng.uniform(-3, 3), q2, q3])) for q2 in angles for q3 in angles],
        axis=0,
    )
    np.testing.assert_allclose(three_link.M0(), brute, atol=1e-12)


def _edited(tmp_path: Path, old: str, new: str, count: int = 1) -> Path:
    text = (URDF / "three_link_arm.urdf").read_text()
    assert old in text
    path = tmp_path / "arm.urdf"
    path.write_text(text.replace(old, new, count))
    return path


@pytest.mark.parametrize(
    ("old", "new", "needle"),
    [
        ('<joint name="joint3" type="continuous">', '<joint name="joint3" type="spherical">',
         "joint 'joint3' type = spherical; revolute or continuous is required"),
        ('<parent link="link2"/>\n    <child link="link3"/>',
         '<parent link="link1"/>\n    <child link="link3"/>',
         "link 'link1' carries the arm joints joint2, joint3"),
        ('<posfb:motor_constant value="1.2"/>', "",
         "actuator posfb:motor_constant of joints joint3 = (missing)"),
        ('<mass value="0.5"/>', '<mass value="0"/>', "link 'link3' mass = 0"),
        ('<posfb:coulomb_friction value="2.5"/>', "",
         "posfb:coulomb_friction of joints joint2 = (missing)"),
    ],
)  # fmt: skip
def test_bad_arms_are_refused_in_one_line_naming_the_element(tmp_path, old, new, needle):
    with pytest.raises(ValueError, match=re.escape(needle)) as error:
        SerialArmModel(_edited(tmp_path, old, new))
    assert len(str(error.value).splitlines()) == 1


def test_the_christoffel_matrix_is_table_1s_and_gives_the_bias_term(three_link):
    model = SerialArmModel(URDF / "two_link_arm.urdf")
    lumped = LumpedModel(identify_urdf(str(URDF / "two_link_arm.urdf")))
    rng = np.random.default_rng(4)
    for _ in range(10):
        q, v = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2)
        np.testing.assert_allclose(model.C(q, v), lumped.C(q, v), atol=1e-12)
        q3, v3 = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-3, 3, 3)
        np.testing.assert_allclose(three_link.C(q3, v3) @ v3, three_link.coriolis(q3, v3),
                                   atol=1e-12)  # fmt: skip


@pytest.mark.slow
def test_sampled_assumption_1_norms_equal_the_two_link_closed_forms(tmp_path):
    from posfb.analysis.uncertainty.coverage import uncertainty_norms as closed_form
    from posfb.models.serial_bounds import BOUND_NAMES, uncertainty_norms

    text = (URDF / "two_link_arm.urdf").read_text()
    heavier = text.replace('<mass value="0.873"/>', '<mass value="1.1"/>')
    heavier = heavier.replace('damping="1.45414"', 'damping="1.2"')
    heavier = heavier.replace('value="1.93894"', 'value="1.7"')
    heavier = heavier.replace('<origin xyz="0.2 0 0" rpy="0 0 0"/>', '<origin xyz="0.21 0 0"/>')
    (tmp_path / "true.urdf").write_text(heavier)
    true, nominal = tmp_path / "true.urdf", URDF / "two_link_arm.urdf"
    sampled = uncertainty_norms(SerialArmModel(true), SerialArmModel(nominal), samples=128)
    expected = closed_form(identify_urdf(str(true)), identify_urdf(str(nominal)))
    assert sampled.converged()
    for name in BOUND_NAMES:
        assert sampled.norms[name] == pytest.approx(expected[name], rel=1e-9), name


@pytest.mark.slow  # over 10 s on 2 cores (issue 45, item 4)
def test_sampled_norms_of_the_three_link_arm_bound_every_random_state(tmp_path, three_link):
    from posfb.models.serial_bounds import uncertainty_norms

    path = _edited(tmp_path, '<mass value="0.5"/>', '<mass value="0.6"/>')
    true = SerialArmModel(path)
    same = uncertainty_norms(three_link, SerialArmModel(URDF / "three_link_arm.urdf"), 16)
    assert all(value == 0.0 for value in same.norms.values())
    sampled = uncertainty_norms(true, three_link, samples=128)
    assert sampled.converged(1e-6)
    assert sampled.norms["delta_M1"] > 0 and sampled.norms["delta_G"] > 0
    rng = np.random.default_rng(5)
    M0 = (three_link.M0(), true.M0())
    for _ in range(300):
        q, x = rng.uniform(-np.pi, np.pi, 3), rng.normal(size=3)
        x /= np.linalg.norm(x)
        m1 = np.linalg.norm((three_link.M(q) - M0[0]) - (true.M(q) - M0[1]), 2)
        c = np.linalg.norm(three_link.C(q, x) - true.C(q, x), 2)
        g = np.linalg.norm(three_link.G(q) - true.G(q))
        assert m1 <= sampled.norms["delta_M1"] * (1 + 1e-9)
        assert c <= sampled.norms["delta_C"] * (1 + 1e-9)
        assert g <= sampled.norms["delta_G"] * (1 + 1e-9)


def test_the_linear_design_is_sized_by_the_arm(three_link):
    """Eq. 5-6, 11, 13-15 and the sampled-data check on the three-link arm's M0*, B*:
    a 9-state augmented system, a stabilising LQR, and a sampled loop whose spectral
    radius tends to exp(T_s max Re s) of the continuous loop as T_s -> 0."""
    from posfb.models.design.augmented import augmented_system, solve_lqr
    from posfb.models.design.closed_loop import (
        continuous_closed_loop,
        sampled_data_closed_loop,
        spectral_radius,
    )
    from posfb.models.design.realisation import linear_control_filter

    M0, B = three_link.M0(), three_link.B()
    system = augmented_system(M0, B, np.array([50.0, 50.0, 50.0]))
    assert system.A_a.shape == (9, 9) and system.B_a1.shape == (9, 3)
    lqr = solve_lqr(system, np.diag([1e4] * 3 + [10.0] * 3 + [1.0] * 3), np.eye(3))
    assert lqr.K.shape == (3, 9)
    assert np.linalg.eigvals(system.A_a - system.B_a1 @ lqr.K).real.max() < 0
    lc = linear_control_filter(lqr.K1, lqr.K2, lqr.K3, system.A_eta)
    slowest = np.linalg.eigvals(continuous_closed_loop(M0, B, lc, np.eye(3))).real.max()
    assert slowest < 0
    for T in (1e-4, 1e-5):
        discrete = lc.discretise(T, "foh")  # FOH: the O(T^2) error below
        radius = spectral_radius(sampled_data_closed_loop(M0, B, discrete, np.eye(3), T))
        assert radius < 1
        assert radius == pytest.approx(np.exp(slowest * T), abs=T**2 * abs(slowest))  # error O(T^2)


#: The six-joint arm as typed from its table (``urdf/six_joint_arm.urdf`` comments):
#: joint origin in the parent link, origin roll-pitch-yaw, axis; link mass, cylinder
#: radius and length along the link's z axis (centre of mass at half the length);
#: gear ratio, rotor inertia, damping, Coulomb level, motor constant.
HALF_PI = 1.5707963267948966
SIX_JOINTS = [
    ((0, 0, 0.089159), (0, 0, 0), (0, 0, 1)),
    ((0, 0.13585, 0), (0, HALF_PI, 0), (0, 1, 0)),
    ((0, -0.1197, 0.425), (0, 0, 0), (0, 1, 0)),
    ((0, 0, 0.39225), (0, HALF_PI, 0), (0, 1, 0)),
    ((0, 0.093, 0), (0, 0, 0), (0, 0, 1)),
    ((0, 0, 0.09465), (0, 0, 0), (0, 1, 0)),
]
SIX_LINKS = [
    (3.7, 0.06, 0.15), (8.393, 0.054, 0.425), (2.275, 0.04, 0.39225),
    (1.219, 0.04, 0.12), (1.219, 0.04, 0.12), (0.1879, 0.0375, 0.0345),
]  # fmt: skip
SIX_MOTORS = [
    (101, 6.0e-5, 20.0, 10.0, 12.0), (101, 6.0e-5, 20.0, 10.0, 12.0),
    (101, 6.0e-5, 15.0, 8.0, 12.0), (101, 1.5e-5, 5.0, 2.0, 3.0),
    (101, 1.5e-5, 5.0, 2.0, 3.0), (101, 1.5e-5, 5.0, 2.0, 3.0),
]  # fmt: skip


def _rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (np.cos, np.sin))
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _about(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation by ``angle`` about the unit ``axis``."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def spatial_newton_euler(q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Joint voltages of the six-joint arm by recursive Newton-Euler in world
    coordinates, from the tables above (no Drake): gravity as an upward base
    acceleration, then the motor stage divided by the motor constants."""
    rotation, origin = np.eye(3), np.zeros(3)
    omega, alpha, acceleration = np.zeros(3), np.zeros(3), np.array([0.0, 0.0, GRAVITY])
    frames = []
    for (xyz, rpy, axis), (mass, radius, length), qi, vi, ai in zip(
        SIX_JOINTS, SIX_LINKS, q, v, a, strict=True
    ):
        offset = rotation @ np.array(xyz, dtype=float)
        acceleration = (
            acceleration + np.cross(alpha, offset) + np.cross(omega, np.cross(omega, offset))
        )
        origin = origin + offset
        rotation = rotation @ _rpy(*rpy)
        z = rotation @ np.array(axis, dtype=float)
        rotation = rotation @ _about(np.array(axis, dtype=float), qi)
        alpha = alpha + z * ai + np.cross(omega, z * vi)
        omega = omega + z * vi
        com = rotation @ np.array([0.0, 0.0, length / 2])
        com_acceleration = (
            acceleration + np.cross(alpha, com) + np.cross(omega, np.cross(omega, com))
        )
        across = mass * (3 * radius**2 + length**2) / 12
        inertia = rotation @ np.diag([across, across, mass * radius**2 / 2]) @ rotation.T
        frames.append((origin, z, com, mass, com_acceleration, inertia, omega, alpha))
    torque = np.zeros(len(q))
    force_next, moment_next, origin_next = np.zeros(3), np.zeros(3), None
    for i in reversed(range(len(q))):
        origin, z, com, mass, com_acceleration, inertia, omega, alpha = frames[i]
        inertial_force = mass * com_acceleration
        moment = (
            inertia @ alpha
            + np.cross(omega, inertia @ omega)
            + np.cross(com, inertial_force)
            + moment_next
        )
        if origin_next is not None:
            moment = moment + np.cross(origin_next - origin, force_next)
        force_next = inertial_force + force_next
        moment_next, origin_next = moment, origin
        torque[i] = z @ moment
    gear, rotor, damping, coulomb, kappa = np.array(SIX_MOTORS, dtype=float).T
    torque += rotor * gear**2 * a + damping * v + coulomb * np.sign(v)
    return torque / kappa


def test_a_spatial_six_joint_arm_agrees_with_an_independent_newton_euler():
    model = SerialArmModel(URDF / "six_joint_arm.urdf")
    assert model.size == 6
    _assert_inverse_dynamics(model, spatial_newton_euler, states=30, speed=2, seed=6)
    np.testing.assert_allclose(model.M0(), model.mean_mass_matrix(6), atol=1e-13)
