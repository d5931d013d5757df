"""One closed-loop run's settings, resolved and validated (``ClosedLoopConfig``: the
controller and its design inputs, the desired path, the scenario's timing, sensor,
actuator and plant sections), and the true arm's departures from its URDF
(``TruePlant``). ``diagrams.wiring`` builds the diagram from it and ``diagrams.runner``
runs it.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from functools import cached_property, partial

from pydrake.systems.analysis import SimulatorConfig

from posfb.diagrams.actuator import ActuatorState
from posfb.diagrams.sections import Actuator, Sensor, SensorState, Timing
from posfb.models.controllers import (
    PAPER_CONTROLLER,
    REGISTRY,
    ControllerConfig,
    ControllerSpec,
    UserPlugin,
    controller_spec,
)
from posfb.models.design.loop_context import InLoopContext, LoopContext
from posfb.models.plant import ArmParameters, PlantConfig
from posfb.models.trajectory import Trajectory, WaveTrajectory


@dataclass(frozen=True)
class TruePlant:
    """The true arm's departures from its URDF: a point ``payload_mass`` (kg) at the
    payload link and absolute ``overrides`` of ``ArmParameters`` fields (name, one value
    per joint). Part of every ``ClosedLoopConfig``, so that a runner built from a
    scenario's config runs the scenario's arm: no call can drop them."""

    payload_mass: float = 0.0
    overrides: tuple[tuple[str, tuple[float, ...]], ...] = ()

    def parameters(self, defaults: ArmParameters) -> ArmParameters:
        """``defaults`` (the URDF's) with the payload and the overrides."""
        return dataclasses.replace(defaults, **dict(self.overrides), payload_mass=self.payload_mass)


@dataclass(frozen=True, eq=False)
class ClosedLoopConfig(InLoopContext):
    """One closed-loop run, resolved and validated (``diagrams.scenario`` builds it
    from a scenario file; the defaults are the paper's settings).

    ``design`` is everything the controller is built from, the loop context included
    (``context``: the nominal model and the sample time ``T_s``, held once,
    ``models.design.loop_context``; ``sample_time`` reads it); ``controller_settings`` the
    settings of a plug-in kind's scenario entry or a user's plug-in
    (``models.controllers.plugin.UserPlugin``; ``None`` for the paper's three, whose
    inputs are all in ``design``); ``trajectory`` the desired path; ``timing``,
    ``sensor`` and ``actuator`` the scenario's sections as they are
    (``diagrams.sections``; copied, and read where they are used: ``timing.duration``,
    ``timing.divergence_bound`` on ``|q~|`` in rad and Drake's integrator
    ``timing.simulator`` (the runner caps ``max_step_size`` at ``T_s``: a step never spans
    more than one control period; the duration must be a whole number of periods);
    ``sensor.location``, ``sensor.delay_samples`` (whole periods), ``sensor.noise_seed``,
    ``actuator.dac_bits`` and ``actuator.compute_delay`` (s, at most ``T_s``) for all
    joints). What a section expands per joint is computed once and validated here:
    ``sensor_state`` (``encoder_counts`` per revolution, 0: ideal, default and its
    justification in ``diagrams.encoder``; ``zero_offset``, rad, added to the true position
    before quantisation; ``noise_std``, rad, additive Gaussian noise after it),
    ``actuator_state`` (``electrical_time_constant``, s; ``diagrams.actuator``; 0 switches
    an effect off) and ``voltage_limit`` (V);
    ``true_plant`` the true arm's payload and parameter overrides
    (``ClosedLoopRunner.run`` applies them unless it is given other parameters, as a
    Monte-Carlo sample is). The number of joints
    ``n`` is the design's nominal model's; the trajectory and the plant URDF must
    have as many. Per-joint values take one number for all joints or one per joint.
    Its errors name each setting by its scenario key (``timing.duration``,
    ``sensor.encoder_counts[1]``), the one name a setting has (``diagrams.scenario``).
    """

    controller: str = PAPER_CONTROLLER
    design: ControllerConfig = field(default_factory=ControllerConfig)
    controller_settings: object | None = None
    trajectory: Trajectory = field(default_factory=WaveTrajectory)
    timing: Timing = field(default_factory=Timing)
    sensor: Sensor = field(default_factory=Sensor)
    actuator: Actuator = field(default_factory=Actuator)
    plant: PlantConfig = field(default_factory=PlantConfig)
    true_plant: TruePlant = field(default_factory=TruePlant)

    def __post_init__(self) -> None:
        plugin = self.controller_settings
        if isinstance(plugin, UserPlugin) and self.controller != plugin.kind:
            raise ValueError(
                f"controller.kind = {self.controller!r}; the plug-in's kind {plugin.kind!r} "
                "is required"
            )
        if not isinstance(plugin, UserPlugin) and self.controller not in REGISTRY:
            raise ValueError(
                f"controller.kind = {self.controller!r}; one of {', '.join(REGISTRY)} is required"
            )
        for name, kind in (
            ("design", ControllerConfig), ("timing", Timing), ("sensor", Sensor),
            ("actuator", Actuator), ("plant", PlantConfig), ("true_plant", TruePlant),
        ):  # fmt: skip
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"{name} = {getattr(self, name)!r} is not a {kind.__name__}")
        # Own copies: a scenario changed later does not change a config built from it.
        set_field = partial(object.__setattr__, self)
        set_field("sensor", copy.deepcopy(self.sensor))
        set_field("actuator", copy.deepcopy(self.actuator))
        simulator = SimulatorConfig(
            **{f.name: getattr(self.timing.simulator, f.name) for f in SimulatorConfig.__fields__}
        )
        set_field("timing", dataclasses.replace(self.timing, simulator=simulator))
        self.timing.check(self.sample_time)
        if not callable(getattr(self.trajectory, "evaluate", None)):
            raise ValueError(f"trajectory = {self.trajectory!r} has no evaluate(t)")
        if self.trajectory.joints != self.joints:
            raise ValueError(
                f"trajectory drives {self.trajectory.joints} joints; the nominal model has "
                f"{self.joints}: one trajectory entry per joint is required"
            )
        # Each section checks its values for this arm's joint count (the first use
        # computes and keeps them: functools.cached_property).
        _ = self.sensor_state, self.voltage_limit, self.actuator_state
        if self.sensor.location == "motor" and not self.plant.gear.compliant:
            raise ValueError(
                "sensor.location = 'motor' with plant.gear_stiffness = "
                f"{list(self.plant.gear.gear_stiffness)} (a rigid gear); "
                "plant.gear_stiffness > 0 at some joint or sensor.location = 'link' is required"
            )

    @cached_property
    def sensor_state(self) -> SensorState:
        """The sensor settings a Context holds (they change per run without rebuilding;
        ``Sensor.state``)."""
        return self.sensor.state(self.joints)

    @cached_property
    def actuator_state(self) -> ActuatorState:
        """The actuator settings a Context holds (the lag's time constants and the DAC's
        bits; they change per run without rebuilding, ``Actuator.state``)."""
        return self.actuator.state(self.joints, self.sample_time)

    @cached_property
    def voltage_limit(self) -> tuple[float, ...]:
        """Armature-voltage saturation (V), one per joint (``actuator.voltage_limit``)."""
        return self.actuator.voltage_limits(self.joints)

    @property
    def spec(self) -> ControllerSpec:
        """The controller's spec (label, style, checks, factory; ``models.controllers``)."""
        return controller_spec(self.controller, self.controller_settings)

    @property
    def context(self) -> LoopContext:
        """What every piece of the loop shares: the design's loop context."""
        return self.design.context

    @property
    def samples(self) -> int:
        """``N0 = duration / T_s``, the number of samples ``k = 1..N0`` the metrics use."""
        return round(self.timing.duration / self.sample_time)

    @property
    def noisy(self) -> bool:
        """Whether the sensor adds noise (the diagram then has a noise source)."""
        return any(std > 0.0 for std in self.sensor_state.noise_std)
