"""The identity of a scenario's arm: what a Monte-Carlo study, a tuned design or a marked
point of the stability map belongs to (``arm_identity``).

The arm is the scenario's ``plant.urdf`` as posfb's plant reads it
(``models.plant.add_arm``): the identity is the SHA-256 of a canonical text of what
Drake and posfb parse from the file, namely every body's name, mass, centre of mass
and rotational inertia, every joint's name, type, parent and child, the poses of its
frames and (revolute) its axis and damping, every actuator's joint, rotor inertia and
gear ratio, and the URDF's per-joint parameters (``ArmParameters``: Coulomb levels and
motor constants included), with each number written to 12 significant digits.

It is built from the parsed arm and not from the file's bytes, so that comments,
whitespace, attribute order and number spellings (``0.5`` or ``5e-1``) leave an arm the
same arm, while any physical change (a link length, an axis, a mass, a motor constant)
or a renamed joint makes it another. The scenario's own plant settings (a payload,
parameter overrides, the friction law, the gear) are settings of that arm, not another
arm, and are not part of it.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.multibody.tree import BodyIndex, Frame, JointActuatorIndex, JointIndex, RevoluteJoint

from posfb.diagrams.scenario import Scenario, resolve_path, scenario_chain, scenario_description
from posfb.models.plant import JOINT_PARAMETERS, PlantConfig, build_arm_diagram

#: Significant digits of each number in the canonical text.
DIGITS = 12


@dataclass(frozen=True, eq=False)
class ArmIdentity:
    """An arm: the URDF as the scenario names it, its arm joints (base to tip) and the
    digest of its canonical description (module docstring); two arms are the same arm
    iff their digests are equal."""

    urdf: str
    joints: tuple[str, ...]
    digest: str

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ArmIdentity) and self.digest == other.digest

    def __hash__(self) -> int:
        return hash(self.digest)

    def __str__(self) -> str:
        return (
            f"the {len(self.joints)}-joint arm of {self.urdf} ({', '.join(self.joints)}; "
            f"digest {self.digest[:12]})"
        )


def _numbers(values: object) -> str:
    """``values`` (any array shape), each to ``DIGITS`` significant digits."""
    return " ".join(f"{float(v):.{DIGITS}g}" for v in np.ravel(values))


def _pose(frame: Frame) -> str:
    """A joint frame's fixed pose in its body's frame, as 12 numbers (``[R | p]``)."""
    return _numbers(frame.GetFixedPoseInBodyFrame().GetAsMatrix34())


def arm_identity(scenario: Scenario, base_dir: Path) -> ArmIdentity:
    """The identity of the arm of ``scenario``'s ``plant.urdf`` (relative paths from
    ``base_dir``); a bad file is refused naming ``plant.urdf``, as ``resolve`` does."""
    chain = scenario_chain(scenario, base_dir)  # the URDF checked, naming plant.urdf
    urdf = resolve_path(scenario.plant.urdf, base_dir)
    description = scenario_description(scenario, base_dir)
    _, arm, _ = build_arm_diagram(PlantConfig(urdf=str(urdf), description=description))
    plant = arm.plant
    lines = [f"arm joints: {' '.join(chain.joints)}"]
    for i in range(1, plant.num_bodies()):  # 0 is the world
        body = plant.get_body(BodyIndex(i))
        inertia = body.default_rotational_inertia()
        lines.append(
            f"body {body.name()}: mass {_numbers([body.default_mass()])}; com "
            f"{_numbers(body.default_com())}; inertia {_numbers(inertia.get_moments())} "
            f"{_numbers(inertia.get_products())}"
        )
    for i in range(plant.num_joints()):
        joint = plant.get_joint(JointIndex(i))
        line = (
            f"joint {joint.name()} {joint.type_name()}: {joint.parent_body().name()} -> "
            f"{joint.child_body().name()}; X_PF {_pose(joint.frame_on_parent())}; "
            f"X_CM {_pose(joint.frame_on_child())}"
        )
        if isinstance(joint, RevoluteJoint):
            line += (
                f"; axis {_numbers(joint.revolute_axis())}; "
                f"damping {_numbers([joint.default_damping()])}"
            )
        lines.append(line)
    for i in range(plant.num_actuators()):
        actuator = plant.get_joint_actuator(JointActuatorIndex(i))
        lines.append(
            f"actuator {actuator.name()} on {actuator.joint().name()}: rotor inertia "
            f"{_numbers([actuator.default_rotor_inertia()])}; gear ratio "
            f"{_numbers([actuator.default_gear_ratio()])}"
        )
    parameters = arm.default_parameters
    for name in JOINT_PARAMETERS:
        lines.append(f"{name}: {_numbers(getattr(parameters, name))}")
    digest = hashlib.sha256("\n".join(lines).encode()).hexdigest()
    return ArmIdentity(scenario.plant.urdf, chain.joints, digest)
