"""A test-only plant that is exactly the nominal lumped model (Sec. 4.1) the
controllers use, friction off:  ``M*(q) q'' + C*(q, q') q' + G*(q) + B* q' = u``,
and a closed loop trajectory -> controller -> plant on it.

The plant is a ``SymbolicVectorSystem`` (state ``[q, q']``, input ``u``, output
``q``) built from ``LumpedModel``'s own expressions, so it is evaluated in C++;
the 2 x 2 inverse of ``M*(q)`` is written out. No quantisation, no saturation.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from pydrake.symbolic import Variable
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import SymbolicVectorSystem, VectorLogSink

from posfb.diagrams.wiring import hold_inputs
from posfb.models.controllers import internals_names, make_controller
from posfb.models.design import ControllerConfig, NonlinearTorqueConfig
from posfb.models.design.loop_context import LoopContext
from posfb.models.lumped import TABLE1, LumpedModel, LumpedParameters
from posfb.models.trajectory import WaveTrajectory, desired, sampled_source

#: Table 1 without Coulomb friction: plant and controllers share it exactly.
FRICTIONLESS = replace(TABLE1, theta6=0.0, theta11=0.0)


def make_lumped_plant(parameters: LumpedParameters) -> SymbolicVectorSystem:
    """The lumped model without Coulomb friction as a continuous system."""
    model = LumpedModel(parameters)
    q = np.array([Variable("q1"), Variable("q2")])
    v = np.array([Variable("v1"), Variable("v2")])
    u = np.array([Variable("u1"), Variable("u2")])
    # Applying np.sin/np.cos to symbolic Variables can report a floating-point
    # "invalid" flag from Drake's C++ (seen only after other Drake work in the same
    # process); no number is computed here, so the flag is meaningless.
    with np.errstate(invalid="ignore"):
        rhs = u - model.C(q, v) @ v - model.G(q) - model.B() @ v
        (m11, m12), (m21, m22) = model.M(q)
    det = m11 * m22 - m12 * m21
    acceleration = [(m22 * rhs[0] - m12 * rhs[1]) / det, (m11 * rhs[1] - m21 * rhs[0]) / det]
    system = SymbolicVectorSystem(
        state=np.concatenate([q, v]),
        input=u,
        dynamics=np.concatenate([v, acceleration]),
        output=q,
    )
    system.set_name("lumped_plant")
    return system


def exact_model_config(sample_time: float) -> ControllerConfig:
    """The paper's settings on the frictionless model, with ``a = 1/T_s`` (``abar = e^-1``
    as the paper's ``a T_s = 1``; the paper's ``a = 100`` is refused below 6.93 ms)."""
    return ControllerConfig(
        context=LoopContext(FRICTIONLESS, sample_time),
        nonlinear=NonlinearTorqueConfig(filter_a=1.0 / sample_time),
    )


@dataclass(frozen=True)
class Run:
    """Logs at the control samples: ``error = q - q_d`` (2 x N), voltage, internals."""

    times: np.ndarray
    error: np.ndarray
    voltage: np.ndarray
    internals: np.ndarray


def simulate(
    kind: str,
    config: ControllerConfig,
    duration: float,
    initial_error: tuple[float, float] = (0.0, 0.0),
) -> Run:
    """Closed loop on the exact lumped plant, starting at ``q_d(0) + initial_error`` at rest."""
    builder = DiagramBuilder()
    plant = builder.AddSystem(make_lumped_plant(config.nominal))
    T = config.sample_time
    samples = round(duration / T) + 3
    trajectory = builder.AddSystem(sampled_source(WaveTrajectory(), T, samples))
    controller = builder.AddSystem(make_controller(kind, config))
    hold_inputs(builder, controller, plant.get_output_port(), trajectory.get_output_port(), T)
    builder.Connect(controller.GetOutputPort("voltage"), plant.get_input_port())
    logs = {}
    for name, port, size in (
        ("q", plant.get_output_port(), 2),
        ("voltage", controller.GetOutputPort("voltage"), 2),
        ("internals", controller.GetOutputPort("internals"), len(internals_names(kind, 2))),
    ):
        logs[name] = builder.AddSystem(VectorLogSink(size, T))
        builder.Connect(port, logs[name].get_input_port())
    simulator = Simulator(builder.Build())
    ApplySimulatorConfig(
        SimulatorConfig(integration_scheme="runge_kutta3", accuracy=1e-8), simulator
    )
    q0 = desired(0.0)[0] + np.asarray(initial_error)
    plant_context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant_context.SetContinuousState(np.concatenate([q0, np.zeros(2)]))
    simulator.AdvanceTo(duration)
    data = {name: log.FindLog(simulator.get_context()) for name, log in logs.items()}
    times = data["q"].sample_times()
    q_d = np.array([desired(t)[0] for t in times]).T
    return Run(times, data["q"].data() - q_d, data["voltage"].data(), data["internals"].data())
