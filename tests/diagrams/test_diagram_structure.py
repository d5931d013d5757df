"""``diagrams.structure``: a Monte-Carlo worker reuses one Diagram for every scenario of
one ``structure_key``. Checked against the Diagrams themselves: for each value a Context
holds (``CONTEXT_VALUES``), a change within its shape builds the same Diagram (systems,
their ports and states, their connections) and keeps the key; a change of its shape
builds another Diagram and changes the key. A value listed there that did shape the
Diagram, or a shape rule that missed a block, fails here."""

from __future__ import annotations

import pytest
from pydrake.systems.framework import Diagram, System

import posfb
from posfb.diagrams.structure import CONTEXT_VALUES, structure_key

SHORT = "timing.duration=0.1"
COMPLIANT = "plant.gear_stiffness=300.0"

#: Scenario key -> (settings of a base scenario, two values of one shape, a value of
#: another shape or None where the value never shapes the Diagram).
CASES = {
    "plant.payload_mass": ([], "0.0", "0.3", None),
    "plant.parameters": ([], "{damping: [0.01]}", "{damping: [0.05]}", None),
    "plant.friction": ([], "!LuGre {sigma0: [100000.0]}", "!LuGre {sigma0: [50000.0]}",
                       "!TanhCoulomb {}"),
    "plant.gear_stiffness": ([], "300.0", "600.0", "0.0"),
    "plant.gear_damping": ([COMPLIANT], "0.1", "0.3", None),
    "plant.backlash": ([COMPLIANT], "0.0", "0.0005", None),
    "sensor.encoder_counts": ([], "20000", "4096", None),
    "sensor.zero_offset": ([], "0.0", "0.001", None),
    "sensor.noise_std": ([], "0.0001", "0.0002", "0.0"),
    "sensor.noise_seed": (["sensor.noise_std=0.0001"], "0", "7", None),
    "actuator.electrical_time_constant": ([], "0.001", "0.002", "0.0"),
    "actuator.dac_bits": ([], "12", "16", "0"),
}


def _signature(system: System, prefix: str = "") -> list[tuple]:
    """Every system of ``system`` (recursively) with its class, port sizes and state
    sizes, and every connection of each diagram, by names (ids differ per build)."""
    name = f"{prefix}/{system.get_name()}"
    context = system.CreateDefaultContext()
    rows = [
        (
            name,
            type(system).__name__,
            tuple(system.get_input_port(i).size() for i in range(system.num_input_ports())),
            tuple(system.get_output_port(i).size() for i in range(system.num_output_ports())),
            context.num_continuous_states(),
            tuple(
                context.get_discrete_state(i).size()
                for i in range(context.num_discrete_state_groups())
            ),
        )
    ]
    if isinstance(system, Diagram):
        for (to_system, to_port), (from_system, from_port) in system.connection_map().items():
            rows.append((name, from_system.get_name(), from_port, to_system.get_name(), to_port))
        for child in system.GetSystems():
            rows.extend(_signature(child, name))
    return sorted(rows, key=repr)


def _loop(settings: list[str]):
    scenario = posfb.load_scenario(set=[SHORT, *settings])
    return scenario, _signature(posfb.build(scenario, "pid").diagram)


def test_every_context_value_is_checked_here():
    assert set(CASES) == {f"{section}.{name}" for section, name in CONTEXT_VALUES}


@pytest.mark.parametrize("key", CASES)
def test_a_context_value_changes_the_diagram_only_through_its_shape(key):
    base, first, second, other = CASES[key]
    one, one_signature = _loop([*base, f"{key}={first}"])
    two, two_signature = _loop([*base, f"{key}={second}"])
    assert structure_key(one.scenario, "pid") == structure_key(two.scenario, "pid")
    assert one_signature == two_signature
    if other is not None:
        three, three_signature = _loop([*base, f"{key}={other}"])
        assert structure_key(three.scenario, "pid") != structure_key(one.scenario, "pid")
        assert three_signature != one_signature


def test_a_setting_that_is_not_a_context_value_is_part_of_the_key():
    one, _ = _loop([])
    settings = ("timing.sample_time=0.005", "actuator.voltage_limit=10", "sensor.delay_samples=1")
    for setting in settings:
        two, _ = _loop([setting])
        assert structure_key(two.scenario, "pid") != structure_key(one.scenario, "pid"), setting
