"""Checks on a built closed loop that several test modules share."""

from __future__ import annotations

import numpy as np

from posfb.diagrams.graph import edges, reachable
from posfb.diagrams.runner import ClosedLoopResult
from posfb.diagrams.wiring import ClosedLoop


def assert_position_only(loop: ClosedLoop, location: str = "link") -> None:
    """The only path from the plant to the controller is the quantised position: the
    controller's inputs are the held measurement and the held desired trajectory, the
    encoder reads the position half of the plant state (or, at ``location = "motor"``,
    the motor angle of a compliant gear), and every path from the plant to the
    controller passes through the encoder."""
    graph = edges(loop.diagram)
    plant, encoder = loop.arm.plant.get_name(), loop.encoder.get_name()
    controller = loop.controller.get_name()
    into_controller = {(e.source, e.output, e.input) for e in graph if e.target == controller}
    assert into_controller == {
        ("encoder_hold", "y", "q_measured"),  # Drake's ZeroOrderHold names its ports u, y
        ("desired_hold", "y", "desired"),
    }
    assert [p.get_name() for p in map(loop.controller.get_input_port,
            range(loop.controller.num_input_ports()))] == ["q_measured", "desired"]  # fmt: skip
    into_holds = {(e.source, e.output, e.target) for e in graph if e.target.endswith("_hold")}
    assert into_holds == {
        (encoder, "q_measured", "encoder_hold"),
        ("desired_trajectory", "y0", "desired_hold"),  # TrajectorySource names it y0
    }
    position = loop.arm.position_output_port(location)
    into_encoder = [(e.source, e.output) for e in graph if e.target == encoder]
    assert into_encoder == [(position.get_system().get_name(), position.get_name())]
    velocity = loop.arm.velocity_output_port()
    assert (position.get_system().get_name(), position.get_name()) != (
        velocity.get_system().get_name(),
        velocity.get_name(),
    )
    assert controller in reachable(graph, plant)
    assert controller not in reachable(graph, plant, blocked=frozenset({encoder}))
    assert not [e for e in graph if e.target == "desired_trajectory"]


def residual_oscillation(result: ClosedLoopResult, window: float = 0.5) -> float:
    """The largest peak-to-peak swing of ``q~`` (rad, over the joints) in the run's last
    ``window`` seconds: about 0 where a stable loop has settled after its excitation, the
    amplitude of the growing (then saturated) oscillation where the loop is unstable."""
    last = result.times >= result.times[-1] - window
    return float(np.max(np.ptp(result.q_error[last], axis=0)))
