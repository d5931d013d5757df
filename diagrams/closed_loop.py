"""The closed loop of Sec. 4 for any of the three controllers, built once and run
many times::

    desired_trajectory -> desired_hold --desired--> controller --voltage--> saturation
                                                       ^                        |
                                          encoder_hold (ZOH, T_s)          u applied
                                                       ^                        v
    [sensor_delay] <- encoder <--------q-------- state_split <--- arm (URDF plant, motor,
                        ^                                                   Coulomb)
                  [encoder_noise]  (bracketed blocks only where the config asks)

Between controller and arm the actuator section (``diagrams.actuator``): [compute_delay]
-> [dac] -> voltage_saturation -> [electrical_lag], each bracketed block only where the
config switches its effect on.

The only path from the plant to the controller is the quantised position
(``tests/test_closed_loop.py`` checks it on the diagram's graph): the true
velocity feeds the friction and motor-work blocks and the loggers, never the
controller. Timing: two ``ZeroOrderHold(T_s)`` blocks sample the encoder and the
desired trajectory at ``t_k = k T_s``; the controller has direct feedthrough
(``models.controllers.base``: ``u_k = g(x_k, y_k)``, ``x_{k+1} = f(x_k, y_k)``), so
the voltage applied on ``[t_k, t_k + T_s)`` uses ``q_measured(t_k)`` with no extra
sample of delay (``docs/drake-notes.md``). A sensor delay of ``d`` samples is a
``DiscreteTimeDelay`` of ``d - 1`` steps at ``T_s`` (read at ``t_k`` before its own
update, it lags one period more than its step count): the controller's update at
``t_k`` reads the measurement of ``t_{k-d}`` (the buffer starts filled with the
first measurement; ``tests/test_scenario.py`` checks the lag); sensor noise
is a ``RandomSource`` sampled at ``T_s`` and scaled inside the encoder.

One logger (a ``VectorLogSink`` of period ``T_s`` behind a ``Multiplexer``,
``log_signals``) records the true and measured ``q``, the desired trajectory, the
commanded and applied voltage and the controller's internals; ``ClosedLoop.log_columns``
says which columns hold which signal. (One sink instead of six: every integrator step
asks each periodic system for its next event, and six sinks cost 8-10 % of a run's
wall time; the simulation is the same to the last bit.) A periodic publish at
``t_k`` is dispatched at the end of the step that reaches ``t_k``, i.e. *before*
the controller's update at ``t_k``: the voltage logged at ``t_{k+1}`` is the one
computed at ``t_k``. ``run`` therefore simulates one sample past ``duration`` and
re-aligns the voltage logs so that every array's row ``k`` belongs to ``t_k`` (the
voltage row is the value applied on ``[t_k, t_k + T_s)``).

Divergence: ``run`` advances the simulator in chunks of ``MONITOR_SAMPLES``
periods (chunk ends are sample instants, so the integrator takes no extra step)
and stops early when the true position is non-finite or ``|q~|`` exceeds
``divergence_bound``; the logged samples are checked against the bound as well,
and an integrator failure is caught. Any of these gives ``status = "diverged"``.
(A monitor system with its own periodic publish would cost a Python callback per
check and, at a period of ``10 T_s``, event times one rounding error away from
the controller's, i.e. extra integrator steps.)

Integration: ``ClosedLoopConfig.simulator``, by default Drake's RK3 with error
control at accuracy 3e-3, steps capped at ``T_s``. Measured on 20 s runs (paper settings,
nominal and payload) against RK3 at 1e-5: Lin+LC's and the proposed
controller's RMS errors change by at most 2 % (joint 2) and 6 % (joint 1, where
they are a few 1e-4 rad) at any accuracy from 1e-2 down.
PID's are sensitive, because its joint-2 error comes from friction bursts at
velocity reversals: at 1e-2 its RMS(q~2) is 20 % low (0.0122 vs 0.0153 rad);
from 3e-3 down it agrees within 3 % (joint 2) and 6 % (joint 1). 3e-3 costs
about 1.2x the wall time of 1e-2; 1e-3 costs 1.3-1.9x for no further gain.
``bench/bench_integrator.py`` measures the whole accuracy-cost curve against RK5
at 1e-9 and the spread of runs perturbed at the integrator's error level.
"""

from __future__ import annotations

import copy
import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property, partial

import numpy as np
from pydrake.common import RandomDistribution, RandomGenerator
from pydrake.geometry import Meshcat, MeshcatVisualizer, SceneGraph
from pydrake.systems.analysis import (
    ApplySimulatorConfig,
    Simulator,
    SimulatorConfig,
)
from pydrake.systems.framework import (
    Context,
    Diagram,
    DiagramBuilder,
    LeafSystem,
    OutputPort,
)
from pydrake.systems.primitives import (
    DiscreteTimeDelay,
    Multiplexer,
    RandomSource,
    Saturation,
    TrajectorySource,
    VectorLogSink,
    ZeroOrderHold,
)

from posfb.diagrams.actuator import (
    ActuatorBlocks,
    ActuatorState,
    add_actuator,
)
from posfb.diagrams.encoder import Encoder
from posfb.diagrams.sections import (
    Actuator,
    Sensor,
    SensorState,
    Timing,
)
from posfb.models.controllers import (
    REGISTRY,
    ControllerConfig,
    ControllerSpec,
    UserPlugin,
    controller_spec,
    make_controller,
)
from posfb.models.controllers.base import SampledController
from posfb.models.controllers.plugin import user_frames
from posfb.models.gear import GearConfig
from posfb.models.plant import (
    Arm,
    ArmParameters,
    PlantConfig,
    add_arm,
    apply_parameters,
    set_friction_law,
    set_gear,
    set_motor_state,
)
from posfb.models.trajectory import Trajectory, WaveTrajectory, sampled_source

#: ``run`` checks for divergence every this many control periods.
MONITOR_SAMPLES = 10

#: Names of the logged signals, in ``ClosedLoop.log_columns``.
LOGGED = ("q_true", "q_measured", "desired", "u_commanded", "u_applied", "internals")


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
class ClosedLoopConfig:
    """One closed-loop run, resolved and validated (``diagrams.scenario`` builds it
    from a scenario file; the defaults are the paper's settings).

    ``design`` is everything the controller is built from, its sample time ``T_s``
    included (the only one: ``sample_time`` reads it); ``controller_settings`` the
    settings of a plug-in kind's scenario entry or a user's plug-in
    (``models.controllers.plugin.UserPlugin``; ``None`` for the paper's three, whose
    inputs are all in ``design``); ``trajectory`` the desired path; ``timing``,
    ``sensor`` and ``actuator`` the scenario's sections as they are
    (``diagrams.sections``; copied, then read through the properties below):
    ``duration``, ``divergence_bound`` on ``|q~|`` in rad and Drake's integrator
    ``simulator`` (the runner caps ``max_step_size`` at ``T_s``: a step never spans more
    than one control period; ``timing.sample_time`` must be the design's); per joint,
    ``encoder_counts`` per revolution (0: ideal; default and its justification in
    ``diagrams.encoder``), ``zero_offset`` (rad, added to the true position before
    quantisation), ``noise_std`` (rad, additive Gaussian noise after it, drawn from
    ``noise_seed``), ``delay_samples`` (whole periods), ``voltage_limit`` (V),
    ``electrical_time_constant`` (s), and ``dac_bits`` and ``compute_delay`` (s, at most
    ``T_s``) for all joints (``diagrams.actuator``; 0 switches an effect off);
    ``true_plant`` the true arm's payload and parameter overrides
    (``ClosedLoopRunner.run`` applies them unless it is given other parameters, as a
    Monte-Carlo sample is). The number of joints
    ``n`` is the design's nominal model's; the trajectory and the plant URDF must
    have as many. Per-joint values take one number for all joints or one per joint.
    Its errors name each setting by its scenario key (``timing.duration``,
    ``sensor.encoder_counts[1]``), the one name a setting has (``diagrams.scenario``).
    """

    controller: str = "proposed"
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
        self.timing.check(self.design.sample_time)
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
    def duration(self) -> float:
        """Simulated seconds (``timing.duration``)."""
        return self.timing.duration

    @property
    def divergence_bound(self) -> float:
        """``|q~|`` (rad) beyond which a run counts as diverged."""
        return self.timing.divergence_bound

    @property
    def simulator(self) -> SimulatorConfig:
        """Drake's integrator settings (``timing.simulator``)."""
        return self.timing.simulator

    @property
    def encoder_counts(self) -> tuple[int, ...]:
        """Counts per revolution, one per joint (``sensor.encoder_counts``)."""
        return self.sensor_state.encoder_counts

    @property
    def zero_offset(self) -> tuple[float, ...]:
        """Encoder zero offset (rad), one per joint."""
        return self.sensor_state.zero_offset

    @property
    def noise_std(self) -> tuple[float, ...]:
        """Encoder noise standard deviation (rad), one per joint."""
        return self.sensor_state.noise_std

    @property
    def sensor_location(self) -> str:
        """``link`` (the encoder reads ``q``) or ``motor`` (``theta_m``, ``models.gear``)."""
        return self.sensor.location

    @property
    def noise_seed(self) -> int:
        return self.sensor.noise_seed

    @property
    def delay_samples(self) -> int:
        """The sensor delay in whole periods."""
        return self.sensor.delay_samples

    @property
    def electrical_time_constant(self) -> tuple[float, ...]:
        """Armature L/R (s), one per joint (0: static motor; ``diagrams.actuator``)."""
        return self.actuator_state.electrical_time_constant

    @property
    def dac_bits(self) -> int:
        """DAC resolution in bits (0: ideal)."""
        return int(self.actuator.dac_bits)

    @property
    def compute_delay(self) -> float:
        """The DSP's computation time (s): ``u_k`` applies from ``t_k + compute_delay``."""
        return float(self.actuator.compute_delay)

    @property
    def spec(self) -> ControllerSpec:
        """The controller's spec (label, style, checks, factory; ``models.controllers``)."""
        return controller_spec(self.controller, self.controller_settings)

    @property
    def joints(self) -> int:
        """``n``: the number of joints (the design's nominal model's)."""
        return self.design.joints

    @property
    def sample_time(self) -> float:
        """``T_s`` (s): the controller's period, which the loggers and the sensor share."""
        return self.design.sample_time

    @property
    def samples(self) -> int:
        """``N0 = duration / T_s``, the number of samples ``k = 1..N0`` the metrics use."""
        return round(self.duration / self.sample_time)

    @property
    def noisy(self) -> bool:
        """Whether the sensor adds noise (the diagram then has a noise source)."""
        return any(std > 0.0 for std in self.noise_std)


@dataclass(frozen=True, eq=False)
class ClosedLoopResult:
    """One run, sampled at ``t_k = k T_s``, ``k = 0..K`` (``K = N0`` unless diverged).

    Arrays have one row per sample: ``q_true``, ``q_measured``, ``q_desired`` (rad,
    n columns), ``qd_desired`` (rad/s) and ``qdd_desired`` (rad/s^2), the rest of the
    desired input the controller held (``None`` in a result made by hand);
    ``u_commanded``, ``u_applied`` (V, the voltage computed at ``t_k`` and applied on
    ``[t_k, t_k + T_s)``); ``internals`` (columns ``internals_names``;
    ``internals_columns`` are the same names with their units). ``status`` is the
    runner's: ``"ok"`` (the run reached ``duration``) or ``"diverged"`` (stopped early);
    ``message`` says why a run stopped early (empty if it did not). Whether a run that
    reached its end tracked its path (``saturated``, ``lost``) is judged from these logs
    by ``analysis.common.metrics.run_verdict``, which every report of a run uses;
    ``wall_time_s`` is the simulation's wall time (build excluded); ``derivative_evaluations`` and
    ``integrator_steps`` are the integrator's counts over the run. Metrics are
    computed from these logs in ``analysis.common.metrics``.
    """

    config: ClosedLoopConfig
    times: np.ndarray
    q_true: np.ndarray
    q_measured: np.ndarray
    q_desired: np.ndarray
    u_commanded: np.ndarray
    u_applied: np.ndarray
    internals: np.ndarray
    internals_names: tuple[str, ...]
    internals_columns: tuple[str, ...]
    status: str
    message: str
    wall_time_s: float
    derivative_evaluations: int = 0
    integrator_steps: int = 0
    qd_desired: np.ndarray | None = None
    qdd_desired: np.ndarray | None = None

    @property
    def controller(self) -> str:
        return self.config.controller

    @property
    def q_error(self) -> np.ndarray:
        """The true tracking error ``q~ = q - q_d`` (rad)."""
        return self.q_true - self.q_desired


@dataclass(frozen=True, eq=False)
class LoopSystems:
    """The closed loop's systems, as an ``extend`` callback of ``build_closed_loop``
    sees them before the diagram is built (``delay`` and ``noise_source`` are ``None``
    where the sensor has no delay or noise; ``actuator`` holds the actuator section's
    blocks, ``diagrams.actuator``)."""

    arm: Arm
    trajectory_source: TrajectorySource
    encoder: Encoder
    delay: DiscreteTimeDelay | None
    noise_source: RandomSource | None
    encoder_hold: ZeroOrderHold
    desired_hold: ZeroOrderHold
    controller: LeafSystem
    saturation: Saturation
    logger: VectorLogSink
    log_columns: dict[str, slice]
    scene_graph: SceneGraph
    actuator: ActuatorBlocks


#: ``extend(builder, systems)``: wires more into a closed loop before it is built.
Extension = Callable[[DiagramBuilder, LoopSystems], None]


@dataclass(frozen=True, eq=False)
class ClosedLoop(LoopSystems):
    """A built closed-loop diagram and handles to its parts."""

    diagram: Diagram | None = None
    visualizer: MeshcatVisualizer | None = None


def _find_scene_graph(builder: DiagramBuilder) -> SceneGraph:
    """The SceneGraph that ``AddMultibodyPlant`` (inside ``add_arm``) created."""
    for system in builder.GetSystems():
        if isinstance(system, SceneGraph):
            return system
    raise RuntimeError("add_arm did not add a SceneGraph")


def _add_sensor(
    builder: DiagramBuilder, config: ClosedLoopConfig, arm: Arm
) -> tuple[Encoder, OutputPort, DiscreteTimeDelay | None, RandomSource | None]:
    """true q -> encoder (offset, quantiser, noise) -> delay: the measured-position port."""
    n = arm.size
    encoder = builder.AddSystem(Encoder(n, config.encoder_counts, noisy=config.noisy))
    builder.Connect(arm.position_output_port(config.sensor_location), encoder.GetInputPort("q"))
    noise_source = None
    if config.noisy:
        noise_source = builder.AddSystem(
            RandomSource(RandomDistribution.kGaussian, n, config.sample_time)
        )
        noise_source.set_name("encoder_noise")
        builder.Connect(noise_source.get_output_port(0), encoder.GetInputPort("unit_noise"))
    measured = encoder.GetOutputPort("q_measured")
    delay = None
    if config.delay_samples > 0:
        delay = builder.AddSystem(
            # Read at t_k before its own update, a delay of n steps lags n + 1 periods.
            DiscreteTimeDelay(config.sample_time, config.delay_samples - 1, n)
        )
        delay.set_name("sensor_delay")
        builder.Connect(measured, delay.get_input_port())
        measured = delay.get_output_port()
    return encoder, measured, delay, noise_source


def hold_inputs(
    builder: DiagramBuilder,
    controller: LeafSystem,
    measured: OutputPort,
    desired: OutputPort,
    sample_time: float,
) -> tuple[ZeroOrderHold, ZeroOrderHold]:
    """Feed ``controller`` (``models.controllers.base``) its measured position and desired
    trajectory through ``ZeroOrderHold(T_s)`` blocks, the sampling the design assumes."""
    holds = []
    for name, port, target in (
        ("encoder_hold", measured, "q_measured"),
        ("desired_hold", desired, "desired"),
    ):
        hold = builder.AddSystem(ZeroOrderHold(sample_time, port.size()))
        hold.set_name(name)
        builder.Connect(port, hold.get_input_port())
        builder.Connect(hold.get_output_port(), controller.GetInputPort(target))
        holds.append(hold)
    return holds[0], holds[1]


def build_closed_loop(
    config: ClosedLoopConfig,
    meshcat: Meshcat | None = None,
    extend: Extension | None = None,
    controller: SampledController | None = None,
) -> ClosedLoop:
    """Wire plant, trajectory, sensor, controller, saturation and loggers. With
    ``meshcat``, a ``MeshcatVisualizer`` of the arm is added (for recordings); with
    ``extend``, ``extend(builder, systems)`` wires more (a disturbance, a second
    logger) before the diagram is built; ``controller`` replaces the one the config
    builds (a software-in-the-loop run's compiled controller, same ports)."""
    builder = DiagramBuilder()
    arm = add_arm(builder, config.plant)
    if arm.size != config.joints:
        raise ValueError(
            f"plant.urdf = {config.plant.urdf!r} has {arm.size} joints; the nominal model "
            f"has {config.joints}: the same number is required"
        )
    # Two samples past the last one read (t_{N0+1}): a sample is exact at its own start.
    trajectory = builder.AddSystem(
        sampled_source(config.trajectory, config.sample_time, config.samples + 3)
    )
    encoder, measured, delay, noise_source = _add_sensor(builder, config, arm)
    if controller is None:
        controller = make_controller(
            config.controller,
            config.design,
            voltage_limit=config.voltage_limit,
            settings=config.controller_settings,
        )
    controller = builder.AddSystem(controller)
    actuator = add_actuator(
        builder,
        controller.GetOutputPort("voltage"),
        limits=config.voltage_limit,
        sample_time=config.sample_time,
        compute_delay=config.compute_delay,
        dac_bits=config.dac_bits,
        electrical_time_constant=config.electrical_time_constant,
    )
    saturation = actuator.saturation

    desired_port = trajectory.get_output_port(0)
    encoder_hold, desired_hold = hold_inputs(
        builder, controller, measured, desired_port, config.sample_time
    )
    builder.Connect(actuator.motor_voltage, arm.voltage_input_port())

    sources = {
        "q_true": arm.position_output_port(),
        "q_measured": measured,
        "desired": desired_port,
        "u_commanded": controller.GetOutputPort("voltage"),
        "u_applied": actuator.applied,
        "internals": controller.GetOutputPort("internals"),
    }
    sizes = [sources[name].size() for name in LOGGED]
    signals = builder.AddSystem(Multiplexer(sizes))
    signals.set_name("log_signals")
    log_columns, start = {}, 0
    for index, (name, size) in enumerate(zip(LOGGED, sizes, strict=True)):
        builder.Connect(sources[name], signals.get_input_port(index))
        log_columns[name] = slice(start, start + size)
        start += size
    logger = builder.AddSystem(VectorLogSink(start, config.sample_time))
    logger.set_name("log")
    builder.Connect(signals.get_output_port(0), logger.get_input_port(0))

    systems = LoopSystems(
        arm, trajectory, encoder, delay, noise_source, encoder_hold, desired_hold, controller,
        saturation, logger, log_columns, _find_scene_graph(builder), actuator,
    )  # fmt: skip
    if extend is not None:
        extend(builder, systems)
    visualizer = (
        None
        if meshcat is None
        else MeshcatVisualizer.AddToBuilder(builder, systems.scene_graph, meshcat)
    )
    diagram = builder.Build()
    diagram.set_name(f"closed_loop_{config.controller}")
    parts = {f.name: getattr(systems, f.name) for f in dataclasses.fields(LoopSystems)}
    return ClosedLoop(**parts, diagram=diagram, visualizer=visualizer)


class ClosedLoopRunner:
    """Builds the closed loop of ``config`` once; ``run`` simulates it on a fresh
    Context, on the config's true arm (``config.true_plant``) or on given true plant
    parameters (the controller keeps the model of ``config.design.nominal``).
    ``meshcat``, ``extend`` and ``controller``: see ``build_closed_loop``."""

    def __init__(
        self,
        config: ClosedLoopConfig,
        *,
        meshcat: Meshcat | None = None,
        extend: Extension | None = None,
        controller: SampledController | None = None,
    ) -> None:
        self.config = config
        self.loop = build_closed_loop(config, meshcat, extend, controller)

    @property
    def diagram(self) -> Diagram:
        return self.loop.diagram

    @property
    def arm(self) -> Arm:
        return self.loop.arm

    def true_parameters(self) -> ArmParameters:
        """The config's true arm: the URDF's parameters with ``config.true_plant``."""
        return self.config.true_plant.parameters(self.arm.default_parameters)

    def new_context(
        self,
        parameters: ArmParameters | None = None,
        sensor: SensorState | None = None,
        friction: object | None = None,
        gear: GearConfig | None = None,
        actuator: ActuatorState | None = None,
    ) -> Context:
        """A fresh Context: true ``parameters`` (default: ``true_parameters()``), the
        ``sensor`` settings (default: the config's), the friction law's values
        (``friction``, an entry of the law the diagram was built with, e.g. a Monte-Carlo
        sample's draw; default: the config's), the gear's values (``gear``; any joint
        compliant only where the diagram has a gear block; default: the config's), the
        ``actuator`` settings (the electrical lag's time constants and the DAC's bits,
        ``diagrams.actuator``; default: the config's), the arm at rest at ``q_d(0)``
        (with a gear block, each motor too: ``theta_m = q``,
        ``models.plant.set_motor_state``); a sensor delay line is filled with the first
        measurement; a compute-delay hold (``diagrams.actuator``) starts at the
        controller's voltage before its first update."""
        loop, config = self.loop, self.config
        sensor = config.sensor_state if sensor is None else sensor
        if any(std > 0.0 for std in sensor.noise_std) and loop.noise_source is None:
            raise ValueError(
                f"noise_std = {list(sensor.noise_std)} needs a diagram built with sensor "
                "noise (a config with noise_std > 0)"
            )
        context = loop.diagram.CreateDefaultContext()
        apply_parameters(loop.arm, context, parameters or self.true_parameters())
        if friction is not None:
            set_friction_law(loop.arm, context, friction)
        if gear is not None:
            set_gear(loop.arm, context, gear)
        loop.actuator.set_state(context, config.actuator_state if actuator is None else actuator)
        encoder_context = loop.encoder.GetMyMutableContextFromRoot(context)
        loop.encoder.set_counts(encoder_context, sensor.encoder_counts)
        loop.encoder.set_zero_offset(encoder_context, sensor.zero_offset)
        if loop.noise_source is not None:
            loop.encoder.set_noise_std(encoder_context, sensor.noise_std)
            loop.noise_source.SetRandomContext(
                loop.noise_source.GetMyMutableContextFromRoot(context),
                RandomGenerator(sensor.noise_seed),
            )
        plant = loop.arm.plant
        plant_context = plant.GetMyMutableContextFromRoot(context)
        plant.SetPositions(plant_context, config.trajectory.evaluate(0.0)[0])
        plant.SetVelocities(plant_context, np.zeros(config.joints))
        set_motor_state(loop.arm, context)
        first = loop.encoder.GetOutputPort("q_measured").Eval(encoder_context)
        if loop.delay is not None:
            delay_context = loop.delay.GetMyMutableContextFromRoot(context)
            buffer = delay_context.get_discrete_state_vector().size() // config.joints
            delay_context.SetDiscreteState(np.tile(first, buffer))
        # The holds start at the first sample (they take it again at t = 0).
        loop.encoder_hold.SetVectorState(
            loop.encoder_hold.GetMyMutableContextFromRoot(context), first
        )
        loop.desired_hold.SetVectorState(
            loop.desired_hold.GetMyMutableContextFromRoot(context),
            np.concatenate(config.trajectory.evaluate(0.0)),
        )
        hold = loop.actuator.compute_delay
        if hold is not None:  # applied until t = compute_delay (diagrams.actuator)
            voltage = loop.controller.GetOutputPort("voltage").Eval(
                loop.controller.GetMyContextFromRoot(context)
            )
            hold.SetVectorState(hold.GetMyMutableContextFromRoot(context), voltage)
        return context

    def new_simulator(
        self,
        parameters: ArmParameters | None = None,
        sensor: SensorState | None = None,
        friction: object | None = None,
        gear: GearConfig | None = None,
        actuator: ActuatorState | None = None,
    ) -> Simulator:
        """A ``Simulator`` on ``new_context(parameters, sensor, friction, gear, actuator)``
        with the config's integrator (``simulator_config``), not yet initialised."""
        simulator = Simulator(
            self.loop.diagram, self.new_context(parameters, sensor, friction, gear, actuator)
        )
        ApplySimulatorConfig(self.simulator_config(), simulator)
        return simulator

    def run(
        self,
        parameters: ArmParameters | None = None,
        sensor: SensorState | None = None,
        progress: Callable[[float], None] | None = None,
        friction: object | None = None,
        gear: GearConfig | None = None,
        actuator: ActuatorState | None = None,
    ) -> ClosedLoopResult:
        """Simulate ``duration`` seconds on the true ``parameters`` with the ``sensor``
        settings, the friction law's, the gear's and the ``actuator``'s values (defaults:
        ``true_parameters()`` and the config's); ``progress`` is called with the simulated
        time after every ``MONITOR_SAMPLES`` periods. Never raises for a diverging run."""
        simulator = self.new_simulator(parameters, sensor, friction, gear, actuator)
        return self.advance(simulator, progress)

    def advance(
        self, simulator: Simulator, progress: Callable[[float], None] | None = None
    ) -> ClosedLoopResult:
        """Run ``simulator`` (from ``new_simulator``) from t = 0 through ``duration``,
        watching for divergence, and collect its logs (``run``)."""
        context = simulator.get_mutable_context()
        T_s = self.config.sample_time
        # One sample past the end: the voltage computed at t_N0 is logged at t_N0+1.
        last = self.config.samples + 1
        status, message = "ok", ""
        start = time.perf_counter()
        try:
            simulator.Initialize()
            for sample in range(MONITOR_SAMPLES, last + MONITOR_SAMPLES, MONITOR_SAMPLES):
                simulator.AdvanceTo(min(sample, last) * T_s)
                if progress is not None:
                    progress(context.get_time())
                message = self._divergence(context)
                if message:
                    status = "diverged"
                    break
        except RuntimeError as error:
            if user_frames(error):  # raised by a user's plug-in controller, not Drake
                raise
            status = "diverged"
            message = f"integrator failed: {str(error).strip().splitlines()[0]}"
        wall = time.perf_counter() - start
        result = self.collect(context, status, message, wall)
        integrator = simulator.get_integrator()
        return dataclasses.replace(
            result,
            derivative_evaluations=integrator.get_num_derivative_evaluations(),
            integrator_steps=integrator.get_num_steps_taken(),
        )

    def simulator_config(self) -> SimulatorConfig:
        """The config's integrator with steps capped at one sample period ``T_s``."""
        settings = self.config.simulator
        values = {entry.name: getattr(settings, entry.name) for entry in SimulatorConfig.__fields__}
        values["max_step_size"] = min(settings.max_step_size, self.config.sample_time)
        return SimulatorConfig(**values)

    def _divergence(self, context: Context) -> str:
        """Why the run in ``context`` counts as diverged now ("" if it does not)."""
        plant = self.loop.arm.plant
        q = plant.GetPositions(plant.GetMyContextFromRoot(context))
        if not np.all(np.isfinite(q)):
            return f"non-finite joint position {q.tolist()} at t = {context.get_time():g} s"
        q_desired = self.config.trajectory.evaluate(context.get_time())[0]
        error = float(np.max(np.abs(q - q_desired)))
        if error > self.config.divergence_bound:
            return (
                f"|q~| = {error:.3g} rad exceeds divergence_bound = "
                f"{self.config.divergence_bound:g} rad at t = {context.get_time():g} s"
            )
        return ""

    def _check_logged(self, q_error: np.ndarray) -> tuple[str, str]:
        """Divergence the monitor (every ``MONITOR_SAMPLES`` periods) may have missed."""
        if not np.all(np.isfinite(q_error)):
            return "diverged", "non-finite joint position in the log"
        worst = float(np.max(np.abs(q_error))) if q_error.size else 0.0
        if worst > self.config.divergence_bound:
            return "diverged", (
                f"|q~| = {worst:.3g} rad exceeds divergence_bound = "
                f"{self.config.divergence_bound:g} rad"
            )
        return "ok", ""

    def collect(
        self, context: Context, status: str = "ok", message: str = "", wall: float = 0.0
    ) -> ClosedLoopResult:
        """The logs in root ``context`` as a ``ClosedLoopResult`` (``status`` is checked
        against the logged errors; a script that advanced a simulator itself passes only
        the context)."""
        log = self.loop.logger.FindLog(context)
        samples = log.data().T
        data = {name: samples[:, columns] for name, columns in self.loop.log_columns.items()}
        times = log.sample_times()
        rows = len(times)
        # Rows 0..K of the state-like logs; the voltage logged at t_{k+1} belongs to t_k.
        # A run that stopped early ends at its last complete pair (at least row 0).
        count = min(rows - 1, self.config.samples + 1)
        kept = max(count, min(rows, 1))
        q_true, q_measured = data["q_true"][:kept], data["q_measured"][:kept]
        n = self.config.joints
        q_desired = data["desired"][:kept, :n]
        shifted = {}
        for name in ("u_commanded", "u_applied", "internals"):
            values = data[name][1 : count + 1]
            shifted[name] = (
                values if len(values) == kept else np.full((kept, values.shape[1]), np.nan)
            )
        if status == "ok":
            status, message = self._check_logged(q_true - q_desired)
        return ClosedLoopResult(
            config=self.config,
            times=times[:kept],
            q_true=q_true,
            q_measured=q_measured,
            q_desired=q_desired,
            u_commanded=shifted["u_commanded"],
            u_applied=shifted["u_applied"],
            internals=shifted["internals"],
            internals_names=tuple(self.loop.controller.internals_names),
            internals_columns=tuple(self.loop.controller.internals_columns),
            status=status,
            message=message,
            wall_time_s=wall,
            qd_desired=data["desired"][:kept, n : 2 * n],
            qdd_desired=data["desired"][:kept, 2 * n : 3 * n],
        )
