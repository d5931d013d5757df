"""A generated N-link planar arm in posfb's URDF conventions, for tests that need an arm
no shipped file describes (``planar_arm_urdf``).

The structure is ``urdf/three_link_arm.urdf``'s: a vertical x-z plane, gravity -z, every
joint axis -y (``q = 0`` points the links along +x, positive angles raise them), uniform
rods (``I = m L^2 / 12`` across the rod), a massless ``payload`` link welded at the tip,
one transmission per joint with ``drake:rotor_inertia``, ``drake:gear_ratio`` and
``posfb:motor_constant``, ``<dynamics damping>`` and ``posfb:coulomb_friction`` per joint.
The numbers change from link to link by their own (non-geometric) patterns, so the arm
resembles no shipped one.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

Limits = tuple[float, float] | None


def link_numbers(i: int) -> dict[str, float]:
    """Link ``i``'s (0-based) length (m), mass (kg), gear ratio, rotor inertia (kg m^2),
    damping (N m s/rad), Coulomb level (N m) and motor constant (N m/V)."""
    return {
        "length": 0.34 - 0.045 * i + 0.02 * (i % 2),
        "mass": 2.6 / (1.0 + 0.9 * i) + 0.15,
        "gear": 120.0 / (1.0 + 0.7 * i),
        "rotor": 1.4e-4 / (1.0 + i * i),
        "damping": 11.0 / (1.0 + 1.3 * i),
        "coulomb": 5.5 / (1.0 + 1.6 * i),
        "motor_constant": 4.8 / (1.0 + 1.1 * i),
    }


def _limits_of(limits: Limits | Sequence[Limits], links: int) -> list[Limits]:
    if limits is None or (len(limits) == 2 and all(isinstance(v, float | int) for v in limits)):
        return [limits] * links  # type: ignore[list-item]
    if len(limits) != links:
        raise ValueError(f"limits has {len(limits)} entries; {links} are required")
    return list(limits)  # type: ignore[arg-type]


def planar_arm_text(links: int, limits: Limits | Sequence[Limits] = None,
                    name: str | None = None, gear_scale: float = 1.0) -> str:  # fmt: skip
    """The URDF text of an ``links``-link planar arm; ``limits``: ``None`` (continuous
    joints), one ``(lower, upper)`` pair (rad) for every joint, or one entry per joint;
    ``gear_scale`` multiplies every gear ratio (a light gear, well below 1, leaves the
    links' inertia, which varies with the configuration, in charge of ``M*(q)``)."""
    if links < 1:
        raise ValueError(f"links = {links}; at least 1 is required")
    per_joint = _limits_of(limits, links)
    name = name or f"planar_arm_{links}"
    parts = [
        '<?xml version="1.0"?>',
        f"<!-- A generated {links}-link planar arm (tests/helpers/planar_arm.py). -->",
        f'<robot name="{name}" xmlns:drake="http://drake.mit.edu" '
        'xmlns:posfb="urn:posfb:urdf">',
        '  <link name="base"/>',
    ]
    for i in range(links):
        k = link_numbers(i)
        length, mass = k["length"], k["mass"]
        across, along = mass * length**2 / 12.0, mass * 0.02**2 / 2.0
        parts.append(
            f'  <link name="link{i + 1}">\n'
            f"    <inertial>\n"
            f'      <origin xyz="{length / 2:.6g} 0 0" rpy="0 0 0"/>\n'
            f'      <mass value="{mass:.6g}"/>\n'
            f'      <inertia ixx="{along:.6g}" ixy="0" ixz="0" iyy="{across:.6g}" iyz="0" '
            f'izz="{across:.6g}"/>\n'
            f"    </inertial>\n"
            f"  </link>"
        )
    parts.append(
        '  <link name="payload">\n    <inertial>\n      <origin xyz="0 0 0" rpy="0 0 0"/>\n'
        '      <mass value="0"/>\n      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" '
        'izz="0"/>\n    </inertial>\n  </link>'
    )
    for i in range(links):
        k = link_numbers(i)
        parent = "base" if i == 0 else f"link{i}"
        x = 0.0 if i == 0 else link_numbers(i - 1)["length"]
        bounds = per_joint[i]
        kind = "continuous" if bounds is None else "revolute"
        limit = (
            ""
            if bounds is None
            else f'\n    <limit lower="{bounds[0]!r}" upper="{bounds[1]!r}" effort="1000" '
            'velocity="100"/>'
        )
        parts.append(
            f'  <joint name="joint{i + 1}" type="{kind}">\n'
            f'    <parent link="{parent}"/>\n    <child link="link{i + 1}"/>\n'
            f'    <origin xyz="{x:.6g} 0 0" rpy="0 0 0"/>\n    <axis xyz="0 -1 0"/>{limit}\n'
            f'    <dynamics damping="{k["damping"]:.6g}"/>\n'
            f'    <posfb:coulomb_friction value="{k["coulomb"]:.6g}"/>\n'
            f"  </joint>"
        )
    tip = link_numbers(links - 1)["length"]
    parts.append(
        f'  <joint name="tip" type="fixed">\n    <parent link="link{links}"/>\n'
        f'    <child link="payload"/>\n    <origin xyz="{tip:.6g} 0 0" rpy="0 0 0"/>\n  </joint>'
    )
    for i in range(links):
        k = link_numbers(i)
        parts.append(
            f'  <transmission name="transmission{i + 1}">\n'
            "    <type>transmission_interface/SimpleTransmission</type>\n"
            f'    <joint name="joint{i + 1}"><hardwareInterface>EffortJointInterface'
            "</hardwareInterface></joint>\n"
            f'    <actuator name="motor{i + 1}">\n'
            f'      <drake:rotor_inertia value="{k["rotor"]:.6g}"/>\n'
            f'      <drake:gear_ratio value="{k["gear"] * gear_scale:.6g}"/>\n'
            f'      <posfb:motor_constant value="{k["motor_constant"]:.6g}"/>\n'
            "    </actuator>\n  </transmission>"
        )
    parts.append("</robot>")
    return "\n".join(parts) + "\n"


def planar_arm_urdf(links: int, directory: Path, **options: object) -> Path:
    """Write an ``links``-link planar arm into ``directory`` and return its path.

    Options: ``limits`` (``None``: continuous joints; one ``(lower, upper)`` pair in rad
    for every joint; or one entry per joint, ``None`` for a continuous one), ``name``
    (the robot's name and file stem, default ``planar_arm_<links>``), ``gear_scale``
    (``planar_arm_text``'s)."""
    known = {"limits", "name", "gear_scale"}
    unknown = set(options) - known
    if unknown:
        raise TypeError(f"unknown options {sorted(unknown)}; known: {sorted(known)}")
    name = str(options.get("name") or f"planar_arm_{links}")
    path = Path(directory) / f"{name}.urdf"
    text = planar_arm_text(
        links, options.get("limits"), name, float(options.get("gear_scale", 1.0))  # type: ignore[arg-type]
    )
    path.write_text(text)
    return path
