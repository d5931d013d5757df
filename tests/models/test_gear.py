"""Gear compliance, backlash and the encoder on the motor shaft (``models.gear``): each
test against a closed form or an independent computation."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.primitives import FirstOrderTaylorApproximation

from helpers.loop_checks import assert_position_only
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.runner import ClosedLoopRunner
from posfb.diagrams.scenario import Scenario
from posfb.diagrams.sections import Sensor
from posfb.diagrams.structure import structure_key
from posfb.models.gear import GearConfig, _gear_system
from posfb.models.plant import (
    PlantConfig,
    build_arm_diagram,
    read_parameters,
    set_gear,
    set_motor_state,
)


def _gear_alone(k: float, c: float, b: float, inertia: float, tau: float):
    """One joint's gear block with the link held (``q = q' = 0``) and a constant motor
    torque ``tau``."""
    system = _gear_system(1)
    context = system.CreateDefaultContext()
    context.get_mutable_numeric_parameter(0).SetFromVector([k, c, b, inertia])
    system.get_input_port(0).FixValue(context, [tau, 0.0, 0.0])
    return system, context


@pytest.mark.parametrize("b", [0.0, 0.004])
@pytest.mark.parametrize("tau", [2.0, -3.0])
def test_link_held_constant_motor_torque_deflects_tau_over_k_plus_b(tau, b):
    k, inertia = 1500.0, 0.01
    c = 2.0 * np.sqrt(k * inertia)  # critically damped: settles in a few 1/omega
    system, context = _gear_alone(k, c, b, inertia, tau)
    simulator = Simulator(system, context)
    simulator.get_mutable_integrator().set_target_accuracy(1e-10)
    simulator.AdvanceTo(2.0)
    theta, omega = context.get_continuous_state_vector().CopyToVector()[:2]
    assert theta == pytest.approx(tau / k + np.sign(tau) * b, rel=1e-7)
    assert abs(omega) < 1e-9
    output = system.get_output_port(0).Eval(context)
    assert output[0] == pytest.approx(tau, rel=1e-7)  # the gear passes the whole torque
    assert output[1] == theta


def _compliant_arm(k=2000.0, c=0.0, b=0.0, rotor=None):
    config = PlantConfig(gear=GearConfig((k,), (c,), (b,)))
    diagram, arm, context = build_arm_diagram(config)
    if rotor is not None:
        parameters = dataclasses.replace(arm.default_parameters, rotor_inertia=rotor)
        diagram, arm, context = build_arm_diagram(config, parameters)
    return diagram, arm, context


def test_reversal_through_the_backlash_has_a_dead_band_of_2b():
    """Sweep the motor angle up and back down around the link's angle; the gear torque
    that reaches the plant's actuation port is 0 exactly over a motor span of 2b."""
    b, k = 0.003, 2000.0
    diagram, arm, context = _compliant_arm(k=k, b=b)
    plant = arm.plant
    q = np.array([0.3, -0.2])
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), q)
    diagram.get_input_port(0).FixValue(context, np.zeros(2))
    sweep = np.linspace(-0.01, 0.01, 2001)
    spans = []
    for direction in (sweep, sweep[::-1]):
        zero = []
        for offset in direction:
            arm.gear.set_state(context, q + offset, np.zeros(2))
            torque = plant.get_actuation_input_port().Eval(plant.GetMyContextFromRoot(context))
            beyond = max(abs(offset) - b, 0.0) * np.sign(offset)
            np.testing.assert_allclose(torque, k * beyond, atol=1e-12)
            if np.all(torque == 0.0):
                zero.append(offset)
        spans.append(max(zero) - min(zero))
    grid = sweep[1] - sweep[0]
    for span in spans:
        assert 2 * b - 2 * grid - 1e-9 <= span <= 2 * b + 1e-9  # grid points at +-b may round out


#: Joint 2's J_m raised from 2.4e-5 to keep the open-loop runs quick.
QUICK_ROTOR = (1.69824, 1e-3)


def _open_loop_path(config: PlantConfig, gear: GearConfig | None = None) -> np.ndarray:
    """q every 10 ms over 0.3 s under a constant voltage (3 V, 1 V), rotor inertia
    ``QUICK_ROTOR``; ``gear``: values set in the Context after building."""
    diagram, arm, context = build_arm_diagram(config)
    parameters = dataclasses.replace(arm.default_parameters, rotor_inertia=QUICK_ROTOR)
    diagram, arm, context = build_arm_diagram(config, parameters)
    if gear is not None:
        set_gear(arm, context, gear)
    diagram.get_input_port(0).FixValue(context, np.array([3.0, 1.0]))
    simulator = Simulator(diagram, context)
    simulator.get_mutable_integrator().set_target_accuracy(1e-7)
    path = []
    for t in np.arange(0.01, 0.3001, 0.01):
        simulator.AdvanceTo(t)
        path.append(arm.plant.GetPositions(arm.plant.GetMyContextFromRoot(context)))
    return np.array(path)


def _damping(k: float, inertia: float) -> float:
    """Damping ratio 0.7 for stiffness ``k`` against ``inertia``."""
    return 2 * 0.7 * np.sqrt(k * inertia)


def test_a_stiff_gear_approaches_the_rigid_arm():
    """Open loop, a constant voltage for 0.3 s: |q_k - q_rigid| shrinks with k (the
    static deflection is tau / k; measured about 20x over these two decades)."""
    rigid = _open_loop_path(PlantConfig())
    errors = []
    for k in (1e3, 1e4, 1e5):
        c = tuple(_damping(k, j) for j in QUICK_ROTOR)
        errors.append(
            np.max(np.abs(_open_loop_path(PlantConfig(gear=GearConfig((k,), c))) - rigid))
        )
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < errors[0] / 10.0
    assert errors[2] < 1e-3


def test_a_rigid_joint_beside_a_compliant_one_is_the_stiff_limit():
    """Joint 1 compliant, joint 2 rigid (k_2 = 0): the limit of joint 2 growing stiff.
    Same 0.3 s open-loop run; |q - q_mixed| shrinks with k_2 as in the all-joint case."""
    k1 = 3000.0
    c1 = _damping(k1, QUICK_ROTOR[0])
    mixed = _open_loop_path(PlantConfig(gear=GearConfig((k1, 0.0), (c1, 0.0))))
    errors = []
    for k2 in (1e3, 1e4, 1e5):
        gear = GearConfig((k1, k2), (c1, _damping(k2, QUICK_ROTOR[1])))
        errors.append(np.max(np.abs(_open_loop_path(PlantConfig(gear=gear)) - mixed)))
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < errors[0] / 10.0
    assert errors[2] < 1e-3


def test_every_joint_rigid_in_the_gear_block_is_the_rigid_arm():
    """The gear block with k = 0 at every joint (set per Context) passes the motor torque
    through and puts J_m back on the actuators: the run equals the arm built without the
    block (to round-off: the block's idle states add nothing to the error norm)."""
    rigid = _open_loop_path(PlantConfig())
    in_block = _open_loop_path(PlantConfig(gear=GearConfig((2000.0,))), gear=GearConfig())
    np.testing.assert_allclose(in_block, rigid, rtol=0.0, atol=1e-12)


def test_a_rigid_joint_passes_the_torque_and_reads_its_link():
    """In a mixed gear the rigid joint's gear torque is its motor torque exactly, its
    motor angle is its link angle, and its actuator keeps J_m."""
    gear = GearConfig((2000.0, 0.0))
    diagram, arm, context = build_arm_diagram(PlantConfig(gear=gear))
    plant = arm.plant
    plant_context = plant.GetMyContextFromRoot(context)
    q, v = np.array([0.3, -0.2]), np.array([0.5, -0.7])
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), q)
    plant.SetVelocities(plant.GetMyMutableContextFromRoot(context), v)
    arm.gear.set_state(context, q + 0.01, np.zeros(2))
    diagram.get_input_port(0).FixValue(context, np.array([4.0, -6.0]))
    motor = arm.gear.motor_torque_input_port()
    tau_m = motor.Eval(arm.gear._input.GetMyContextFromRoot(context))
    tau_g = plant.get_actuation_input_port().Eval(plant_context)
    assert tau_g[1] == tau_m[1]
    assert tau_g[0] == pytest.approx(2000.0 * 0.01, rel=1e-12)
    theta, omega = arm.gear.state(context)
    assert (theta[1], omega[1]) == (q[1], v[1])
    assert theta[0] == q[0] + 0.01
    ratio = plant.GetJointActuatorByName(arm.layout.actuators[1]).default_gear_ratio()
    rotor = [
        plant.GetJointActuatorByName(a).rotor_inertia(plant_context) for a in arm.layout.actuators
    ]
    assert rotor == [0.0, arm.default_parameters.rotor_inertia[1] / ratio**2]


def test_natural_frequencies_match_the_two_mass_eigenproblem():
    """Linearised at rest (no friction, no damping): the oscillation frequencies are
    those of ``[M 0; 0 J_m] x'' + [K -K; -K K] x = 0`` with ``M`` the MultibodyPlant's
    mass matrix without rotor inertia (computed here independently); for one joint alone
    the closed form is ``sqrt(k (1/J_m + 1/J_link))``."""
    k = np.array([3000.0, 800.0])
    config = PlantConfig(gear=GearConfig(tuple(k)))
    diagram, arm, context = build_arm_diagram(config)
    parameters = dataclasses.replace(
        arm.default_parameters, coulomb=(0.0, 0.0), damping=(0.0, 0.0), rotor_inertia=(0.2, 0.01)
    )
    diagram, arm, context = build_arm_diagram(config, parameters)
    q0 = np.array([0.0, 0.7])
    arm.plant.SetPositions(arm.plant.GetMyMutableContextFromRoot(context), q0)
    set_motor_state(arm, context)
    theta, omega = arm.gear.state(context)
    arm.gear.set_state(context, theta + 1e-6, omega)  # off the dead zone's kink at d = 0
    diagram.get_input_port(0).FixValue(context, np.zeros(2))
    linear = FirstOrderTaylorApproximation(diagram, context)
    found = np.sort(np.abs(np.linalg.eigvals(linear.A()).imag))
    found = np.unique(np.round(found[found > 1e-6], 6))

    mass = np.zeros((4, 4))
    plant_context = arm.plant.GetMyContextFromRoot(context)
    mass[:2, :2] = arm.plant.CalcMassMatrix(plant_context)  # rotor inertia 0 in the plant
    mass[2:, 2:] = np.diag(read_parameters(arm, context).rotor_inertia)
    stiffness = np.block([[np.diag(k), -np.diag(k)], [-np.diag(k), np.diag(k)]])
    squared = np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real
    expected = np.sort(np.sqrt(squared[squared > 1e-6]))
    # found also holds a slow rigid-body mode (~1 rad/s: the state 1e-6 off equilibrium
    # and the arm's own statics); the two gear modes agree to the 1e-6 offset's effect
    np.testing.assert_allclose(found[found > 10.0], expected, rtol=1e-4)

    # one joint alone: joint 2's block with link 2 as a rigid body of inertia M_22 about
    # its joint (joint 1 held): the two-mass closed form
    j_link, j_motor = mass[1, 1], 0.01
    one = np.sqrt(k[1] * (1 / j_motor + 1 / j_link))
    sub = np.array([[k[1] / j_link, -k[1] / j_link], [-k[1] / j_motor, k[1] / j_motor]])
    assert np.sqrt(np.max(np.linalg.eigvals(sub).real)) == pytest.approx(one, rel=1e-12)


@pytest.fixture(scope="module")
def motor_runner():
    config = ClosedLoopConfig(
        sensor=Sensor(encoder_counts=[0], location="motor"),
        plant=PlantConfig(gear=GearConfig((4000.0,), (2.0,))),
    )
    return ClosedLoopRunner(config)


def test_the_encoder_on_the_motor_reads_theta_m(motor_runner):
    loop = motor_runner.loop
    context = motor_runner.new_context()
    q = loop.arm.plant.GetPositions(loop.arm.plant.GetMyContextFromRoot(context))
    theta = q + np.array([0.013, -0.021])
    loop.arm.gear.set_state(context, theta, np.zeros(2))
    measured = loop.encoder.GetOutputPort("q_measured").Eval(
        loop.encoder.GetMyContextFromRoot(context)
    )
    np.testing.assert_array_equal(measured, theta)  # ideal encoder: theta_m itself, not q


def test_motor_encoder_keeps_the_position_only_structure(motor_runner):
    assert_position_only(motor_runner.loop, "motor")


def test_gear_values_are_per_context_and_rotor_inertia_moves_to_the_motor(motor_runner):
    arm = motor_runner.arm
    first = motor_runner.new_context()
    second = motor_runner.new_context(gear=GearConfig((9000.0, 7000.0), (0.5,), (0.001,)))
    np.testing.assert_array_equal(arm.gear.gear(first)[0], [4000.0, 4000.0])
    np.testing.assert_array_equal(arm.gear.gear(second)[0], [9000.0, 7000.0])
    np.testing.assert_array_equal(arm.gear.gear(second)[2], [0.001, 0.001])
    plant = arm.plant
    plant_context = plant.GetMyContextFromRoot(first)
    for name in arm.layout.actuators:  # J_m left the MultibodyPlant
        assert plant.GetJointActuatorByName(name).rotor_inertia(plant_context) == 0.0
    assert read_parameters(arm, first).rotor_inertia == arm.default_parameters.rotor_inertia
    rigid = plant.GetMyContextFromRoot(motor_runner.new_context(gear=GearConfig()))
    defaults = arm.default_parameters.rotor_inertia
    for name, inertia in zip(arm.layout.actuators, defaults, strict=True):
        actuator = plant.GetJointActuatorByName(name)  # k = 0: J_m back on the actuator
        assert actuator.rotor_inertia(rigid) * actuator.default_gear_ratio() ** 2 == pytest.approx(
            inertia, rel=1e-15
        )


def test_compliance_is_structure_and_its_values_are_not():
    def key(**plant):
        scenario = Scenario()
        for name, value in plant.items():
            setattr(scenario.plant, name, value)
        return structure_key(scenario, "pid")

    assert key() == key(gear_stiffness=[0.0])
    assert key(gear_stiffness=[1e3]) == key(
        gear_stiffness=[5e3, 2e3], gear_damping=[1.0], backlash=[0.001]
    )
    assert key() != key(gear_stiffness=[1e3])


def test_a_compliant_joint_needs_its_own_motor_inertia():
    config = PlantConfig(gear=GearConfig((1000.0, 0.0)))
    diagram, arm, context = build_arm_diagram(config)
    zero = dataclasses.replace(arm.default_parameters, rotor_inertia=(0.0, 1e-3))
    needle = r"rotor_inertia\[0\] \(or the URDF's\) = 0.*gear_stiffness\[0\]"
    with pytest.raises(ValueError, match=needle):
        build_arm_diagram(config, zero)
    rigid_zero = dataclasses.replace(arm.default_parameters, rotor_inertia=(1.0, 0.0))
    build_arm_diagram(config, rigid_zero)  # a rigid joint may have J_m = 0
