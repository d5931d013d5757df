"""Published arm descriptions from the registry's ``example-robot-data`` package (PyPI,
installed with posfb's dev extra), with the drive data a user gives for them: the files
carry no gear, no rotor inertia and no motor constants, only each joint's ``<limit
effort>`` (and ``<dynamics damping="0" friction="0">``).

``published_urdf`` finds a file of the package; posfb reads it as it is (issue 41).
``user_drives`` writes the ``--drives`` file a user hands to ``scenario init`` with it:
per arm joint a Coulomb level and a viscous damping as small shares of the rated effort
(``DRIVE_SHARES``; typical of a harmonic drive's no-load losses, a user's estimate, not
the arm's data). The motor constant is init's own rule: the rated effort at the voltage
limit ``VOLTS``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from importlib import metadata
from pathlib import Path

#: Where the package's robot descriptions are installed (a cmeel prefix).
ROBOTS = "cmeel.prefix/share/example-robot-data/robots"

#: The drive data a user writes for a joint of rated effort ``tau`` (N m): Coulomb level
#: ``coulomb * tau`` (N m) and viscous damping ``damping * tau`` (N m s/rad).
DRIVE_SHARES = {"coulomb": 0.02, "damping": 0.01}

#: The voltage the motor constants are written for (V): ``kappa = effort / VOLTS``.
VOLTS = 24.0

UR5 = "ur_description/urdf/ur5_joint_limited_robot.urdf"
SO101 = "so_arm_description/urdf/so101.urdf"


def published_urdf(relative: str) -> Path:
    """The package's file ``relative`` (under its ``robots`` folder)."""
    path = Path(str(metadata.distribution("example-robot-data").locate_file(ROBOTS))) / relative
    if not path.is_file():
        raise FileNotFoundError(f"{relative} is not in example-robot-data ({path})")
    return path


def user_drives(urdf: Path, target: Path) -> Path:
    """Write the ``--drives`` YAML for ``urdf``'s revolute joints (module docstring),
    in the file's order, which the registry's serial arms declare base to tip."""
    efforts = [
        float(joint.find("limit").get("effort"))
        for joint in ET.parse(urdf).getroot().findall("joint")
        if joint.get("type") in ("revolute", "continuous")
    ]
    target.write_text(
        "".join(
            f"{name}: [{', '.join(f'{share * effort:g}' for effort in efforts)}]\n"
            for name, share in DRIVE_SHARES.items()
        )
    )
    return target


#: A tiny valid Wavefront OBJ (one triangle): a visual mesh Drake loads.
OBJ = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\n"


def _link(name: str, mass: float, length: float, meshes: str = "") -> str:
    inertia = mass * length**2 / 12 + 1e-4
    return (
        f'<link name="{name}"><inertial><origin xyz="{length / 2} 0 0"/><mass value="{mass}"/>'
        f'<inertia ixx="1e-4" iyy="{inertia}" izz="{inertia}" ixy="0" ixz="0" iyz="0"/>'
        f"</inertial>{meshes}</link>"
    )


def featured_description(folder: Path) -> Path:
    """A published-style description in its own package folder (``folder/my_arm``, with a
    ``package.xml``) that uses every feature a published file brings (issue 41): a
    ``world`` link, ``package://`` meshes (a visual ``.obj`` that resolves, ``.stl`` and
    ``.dae`` collision meshes, a mesh that does not exist), prismatic fingers of which one
    mimics the other, a revolute gripper joint (``gripper_turn``, to weld), transmissions
    out of the chain's order, and drive data only in ``<limit effort>`` and
    ``<dynamics>``. Three arm joints about ``y`` in the vertical x-z plane. Returns the
    URDF's path (``folder/my_arm/urdf/arm.urdf``)."""
    package = folder / "my_arm"
    (package / "urdf").mkdir(parents=True)
    (package / "meshes").mkdir()
    (package / "package.xml").write_text(
        '<?xml version="1.0"?><package format="3"><name>my_arm</name><version>1.0.0</version>'
        "<description>test</description><maintainer email='a@b.c'>a</maintainer>"
        "<license>BSD</license></package>"
    )
    (package / "meshes" / "link.obj").write_text(OBJ)
    (package / "meshes" / "link.stl").write_text("solid x\nendsolid x\n")
    (package / "meshes" / "link.dae").write_text("<COLLADA/>")
    meshes = (
        '<visual><geometry><mesh filename="package://my_arm/meshes/link.obj"/></geometry>'
        "</visual>"
        '<visual><geometry><mesh filename="package://my_arm/meshes/missing.obj"/></geometry>'
        "</visual>"
        '<collision><geometry><mesh filename="package://my_arm/meshes/link.stl"/></geometry>'
        "</collision>"
        '<collision><geometry><mesh filename="package://my_arm/meshes/link.dae"/></geometry>'
        "</collision>"
    )
    lengths, efforts = (0.4, 0.3, 0.2), (150.0, 80.0, 40.0)
    parts = ['<robot name="featured">', '<link name="world"/>', _link("base", 2.0, 0.1)]
    parts.append(
        '<joint name="world_joint" type="fixed"><parent link="world"/><child link="base"/>'
        '<origin xyz="0 0 0.5"/></joint>'
    )
    parent = "base"
    for j, (length, effort) in enumerate(zip(lengths, efforts, strict=True), start=1):
        parts.append(_link(f"link{j}", 1.0 * length / 0.2, length, meshes))
        offset = 0.1 if j == 1 else lengths[j - 2]
        parts.append(
            f'<joint name="joint{j}" type="revolute"><parent link="{parent}"/>'
            f'<child link="link{j}"/><origin xyz="{offset} 0 0"/><axis xyz="0 1 0"/>'
            f'<limit effort="{effort}" lower="-2" upper="2" velocity="3"/>'
            f'<dynamics damping="{0.01 * effort}" friction="{0.02 * effort}"/></joint>'
        )
        parent = f"link{j}"
    parts += [_link("hand", 0.3, 0.05), _link("finger1", 0.05, 0.02), _link("finger2", 0.05, 0.02)]
    parts.append(
        '<joint name="gripper_turn" type="revolute"><parent link="link3"/><child link="hand"/>'
        '<origin xyz="0.2 0 0"/><axis xyz="1 0 0"/>'
        '<limit effort="1" lower="-1" upper="1" velocity="1"/></joint>'
    )
    for k, sign in ((1, 1), (2, -1)):
        mimic = '<mimic joint="finger1_joint" multiplier="1"/>' if k == 2 else ""
        parts.append(
            f'<joint name="finger{k}_joint" type="prismatic"><parent link="hand"/>'
            f'<child link="finger{k}"/><origin xyz="0.05 0 0"/><axis xyz="0 {sign} 0"/>'
            f'<limit effort="20" lower="0.01" upper="0.04" velocity="0.2"/>{mimic}</joint>'
        )
    for j in (3, 1, 2, 4):  # out of order, and one of the welded gripper joint
        joint = f"joint{j}" if j < 4 else "gripper_turn"
        parts.append(
            f'<transmission name="t{j}"><type>transmission_interface/SimpleTransmission</type>'
            f'<joint name="{joint}"><hardwareInterface>EffortJointInterface</hardwareInterface>'
            f'</joint><actuator name="motor{j}"><mechanicalReduction>50</mechanicalReduction>'
            "</actuator></transmission>"
        )
    parts.append("</robot>")
    urdf = package / "urdf" / "arm.urdf"
    urdf.write_text("\n".join(parts) + "\n")
    return urdf
