"""The closed loop of Sec. 4 wired as a Drake diagram (``build_closed_loop``), for any
controller::

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
(``tests/diagrams/test_closed_loop.py`` checks it on the diagram's graph): the true
velocity feeds the friction and motor-work blocks and the loggers, never the
controller. Timing: two ``ZeroOrderHold(T_s)`` blocks sample the encoder and the
desired trajectory at ``t_k = k T_s``; the controller has direct feedthrough
(``models.controllers.base``: ``u_k = g(x_k, y_k)``, ``x_{k+1} = f(x_k, y_k)``), so
the voltage applied on ``[t_k, t_k + T_s)`` uses ``q_measured(t_k)`` with no extra
sample of delay (``docs/drake-notes.md``). A sensor delay of ``d`` samples is a
``DiscreteTimeDelay`` of ``d - 1`` steps at ``T_s`` (read at ``t_k`` before its own
update, it lags one period more than its step count): the controller's update at
``t_k`` reads the measurement of ``t_{k-d}`` (the buffer starts filled with the
first measurement; ``tests/diagrams/test_scenario.py`` checks the lag); sensor noise
is a ``RandomSource`` sampled at ``T_s`` and scaled inside the encoder.

One logger (a ``VectorLogSink`` of period ``T_s`` behind a ``Multiplexer``,
``log_signals``) records the true and measured ``q``, the desired trajectory, the
commanded and applied voltage and the controller's internals; ``ClosedLoop.log_columns``
says which columns hold which signal. (One sink instead of six: every integrator step
asks each periodic system for its next event, and six sinks cost 8-10 % of a run's
wall time; the simulation is the same to the last bit.)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

from pydrake.common import RandomDistribution
from pydrake.geometry import Meshcat, MeshcatVisualizer, SceneGraph
from pydrake.systems.framework import (
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

from posfb.diagrams.actuator import ActuatorBlocks, add_actuator
from posfb.diagrams.encoder import Encoder
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.models.controllers import make_controller
from posfb.models.controllers.base import SampledController
from posfb.models.plant import Arm, add_arm
from posfb.models.trajectory import sampled_source

#: Names of the logged signals, in ``ClosedLoop.log_columns``.
LOGGED = ("q_true", "q_measured", "desired", "u_commanded", "u_applied", "internals")


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
    encoder = builder.AddSystem(Encoder(n, config.sensor_state.encoder_counts, noisy=config.noisy))
    builder.Connect(arm.position_output_port(config.sensor.location), encoder.GetInputPort("q"))
    noise_source = None
    if config.noisy:
        noise_source = builder.AddSystem(
            RandomSource(RandomDistribution.kGaussian, n, config.sample_time)
        )
        noise_source.set_name("encoder_noise")
        builder.Connect(noise_source.get_output_port(0), encoder.GetInputPort("unit_noise"))
    measured = encoder.GetOutputPort("q_measured")
    delay = None
    if config.sensor.delay_samples > 0:
        delay = builder.AddSystem(
            # Read at t_k before its own update, a delay of n steps lags n + 1 periods.
            DiscreteTimeDelay(config.sample_time, config.sensor.delay_samples - 1, n)
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
        compute_delay=config.actuator.compute_delay,
        dac_bits=config.actuator.dac_bits,
        electrical_time_constant=config.actuator_state.electrical_time_constant,
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
