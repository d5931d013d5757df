"""The URDF plant: per-Context parameters, energy, bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig

from posfb.models.plant import (
    ArmParameters,
    PlantConfig,
    apply_parameters,
    build_arm_diagram,
    energy_accounts,
    read_parameters,
)


def _total_energy(arm, context) -> float:
    """0.5 v' M(q) v (rotor inertia included) + gravitational potential."""
    plant = arm.plant
    plant_context = plant.GetMyContextFromRoot(context)
    v = plant.GetVelocities(plant_context)
    return 0.5 * v @ plant.CalcMassMatrix(plant_context) @ v + plant.CalcPotentialEnergy(
        plant_context
    )


def _released_energies(
    parameters: ArmParameters, duration: float = 5.0, voltage=(0.0, 0.0)
) -> np.ndarray:
    """Mechanical energy minus motor work plus friction loss, sampled over a run."""
    diagram, arm, context = build_arm_diagram(parameters=parameters)
    diagram.get_input_port(0).FixValue(context, np.asarray(voltage))
    plant_context = arm.plant.GetMyMutableContextFromRoot(context)
    arm.plant.SetPositions(plant_context, [0.2, 1.0])
    arm.plant.SetVelocities(plant_context, [1.0, -2.0])
    simulator = Simulator(diagram, context)
    ApplySimulatorConfig(
        SimulatorConfig(integration_scheme="runge_kutta5", accuracy=1e-12), simulator
    )

    def balance() -> float:
        motor_work, friction_loss = energy_accounts(arm, context)
        return _total_energy(arm, context) - motor_work + friction_loss

    energies = [balance()]
    for t in np.linspace(0.05, duration, 100):
        simulator.AdvanceTo(t)
        energies.append(balance())
    return np.array(energies)


def test_energy_is_conserved_without_damping_and_friction(arm_diagram):
    _, arm, _ = arm_diagram
    lossless = dataclasses.replace(arm.default_parameters, damping=(0, 0), coulomb=(0, 0))
    energies = _released_energies(lossless)
    drift = np.abs(energies - energies[0]).max() / abs(energies[0])
    assert drift <= 1e-6


@pytest.mark.slow
def test_energy_balance_with_motor_work_and_friction_loss(arm_diagram):
    """E(t) - E(0) = motor work - friction loss when there is no viscous damping."""
    _, arm, _ = arm_diagram
    undamped = dataclasses.replace(arm.default_parameters, damping=(0, 0))
    balance = _released_energies(undamped, duration=2.0, voltage=(3.0, -1.0))
    assert np.abs(balance - balance[0]).max() <= 1e-6 * abs(balance[0])


def test_energy_never_rises_with_damping_and_friction(arm_diagram):
    _, arm, _ = arm_diagram
    energies = []
    diagram, arm, context = build_arm_diagram()
    diagram.get_input_port(0).FixValue(context, np.zeros(2))
    plant_context = arm.plant.GetMyMutableContextFromRoot(context)
    arm.plant.SetPositions(plant_context, [0.2, 1.0])
    arm.plant.SetVelocities(plant_context, [1.0, -2.0])
    simulator = Simulator(diagram, context)
    for t in np.linspace(0.0, 2.0, 101):
        simulator.AdvanceTo(t)
        energies.append(_total_energy(arm, context))
    energies = np.array(energies)
    assert np.all(np.diff(energies) <= 1e-9 * abs(energies[0]))
    assert energies[-1] < energies[0]


def test_parameters_change_per_context_without_rebuilding(arm_diagram):
    diagram, arm, context = arm_diagram
    other = diagram.CreateDefaultContext()
    apply_parameters(arm, other, arm.default_parameters)
    changed = ArmParameters(
        link_mass=(4.0, 1.1),
        link_com=(0.18, 0.16),
        link_inertia=(0.04, 0.011),
        rotor_inertia=(1.5, 3e-5),
        damping=(15.0, 1.3),
        coulomb=(8.0, 2.1),
        motor_constant=(6.5, 1.3),
        payload_mass=0.2,
    )
    apply_parameters(arm, context, changed)
    read_back = read_parameters(arm, context)
    for field in dataclasses.fields(ArmParameters):
        np.testing.assert_allclose(
            getattr(read_back, field.name), getattr(changed, field.name), rtol=1e-12
        )
    untouched = read_parameters(arm, other)
    assert untouched == arm.default_parameters or np.allclose(
        untouched.link_mass, arm.default_parameters.link_mass
    )
    assert untouched.payload_mass == 0.0


def test_discrete_plant_option_builds():
    diagram, arm, _ = build_arm_diagram(PlantConfig(time_step=1e-3))
    assert arm.plant.time_step() == 1e-3


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("link_mass", (-1.0, 0.873)),
        ("link_mass", (5.0, float("nan"))),
        ("damping", (-0.1, 1.0)),
        ("coulomb", (1.0, float("inf"))),
        ("motor_constant", (0.0, 1.0)),
        ("payload_mass", -0.288),
    ],
)
def test_bad_physical_parameters_are_refused_by_name(arm_diagram, field, value):
    _, arm, _ = arm_diagram
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(arm.default_parameters, **{field: value})


def test_missing_urdf_names_the_file(tmp_path):
    missing = tmp_path / "nope.urdf"
    with pytest.raises(FileNotFoundError, match="nope.urdf"):
        build_arm_diagram(PlantConfig(urdf=str(missing)))


def test_malformed_urdf_names_the_file_and_the_problem(tmp_path):
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='base'>")
    with pytest.raises(ValueError, match=r"broken.urdf.*not well-formed"):
        build_arm_diagram(PlantConfig(urdf=str(broken)))


def test_urdf_without_posfb_extras_is_refused(tmp_path):
    bare = tmp_path / "bare.urdf"
    bare.write_text("<robot name='x'><link name='base'/></robot>")
    with pytest.raises(ValueError, match="motor_constant"):
        build_arm_diagram(PlantConfig(urdf=str(bare)))


@pytest.mark.parametrize(("field", "value"), [("time_step", -1e-3), ("friction_velocity", 0.0)])
def test_bad_plant_config_is_refused(field, value):
    with pytest.raises(ValueError, match=field):
        PlantConfig(**{field: value})


def test_context_without_parameters_fails_loudly():
    """The symbolic blocks' parameters default to NaN: a Context that never got
    apply_parameters cannot be simulated silently with wrong physics."""
    diagram, arm, _ = build_arm_diagram()
    context = diagram.CreateDefaultContext()
    diagram.get_input_port(0).FixValue(context, [10.0, 10.0])
    with pytest.raises(RuntimeError, match="NaN"):
        diagram.EvalTimeDerivatives(context)
    apply_parameters(arm, context, arm.default_parameters)
    assert np.all(np.isfinite(diagram.EvalTimeDerivatives(context).CopyToVector()))
