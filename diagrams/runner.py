"""The closed-loop runner: builds a config's diagram once (``diagrams.wiring``) and
simulates it on fresh Contexts, returning the logs (``ClosedLoopResult``).

A periodic publish at
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

Integration: ``ClosedLoopConfig.timing.simulator``, by default Drake's RK3 with error
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

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydrake.common import RandomGenerator
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import Context, Diagram

from posfb.diagrams.actuator import ActuatorState
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.sections import SensorState
from posfb.diagrams.wiring import Extension, build_closed_loop
from posfb.models.controllers.base import SampledController
from posfb.models.controllers.plugin import user_frames
from posfb.models.gear import GearConfig
from posfb.models.plant import (
    Arm,
    ArmParameters,
    apply_parameters,
    set_friction_law,
    set_gear,
    set_motor_state,
)

#: ``run`` checks for divergence every this many control periods.
MONITOR_SAMPLES = 10


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
        settings = self.config.timing.simulator
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
        if error > self.config.timing.divergence_bound:
            return (
                f"|q~| = {error:.3g} rad exceeds divergence_bound = "
                f"{self.config.timing.divergence_bound:g} rad at t = {context.get_time():g} s"
            )
        return ""

    def _check_logged(self, q_error: np.ndarray) -> tuple[str, str]:
        """Divergence the monitor (every ``MONITOR_SAMPLES`` periods) may have missed."""
        if not np.all(np.isfinite(q_error)):
            return "diverged", "non-finite joint position in the log"
        worst = float(np.max(np.abs(q_error))) if q_error.size else 0.0
        if worst > self.config.timing.divergence_bound:
            return "diverged", (
                f"|q~| = {worst:.3g} rad exceeds divergence_bound = "
                f"{self.config.timing.divergence_bound:g} rad"
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
