"""``scenario init``'s rules for the drive data a published URDF lacks.

A published description carries the arm's links and joint limits but rarely posfb's
drive elements. For each arm joint (``models.description``: after the welds) and each
drive field, the value is taken from the first source that has it:

=================  ===============================================================
field              sources, in order
=================  ===============================================================
motor_constant     the user's ``--drives`` file; ``posfb:motor_constant``;
                   ``<limit effort>`` / the voltage limit (the torque at full
                   voltage is the joint's rated effort); none: refused
coulomb            ``--drives``; ``posfb:coulomb_friction``; ``<dynamics friction>``;
                   0 (the file states no friction)
damping            ``--drives``; ``<dynamics damping>``; 0 (Drake's default)
gear_ratio         ``--drives``; ``drake:gear_ratio``; the actuator's
                   ``<mechanicalReduction>``; 1
rotor_inertia      ``--drives``; ``drake:rotor_inertia``; 0 (the file states none)
=================  ===============================================================

A field is written into the scenario's ``plant.drives`` only where some joint's value
does not come from the file's own posfb/Drake element (which the plant reads anyway), with
one comment line per source naming its joints.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from posfb.models.description import (
    DRIVE_ELEMENTS,
    DRIVE_FIELDS,
    Description,
    Drives,
    prepare_urdf,
)
from posfb.models.urdf_check import finite_number
from posfb.models.urdf_tree import (
    SERIAL_JOINTS,
    actuator_of,
    drive_element,
    parse_robot,
    read_tree,
    read_urdf_bytes,
    serial_chain,
)

#: Where a value comes from when it is the file's own element (not written again).
FILE_ELEMENT = {**DRIVE_ELEMENTS, "damping": "<dynamics damping>"}


@dataclass(frozen=True)
class DerivedDrives:
    """The drive values of every arm joint (``joints``, base to tip) and where each came
    from, per field (``DRIVE_FIELDS``)."""

    joints: tuple[str, ...]
    values: dict[str, tuple[float, ...]]
    sources: dict[str, tuple[str, ...]]

    @property
    def written(self) -> Drives:
        """The fields where a value does not come from the file's own element."""
        return Drives(
            **{
                name: self.values[name]
                for name in DRIVE_FIELDS
                if any(source != FILE_ELEMENT[name] for source in self.sources[name])
            },
            label="plant.drives",
        )

    def rules(self, name: str) -> list[str]:
        """One line per source of ``name``'s values, naming its joints."""
        unit = DRIVE_FIELDS[name][0]
        by_source: dict[str, list[str]] = {}
        for joint, source in zip(self.joints, self.sources[name], strict=True):
            by_source.setdefault(source, []).append(joint)
        if len(by_source) == 1:
            return [f"{name} ({unit}): {next(iter(by_source))}, every joint."]
        return [f"{name} ({unit}): {source}: {', '.join(j)}." for source, j in by_source.items()]


def _number(element: ET.Element | None, attribute: str = "value") -> float | None:
    return None if element is None else finite_number(element.get(attribute))


def _element(parent: ET.Element | None, field: str) -> float | None:
    """The number of ``parent``'s own element for ``field`` (``FILE_ELEMENT``)."""
    return None if parent is None else _number(drive_element(parent, FILE_ELEMENT[field]))


def derive_drives(
    path: Path, description: Description, voltage_limit: float, given: Drives
) -> DerivedDrives:
    """Every arm joint's drive values by the rules of the module docstring; ``given`` is
    the user's ``--drives``. Raises a one-line ``ValueError`` naming every joint without a
    motor constant."""
    prepared = prepare_urdf(path, Description(description.package_paths, description.welds))
    _, joints, root, parent_joint = read_tree(
        parse_robot(path, prepared.text.encode()), SERIAL_JOINTS
    )
    chain = [joint.name for joint in serial_chain(root, joints, parent_joint)]
    robot = parse_robot(path, read_urdf_bytes(path))
    try:
        return _derive(path, robot, chain, voltage_limit, given)
    except ValueError as error:
        raise ValueError(f"URDF {path}: {error}") from None


def _derive(
    path: Path, robot: ET.Element, chain: list[str], voltage_limit: float, given: Drives
) -> DerivedDrives:
    """``derive_drives`` on the parsed file ``robot`` and its arm joints ``chain``."""
    elements = {element.get("name"): element for element in robot.findall("joint")}
    n = len(chain)
    user = {name: given.per_joint(name, n) for name in DRIVE_FIELDS}
    values: dict[str, list[float]] = {name: [] for name in DRIVE_FIELDS}
    sources: dict[str, list[str]] = {name: [] for name in DRIVE_FIELDS}
    for j, name in enumerate(chain):
        joint = elements[name]
        actuator = actuator_of(robot, name)
        dynamics = joint.find("dynamics")
        effort = _number(joint.find("limit"), "effort")
        reduction = None if actuator is None else actuator.find("mechanicalReduction")
        ratio = None if reduction is None else finite_number(reduction.text)
        candidates = {
            "motor_constant": [
                (
                    None if not effort or effort <= 0 else effort / voltage_limit,
                    f"<limit effort> / the voltage limit {voltage_limit:g} V",
                ),
            ],
            "coulomb": [
                (_number(dynamics, "friction"), "<dynamics friction>"),
                (0.0, "0, the file states no friction"),
            ],
            "damping": [(0.0, "0, the file states no damping")],
            "gear_ratio": [
                (ratio if ratio and ratio > 0 else None, "<mechanicalReduction>"),
                (1.0, "1, the file states no gear"),
            ],
            "rotor_inertia": [(0.0, "0, the file states none")],
        }
        own = {"damping": _number(dynamics, "damping"), "coulomb": _element(joint, "coulomb")}
        for field in ("motor_constant", "gear_ratio", "rotor_inertia"):
            own[field] = _element(actuator, field)
        for field, options in candidates.items():
            options = [(own[field], FILE_ELEMENT[field]), *options]
            if user[field] is not None:
                options = [(user[field][j], "--drives")]
            value, source = next(((v, s) for v, s in options if v is not None), (None, ""))
            values[field].append(math.nan if value is None else float(value))
            sources[field].append(source)
    missing = [name for name, k in zip(chain, values["motor_constant"], strict=True) if k != k]
    if missing:
        raise ValueError(
            f"motor constant of joints {', '.join(missing)} = (missing): the file "
            "has neither posfb:motor_constant nor <limit effort> > 0 for them; give the "
            "datasheet's with --drives FILE.yaml (motor_constant: [N m/V per joint])"
        )
    return DerivedDrives(
        tuple(chain),
        {name: tuple(v) for name, v in values.items()},
        {name: tuple(s) for name, s in sources.items()},
    )
