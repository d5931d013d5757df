"""A scenario's effects between the filter and the arm, as the sampled-loop analyses
(``posfb design``, ``design --map``, ``tune``, a study's per-sample rho) take them.

``loop_effects`` reads the linear ones (``models.design.closed_loop.LoopEffects``): the
sensor delay, the compute delay, the armature lag and a compliant gear, whose stiffness,
damping and motor inertia it puts in the nominal model's volts with the arm's motor
constants (``k / kappa``, ``c / kappa``, ``J_m / kappa``). ``left_out`` names the settings
that are not linear and that no sampled loop includes (the DAC's quantisation, the
gear's backlash, a friction law other than the default, an encoder quantisation other
than the default one; 0 counts is an ideal encoder): the commands say so in one note.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from posfb.diagrams.encoder import DEFAULT_ENCODER_COUNTS
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.resolve import ResolvedScenario
from posfb.models.design import CompliantGear, LoopEffects
from posfb.models.friction import DEFAULT_LAW
from posfb.models.gear import GearConfig
from posfb.models.plant import ArmParameters, PlantConfig, build_arm_diagram


def loop_effects(config: ClosedLoopConfig, parameters: ArmParameters | None) -> LoopEffects:
    """The linear effects ``config`` sets, on the arm with ``parameters`` (its motor
    constants and rotor inertias scale a compliant gear; ``None`` only for a rigid one)."""
    gear = None
    if config.plant.gear.compliant:
        if parameters is None:
            raise ValueError("a compliant gear needs the arm's parameters (kappa, J_m)")
        k, c, _ = config.plant.gear.values(config.joints, prefix="plant.")
        kappa = np.asarray(parameters.motor_constant, dtype=float)
        gear = CompliantGear(
            stiffness=tuple(float(v) for v in k / kappa),
            damping=tuple(float(v) for v in c / kappa),
            motor_inertia=tuple(float(v) for v in np.asarray(parameters.rotor_inertia) / kappa),
            motor_sensor=config.sensor.location == "motor",
        )
    return LoopEffects(
        delay_samples=config.sensor.delay_samples,
        compute_delay=config.actuator.compute_delay,
        electrical_time_constant=config.actuator_state.electrical_time_constant,
        gear=gear,
    )


def rigid_plant(plant: PlantConfig) -> PlantConfig:
    """``plant`` with a rigid gear: the arm whose linear part ``M0, B`` holds each rotor
    inertia in its joint, as the nominal model's does (``loop_effects`` moves it to the
    motor)."""
    return replace(plant, gear=GearConfig()) if plant.gear.compliant else plant


def nominal_effects(resolved: ResolvedScenario) -> LoopEffects:
    """``loop_effects`` of the scenario on its own true arm (the arm is built only for a
    compliant gear, whose scale needs its parameters)."""
    config = resolved.config
    if not config.plant.gear.compliant:
        return loop_effects(config, None)
    _, arm, _ = build_arm_diagram(rigid_plant(config.plant))
    return loop_effects(config, resolved.true_parameters(arm.default_parameters))


def left_out(config: ClosedLoopConfig) -> list[str]:
    """The scenario's nonlinear settings, away from their defaults, that the sampled-loop
    analyses leave out (``key = value`` each)."""
    found = []
    if config.actuator.dac_bits > 0:
        found.append(f"actuator.dac_bits = {config.actuator.dac_bits}")
    backlash = config.plant.gear.values(config.joints, prefix="plant.")[2]
    if np.any(backlash > 0.0):
        found.append(f"plant.backlash = {backlash.tolist()}")
    if type(config.plant.friction) is not DEFAULT_LAW:
        found.append(f"plant.friction = !{type(config.plant.friction).__name__}")
    counts = config.sensor_state.encoder_counts
    if any(count not in (0, DEFAULT_ENCODER_COUNTS) for count in counts):
        found.append(f"sensor.encoder_counts = {list(counts)}")
    return found


def left_out_note(found: list[str]) -> str:
    """One line naming the settings ``found`` by ``left_out`` (empty when none)."""
    if not found:
        return ""
    return (
        "note: the sampled-loop analysis is linear and leaves out "
        + ", ".join(found)
        + " (nonlinear: the simulation has them)"
    )
