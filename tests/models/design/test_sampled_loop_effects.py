"""The sampled-loop analyses include the scenario's linear effects (issue 27, item 8):
compute delay, sensor delay, armature lag and a compliant gear
(``models.design.closed_loop.LoopEffects``, ``analysis.common.loop_effects``).

Per effect, a sweep across the value where the analysed rho crosses 1, each value also
simulated (3 s, Lin+LC near a fixed posture with ``q2 = pi/2``, where ``M(q) = M0*``;
Coulomb friction and the encoder's quantisation off, so the arm is linear there): rho <
1 where the excited loop settles, rho > 1 where its oscillation grows to the
saturation's limit cycle. Without effects the loop is today's, to round-off, checked
against the previous formula written out here."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from helpers.loop_checks import residual_oscillation
from posfb.analysis.cli.commands.design import scenario_design
from posfb.analysis.common.loop_effects import left_out, loop_effects, nominal_effects
from posfb.analysis.design.problem import TuningProblem
from posfb.analysis.design.stability_map import evaluate_point, map_setup
from posfb.diagrams.resolve import load_scenario, resolve, run_resolved
from posfb.models.design import (
    DESIGNED_LOOPS,
    CompliantGear,
    Design,
    LoopEffects,
    compute_design,
    held_design_radius,
    with_effects,
)
from posfb.models.design.closed_loop import held_plant
from posfb.models.plant import build_arm_diagram

SCENARIO = "analysis/scenarios/paper_nominal.yaml"

#: The step (rad) each joint makes from rest: the excitation of the swept runs.
STEP = 0.05

#: A linear arm: near a fixed posture (q2 = pi/2: M1*(q) = 0), no Coulomb friction, an
#: ideal encoder, a smooth step of STEP on each joint, 3 s.
QUIET = [
    "trajectory=!Wave {joints: ["
    f"{{offset: {-math.pi / 2!r}, amplitude: {STEP}, wave_amplitude: 0.0, frequency: 1.0}}, "
    f"{{offset: {math.pi / 2!r}, amplitude: {STEP}, wave_amplitude: 0.0, frequency: 1.0}}]}}",
    "plant.parameters.coulomb=[0.0, 0.0]",
    "sensor.encoder_counts=[0]",
    "timing.duration=3",
]
LIN_LC = ["controller.kind=lin_lc"]
#: Lin+LC with R / 20: a faster loop, whose rho crosses 1 within a compute delay of T_s.
FAST_LIN_LC = [*LIN_LC, "controller.R=[[2.5e-05, 0.0], [0.0, 7.5e-05]]"]

#: (entry, setting with {} for the value, values): each sweep crosses rho = 1.
SWEEPS = {
    "compute_delay": (FAST_LIN_LC, ["actuator.compute_delay={}"], (0.002, 0.004, 0.006, 0.008)),
    "sensor_delay": (LIN_LC, ["sensor.delay_samples={}"], (1, 2, 3, 4)),
    "lag": (FAST_LIN_LC, ["actuator.electrical_time_constant={}"], (0.005, 0.01, 0.02, 0.05)),
    "gear": (
        FAST_LIN_LC,
        ["plant.gear_stiffness=[{}, 0.0]", "plant.gear_damping=[5.0, 0.0]"],
        (10000.0, 5000.0, 3000.0, 1000.0),
    ),
}


def _settings(effect: str, value: float) -> list[str]:
    entry, settings, _ = SWEEPS[effect]
    return [*entry, *QUIET, *(s.format(value) for s in settings)]


def _lin_lc_radius(settings: list[str]) -> float:
    resolved = resolve(load_scenario(SCENARIO, settings))
    return scenario_design(resolved).sampled_data_spectral_radius_lin_lc


@pytest.mark.parametrize(
    ("effect", "value"), [(e, v) for e, (_, _, values) in SWEEPS.items() for v in values]
)
def test_analysed_rho_crosses_one_where_the_simulation_grows(effect: str, value: float) -> None:
    resolved = resolve(load_scenario(SCENARIO, _settings(effect, value)))
    rho = scenario_design(resolved).sampled_data_spectral_radius_lin_lc
    residual = residual_oscillation(run_resolved(resolved))
    if rho < 1.0:
        assert residual < STEP / 100, (rho, residual)  # settled
    else:
        assert residual > STEP / 10, (rho, residual)  # a sustained, grown oscillation


@pytest.mark.parametrize("effect", SWEEPS)
def test_each_sweep_crosses_one(effect: str) -> None:
    """The sweeps above are not one-sided: the first value is stable, the last not."""
    values = SWEEPS[effect][2]
    assert _lin_lc_radius(_settings(effect, values[0])) < 1.0
    assert _lin_lc_radius(_settings(effect, values[-1])) > 1.0


def _previous_transition(design: Design, controller: str) -> np.ndarray:
    """The loop before effects existed: ``[q~, q~']`` held by one matrix exponential,
    then ``[[Phi + Gamma G D C, Gamma G C_s], [B_s C, A_s]]``, ``G`` the output gain of
    Eq. 13 (Lin+LC) or Eq. 19 at ``alpha*`` (the proposed filter's ``[eta~, phi, p,
    pbar]``)."""
    n, T = len(design.M0), design.config.sample_time
    if controller == "sampled_data_lin_lc":
        filt, gain = design.lin_lc_filter, np.eye(n)
    else:
        filt, alpha = design.proposed_filter, design.config.nonlinear.alpha_star
        gain = np.zeros((n, filt.C.shape[0]))
        gain[:, :n], gain[:, n : 2 * n] = np.eye(n), -alpha * np.eye(n)
    M_inv = np.linalg.inv(design.M0)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [np.zeros((n, n)), -M_inv @ design.B]])
    block = np.zeros((3 * n, 3 * n))
    block[: 2 * n, : 2 * n], block[: 2 * n, 2 * n :] = A * T, np.vstack([0 * M_inv, M_inv]) * T
    exponential = scipy.linalg.expm(block)
    Phi, Gamma = exponential[: 2 * n, : 2 * n], exponential[: 2 * n, 2 * n :]
    C = np.hstack([np.eye(n), np.zeros((n, n))])
    return np.block(
        [[Phi + Gamma @ gain @ filt.D @ C, Gamma @ gain @ filt.C], [filt.B @ C, filt.A]]
    )


def _radius(matrix: np.ndarray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(matrix))))


def test_without_effects_the_loop_is_the_previous_one() -> None:
    design = compute_design()
    n, T = len(design.M0), design.config.sample_time
    at_zero = LoopEffects(
        delay_samples=0,
        compute_delay=0.0,
        electrical_time_constant=(0.0,) * n,
        gear=CompliantGear(stiffness=(0.0,) * n, damping=(0.0,) * n, motor_inertia=(0.1,) * n),
    )
    reported = {
        "sampled_data": design.sampled_data_spectral_radius,
        "sampled_data_lin_lc": design.sampled_data_spectral_radius_lin_lc,
    }
    for controller in DESIGNED_LOOPS:
        previous = _radius(_previous_transition(design, controller))
        held = held_plant(design.M0, design.B, T, at_zero)
        assert held_design_radius(design, controller, held) == pytest.approx(previous, abs=1e-12)
        assert reported[controller] == pytest.approx(previous, abs=1e-12)
    assert with_effects(design, at_zero) is design


def test_a_whole_period_of_compute_delay_is_one_sample_of_sensor_delay() -> None:
    """Input and output delays of one period give the same loop spectrum."""
    design = compute_design()
    T = design.config.sample_time
    compute = with_effects(design, LoopEffects(compute_delay=T))
    sensor = with_effects(design, LoopEffects(delay_samples=1))
    assert compute.sampled_data_spectral_radius == pytest.approx(
        sensor.sampled_data_spectral_radius, abs=1e-9
    )
    assert compute.sampled_data_spectral_radius_lin_lc == pytest.approx(
        sensor.sampled_data_spectral_radius_lin_lc, abs=1e-9
    )


def test_small_effects_tend_to_the_ideal_loop() -> None:
    """A vanishing lag, a vanishing compute delay and a stiff, damped gear give back the
    ideal loop's radius (continuity of each model at its off value)."""
    design = compute_design()
    n = len(design.M0)
    ideal = design.sampled_data_spectral_radius_lin_lc
    stiff = CompliantGear(stiffness=(1e7,) * n, damping=(1e3,) * n, motor_inertia=(0.05, 1e-5))
    for effects in (
        LoopEffects(electrical_time_constant=(1e-7,) * n),
        LoopEffects(compute_delay=1e-9),
        LoopEffects(gear=stiff),
    ):
        assert with_effects(design, effects).sampled_data_spectral_radius_lin_lc == pytest.approx(
            ideal, abs=1e-3
        )


def test_a_gear_the_nominal_model_cannot_carry_is_refused() -> None:
    design = compute_design()
    heavy = CompliantGear(stiffness=(1e3, 0.0), damping=(0.0, 0.0), motor_inertia=(10.0, 0.0))
    with pytest.raises(
        ValueError, match=r"plant\.gear_stiffness > 0 at joints \[0\].*rotor_inertia"
    ):
        held_plant(design.M0, design.B, design.config.sample_time, LoopEffects(gear=heavy))


def test_the_gear_is_scaled_by_the_arm_s_motor_constants() -> None:
    resolved = resolve(load_scenario(SCENARIO, _settings("gear", 3000.0)))
    effects = nominal_effects(resolved)
    assert effects.gear is not None and not effects.gear.motor_sensor
    _, arm, _ = build_arm_diagram()
    true = resolved.true_parameters(arm.default_parameters)
    assert effects.gear.stiffness[0] == pytest.approx(3000.0 / true.motor_constant[0])
    assert effects.gear.motor_inertia[0] == pytest.approx(
        true.rotor_inertia[0] / true.motor_constant[0]
    )
    assert effects.gear.stiffness[1] == 0.0


def test_design_report_names_the_effects_it_includes() -> None:
    resolved = resolve(load_scenario(SCENARIO, _settings("compute_delay", 0.008)))
    design = scenario_design(resolved)
    check = {c.name: c for c in design.checks}["sampled_data_lin_lc"]
    assert not check.passed
    assert "compute delay 0.008 s" in check.detail


def test_tuning_and_map_judge_the_loop_with_the_effects() -> None:
    """The tuner's nominal radius and the map's nominal rho at the scenario's point are
    the design report's, effects included; so are the map's plants' (held with them)."""
    settings = _settings("compute_delay", 0.008)
    loaded = load_scenario(SCENARIO, settings)
    resolved = resolve(loaded)
    expected = scenario_design(resolved).sampled_data_spectral_radius_lin_lc
    assert expected > 1.0
    problem = TuningProblem(resolved, "lin_lc", loaded.scenario.controller, [], 0.02)
    assert problem.evaluate(loaded.scenario.controller).nominal_radius == pytest.approx(expected)
    setup = map_setup(loaded, ("sampled_data_lin_lc",), None, 2, 0, 0.02)
    point = evaluate_point(setup, {})
    assert point.rho == pytest.approx(expected)
    for plant, rho in zip(setup.plants, point.plant_rho, strict=True):
        effects = loop_effects(resolved.config, None)
        assert plant.effects == effects
        design = compute_design(resolved.config.design)
        held = held_plant(plant.M0, plant.B, resolved.config.sample_time, effects)
        assert rho == pytest.approx(held_design_radius(design, "sampled_data_lin_lc", held))


def test_nonlinear_settings_are_named_as_left_out() -> None:
    assert left_out(resolve(load_scenario(SCENARIO)).config) == []
    assert left_out(resolve(load_scenario(SCENARIO, QUIET)).config) == []  # linear settings
    settings = ["actuator.dac_bits=12", "plant.gear_stiffness=[3000.0]", "plant.backlash=[0.001]"]
    found = left_out(resolve(load_scenario(SCENARIO, settings)).config)
    assert found[0] == "actuator.dac_bits = 12"
    assert found[1].startswith("plant.backlash = [0.001")
