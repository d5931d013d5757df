"""A disturbance torque added to the closed loop
===============================================

A script that wires more into posfb's Drake diagram.

``posfb.build`` gives the scenario's Drake diagram before it is built (``extend``):
here a step torque of ``TORQUE`` N m acts on one joint from ``ONSET`` s on, as equal
and opposite torques about the joint's axis on the joint's child and parent links
(``ExternallyAppliedSpatialForce`` on the plant's spatial-force port; for a planar arm,
whose joint axes keep their direction, that is a torque on that joint alone). The
controller still sees only the quantised position. The logs go to the same metrics as
every posfb run.

Run it: ``.venv/bin/python examples/disturbance_torque.py [--duration 5]``.
"""

from __future__ import annotations

import argparse

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

import posfb

#: The disturbance: joint (0-based), size (N m) and onset (s).
JOINT, TORQUE, ONSET = 1, 0.5, 1.0


class StepJointTorque(LeafSystem):
    """A torque ``torque`` (N m) on ``joint`` of ``plant`` from ``onset`` seconds on, as a
    list of two ``ExternallyAppliedSpatialForce`` (child +, parent -)."""

    def __init__(self, plant, joint_name: str, torque: float, onset: float) -> None:
        super().__init__()
        joint = plant.GetJointByName(joint_name)
        context = plant.CreateDefaultContext()
        rotation = joint.frame_on_child().CalcPoseInWorld(context).rotation()
        self._axis_W = rotation.multiply(joint.revolute_axis())
        self._bodies = (joint.child_body().index(), joint.parent_body().index())
        self._torque, self._onset = torque, onset
        self.DeclareAbstractOutputPort(
            "spatial_forces",
            lambda: AbstractValue.Make([ExternallyAppliedSpatialForce()]),
            self._calc,
        )

    def _calc(self, context, output) -> None:
        torque = self._torque if context.get_time() >= self._onset else 0.0
        forces = []
        for body, sign in zip(self._bodies, (1.0, -1.0), strict=True):
            force = ExternallyAppliedSpatialForce()
            force.body_index = body
            force.p_BoBq_B = np.zeros(3)
            force.F_Bq_W = SpatialForce(tau=sign * torque * self._axis_W, f=np.zeros(3))
            forces.append(force)
        output.set_value(forces)


def run_with_disturbance(
    scenario: posfb.LoadedScenario, controller: str, torque: float = TORQUE
) -> posfb.Run:
    """``controller`` on ``scenario`` with the step torque on joint ``JOINT``."""

    def extend(builder, systems) -> None:
        plant = systems.arm.plant
        name = systems.arm.layout.joints[JOINT]
        step = builder.AddSystem(StepJointTorque(plant, name, torque, ONSET))
        builder.Connect(step.get_output_port(), plant.get_applied_spatial_force_input_port())

    return posfb.build(scenario, controller, extend=extend).run()


def main(duration: float = 5.0) -> dict[str, tuple[posfb.Run, posfb.Run]]:
    """Each controller without and with the disturbance, printed side by side."""
    scenario = posfb.load_scenario(set={"timing.duration": duration})
    runs = {}
    for controller in ("pid", "lin_lc"):
        calm = posfb.simulate(scenario, controller)
        pushed = run_with_disturbance(scenario, controller)
        runs[controller] = (calm, pushed)
        print(
            f"{calm.label:24s} RMS(q~{JOINT + 1}) {calm.rms_q[JOINT]:.5f} rad without, "
            f"{pushed.rms_q[JOINT]:.5f} rad with {TORQUE:g} N m from t = {ONSET:g} s "
            f"({pushed.status})"
        )
    return runs


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds")
    main(parser.parse_args().duration)
