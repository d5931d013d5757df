"""Friction laws (``models.friction``): each against its closed form or an independent
computation; per-Context parameters; closed-loop runs and a Monte-Carlo study that
draws a law parameter."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, PassThrough

import posfb
from helpers.montecarlo_helpers import run_into_store
from posfb.analysis.cli import main
from posfb.analysis.montecarlo.store import ResultStore
from posfb.diagrams.scenario import Scenario, apply_setting
from posfb.diagrams.structure import structure_key
from posfb.models.friction import REGISTRY
from posfb.models.friction.block import SymbolicFriction
from posfb.models.friction.lugre import LuGre
from posfb.models.friction.stribeck import Stribeck
from posfb.models.friction.tanh_coulomb import TanhCoulomb
from posfb.models.plant import (
    PlantConfig,
    apply_parameters,
    build_arm_diagram,
    energy_accounts,
    set_friction_law,
)

LEVELS = (2.0, 0.5)  # f_c, N m
V_S = 0.01  # rad/s


def _block(settings: object, velocity, levels=LEVELS, v_s=V_S):
    """The law's block alone, fed a constant velocity (a parameter of the source)."""
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource(np.asarray(velocity, dtype=float)))
    sink = builder.AddSystem(PassThrough(len(levels)))
    block = SymbolicFriction(builder, settings, source.get_output_port(0), sink.get_input_port(0))
    builder.ExportOutput(sink.get_output_port(0), "force")
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    block.set_coulomb(context, levels, v_s)
    block.set_law(context, settings)

    def set_velocity(value) -> None:
        source_context = source.GetMyMutableContextFromRoot(context)
        source.get_mutable_source_value(source_context).set_value(np.asarray(value, float))

    return diagram, block, context, set_velocity


def _force(settings: object, velocity, **kwargs) -> np.ndarray:
    diagram, _, context, _ = _block(settings, velocity, **kwargs)
    return diagram.get_output_port(0).Eval(context)


def _stribeck_curve(v, level, ratio, v_st):
    """``g(v) = f_c + (f_s - f_c) exp(-(v / v_st)^2)`` in numpy."""
    return level + (ratio * level - level) * np.exp(-((v / v_st) ** 2))


@pytest.mark.parametrize("v", [-0.3, -0.02, 0.004, 0.05, 1.0])
def test_stribeck_force_at_steady_velocities_is_its_formula(v):
    law = Stribeck(static_ratio=[1.5, 2.0], stribeck_velocity=[0.05, 0.02])
    velocity = np.array([v, -v])
    force = _force(law, velocity)
    ratio, v_st = np.array([1.5, 2.0]), np.array([0.05, 0.02])
    expected = -_stribeck_curve(velocity, np.array(LEVELS), ratio, v_st) * np.tanh(velocity / V_S)
    np.testing.assert_allclose(force, expected, rtol=1e-14, atol=0.0)


def test_stribeck_tends_to_tanh_coulomb_far_above_the_stribeck_velocity():
    velocity = np.array([40.0, -40.0]) * 0.05  # 40 v_st: exp(-1600) underflows
    law = Stribeck(static_ratio=[3.0], stribeck_velocity=[0.05])
    np.testing.assert_array_equal(_force(law, velocity), _force(TanhCoulomb(), velocity))
    near = np.array([0.1, -0.1])  # 2 v_st: 3 % of the static excess is left
    gap = _force(law, near) - _force(TanhCoulomb(), near)
    np.testing.assert_allclose(gap, -2.0 * np.array(LEVELS) * np.exp(-4.0) * np.sign(near))


@pytest.mark.parametrize("v", [-1.0, -0.003, 0.0, 0.001, 0.2])
def test_stribeck_with_static_ratio_one_is_tanh_coulomb(v):
    velocity = np.array([v, 2 * v])
    law = Stribeck(static_ratio=[1.0], stribeck_velocity=[0.05])
    np.testing.assert_array_equal(_force(law, velocity), _force(TanhCoulomb(), velocity))


def _simulate_block(settings: object, velocity, duration: float):
    diagram, block, context, set_velocity = _block(settings, velocity)
    simulator = Simulator(diagram, context)
    ApplySimulatorConfig(
        SimulatorConfig(integration_scheme="runge_kutta5", accuracy=1e-10), simulator
    )
    simulator.AdvanceTo(duration)
    return diagram, block, context, set_velocity


@pytest.mark.parametrize("v", [0.2, -0.003])
def test_lugre_steady_sliding_force_is_its_stribeck_curve(v):
    """At constant v, dz/dt = 0 gives z = g(v) sgn(v) / sigma0 and f = -g(v) sgn(v)."""
    law = LuGre(static_ratio=[1.5], stribeck_velocity=[0.01], sigma0=[1e4], sigma1=[30.0])
    velocity = np.array([v, v])
    g = _stribeck_curve(velocity, np.array(LEVELS), 1.5, 0.01)
    settle = 20 * float(np.max(g)) / (1e4 * abs(v))  # 20 time constants of z
    diagram, block, context, _ = _simulate_block(law, velocity, settle)
    np.testing.assert_allclose(block.law_states(context), g * np.sign(v) / 1e4, rtol=1e-5)
    force = diagram.get_output_port(0).Eval(context)
    np.testing.assert_allclose(force, -g * np.sign(velocity), rtol=1e-5)


def test_lugre_presliding_stiffness_is_sigma0():
    """From rest, a displacement dq far below g / sigma0 and a stop: f / dq -> -sigma0."""
    sigma0, dq, duration = 1e4, 1e-8, 0.01
    law = LuGre(static_ratio=[1.5], stribeck_velocity=[0.01], sigma0=[sigma0], sigma1=[30.0])
    diagram, block, context, set_velocity = _simulate_block(law, [dq / duration] * 2, duration)
    set_velocity([0.0, 0.0])
    stiffness = -diagram.get_output_port(0).Eval(context) / dq
    # The bristle law's own correction is sigma0 dq / g ~ 1e-4 relative.
    np.testing.assert_allclose(stiffness, sigma0, rtol=1e-3)


def test_one_diagram_takes_the_law_parameters_per_context():
    diagram, arm, first = build_arm_diagram(PlantConfig(friction=Stribeck()))
    second = diagram.CreateDefaultContext()
    apply_parameters(arm, second, arm.default_parameters)
    set_friction_law(arm, second, Stribeck(static_ratio=[2.5], stribeck_velocity=[0.05]))
    forces = []
    for context in (first, second):
        plant_context = arm.plant.GetMyMutableContextFromRoot(context)
        arm.plant.SetVelocities(plant_context, [0.02, -0.03])
        forces.append(arm.plant.get_applied_generalized_force_input_port().Eval(plant_context))
    levels = np.array(arm.default_parameters.coulomb)
    v = np.array([0.02, -0.03])
    for force, ratio in zip(forces, (1.5, 2.5), strict=True):
        expected = -_stribeck_curve(v, levels, ratio, 0.05) * np.tanh(v / 0.01)
        np.testing.assert_allclose(force, expected, rtol=1e-14)
    assert not np.allclose(forces[0], forces[1])
    with pytest.raises(ValueError, match="a new diagram is required"):
        set_friction_law(arm, second, LuGre())


@pytest.mark.parametrize(
    "law", [Stribeck(), LuGre(sigma0=[1e3], sigma1=[10.0], stribeck_velocity=[0.01])]
)
def test_energy_balance_holds_with_the_new_laws(law):
    """Without viscous damping, E(t) - E(0) = motor work - work against friction."""
    config = PlantConfig(friction=law)
    _, arm, _ = build_arm_diagram(config)
    undamped = dataclasses.replace(arm.default_parameters, damping=(0, 0))
    diagram, arm, context = build_arm_diagram(config, undamped)
    diagram.get_input_port(0).FixValue(context, np.array([3.0, -1.0]))
    plant, plant_context = arm.plant, arm.plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, [0.2, 1.0])
    plant.SetVelocities(plant_context, [1.0, -2.0])

    def balance() -> float:
        v = plant.GetVelocities(plant_context)
        energy = 0.5 * v @ plant.CalcMassMatrix(plant_context) @ v
        motor, friction = energy_accounts(arm, context)
        return energy + plant.CalcPotentialEnergy(plant_context) - motor + friction

    simulator = Simulator(diagram, context)
    # A first trial step far beyond the bristles' time scale would overflow to NaN.
    config = SimulatorConfig(integration_scheme="runge_kutta5", accuracy=1e-10, max_step_size=1e-3)
    ApplySimulatorConfig(config, simulator)
    start = balance()
    simulator.AdvanceTo(0.5)
    assert energy_accounts(arm, context)[1] > 0.0
    assert abs(balance() - start) <= 1e-6 * abs(start)


@pytest.mark.parametrize(
    "law",
    ["!TanhCoulomb {}", "!Stribeck {static_ratio: 1.5, stribeck_velocity: 0.05}", "!LuGre {}"],
)
@pytest.mark.slow
def test_a_closed_loop_run_finishes_with_each_law(law):
    scenario = posfb.load_scenario(set={"plant.friction": law, "timing.duration": 2})
    run = posfb.simulate(scenario, "pid")
    assert run.status == "ok", run.message
    assert np.all(np.isfinite(run.rms_q)) and max(run.rms_q) < 0.2


def test_the_registry_holds_the_three_laws_default_first():
    assert [spec.settings for spec in REGISTRY.values()] == [TanhCoulomb, Stribeck, LuGre]


def test_a_law_parameter_is_a_context_value_and_its_kind_a_structure():
    base = apply_setting(Scenario(), "plant.friction=!Stribeck {}")
    drawn = apply_setting(base, "plant.friction.static_ratio=2.25")
    lugre = apply_setting(Scenario(), "plant.friction=!LuGre {}")
    assert structure_key(base, "pid") == structure_key(drawn, "pid")
    assert structure_key(base, "pid") != structure_key(lugre, "pid")
    assert structure_key(base, "pid") != structure_key(Scenario(), "pid")


STUDY = """\
seed: 3
samples: 2
duration: 0.5
controllers: [pid]
settings: ["plant.friction=!Stribeck {stribeck_velocity: 0.05}"]
draws:
  plant.friction.static_ratio: !Uniform {min: 1.0, max: 3.0}
"""


@pytest.mark.slow
def test_a_study_draws_a_law_parameter_and_replays(tmp_path: Path, capsys):
    db = run_into_store(tmp_path / "study.sqlite", STUDY)
    with ResultStore.open_existing(db) as store:
        samples, runs = store.sample_rows(), store.run_rows()
    assert [run["status"] for run in runs] == ["ok", "ok"]
    assert all(math_ok(run["rms_q1"]) for run in runs)
    assert runs[0]["rms_q2"] != runs[1]["rms_q2"]
    assert len({str(sample["parameters"]) for sample in samples}) == 2
    out_dir = tmp_path / "replay"
    code = main(["montecarlo", "replay", "--db", str(db), "--sample", "1", "--out", str(out_dir)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "pid: matches the stored row" in out


def math_ok(value: object) -> bool:
    return isinstance(value, float) and np.isfinite(value)
