"""The two implementations of the motor and friction blocks (``models.drive``): the same
physics, parameters per Context, and the same closed loop where the loop does not
amplify round-off."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from helpers.paths import REPO
from posfb.diagrams.resolve import load_scenario, run_scenario
from posfb.models.plant import (
    DEFAULT_URDF,
    ArmParameters,
    PlantConfig,
    apply_parameters,
    build_arm_diagram,
    energy_accounts,
    read_parameters,
)

ARMS = [DEFAULT_URDF, DEFAULT_URDF.parent / "three_link_arm.urdf"]


def _plant_accelerations(blocks: str, urdf, states, voltages, parameters=None) -> np.ndarray:
    """The arm's joint accelerations at each (state, voltage)."""
    diagram, arm, context = build_arm_diagram(
        PlantConfig(urdf=str(urdf), motor_friction_blocks=blocks), parameters
    )
    plant = arm.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    n = arm.size
    rows = []
    for state, voltage in zip(states, voltages, strict=True):
        plant.SetPositionsAndVelocities(plant_context, state)
        diagram.get_input_port(0).FixValue(context, voltage)
        rows.append(plant.EvalTimeDerivatives(plant_context).CopyToVector()[n:])
    return np.array(rows)


@pytest.mark.parametrize("urdf", ARMS, ids=lambda path: path.stem)
def test_perceptron_blocks_give_the_symbolic_blocks_accelerations(urdf):
    """Velocities from 1e-4 rad/s (inside the tanh's knee) to 3 rad/s, voltages to 24 V."""
    n = 2 if urdf == DEFAULT_URDF else 3
    rng = np.random.default_rng(7)
    count = 40
    positions = rng.uniform(-np.pi, np.pi, (count, n))
    velocities = rng.choice([1e-4, 1e-2, 3.0], (count, n)) * rng.uniform(-1, 1, (count, n))
    states = np.hstack([positions, velocities])
    voltages = rng.uniform(-24.0, 24.0, (count, n))
    symbolic = _plant_accelerations("symbolic", urdf, states, voltages)
    perceptron = _plant_accelerations("perceptron", urdf, states, voltages)
    scale = np.abs(symbolic).max(axis=1, keepdims=True)
    assert np.max(np.abs(perceptron - symbolic) / scale) <= 1e-12


def test_perceptron_parameters_change_per_context_and_read_back():
    diagram, arm, context = build_arm_diagram(PlantConfig(motor_friction_blocks="perceptron"))
    other = diagram.CreateDefaultContext()
    apply_parameters(arm, other, arm.default_parameters)
    changed = dataclasses.replace(
        arm.default_parameters, coulomb=(8.0, 2.1), motor_constant=(6.5, 1.3), payload_mass=0.2
    )
    apply_parameters(arm, context, changed)
    assert read_parameters(arm, context).coulomb == changed.coulomb
    assert read_parameters(arm, context).motor_constant == changed.motor_constant
    assert read_parameters(arm, other) == arm.default_parameters
    # The parameters act: a sampled arm's accelerations are the symbolic arm's.
    state, voltage = np.array([[0.3, -0.4, 0.02, -0.5]]), np.array([[5.0, -3.0]])
    np.testing.assert_allclose(
        _plant_accelerations("perceptron", DEFAULT_URDF, state, voltage, changed),
        _plant_accelerations("symbolic", DEFAULT_URDF, state, voltage, changed),
        rtol=1e-12,
    )


def test_perceptron_blocks_keep_no_energy_accounts():
    _, arm, context = build_arm_diagram(PlantConfig(motor_friction_blocks="perceptron"))
    with pytest.raises(ValueError, match="motor_friction_blocks = 'perceptron'.*'symbolic'"):
        energy_accounts(arm, context)


@pytest.mark.parametrize("value", ["fast", "", None, 1])
def test_bad_blocks_are_refused_by_name(value):
    with pytest.raises(ValueError, match=r"motor_friction_blocks = .*symbolic, perceptron"):
        PlantConfig(motor_friction_blocks=value)


def test_the_two_implementations_give_the_same_lin_lc_run():
    """Lin+LC's loop is stable and its encoder counts do not flip on round-off: 5 s of
    the paper's payload scenario agree to 1e-9 rad sample by sample."""
    scenario = REPO / "analysis" / "scenarios" / "paper_payload.yaml"
    settings = ["controller.kind=lin_lc", "timing.duration=5"]
    runs = {
        blocks: run_scenario(
            load_scenario(scenario, [*settings, f"plant.motor_friction_blocks={blocks}"])
        )
        for blocks in ("symbolic", "perceptron")
    }
    symbolic, perceptron = runs["symbolic"], runs["perceptron"]
    assert symbolic.status == perceptron.status == "ok"
    np.testing.assert_allclose(perceptron.q_true, symbolic.q_true, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(perceptron.q_measured, symbolic.q_measured)


def test_default_parameters_equal_between_implementations():
    defaults = {
        blocks: build_arm_diagram(PlantConfig(motor_friction_blocks=blocks))[1].default_parameters
        for blocks in ("symbolic", "perceptron")
    }
    assert defaults["symbolic"] == defaults["perceptron"]
    assert isinstance(defaults["symbolic"], ArmParameters)
