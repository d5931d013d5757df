"""A published arm description as posfb's plant and nominal model read it: the user's URDF,
unedited, plus what the scenario says about it (``Description``).

posfb never edits the user's file. ``prepare_urdf`` reads it and hands Drake a prepared
copy of its text (in memory) in which:

* **package and file URIs resolve.** ``package://NAME/PATH`` is looked up in the
  ``package_paths`` (each a folder holding a ``package.xml`` or one searched for them,
  Drake's ``PackageMap.PopulateFromFolder``), then in ``ROS_PACKAGE_PATH``'s folders,
  then in the URDF's own ancestor folders; where no ``package.xml`` names ``NAME``, a
  folder of those named ``NAME`` (or holding a ``NAME`` folder) serves, as ROS and
  Pinocchio resolve it. ``file://`` and relative paths are taken from the URDF's folder.
  Every mesh is written as an absolute ``file://`` URI.
* **geometry posfb cannot use is dropped.** posfb's dynamics need no geometry: a
  ``<visual>`` is kept where its mesh file exists (the animation draws it), a
  ``<collision>`` where its mesh exists and is an ``.obj`` (Drake builds a convex hull
  of it; posfb simulates no contact). Everything dropped is named in one note line.
* **joints that are not the arm's are welded.** A prismatic, planar or floating joint,
  any joint with ``<mimic>``, and every joint named in ``welds`` become fixed joints at a
  stated position: the ``welds`` entry's, else 0 clipped to the joint's limits (a mimic
  joint: its ``multiplier`` times its leader's welded position, or 0, plus its
  ``offset``). Their transmissions are dropped; the note names each weld.
* **the arm's transmissions are in the chain's order** (Drake numbers actuators in the
  order of the file's ``<transmission>`` elements and posfb's actuation input is in
  chain order); an arm joint without one gets one.
* **the drive data are the scenario's** (``Drives``): where it gives a value, it replaces
  the file's ``posfb:coulomb_friction``, ``posfb:motor_constant``, ``drake:rotor_inertia``,
  ``drake:gear_ratio`` and ``<dynamics damping>``.
* **a joint frame the file rounds is read exact** (``_snap_joint_frames``): a joint
  origin's roll, pitch or yaw within ``SNAP_TOLERANCE`` (1e-5 rad) of a multiple of
  pi/2 is that multiple, and a joint axis within ``SNAP_TOLERANCE`` of a frame axis is
  that axis. Published files write pi as ``3.14159`` or ``1.5708`` (2.7e-6 and 3.7e-6
  rad off); read literally, such an axis tilts a joint by a few micro-radians, which
  makes parameters the arm's geometry hides barely visible (the hobby arm's base link's
  first moment, identified as -9.7 +- 2.3 kg m for a 0.1 kg link). The note counts them.
* **what Drake would warn about and posfb models otherwise is left out**
  (``_drop_unmodelled``): ``<dynamics friction>`` and ``<mechanicalReduction>`` (posfb's
  Coulomb level and gear ratio are the drive's; ``scenario init`` reads them from there),
  ``<safety_controller>``, and a named material's repeated definitions.

The prepared text is then checked (``models.urdf_check.check_serial_urdf``) and parsed
(``parse_urdf``). A file that needs none of this is handed over with the same elements
and attribute texts, so the shipped arms' plants are the same.
"""

from __future__ import annotations

import functools
import logging
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np

from posfb.models.urdf_tree import (
    DRAKE_NS,
    POSFB_NS,
    SERIAL_JOINTS,
    actuator_of,
    drive_element,
    parse_robot,
    read_tree,
    read_urdf_bytes,
    serial_chain,
)
from posfb.models.validation import require_finite

#: The per-joint drive fields, their unit and whether a value must be > 0 (else >= 0).
DRIVE_FIELDS = {
    "motor_constant": ("N m/V", True),
    "gear_ratio": ("dimensionless", True),
    "rotor_inertia": ("kg m^2, at the motor", False),
    "damping": ("N m s/rad", False),
    "coulomb": ("N m", False),
}

#: The URDF element each drive field (but damping, ``<dynamics damping>``) is read from.
DRIVE_ELEMENTS = {
    "motor_constant": "posfb:motor_constant",
    "coulomb": "posfb:coulomb_friction",
    "gear_ratio": "drake:gear_ratio",
    "rotor_inertia": "drake:rotor_inertia",
}

#: Joint types posfb welds without being asked: no motor of posfb's drives them.
WELDED_TYPES = ("prismatic", "planar", "floating")

#: How close (rad) a joint origin's rpy angle must be to a multiple of pi/2, and a joint
#: axis to a frame axis, to be read as exactly that (module docstring): far above a
#: file's rounding of pi to 5 or 6 digits, far below any tilt a mechanism is built with.
SNAP_TOLERANCE = 1e-5

#: Collision mesh formats Drake 1.51 makes a convex hull of.
COLLISION_MESHES = (".obj",)

_LOG = logging.getLogger("posfb")
_SHOWN_NOTES: set[str] = set()


@dataclass(frozen=True)
class Drives:
    """Per-joint drive data that replace the URDF's (SI units; base-to-tip order, one value
    for every joint or one per arm joint; ``None``: the URDF's): ``motor_constant``
    (N m/V, > 0), ``gear_ratio`` (> 0), ``rotor_inertia`` (kg m^2 at the motor, >= 0; Drake
    reflects it to the joint times ``gear_ratio^2``), ``damping`` (N m s/rad, >= 0) and
    ``coulomb`` (N m, >= 0)."""

    motor_constant: tuple[float, ...] | None = None
    gear_ratio: tuple[float, ...] | None = None
    rotor_inertia: tuple[float, ...] | None = None
    damping: tuple[float, ...] | None = None
    coulomb: tuple[float, ...] | None = None
    #: How the values are named in messages (the scenario section's key).
    label: str = field(default="drives", compare=False)

    def __post_init__(self) -> None:
        for name, (unit, positive) in DRIVE_FIELDS.items():
            values = getattr(self, name)
            if values is None:
                continue
            values = tuple(values)
            object.__setattr__(self, name, values)
            if not values:
                raise ValueError(
                    f"{self.label}.{name} = []; one value (every joint) or one per arm joint "
                    "is required"
                )
            for j, value in enumerate(values):
                key = f"{self.label}.{name}[{j}]"
                number = require_finite(key, value)
                if number < 0.0 or (positive and number == 0.0):
                    bound = "> 0" if positive else ">= 0"
                    raise ValueError(f"{key} = {value!r}; a value {bound} ({unit}) is required")

    def given(self) -> bool:
        """Whether any value is given."""
        return any(getattr(self, name) is not None for name in DRIVE_FIELDS)

    def per_joint(self, name: str, joints: int) -> tuple[float, ...] | None:
        """``name``'s values for ``joints`` arm joints (one value repeated), ``None`` when
        not given; a list of another length is refused."""
        values = getattr(self, name)
        if values is None:
            return None
        if len(values) == 1:
            return values * joints
        if len(values) != joints:
            raise ValueError(
                f"{self.label}.{name} has {len(values)} values; one (every joint) or "
                f"{joints} (one per arm joint) is required"
            )
        return values


@dataclass(frozen=True)
class Description:
    """What the scenario adds to the URDF it names (module docstring): folders that resolve
    ``package://`` URIs, the joints to weld (``(name, position)``; ``None``: 0 clipped to
    its limits) and the drive data."""

    package_paths: tuple[str, ...] = ()
    welds: tuple[tuple[str, float | None], ...] = ()
    drives: Drives = field(default_factory=Drives)

    def __post_init__(self) -> None:
        object.__setattr__(self, "package_paths", tuple(str(p) for p in self.package_paths))
        object.__setattr__(self, "welds", tuple((str(n), p) for n, p in self.welds))
        for j, folder in enumerate(self.package_paths):
            path = Path(folder).expanduser()
            if not path.is_dir():
                what = "does not exist" if not path.exists() else "is not a folder"
                raise ValueError(
                    f"package_paths[{j}] = {folder!r} {what}; a folder holding a package.xml, "
                    "or one searched for them, is required"
                )
        names = [name for name, _ in self.welds]
        for name, position in self.welds:
            if names.count(name) > 1:
                raise ValueError(f"weld {name!r} is given twice; one position per joint")
            if position is not None:
                require_finite(f"weld {name!r} position", position)


@dataclass(frozen=True)
class Weld:
    """A joint posfb welds: its name, the position it is welded at (rad or m) and why."""

    joint: str
    position: float
    reason: str


@dataclass(frozen=True)
class PreparedUrdf:
    """The text Drake parses for the URDF at ``path`` (module docstring), the joints it
    welded, the geometry it dropped (``"<role> meshes: <why>"`` per element) and how many
    joint angles and axes it read as exact (``snapped``)."""

    path: Path
    text: str
    welds: tuple[Weld, ...]
    dropped: tuple[str, ...]
    snapped: int = 0

    def note(self) -> str | None:
        """One line naming what was welded and dropped (``None`` if nothing was)."""
        parts = []
        if self.welds:
            listed = ", ".join(f"{w.joint} ({w.reason}) at {w.position:g}" for w in self.welds)
            parts.append(f"welded {listed}")
        if self.dropped:
            counts = {why: self.dropped.count(why) for why in dict.fromkeys(self.dropped)}
            listed = ", ".join(f"{count} {why}" for why, count in counts.items())
            parts.append(f"dropped geometry posfb's dynamics do not need: {listed}")
        if self.snapped:
            parts.append(
                f"read {self.snapped} joint angles or axes within {SNAP_TOLERANCE:g} rad of "
                "a multiple of pi/2 or a frame axis as exact"
            )
        return f"note: URDF {self.path}: {'; '.join(parts)}" if parts else None

    def show_note(self) -> None:
        """Log ``note()`` once per process on the ``posfb`` logger."""
        line = self.note()
        if line is not None and line not in _SHOWN_NOTES:
            _SHOWN_NOTES.add(line)
            _LOG.warning("%s", line)


def prepare_urdf(path: str | Path, description: Description | None = None) -> PreparedUrdf:
    """The prepared text of the URDF at ``path`` (module docstring). Raises as
    ``models.urdf_tree.read_urdf_bytes``: ``FileNotFoundError`` or one-line ``ValueError``s."""
    path = Path(path)
    text = read_urdf_bytes(path)
    return _prepare(path, text, description or Description(), os.environ.get("ROS_PACKAGE_PATH"))


@functools.lru_cache(maxsize=64)
def _prepare(
    path: Path, text: bytes, description: Description, ros_package_path: str | None
) -> PreparedUrdf:
    robot = parse_robot(path, text, comments=True)
    try:
        snapped = _snap_joint_frames(robot)
        welds = _weld_joints(robot, description.welds)
        dropped = _resolve_geometry(robot, path, _Packages(path, description, ros_package_path))
        _drop_unmodelled(robot)
        _order_transmissions(robot, description.drives, {w.joint for w in welds})
    except ValueError as error:
        raise ValueError(f"URDF {path}: {error}") from None
    _register_namespaces()
    return PreparedUrdf(path, ET.tostring(robot, encoding="unicode"), welds, dropped, snapped)


# --- packages -------------------------------------------------------------------


class _Packages:
    """Resolves ``package://`` URIs (module docstring)."""

    def __init__(self, urdf: Path, description: Description, ros_package_path: str | None):
        from pydrake.multibody.parsing import PackageMap

        self.folders = [Path(p).expanduser().resolve() for p in description.package_paths]
        environment = (ros_package_path or "").split(os.pathsep)
        self.folders += [Path(p).resolve() for p in environment if p and Path(p).is_dir()]
        self.ancestors = list(urdf.resolve().parents)
        self.map = PackageMap.MakeEmpty()
        for folder in self.folders:
            self.map.PopulateFromFolder(str(folder))
        for folder in self.ancestors:
            if (folder / "package.xml").is_file():
                self.map.AddPackageXml(str(folder / "package.xml"))

    def root(self, name: str) -> Path | None:
        if self.map.Contains(name):
            return Path(self.map.GetPath(name))
        for folder in [*self.folders, *self.ancestors]:
            if folder.name == name:
                return folder
            if (folder / name).is_dir():
                return folder / name
        return None


def _mesh_file(uri: str, urdf: Path, packages: _Packages) -> Path | None:
    """The file a mesh ``filename`` names, ``None`` where it does not resolve."""
    parsed = urlparse(uri)
    if parsed.scheme == "package":
        root = packages.root(parsed.netloc)
        if root is None:
            return None
        candidate = root / unquote(parsed.path).lstrip("/")
    elif parsed.scheme == "file":
        candidate = Path(unquote(parsed.netloc + parsed.path))
    elif parsed.scheme in ("",) or len(parsed.scheme) == 1:  # a path (or a drive letter)
        candidate = Path(uri).expanduser()
    else:
        return None
    if not candidate.is_absolute():
        candidate = urdf.parent / candidate
    return candidate if candidate.is_file() else None


def _resolve_geometry(robot: ET.Element, urdf: Path, packages: _Packages) -> tuple[str, ...]:
    """Write every usable mesh with its absolute path; drop the rest (named)."""
    dropped = []
    for link in robot.findall("link"):
        for role in ("visual", "collision"):
            for element in link.findall(role):
                mesh = element.find("geometry/mesh")
                if mesh is None:
                    continue
                uri = mesh.get("filename", "")
                file = _mesh_file(uri, urdf, packages)
                if file is None:
                    why = "not found"
                elif role == "collision" and file.suffix.lower() not in COLLISION_MESHES:
                    why = f"{file.suffix.lower()} (Drake hulls .obj only)"
                else:
                    mesh.set("filename", file.resolve().as_uri())
                    continue
                link.remove(element)
                dropped.append(f"{role} meshes: {why}")
    return tuple(dropped)


def _drop_unmodelled(robot: ET.Element) -> None:
    """Leave out what Drake would warn about and posfb models otherwise or not at all:
    ``<dynamics friction>`` (posfb's Coulomb level is the drive's), ``<safety_controller>``,
    an actuator's ``<mechanicalReduction>`` (the drive's gear ratio is posfb's), and the
    repeated definitions of a named material (Drake refuses a second one)."""
    for joint in robot.findall("joint"):
        for dynamics in joint.findall("dynamics"):
            dynamics.attrib.pop("friction", None)
        for child in joint.findall("safety_controller"):
            joint.remove(child)
    for actuator in robot.findall("transmission/actuator"):
        for child in actuator.findall("mechanicalReduction"):
            actuator.remove(child)
    defined = {material.get("name") for material in robot.findall("material")}
    for material in robot.findall("link/visual/material"):
        name = material.get("name")
        if any(isinstance(child.tag, str) for child in material) and name in defined:
            for child in list(material):
                material.remove(child)
        defined.add(name)


# --- joint frames ------------------------------------------------------------------


def _snapped_angle(angle: float) -> float:
    """``angle``, or the multiple of pi/2 within ``SNAP_TOLERANCE`` of it."""
    multiple = round(angle / (0.5 * math.pi)) * 0.5 * math.pi
    return multiple if abs(angle - multiple) <= SNAP_TOLERANCE else angle


def _snapped_axis(axis: np.ndarray) -> np.ndarray:
    """``axis``, or the signed unit frame axis within ``SNAP_TOLERANCE`` (rad) of it."""
    major = int(np.argmax(np.abs(axis)))
    tilt = math.atan2(float(np.linalg.norm(np.delete(axis, major))), abs(float(axis[major])))
    if tilt > SNAP_TOLERANCE:
        return axis
    exact = np.zeros(3)
    exact[major] = math.copysign(1.0, float(axis[major]))
    return exact


def _snap_joint_frames(robot: ET.Element) -> int:
    """Read each joint's near-exact angles and axis as exact (module docstring); the
    number of values changed. Malformed attributes are left to the check."""
    snapped = 0
    for joint in robot.findall("joint"):
        for element, attribute, snap in (
            (joint.find("origin"), "rpy", lambda v: np.array([_snapped_angle(a) for a in v])),
            (joint.find("axis"), "xyz", _snapped_axis),
        ):
            if element is None or attribute not in element.attrib:
                continue
            values = _floats(element, attribute, "nan nan nan")
            if values.shape != (3,) or not np.all(np.isfinite(values)) or not values.any():
                continue
            exact = snap(values)
            changed = int(np.count_nonzero(exact != values))
            if changed:
                element.set(attribute, " ".join(repr(float(v)) for v in exact))
                snapped += changed if attribute == "rpy" else 1
    return snapped


# --- welds ----------------------------------------------------------------------


def _limits(element: ET.Element) -> tuple[float, float]:
    limit = element.find("limit")
    if limit is None or element.get("type") == "continuous":
        return -math.inf, math.inf
    try:
        return float(limit.get("lower", "0")), float(limit.get("upper", "0"))
    except ValueError:
        return -math.inf, math.inf


def _weld_joints(
    robot: ET.Element, asked: tuple[tuple[str, float | None], ...]
) -> tuple[Weld, ...]:
    """Make every joint that is not the arm's a fixed joint (module docstring)."""
    joints = {element.get("name"): element for element in robot.findall("joint")}
    unknown = [name for name, _ in asked if name not in joints]
    if unknown:
        raise ValueError(
            f"weld {', '.join(unknown)}: no such joint; one of the file's joints is required "
            f"({', '.join(n for n, e in joints.items() if e.get('type') != 'fixed')})"
        )
    fixed = [name for name, _ in asked if joints[name].get("type") == "fixed"]
    if fixed:
        raise ValueError(
            f"weld {', '.join(fixed)}: a fixed joint already; a moving joint is required"
        )
    positions = dict(asked)
    welds: dict[str, Weld] = {}

    def weld(name: str, reason: str) -> Weld:
        if name in welds:
            return welds[name]
        element = joints[name]
        lower, upper = _limits(element)
        mimic = element.find("mimic")
        position = positions.get(name)
        if position is None and mimic is not None and mimic.get("joint") in joints:
            leader = mimic.get("joint")
            reason = _weld_reason(joints[leader], leader, positions)
            base = weld(leader, reason).position if reason else 0.0
            position = float(mimic.get("multiplier", "1")) * base + float(mimic.get("offset", "0"))
        if position is None:
            position = float(np.clip(0.0, lower, upper)) if lower <= upper else 0.0
        welds[name] = Weld(name, float(position), reason)
        return welds[name]

    for name, element in joints.items():
        reason = _weld_reason(element, name, positions)
        if reason:
            weld(name, reason)
    for item in welds.values():
        _make_fixed(joints[item.joint], item.position)
    return tuple(welds[name] for name in joints if name in welds)


def _weld_reason(element: ET.Element, name: str, positions: dict[str, float | None]) -> str:
    """Why the joint is welded: ``asked``, its type (``WELDED_TYPES``) or ``mimic``; ``""``
    for an arm joint (or a fixed one)."""
    kind = element.get("type")
    if name in positions:
        return "asked"
    if kind in WELDED_TYPES:
        return kind
    return "mimic" if element.find("mimic") is not None and kind != "fixed" else ""


def _floats(element: ET.Element | None, attribute: str, default: str) -> np.ndarray:
    """The numbers of ``attribute`` (``default`` where the element or attribute is absent;
    the check refuses a malformed one)."""
    text = default if element is None else element.get(attribute, default)
    try:
        return np.array([float(v) for v in text.split()])
    except ValueError:
        return np.array([float(v) for v in default.split()])


def _axis(element: ET.Element) -> np.ndarray:
    values = _floats(element.find("axis"), "xyz", "1 0 0")
    norm = float(np.linalg.norm(values))
    return values / norm if norm > 0.0 else values


def _make_fixed(element: ET.Element, position: float) -> None:
    """Turn the joint into a fixed one at ``position`` along or about its axis."""
    from pydrake.common.eigen_geometry import AngleAxis
    from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

    origin = element.find("origin")
    placed = RigidTransform(
        RollPitchYaw(_floats(origin, "rpy", "0 0 0")), _floats(origin, "xyz", "0 0 0")
    )
    kind = element.get("type")
    if position != 0.0 and kind in ("revolute", "continuous"):
        turn = RotationMatrix(AngleAxis(position, _axis(element)))
        placed = placed @ RigidTransform(turn, np.zeros(3))
    elif position != 0.0 and kind == "prismatic":
        placed = placed @ RigidTransform(position * _axis(element))
    element.set("type", "fixed")
    for tag in ("axis", "limit", "dynamics", "mimic", "calibration", "safety_controller"):
        for child in element.findall(tag):
            element.remove(child)
    if position != 0.0:
        if origin is None:
            origin = ET.SubElement(element, "origin")
        rpy = RollPitchYaw(placed.rotation()).vector()
        origin.set("xyz", " ".join(repr(float(v)) for v in placed.translation()))
        origin.set("rpy", " ".join(repr(float(v)) for v in rpy))


# --- transmissions and drives ------------------------------------------------------


def _register_namespaces() -> None:
    """Write Drake's and posfb's elements with the prefixes Drake's parser matches."""
    ET.register_namespace("drake", DRAKE_NS)
    ET.register_namespace("posfb", POSFB_NS)


def _order_transmissions(robot: ET.Element, drives: Drives, welded: set[str]) -> None:
    """Transmissions of the arm joints in chain order (one each), the others dropped, and
    the drive values written where ``drives`` gives them."""
    _, joints, root, parent_joint = read_tree(robot, SERIAL_JOINTS)
    chain = serial_chain(root, joints, parent_joint)
    names = [joint.name for joint in chain]
    transmissions = robot.findall("transmission")
    by_joint = {}
    for element in transmissions:
        driven = element.find("joint")
        name = None if driven is None else driven.get("name")
        if name in names and name not in by_joint:
            by_joint[name] = element
    if [t for t in transmissions if t not in by_joint.values()] or list(by_joint) != [
        n for n in names if n in by_joint
    ]:
        for element in transmissions:
            robot.remove(element)
        for name in names:
            if name in by_joint:
                robot.append(by_joint[name])
    if not drives.given():
        return
    values = {name: drives.per_joint(name, len(names)) for name in DRIVE_FIELDS}
    for j, joint in enumerate(chain):
        if joint.name not in by_joint:
            by_joint[joint.name] = _new_transmission(robot, joint.name)
        actuator = actuator_of(robot, joint.name)
        namespaces = {"posfb": POSFB_NS, "drake": DRAKE_NS}
        for name, parent in (
            ("coulomb", joint.element),
            ("motor_constant", actuator),
            ("rotor_inertia", actuator),
            ("gear_ratio", actuator),
        ):
            if values[name] is None:
                continue
            element = drive_element(parent, DRIVE_ELEMENTS[name])
            if element is None:
                prefix, _, local = DRIVE_ELEMENTS[name].partition(":")
                element = ET.SubElement(parent, f"{{{namespaces[prefix]}}}{local}")
            element.set("value", repr(float(values[name][j])))
        if values["damping"] is not None:
            dynamics = joint.element.find("dynamics")
            if dynamics is None:
                dynamics = ET.SubElement(joint.element, "dynamics")
            dynamics.set("damping", repr(float(values["damping"][j])))


def _new_transmission(robot: ET.Element, joint: str) -> ET.Element:
    """A simple transmission of ``joint`` (actuator ``<joint>_motor``), last in the file."""
    transmission = ET.SubElement(robot, "transmission", {"name": f"{joint}_transmission"})
    ET.SubElement(transmission, "type").text = "SimpleTransmission"
    ET.SubElement(transmission, "joint", {"name": joint})
    ET.SubElement(transmission, "actuator", {"name": f"{joint}_motor"})
    return transmission
