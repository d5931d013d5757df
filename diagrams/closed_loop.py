"""The closed loop of Sec. 4 for any of the three controllers, built once and run
many times::

    desired_trajectory --desired--> controller --voltage--> saturation (+-24 V)
                                        ^                       |
                                   q_measured              u applied
                                        |                       v
    encoder (quantiser) <----q---- state_split <--- arm (URDF plant, motor, Coulomb)

The only path from the plant to the controller is the quantised position
(``tests/test_closed_loop.py`` checks it on the diagram's graph): the true
velocity feeds the friction and motor-work blocks and the loggers, never the
controller. Timing: the controller's periodic update at ``t_k = k T_s`` reads
``q_measured(t_k)`` straight from the stateless encoder and holds its voltage on
``[t_k, t_k + T_s)``; there is no ZeroOrderHold in between (it would add one
sample of delay, ``../shared/DRAKE-NOTES.md``).

Loggers (``VectorLogSink``, period ``T_s``) record the true and measured ``q``,
the desired trajectory, the commanded and applied voltage and the controller's
internals. A periodic publish at ``t_k`` is dispatched at the end of the step
that reaches ``t_k``, i.e. *before* the controller's update at ``t_k``: the
voltage logged at ``t_{k+1}`` is the one computed at ``t_k``. ``run`` therefore
simulates one sample past ``duration`` and re-aligns the voltage logs so that
every array's row ``k`` belongs to ``t_k`` (the voltage row is the value applied
on ``[t_k, t_k + T_s)``).

Divergence: ``run`` advances the simulator in chunks of ``MONITOR_SAMPLES``
periods (chunk ends are sample instants, so the integrator takes no extra step)
and stops early when the true position is non-finite or ``|q~|`` exceeds
``divergence_bound``; the logged samples are checked against the bound as well,
and an integrator failure is caught. Any of these gives ``status = "diverged"``.
(A monitor system with its own periodic publish would cost a Python callback per
check and, at a period of ``10 T_s``, event times one rounding error away from
the controller's, i.e. extra integrator steps.)

Integration: Drake's RK3 with error control at accuracy ``integrator_accuracy``
(default 3e-3), steps capped at ``T_s``. Measured on 20 s runs (paper settings,
nominal and payload) against RK3 at 1e-5: Lin+LC's and the proposed
controller's RMS errors change by at most 2 % (joint 2) and 6 % (joint 1, where
they are a few 1e-4 rad) at any accuracy from 1e-2 down.
PID's are sensitive, because its joint-2 error comes from friction bursts at
velocity reversals: at 1e-2 its RMS(q~2) is 20 % low (0.0122 vs 0.0153 rad);
from 3e-3 down it agrees within 3 % (joint 2) and 6 % (joint 1). 3e-3 costs
about 1.2x the wall time of 1e-2; 1e-3 costs 1.3-1.9x for no further gain.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from posfb.analysis.metrics import RunMetrics, compute_metrics
from posfb.diagrams.encoder import DEFAULT_ENCODER_COUNTS, Encoder, require_counts
from posfb.models.controllers import CONTROLLER_KINDS, ControllerConfig, make_controller
from posfb.models.lumped import TABLE1, LumpedParameters
from posfb.models.plant import Arm, ArmParameters, PlantConfig, add_arm, apply_parameters
from posfb.models.trajectory import DesiredTrajectory, desired
from posfb.models.validation import require_positive
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
)
from pydrake.systems.primitives import Saturation, VectorLogSink

#: The paper's armature-voltage range, +-24 V (Sec. 4.1).
VOLTAGE_LIMIT = 24.0

#: Default bound on |q~| (rad) beyond which a run counts as diverged: about
#: 60 deg, 200x the largest RMS error of Tables 3-4: no controller that still
#: tracks gets near it, and a runaway is stopped before it costs much time.
DIVERGENCE_BOUND = 1.0

#: ``run`` checks for divergence every this many control periods.
MONITOR_SAMPLES = 10

#: Names of the logged signals, in ``ClosedLoop.loggers``.
LOGGED = ("q_true", "q_measured", "desired", "u_commanded", "u_applied", "internals")


@dataclass(frozen=True)
class ClosedLoopConfig:
    """One closed-loop experiment of Sec. 4 (defaults: the paper's settings).

    ``encoder_counts`` per joint revolution (0: ideal sensor; default and its
    justification in ``diagrams.encoder``), ``voltage_limit`` in volts,
    ``divergence_bound`` on ``|q~|`` in rad, ``integrator_accuracy`` for RK3.
    """

    controller: str = "proposed"
    sample_time: float = 0.01
    duration: float = 20.0
    encoder_counts: int = DEFAULT_ENCODER_COUNTS
    voltage_limit: float = VOLTAGE_LIMIT
    plant: PlantConfig = field(default_factory=PlantConfig)
    divergence_bound: float = DIVERGENCE_BOUND
    integrator_accuracy: float = 3e-3

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLER_KINDS:
            raise ValueError(
                f"controller = {self.controller!r}; one of {', '.join(CONTROLLER_KINDS)} "
                "is required"
            )
        require_positive("sample_time", self.sample_time)
        require_positive("duration", self.duration)
        if (
            self.duration < self.sample_time
            or abs(self.samples * self.sample_time - self.duration) > 1e-9 * self.duration
        ):
            raise ValueError(
                f"duration = {self.duration!r} is not a whole number (>= 1) of sample_time = "
                f"{self.sample_time!r} periods"
            )
        require_counts("encoder_counts", self.encoder_counts)
        require_positive("voltage_limit", self.voltage_limit)
        require_positive("divergence_bound", self.divergence_bound)
        accuracy = require_positive("integrator_accuracy", self.integrator_accuracy)
        if accuracy >= 1.0:
            raise ValueError(f"integrator_accuracy = {accuracy!r}; a value in (0, 1) is required")
        if not isinstance(self.plant, PlantConfig):
            raise ValueError(f"plant = {self.plant!r} is not a PlantConfig")

    @property
    def samples(self) -> int:
        """``N0 = duration / T_s``, the number of samples ``k = 1..N0`` the metrics use."""
        return round(self.duration / self.sample_time)


@dataclass(frozen=True, eq=False)
class ClosedLoopResult:
    """One run, sampled at ``t_k = k T_s``, ``k = 0..K`` (``K = N0`` unless diverged).

    Arrays have one row per sample: ``q_true``, ``q_measured``, ``q_desired`` (rad,
    2 columns); ``u_commanded``, ``u_applied`` (V, the voltage computed at ``t_k``
    and applied on ``[t_k, t_k + T_s)``); ``internals`` (columns
    ``internals_names``). ``metrics`` use rows ``1..K``. ``status`` is ``"ok"`` or
    ``"diverged"``; ``message`` says why a run stopped early (empty if it did not).
    """

    controller: str
    times: np.ndarray
    q_true: np.ndarray
    q_measured: np.ndarray
    q_desired: np.ndarray
    u_commanded: np.ndarray
    u_applied: np.ndarray
    internals: np.ndarray
    internals_names: tuple[str, ...]
    metrics: RunMetrics
    status: str
    message: str

    @property
    def q_error(self) -> np.ndarray:
        """The true tracking error ``q~ = q - q_d`` (rad)."""
        return self.q_true - self.q_desired


@dataclass(frozen=True, eq=False)
class ClosedLoop:
    """A built closed-loop diagram and handles to its parts."""

    diagram: Diagram
    arm: Arm
    encoder: Encoder
    controller: LeafSystem
    loggers: dict[str, VectorLogSink]
    scene_graph: SceneGraph
    visualizer: MeshcatVisualizer | None


def _find_scene_graph(builder: DiagramBuilder) -> SceneGraph:
    """The SceneGraph that ``AddMultibodyPlant`` (inside ``add_arm``) created."""
    for system in builder.GetSystems():
        if isinstance(system, SceneGraph):
            return system
    raise RuntimeError("add_arm did not add a SceneGraph")


def build_closed_loop(
    config: ClosedLoopConfig,
    controller_config: ControllerConfig,
    meshcat: Meshcat | None = None,
) -> ClosedLoop:
    """Wire plant, trajectory, encoder, controller, saturation, loggers and monitor.

    ``controller_config.sample_time`` must equal ``config.sample_time``. With
    ``meshcat``, a ``MeshcatVisualizer`` of the arm is added (for recordings)."""
    if controller_config.sample_time != config.sample_time:
        raise ValueError(
            f"controller sample_time = {controller_config.sample_time!r} differs from "
            f"sample_time = {config.sample_time!r}"
        )
    builder = DiagramBuilder()
    arm = add_arm(builder, config.plant)
    trajectory = builder.AddSystem(DesiredTrajectory())
    encoder = builder.AddSystem(Encoder(2, config.encoder_counts))
    controller = builder.AddSystem(make_controller(config.controller, controller_config))
    limit = np.full(2, config.voltage_limit)
    saturation = builder.AddSystem(Saturation(-limit, limit))
    saturation.set_name("voltage_saturation")

    desired_port = trajectory.get_output_port(0)
    builder.Connect(arm.position_output_port(), encoder.get_input_port(0))
    builder.Connect(encoder.get_output_port(0), controller.GetInputPort("q_measured"))
    builder.Connect(desired_port, controller.GetInputPort("desired"))
    builder.Connect(controller.GetOutputPort("voltage"), saturation.get_input_port(0))
    builder.Connect(saturation.get_output_port(0), arm.voltage_input_port())

    sources = {
        "q_true": arm.position_output_port(),
        "q_measured": encoder.get_output_port(0),
        "desired": desired_port,
        "u_commanded": controller.GetOutputPort("voltage"),
        "u_applied": saturation.get_output_port(0),
        "internals": controller.GetOutputPort("internals"),
    }
    loggers = {}
    for name in LOGGED:
        port = sources[name]
        logger = builder.AddSystem(VectorLogSink(port.size(), config.sample_time))
        logger.set_name(f"log_{name}")
        builder.Connect(port, logger.get_input_port(0))
        loggers[name] = logger

    scene_graph = _find_scene_graph(builder)
    visualizer = (
        None if meshcat is None else MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    )
    diagram = builder.Build()
    diagram.set_name(f"closed_loop_{config.controller}")
    return ClosedLoop(diagram, arm, encoder, controller, loggers, scene_graph, visualizer)


class ClosedLoopRunner:
    """Builds the closed loop of ``config`` once; ``run`` simulates it on a fresh
    Context with given true plant parameters (the controller keeps ``nominal``).

    ``controller_config`` overrides the controller design (default: the paper's
    Sec. 4.2 settings); its ``nominal`` and ``sample_time`` are replaced by
    ``nominal`` and ``config.sample_time``."""

    def __init__(
        self,
        config: ClosedLoopConfig,
        nominal: LumpedParameters = TABLE1,
        *,
        controller_config: ControllerConfig | None = None,
        meshcat: Meshcat | None = None,
    ) -> None:
        self.config = config
        self.controller_config = replace(
            controller_config or ControllerConfig(),
            nominal=nominal,
            sample_time=config.sample_time,
        )
        self.loop = build_closed_loop(config, self.controller_config, meshcat)
        self._simulator_config = SimulatorConfig(
            integration_scheme="runge_kutta3",
            accuracy=config.integrator_accuracy,
            max_step_size=config.sample_time,
            use_error_control=True,
        )

    @property
    def diagram(self) -> Diagram:
        return self.loop.diagram

    @property
    def arm(self) -> Arm:
        return self.loop.arm

    def new_context(
        self, parameters: ArmParameters | None = None, encoder_counts: int | None = None
    ) -> Context:
        """A fresh Context: true ``parameters`` (default: the URDF's), the encoder
        resolution (default: the config's), the arm at rest at ``q_d(0)``."""
        loop = self.loop
        context = loop.diagram.CreateDefaultContext()
        apply_parameters(loop.arm, context, parameters or loop.arm.default_parameters)
        counts = self.config.encoder_counts if encoder_counts is None else encoder_counts
        loop.encoder.set_counts(loop.encoder.GetMyMutableContextFromRoot(context), counts)
        plant = loop.arm.plant
        plant_context = plant.GetMyMutableContextFromRoot(context)
        plant.SetPositions(plant_context, desired(0.0)[0])
        plant.SetVelocities(plant_context, np.zeros(2))
        return context

    def run(
        self, parameters: ArmParameters | None = None, encoder_counts: int | None = None
    ) -> ClosedLoopResult:
        """Simulate ``duration`` seconds; never raises for a diverging run."""
        context = self.new_context(parameters, encoder_counts)
        simulator = Simulator(self.loop.diagram, context)
        ApplySimulatorConfig(self._simulator_config, simulator)
        T_s = self.config.sample_time
        # One sample past the end: the voltage computed at t_N0 is logged at t_N0+1.
        last = self.config.samples + 1
        status, message = "ok", ""
        start = time.perf_counter()
        try:
            simulator.Initialize()
            for sample in range(MONITOR_SAMPLES, last + MONITOR_SAMPLES, MONITOR_SAMPLES):
                simulator.AdvanceTo(min(sample, last) * T_s)
                message = self._divergence(context)
                if message:
                    status = "diverged"
                    break
        except RuntimeError as error:
            status = "diverged"
            message = f"integrator failed: {str(error).strip().splitlines()[0]}"
        wall = time.perf_counter() - start
        return self._collect(context, status, message, wall)

    def _divergence(self, context: Context) -> str:
        """Why the run in ``context`` counts as diverged now ("" if it does not)."""
        plant = self.loop.arm.plant
        q = plant.GetPositions(plant.GetMyContextFromRoot(context))
        if not np.all(np.isfinite(q)):
            return f"non-finite joint position {q.tolist()} at t = {context.get_time():g} s"
        error = float(np.max(np.abs(q - desired(context.get_time())[0])))
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
        worst = float(np.max(np.abs(q_error)))
        if worst > self.config.divergence_bound:
            return "diverged", (
                f"|q~| = {worst:.3g} rad exceeds divergence_bound = "
                f"{self.config.divergence_bound:g} rad"
            )
        return "ok", ""

    def _collect(
        self, context: Context, status: str, message: str, wall: float
    ) -> ClosedLoopResult:
        logs = {name: logger.FindLog(context) for name, logger in self.loop.loggers.items()}
        data = {name: log.data().T for name, log in logs.items()}
        times = logs["q_true"].sample_times()
        # Rows 0..K of the state-like logs; voltage/internals rows shifted by one sample.
        rows = min(len(values) for values in data.values())
        # Rows 0..K of the state-like logs; the voltage logged at t_{k+1} belongs to t_k.
        # A run that stopped early ends at its last complete pair (at least row 0).
        count = min(rows - 1, self.config.samples + 1)
        kept = max(count, min(rows, 1))
        q_true, q_measured = data["q_true"][:kept], data["q_measured"][:kept]
        q_desired = data["desired"][:kept, :2]
        shifted = {}
        for name in ("u_commanded", "u_applied", "internals"):
            values = data[name][1 : count + 1]
            shifted[name] = (
                values if len(values) == kept else np.full((kept, values.shape[1]), np.nan)
            )
        u_commanded, u_applied = shifted["u_commanded"], shifted["u_applied"]
        internals = shifted["internals"]
        if count < 2:
            nan = (math.nan, math.nan)
            metrics = RunMetrics(nan, nan, math.nan, math.nan, wall)
        else:
            metrics = compute_metrics(
                q_true[1:] - q_desired[1:],
                u_applied[1:],
                u_commanded[1:],
                self.config.voltage_limit,
                wall,
            )
        if status == "ok":
            status, message = self._check_logged(q_true - q_desired)
        return ClosedLoopResult(
            controller=self.config.controller,
            times=times[:kept],
            q_true=q_true,
            q_measured=q_measured,
            q_desired=q_desired,
            u_commanded=u_commanded,
            u_applied=u_applied,
            internals=internals,
            internals_names=tuple(self.loop.controller.internals_names),
            metrics=metrics,
            status=status,
            message=message,
        )
