"""Which settings of a scenario shape the closed-loop diagram, and which a Context holds.

``build_closed_loop`` builds a Diagram from a whole config; ``ClosedLoopRunner.new_context``
then sets, per run, the values listed in ``CONTEXT_VALUES`` (the true plant's parameters,
the friction law's and the gear's values, the sensor's and the actuator's state), so
that a Monte-Carlo worker reuses one Diagram for every sample that differs only in
those. Some of them still decide whether a block exists (a compliant gear adds the
gear block, a non-zero L/R the lag, ``dac_bits > 0`` the DAC, noise the noise source,
the friction law's kind its block): ``CONTEXT_VALUES`` maps each key to that shape.

``structure_key`` is the scenario with every such value replaced by its shape: two
scenarios with one key build the same Diagram. Every other setting is part of the
key as it is, so a new setting (or a new block it switches) rebuilds by default; a new
value that a Context holds is listed here, where ``tests/diagrams/test_diagram_structure.py``
checks, key by key, that changing it within its shape leaves the built Diagram's graph
unchanged and changing its shape changes it.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

from posfb.diagrams.scenario import ParameterOverrides, Scenario, dump_scenario, with_controller


def _none(_value: object) -> object:
    """A value that never shapes the diagram."""
    return None


def _any_positive(values: list[float]) -> list[float]:
    """A block exists when any joint's value is positive (written as ``[1.0]``) or none
    (``[0.0]``)."""
    return [1.0 if any(value > 0.0 for value in values) else 0.0]


def _kind(section: object) -> object:
    """A tagged section's kind, with its defaults in place of its values."""
    return type(section)()


#: Scenario key (section, field) whose value a Context holds -> the part of the value
#: that shapes the diagram (module docstring).
CONTEXT_VALUES: dict[tuple[str, str], Callable[[object], object]] = {
    ("plant", "payload_mass"): lambda _mass: 0.0,
    ("plant", "parameters"): lambda _overrides: ParameterOverrides(),
    ("plant", "friction"): _kind,
    ("plant", "gear_stiffness"): _any_positive,  # a gear block (models.gear) or none
    ("plant", "gear_damping"): lambda _values: [0.0],
    ("plant", "backlash"): lambda _values: [0.0],
    ("sensor", "encoder_counts"): lambda _counts: [0],
    ("sensor", "zero_offset"): lambda _offsets: [0.0],
    ("sensor", "noise_std"): _any_positive,  # a noise source (diagrams.encoder) or none
    ("sensor", "noise_seed"): lambda _seed: 0,
    ("actuator", "electrical_time_constant"): _any_positive,  # a lag (diagrams.actuator)
    ("actuator", "dac_bits"): lambda bits: min(bits, 1),  # a DAC block or none
}


def diagram_shape(scenario: Scenario) -> Scenario:
    """A copy of ``scenario`` with each value a Context holds replaced by its shape."""
    shape = copy.deepcopy(scenario)
    for (section, name), shape_of in CONTEXT_VALUES.items():
        part = getattr(shape, section)
        setattr(part, name, shape_of(getattr(part, name)))
    return shape


def structure_key(scenario: Scenario, controller: str) -> str:
    """What the Diagram of ``controller`` on ``scenario`` is built from: the scenario
    with that controller, without the values a Context holds (their shapes kept)."""
    return dump_scenario(diagram_shape(with_controller(scenario, controller)))
