"""The closed loop's own settings, as a scenario file writes them and the runner consumes
them: ``timing``, ``sensor`` and ``actuator`` (``diagrams.scenario`` holds them in the
settings tree; ``diagrams.closed_loop.ClosedLoopConfig`` takes them as they are, so no
code copies them field by field). Each default is written here once.
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

from dataclasses import dataclass, field

from pydrake.systems.analysis import SimulatorConfig

from posfb.diagrams.encoder import DEFAULT_ENCODER_COUNTS
from posfb.models.design import ControllerConfig
from posfb.models.design.settings import default_of

#: The paper's armature-voltage range, +-24 V (Sec. 4.1).
VOLTAGE_LIMIT = 24.0

#: Default bound on |q~| (rad) beyond which a run counts as diverged: about
#: 60 deg, 200x the largest RMS error of Tables 3-4: no controller that still
#: tracks gets near it, and a runaway is stopped before it costs much time.
DIVERGENCE_BOUND = 1.0

#: The paper's run: 20 s (Sec. 4.2).
DURATION = 20.0


def default_simulator() -> SimulatorConfig:
    """Drake's RK3 with error control at accuracy 3e-3 (``diagrams.closed_loop``)."""
    return SimulatorConfig(
        integration_scheme="runge_kutta3", accuracy=3e-3, use_error_control=True
    )


@dataclass
class Timing:
    """Sample time ``T_s`` (s) of the controller and the sensor, simulated ``duration``
    (s, a whole number of periods), the ``|q~|`` (rad) beyond which a run is stopped
    as diverged, and Drake's integrator settings."""

    sample_time: float = field(default_factory=default_of(ControllerConfig, "sample_time"))
    duration: float = DURATION
    divergence_bound: float = DIVERGENCE_BOUND
    simulator: SimulatorConfig = field(default_factory=default_simulator)

    def __eq__(self, other: object) -> bool:
        """By value (Drake's ``SimulatorConfig`` itself compares by identity)."""
        if not isinstance(other, Timing):
            return NotImplemented

        def values(timing: Timing) -> tuple:
            simulator = tuple(getattr(timing.simulator, f.name) for f in SimulatorConfig.__fields__)
            return timing.sample_time, timing.duration, timing.divergence_bound, simulator

        return values(self) == values(other)


@dataclass
class Sensor:
    """Joint encoders: counts per revolution (0: ideal), zero offset (rad), additive
    Gaussian noise (rad, from ``noise_seed``), a delay of whole samples, and where each
    encoder sits: ``link`` (reads the joint angle ``q``) or ``motor`` (reads the motor
    shaft ``theta_m`` at the link side, as the paper's arm, Sec. 4.1; needs a compliant
    gear, ``models.gear``)."""

    encoder_counts: list[int] = field(default_factory=lambda: [DEFAULT_ENCODER_COUNTS])
    zero_offset: list[float] = field(default_factory=lambda: [0.0])
    noise_std: list[float] = field(default_factory=lambda: [0.0])
    noise_seed: int = 0
    delay_samples: int = 0
    location: str = "link"


@dataclass
class Actuator:
    """The path from the controller's voltage to the motor (``diagrams.actuator``, which
    gives the models, their order and sources): armature-voltage saturation (V) per
    joint; the DSP's ``compute_delay`` (s, ``0 <= d <= T_s``: the voltage computed from
    the sample at ``t_k`` applies from ``t_k + d``); the DAC's resolution ``dac_bits``
    (``2^bits`` levels over ``[-voltage_limit, +voltage_limit]``); the armature's
    ``electrical_time_constant`` L/R (s) per joint. A 0 switches an effect off (the
    defaults: no block is added)."""

    voltage_limit: list[float] = field(default_factory=lambda: [VOLTAGE_LIMIT])
    electrical_time_constant: list[float] = field(default_factory=lambda: [0.0])
    dac_bits: int = 0
    compute_delay: float = 0.0
