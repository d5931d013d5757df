"""The closed loop's own settings, as a scenario file writes them and the runner consumes
them: ``timing``, ``sensor`` and ``actuator`` (``diagrams.scenario`` holds them in the
settings tree; ``diagrams.loop_config.ClosedLoopConfig`` takes them as they are, so no
code copies them field by field). Each default is written here once, and each section
checks its own values (``Timing.check``, ``Sensor.state``, ``Actuator.state`` and
``Actuator.voltage_limits``), naming them by their scenario keys.
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

import copyreg
from dataclasses import MISSING, Field, dataclass, field, fields, make_dataclass

import numpy as np
from pydrake.systems.analysis import GetIntegrationSchemes, SimulatorConfig

from posfb.diagrams.actuator import (
    ActuatorState,
    require_compute_delay,
    require_dac_bits,
    require_time_constant,
)
from posfb.diagrams.encoder import DEFAULT_ENCODER_COUNTS, per_joint_counts
from posfb.models.design.configurations import CONFIGURATION_SPACING
from posfb.models.design.loop_context import LoopContext
from posfb.models.design.settings import default_of
from posfb.models.validation import (
    per_joint,
    require_finite,
    require_nonnegative,
    require_positive,
)

#: The paper's armature-voltage range, +-24 V (Sec. 4.1).
VOLTAGE_LIMIT = 24.0

#: Default bound on |q~| (rad) beyond which a run counts as diverged: about
#: 60 deg, 200x the largest RMS error of Tables 3-4: no controller that still
#: tracks gets near it, and a runaway is stopped before it costs much time.
DIVERGENCE_BOUND = 1.0

#: Default bound (rad) on a joint's RMS tracking error over the second half of a run
#: above which a run that finished counts as ``lost`` (``analysis.common.metrics.run_verdict``):
#: about 14 deg, a quarter of ``DIVERGENCE_BOUND`` and twice the largest such error of
#: any registered controller on a shipped scenario (PD + gravity's 0.117 rad, joint 2
#: of the paper's payload case, a baseline that trails its path): an arm that far from
#: its path on average, once the start-up transient is over, does not track it. The verdict
#: takes the smaller of this and ``LOST_FRACTION`` of the path's excursion: an absolute
#: cap on a path of any size.
LOST_BOUND = 0.25

#: Default fraction of the path's excursion (the largest half peak-to-peak of any joint's
#: ``q_d`` over the path's first ``DURATION`` seconds, or the run if longer:
#: ``analysis.common.metrics.path_excursion``) that a joint's RMS error over the run's
#: second half may reach before a finished run counts as ``lost``
#: (``analysis.common.metrics.judge``): a bound stated relative to the path, so that a
#: small path is judged as strictly as a large one and the verdict does not depend on
#: the run's length. About
#: twice the largest such ratio of any registered controller on a shipped scenario over
#: 20 s (0.149: PD + gravity's 0.117 rad on joint 2 of the paper's payload case, whose
#: path's excursion is 0.785 rad; the paper's three and ADRC stay below 0.08), and well
#: under the ratio of an arm that stands still at the middle of a sine (``1/sqrt 2``).
#: Measured on the runs of ``posfb simulate --scenario NAME --controller C`` for every
#: shipped scenario and registered controller (the ratio from each run's ``q_error`` and
#: ``q_desired`` logs).
LOST_FRACTION = 0.3

#: Default share of the second half's control samples with a commanded voltage beyond
#: the limit above which a run that finished counts as ``saturated``
#: (``analysis.common.metrics.run_verdict``): a designed loop never reaches it, and a loop
#: at its limit that long is no longer the linear loop its design judged. Every registered
#: controller (the paper's three, PD + gravity, ADRC) on every shipped scenario saturates
#: on 0.0 % of its second half over 20 s (``posfb simulate --scenario NAME --controller C
#: --json`` for NAME in ``paper_nominal``, ``paper_payload``, ``paper_tuned``,
#: ``six_joint_nominal``, ``six_joint_tuned``, ``three_link_nominal``, ``three_link_tuned``),
#: except the untuned, labelled ``three_link_nominal.yaml``'s paper controller: 67 %. A
#: loop made unstable by a delay 20 % beyond its margin saturates 12-20 % of the time
#: (``tests/models/design/test_margins.py``). 5 % leaves room for brief clipping (a friction
#: break-away, the peak of a fast path), and a steady saturation far from 5 % either way is
#: judged the same at any duration (a share near 50 % judged a six-joint run at its limit
#: 47.6 % of its second half ``ok`` over 20 s and ``saturated`` over 5 s).
SATURATED_SHARE = 0.05

#: The paper's run: 20 s (Sec. 4.2).
DURATION = 20.0

#: Most control samples one run may take (``timing.duration / timing.sample_time``),
#: refused before any work beyond it: a run costs about 0.14 ms of wall time per
#: sample (the paper's controller at 1 kHz on the project's 2-core machine: 20 s,
#: 20000 samples, 2.8 s), so a million samples is minutes per run and a study
#: multiplies that; the paper's run is 2000 samples, 20 s at 50 kHz is a million.
MAX_RUN_SAMPLES = 1_000_000


def require_run_samples(samples: float, where: str) -> None:
    """Refuse ``samples`` (a run's ``duration / sample_time``) above ``MAX_RUN_SAMPLES``;
    ``where`` names the settings (``timing.duration / timing.sample_time``)."""
    if samples > MAX_RUN_SAMPLES:
        raise ValueError(
            f"{where} = {samples:.4g} control samples; at most {MAX_RUN_SAMPLES:,} per run "
            "are allowed (a shorter duration or a longer sample time)"
        )


#: Fewest counts per revolution a quantising encoder may have (0, the ideal encoder,
#: aside): one count ``2 pi / N`` must be at most a quarter turn
#: (``models.design.initial.QUARTER_TURN``, the largest excursion ``scenario init`` gives
#: a joint), or a joint's whole motion fits inside one count and the encoder reads none
#: of it (``tests/models/design/test_arm_defaults.py`` pins the arithmetic; written out here
#: so that loading a scenario does not import the rules' optimiser).
MIN_ENCODER_COUNTS = 4

#: Fewest bits a DAC may have (0, the ideal DAC, aside): one step ``2 / 2^b`` of the
#: voltage limit must be at most ``models.design.initial.QUANTISATION_FRACTION`` (5 %),
#: the share of the limit that ``scenario init``'s PID rule lets one encoder count move
#: the voltage by: 3.1 % at 6 bits, 6.3 % at 5. A coarser DAC commands steps as large as
#: the corrections themselves (at 1 bit its levels are -limit and 0: the arm is pushed
#: one way only).
MIN_DAC_BITS = 6


def require_encoder_resolution(counts: list[int]) -> None:
    """Refuse ``sensor.encoder_counts`` entries from 1 to ``MIN_ENCODER_COUNTS - 1`` (0 is
    the ideal encoder, documented as such)."""
    for j, value in enumerate(counts):
        if 0 < value < MIN_ENCODER_COUNTS:
            raise ValueError(
                f"sensor.encoder_counts[{j}] = {value}; 0 (ideal) or at least "
                f"{MIN_ENCODER_COUNTS} counts per revolution is required (one count must be "
                "at most a quarter turn, or the encoder reads none of the motion)"
            )


def require_dac_resolution(bits: int) -> None:
    """Refuse ``actuator.dac_bits`` from 1 to ``MIN_DAC_BITS - 1`` (0 is the ideal DAC)."""
    if 0 < bits < MIN_DAC_BITS:
        from posfb.models.design.initial import QUANTISATION_FRACTION  # its optimiser on use

        raise ValueError(
            f"actuator.dac_bits = {bits}; 0 (ideal) or at least {MIN_DAC_BITS} bits is required "
            f"(one step must be at most {QUANTISATION_FRACTION:.0%} of the voltage limit, or "
            "the DAC commands steps as large as the corrections)"
        )


def _copied(entry: Field) -> Field:
    """A new ``field`` with ``entry``'s default (or default factory)."""
    if entry.default_factory is not MISSING:
        return field(default_factory=entry.default_factory)
    return field(default=entry.default)


def _simulator_config(values: dict[str, object]) -> SimulatorConfig:
    """The ``SimulatorConfig`` of ``values`` (its pickled form: the ``copyreg`` below)."""
    return SimulatorConfig(**values)


# Drake's SimulatorConfig does not pickle: a scenario crosses to a worker process (a
# report's figures) field by field.
copyreg.pickle(SimulatorConfig, lambda config: (
    _simulator_config, ({f.name: getattr(config, f.name) for f in SimulatorConfig.__fields__},)))


def default_simulator() -> SimulatorConfig:
    """Drake's RK3 with error control at accuracy 3e-3 (``diagrams.runner``)."""
    return SimulatorConfig(integration_scheme="runge_kutta3", accuracy=3e-3, use_error_control=True)


@dataclass
class Timing:
    """How the loop is run and judged: simulated ``duration`` (s, a whole number of periods
    ``T_s``; the loop context holds the sample time, ``models.design.loop_context``), the
    ``|q~|`` (rad) beyond which a run is stopped as diverged, the verdict's bounds on a
    run that finished (``lost_bound``: the largest RMS ``|q~|`` (rad) a joint may have
    over the run's second half; ``lost_fraction``: the largest such RMS as a fraction of
    the path's excursion (the largest half peak-to-peak of a joint's ``q_d``,
    ``analysis.common.metrics.path_excursion``; the smaller of the two bounds applies);
    ``saturated_share``: the largest share of the second half's samples with a commanded
    voltage beyond the limit; ``analysis.common.metrics.run_verdict``), Drake's integrator
    settings, and the spacing (s) of the path's configurations at which the linear
    verdicts freeze ``M*(q)`` (``configuration_spacing``, ``models.design.configurations``)."""

    duration: float = DURATION
    divergence_bound: float = DIVERGENCE_BOUND
    lost_bound: float = LOST_BOUND
    lost_fraction: float = LOST_FRACTION
    saturated_share: float = SATURATED_SHARE
    simulator: SimulatorConfig = field(default_factory=default_simulator)
    configuration_spacing: float = CONFIGURATION_SPACING

    def __eq__(self, other: object) -> bool:
        """By value (Drake's ``SimulatorConfig`` itself compares by identity)."""
        if not isinstance(other, Timing):
            return NotImplemented
        return _timing_values(self) == _timing_values(other)

    def check(self, sample_time: float) -> None:
        """Refuse a duration that is not a whole number (>= 1, at most
        ``MAX_RUN_SAMPLES``) of the loop's ``sample_time`` periods, bounds outside their
        ranges and integrator settings Drake's ``Simulator`` would not run as posfb's
        runner expects."""
        require_positive("timing.duration", self.duration)
        samples = round(self.duration / sample_time)
        if (
            self.duration < sample_time
            or abs(samples * sample_time - self.duration) > 1e-9 * self.duration
        ):
            raise ValueError(
                f"timing.duration = {self.duration!r} is not a whole number (>= 1) of "
                f"timing.sample_time = {sample_time!r} periods"
            )
        require_run_samples(samples, "timing.duration / timing.sample_time")
        require_positive("timing.divergence_bound", self.divergence_bound)
        require_positive("timing.lost_bound", self.lost_bound)
        fraction = require_positive("timing.lost_fraction", self.lost_fraction)
        if fraction > 1.0:
            raise ValueError(
                f"timing.lost_fraction = {fraction!r}; a fraction in (0, 1] of the path's "
                "excursion is required"
            )
        share = require_finite("timing.saturated_share", self.saturated_share)
        if not 0.0 <= share <= 1.0:
            raise ValueError(f"timing.saturated_share = {share!r}; a share in [0, 1] is required")
        require_positive("timing.configuration_spacing", self.configuration_spacing)
        self._check_simulator()

    def _check_simulator(self) -> None:
        simulator = self.simulator
        schemes = GetIntegrationSchemes()
        key = "timing.simulator"
        if simulator.integration_scheme not in schemes:
            raise ValueError(
                f"{key}.integration_scheme = {simulator.integration_scheme!r}; one of "
                f"{', '.join(schemes)} is required"
            )
        accuracy = require_positive(f"{key}.accuracy", simulator.accuracy)
        if accuracy >= 1.0:
            raise ValueError(f"{key}.accuracy = {accuracy!r}; a value in (0, 1) is required")
        require_positive(f"{key}.max_step_size", simulator.max_step_size)
        require_nonnegative(f"{key}.target_realtime_rate", simulator.target_realtime_rate)
        if simulator.start_time != 0.0:
            raise ValueError(
                f"{key}.start_time = {simulator.start_time!r}; 0 is required (a run starts "
                "at t = 0)"
            )


#: Where an encoder can sit (``sensor.location``): on the link or on the motor shaft.
SENSOR_LOCATIONS = ("link", "motor")


def _finite_per_joint(name: str, value: object, joints: int) -> tuple[float, ...]:
    values = per_joint(name, value, joints)
    return tuple(require_finite(f"{name}[{j}]", v) for j, v in enumerate(values))


@dataclass(frozen=True)
class SensorState:
    """The sensor settings of one run that live in the Context, not in the diagram:
    counts per revolution, zero offset (rad) and noise standard deviation (rad) per
    joint, and the noise seed. (Whether there is noise at all, and the delay, are
    part of the diagram.)"""

    encoder_counts: tuple[int, ...]
    zero_offset: tuple[float, ...]
    noise_std: tuple[float, ...]
    noise_seed: int


@dataclass
class Sensor:
    """Joint encoders: counts per revolution (0: ideal, otherwise at least
    ``MIN_ENCODER_COUNTS``), zero offset (rad), additive
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

    def state(self, joints: int) -> SensorState:
        """The per-joint values of ``joints`` encoders (one value is every joint's),
        checked: counts as ``diagrams.encoder`` allows, finite offsets, noise >= 0, the
        seed and the delay integers >= 0, a known ``location``."""
        counts = per_joint_counts("sensor.encoder_counts", self.encoder_counts, joints)
        offsets = _finite_per_joint("sensor.zero_offset", self.zero_offset, joints)
        noise = _finite_per_joint("sensor.noise_std", self.noise_std, joints)
        for j, std in enumerate(noise):
            require_nonnegative(f"sensor.noise_std[{j}]", std)
        for name in ("noise_seed", "delay_samples"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
                raise ValueError(f"sensor.{name} = {value!r}; an integer >= 0 is required")
        if self.location not in SENSOR_LOCATIONS:
            raise ValueError(
                f"sensor.location = {self.location!r}; one of {', '.join(SENSOR_LOCATIONS)} "
                "is required"
            )
        return SensorState(counts, offsets, noise, self.noise_seed)


@dataclass
class Actuator:
    """The path from the controller's voltage to the motor (``diagrams.actuator``, which
    gives the models, their order and sources): armature-voltage saturation (V) per
    joint; the DSP's ``compute_delay`` (s, ``0 <= d <= T_s``: the voltage computed from
    the sample at ``t_k`` applies from ``t_k + d``); the DAC's resolution ``dac_bits``
    (``2^bits`` levels over ``[-voltage_limit, +voltage_limit]``, at least
    ``MIN_DAC_BITS``); the armature's
    ``electrical_time_constant`` L/R (s) per joint. A 0 switches an effect off (the
    defaults: no block is added)."""

    voltage_limit: list[float] = field(default_factory=lambda: [VOLTAGE_LIMIT])
    electrical_time_constant: list[float] = field(default_factory=lambda: [0.0])
    dac_bits: int = 0
    compute_delay: float = 0.0

    def voltage_limits(self, joints: int) -> tuple[float, ...]:
        """The saturation (V) of each of ``joints`` joints, each finite and > 0."""
        limits = _finite_per_joint("actuator.voltage_limit", self.voltage_limit, joints)
        for j, limit in enumerate(limits):
            require_positive(f"actuator.voltage_limit[{j}]", limit)
        return limits

    def state(self, joints: int, sample_time: float) -> ActuatorState:
        """The values a Context holds (``diagrams.actuator``) for ``joints`` joints,
        checked, and the compute delay checked against ``sample_time``."""
        key = "actuator.electrical_time_constant"
        taus = per_joint(key, self.electrical_time_constant, joints)
        checked = tuple(require_time_constant(f"{key}[{j}]", tau) for j, tau in enumerate(taus))
        bits = require_dac_bits("actuator.dac_bits", self.dac_bits)
        require_compute_delay("actuator.compute_delay", self.compute_delay, sample_time)
        return ActuatorState(checked, bits)


def _timing_values(timing: object) -> tuple:
    """A ``Timing``'s (or ``TimingSection``'s) values, its integrator settings by value."""
    simulator = tuple(getattr(timing.simulator, f.name) for f in SimulatorConfig.__fields__)
    return tuple(
        simulator if f.name == "simulator" else getattr(timing, f.name) for f in fields(timing)
    )


def _loop_timing(section: object) -> Timing:
    """The loop's ``Timing`` of this section: every key but ``sample_time``, which the
    loop context holds (``diagrams.resolve``)."""
    return Timing(**{f.name: getattr(section, f.name) for f in fields(Timing)})


def _section_eq(self: object, other: object) -> bool:
    if not isinstance(other, TimingSection):
        return NotImplemented
    return _timing_values(self) == _timing_values(other)


#: The scenario's ``timing:`` section: ``sample_time``, the loop's sample time ``T_s`` (s)
#: of the controller, the encoder's hold and the voltage command (resolved into the loop
#: context, its one home, ``models.design.loop_context``), then ``Timing``'s keys (made
#: from its fields, so each is written once; ``loop_timing()`` is the loop's ``Timing``).
TimingSection = make_dataclass(
    "TimingSection",
    [("sample_time", float, field(default_factory=default_of(LoopContext, "sample_time")))]
    + [(f.name, f.type, _copied(f)) for f in fields(Timing)],
    namespace={
        "__doc__": "``sample_time`` (s, the sample time ``T_s`` of the controller and the "
        "sensor, which resolve hands to the loop context, ``models.design.loop_context``), "
        "then the run's timing and verdict bounds (``Timing``).",
        "__module__": __name__,
        "__eq__": _section_eq,
        "loop_timing": _loop_timing,
    },
)
