"""A random spatial serial arm as a URDF: joint origins with roll-pitch-yaw, axes in any
direction, full (off-diagonal) inertias about rotated centre-of-mass frames, a welded
mount under joint 1, a welded flange between two moving links and a welded tool at the
tip, motor stages with rotor inertias and gears. It exercises every case of a serial
arm that the shipped (planar or axis-aligned) arms do not."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation


def _triple(values: np.ndarray) -> str:
    return " ".join(f"{v:.17g}" for v in values)


def _inertial(rng: np.random.Generator, mass: float) -> str:
    """A physically valid inertia (principal moments obeying the triangle inequality)
    about a centre of mass at a random offset, in a randomly rotated frame."""
    principal = rng.uniform(0.5, 1.0, 3) * mass * 0.01
    rotation = Rotation.random(random_state=rng).as_matrix()
    inertia = rotation @ np.diag(principal) @ rotation.T
    return f"""    <inertial>
      <origin xyz="{_triple(rng.uniform(-0.1, 0.1, 3))}" rpy="{_triple(rng.uniform(-1, 1, 3))}"/>
      <mass value="{mass:.17g}"/>
      <inertia ixx="{inertia[0, 0]:.17g}" ixy="{inertia[0, 1]:.17g}" ixz="{inertia[0, 2]:.17g}"
               iyy="{inertia[1, 1]:.17g}" iyz="{inertia[1, 2]:.17g}" izz="{inertia[2, 2]:.17g}"/>
    </inertial>"""


def _fixed(name: str, parent: str, child: str, rng: np.random.Generator) -> str:
    return f"""  <joint name="{name}" type="fixed">
    <parent link="{parent}"/><child link="{child}"/>
    <origin xyz="{_triple(rng.uniform(-0.2, 0.2, 3))}" rpy="{_triple(rng.uniform(-1, 1, 3))}"/>
  </joint>"""


def spatial_arm_text(joints: int, seed: int) -> str:
    """The URDF text of a random ``joints``-joint spatial arm (module docstring)."""
    rng = np.random.default_rng(seed)
    links = ['  <link name="base"/>', f'  <link name="mount">\n{_inertial(rng, 2.0)}\n  </link>']
    elements = [_fixed("to_mount", "base", "mount", rng)]
    parent, flange_after = "mount", joints // 2
    for j in range(1, joints + 1):
        link = f"link{j}"
        links.append(f'  <link name="{link}">\n{_inertial(rng, rng.uniform(0.5, 3.0))}\n  </link>')
        axis = rng.normal(size=3)
        elements.append(f"""  <joint name="joint{j}" type="revolute">
    <parent link="{parent}"/><child link="{link}"/>
    <origin xyz="{_triple(rng.uniform(-0.3, 0.3, 3))}" rpy="{_triple(rng.uniform(-1.5, 1.5, 3))}"/>
    <axis xyz="{_triple(axis / np.linalg.norm(axis))}"/>
    <limit lower="-6.28" upper="6.28" effort="1000" velocity="10"/>
    <dynamics damping="{rng.uniform(0.5, 5.0):.17g}"/>
    <posfb:coulomb_friction value="{rng.uniform(0.1, 2.0):.17g}"/>
  </joint>
  <transmission name="transmission{j}">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="joint{j}"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="motor{j}">
      <drake:rotor_inertia value="{rng.uniform(1e-5, 1e-4):.17g}"/>
      <drake:gear_ratio value="{rng.uniform(20, 120):.17g}"/>
      <posfb:motor_constant value="{rng.uniform(0.5, 6.0):.17g}"/>
    </actuator>
  </transmission>""")
        parent = link
        if j == flange_after:
            links.append(f'  <link name="flange">\n{_inertial(rng, 0.4)}\n  </link>')
            elements.append(_fixed("to_flange", link, "flange", rng))
            parent = "flange"
    links.append(f'  <link name="tool">\n{_inertial(rng, 0.8)}\n  </link>')
    elements.append(_fixed("to_tool", parent, "tool", rng))
    body = "\n".join(links + elements)
    return f"""<?xml version="1.0"?>
<robot name="spatial_arm" xmlns:drake="http://drake.mit.edu" xmlns:posfb="urn:posfb:urdf">
{body}
</robot>
"""


def spatial_arm_urdf(joints: int, directory: Path, seed: int = 0) -> Path:
    """``spatial_arm_text`` written to ``directory``; its path."""
    path = directory / f"spatial_arm_{joints}_{seed}.urdf"
    path.write_text(spatial_arm_text(joints, seed))
    return path
