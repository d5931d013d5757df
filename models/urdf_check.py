"""An arm URDF checked where it enters posfb, before Drake parses it.

Two checks, each run where its model is made: ``check_serial_urdf`` (any serial arm)
inside ``models.plant.add_arm``, so that every way a URDF enters (a scenario's
``plant.urdf``, a ``PlantConfig``, a nominal model named by a URDF) gets it; and
``check_arm_urdf`` (the paper's planar two-link model) inside
``models.theta_of_plant.identify_urdf`` (``posfb identify``, a ``!Theta`` nominal model
identified from a URDF). Each failure is one line, ``URDF <path>: <element> =
<value>; <what is allowed>``, raised as ``ValueError`` (``FileNotFoundError`` for a
file that does not exist). A file is parsed and checked once per content: both
checks keep their result for the file's bytes (``_checked``), so the many plants of
a study, or the two checks of one scenario, read it once each.

What ``check_arm_urdf`` checks is what the planar two-link model of Sec. 4.1
(``models.lumped``, identified by ``models.theta_of_plant``) and posfb's plant
(``models.plant``) can represent:

* the file: it exists, is a file (a directory is named as such), can be read,
  is well-formed XML and its root is ``<robot>``;
* the tree: unique link and joint names, joints between links of the file,
  one parent joint per link, one root (the base, welded to the world), no
  loops, no ``<drake:joint>``;
* the arm: exactly two revolute or continuous joints, every other joint
  ``fixed`` (a welded body such as the tip payload); joint 1 hangs from the
  base (or a body welded to it), joint 2 from joint 1's child link;
* what ``models.plant`` reads besides Drake: each arm joint carries
  ``posfb:coulomb_friction`` >= 0 and has a transmission whose actuator
  carries ``posfb:motor_constant`` > 0; ``<dynamics damping>`` >= 0,
  ``drake:rotor_inertia`` >= 0 and ``drake:gear_ratio`` > 0 where given;
* masses and inertias: finite masses, > 0 for the two arm links and >= 0 for
  other bodies; rotational inertias physically valid (principal moments >= 0,
  each at most the sum of the other two);
* the axes, in the world at ``q = 0``: nonzero, perpendicular to gravity
  (``-z``; an axis along gravity leaves the arm horizontal, gravity gives no
  torque and theta4 = 0), joint 2's parallel to joint 1's with the same sense
  (otherwise q2 turns the other way and gravity becomes ``cos(q1 - q2)``); in
  its own link frame each axis is ``(0, +-1, 0)``, because ``models.plant``
  reads a link's inertia about that frame's y axis;
* the geometry at ``q = 0``: joint 2 sits on link 1's x axis at ``(+-l1, 0,
  0)`` with ``l1 > 0`` (``models.plant`` takes l1 as that distance and a link's
  centre of mass along x); link 1 is horizontal (the model's ``theta4 cos
  q1``); positive q1 raises it (theta4 > 0, and gravity on joint 2 is ``+cos(q1
  + q2)``); link 2's x axis continues link 1's line (the model's ``cos q2``);
  the centre of mass of every body with mass, and the payload link's origin,
  lie on their link's line (no in-plane offset, ``z = 0`` in the link frame);
  link 2 has a moment of inertia about joint 2 (theta7 > 0).

A serial arm of any joint count (``check_serial_urdf``) gets every check above that
is not about the planar two-link model: the file, the tree, the motor stages, the
masses and inertias, nonzero axes and some inertia about each joint's axis. The file,
the tree and the drive elements are read with ``models.urdf_tree``'s primitives, which
``models.description.prepare_urdf`` reads the file with too.

Drake then parses the file (``add_urdf_models``): each warning its parser logs is
shown once per process, as one line.

Allowed on purpose, because the model represents them: an arm in any
vertical plane (a yaw of joint 1's origin), either sign of ``(+-l1, 0, 0)``
and of the axes as long as positive q1 raises link 1, offsets along the joint
axes for centres of mass, point-mass and thin-rod links (singular but valid
inertias, as ``models.plant.apply_parameters`` itself writes), bodies welded
anywhere, and any link and joint names (``models.plant`` checks the names it
needs after Drake parses the file).
"""

from __future__ import annotations

import functools
import logging
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from posfb.models.description import Description, PreparedUrdf, prepare_urdf
from posfb.models.urdf_tree import (
    DRAKE_NS,
    SERIAL_JOINTS,
    _attribute,
    _carrier,
    _Joint,
    _posfb_element,
    _rotation,
    _shown,
    _triple,
    actuator_of,
    parse_robot,
    read_tree,
    read_urdf_bytes,
    serial_chain,
)

if TYPE_CHECKING:
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

#: Relative tolerance of the geometry checks, for unit directions and for
#: offsets relative to l1: angles written with five decimals of pi (3.14159 is
#: 2.7e-6 off) pass, and what it lets through changes the model by < 1e-5.
TOLERANCE = 1e-5

#: Relative slack of the inertia checks (round-off in thin-plate inertias).
INERTIA_TOLERANCE = 1e-9

UP = np.array([0.0, 0.0, 1.0])
X_AXIS = np.array([1.0, 0.0, 0.0])
Y_AXIS = np.array([0.0, 1.0, 0.0])


@dataclass(frozen=True)
class _Body:
    """A body with mass, expressed in the frame of the link that carries it."""

    link: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class _Arm:
    """The parsed tree: world poses at ``q = 0`` and the two arm joints."""

    links: dict[str, ET.Element]
    parent_joint: dict[str, _Joint]
    poses: dict[str, tuple[np.ndarray, np.ndarray]]
    shoulder: _Joint
    elbow: _Joint


def check_arm_urdf(path: str | Path, payload_link: str | None = None) -> None:
    """Refuse a URDF that the model of Sec. 4.1 and ``models.plant`` cannot represent.

    ``payload_link``: the link at whose origin ``models.plant`` puts the tip
    payload; where the file has it, it must be welded to link 2 on its line.
    Raises ``FileNotFoundError`` if ``path`` does not exist and ``ValueError``
    (one line naming the element, its value and what is allowed) otherwise."""
    path = Path(path)
    _check_arm(path, read_urdf_bytes(path), payload_link)


@functools.lru_cache(maxsize=64)
def _check_arm(path: Path, text: bytes, payload_link: str | None) -> None:
    """``check_arm_urdf`` on the bytes ``text`` of ``path``."""
    robot = parse_robot(path, text)
    try:
        arm = _parse_arm(robot)
        _check_drives(robot, [arm.shoulder, arm.elbow])
        bodies = _bodies(
            arm.links, arm.parent_joint, arm.poses, (arm.shoulder.child, arm.elbow.child)
        )
        _check_axes(arm)
        _check_geometry(arm, bodies)
        if payload_link in arm.links:
            _check_payload(arm, payload_link)
    except ValueError as error:
        raise ValueError(f"URDF {path}: {error}") from None


#: Drake's parser warnings already shown in this process (``add_urdf_models``).
_SHOWN_WARNINGS: set[str] = set()


class _HeldWarnings(logging.Filter):
    """Holds back the warnings logged on Drake's logger while it is attached (all but
    those ``add_urdf_models`` shows)."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno != logging.WARNING or getattr(record, "posfb_shown", False):
            return True
        self.records.append(record)
        return False


def add_urdf_models(parser: Parser, prepared: PreparedUrdf) -> None:
    """Parse the ``prepared`` URDF text (``models.description.prepare_urdf``) into
    ``parser``'s plant, its note shown once per process; each warning Drake's parser logs
    is shown once per process and as one line on Drake's logger: Drake writes some on
    several lines, and posfb parses one file several times (the plant, the nominal model,
    each sample)."""
    prepared.show_note()
    logger = logging.getLogger("drake")
    held = _HeldWarnings()
    logger.addFilter(held)
    try:
        parser.AddModelsFromString(prepared.text, "urdf")
    finally:
        logger.removeFilter(held)
        for record in held.records:
            line = " ".join(record.getMessage().split())
            line = line.replace("<literal-string>.urdf", str(prepared.path))
            if line not in _SHOWN_WARNINGS:
                _SHOWN_WARNINGS.add(line)
                logger.warning("%s", line, extra={"posfb_shown": True})


def weld_base(plant: MultibodyPlant, base: str) -> None:
    """Weld the chain's ``base`` link to the world, unless it is the world itself: a URDF
    link named ``world`` is Drake's world body, and the file's own fixed joint from it
    places the arm (published descriptions carry one)."""
    from pydrake.math import RigidTransform

    frame = plant.GetFrameByName(base)
    if frame.body().index() != plant.world_body().index():
        plant.WeldFrames(plant.world_frame(), frame, RigidTransform())


# --- numbers --------------------------------------------------------------


def _vector(values: np.ndarray) -> str:
    return "(" + ", ".join(f"{v + 0.0:.6g}" for v in values) + ")"


def _value(element: ET.Element | None) -> str | None:
    return _attribute(element, "value")


def _scalar(value: str | None, name: str, positive: bool, unit: str) -> float:
    """``value`` as a finite number, > 0 if ``positive`` else >= 0."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not math.isfinite(number) or number < 0.0 or (positive and number == 0.0):
        bound = "> 0" if positive else ">= 0"
        raise ValueError(f"{name} = {_shown(value)}; a finite value {bound} ({unit}) is required")
    return number


# --- the tree ---------------------------------------------------------------


#: What the two-link model accepts as joints (in messages).
TWO_LINK_JOINTS = (
    "revolute or continuous is required for the two arm joints of Sec. 4.1 and fixed for "
    "any other joint (a welded body)"
)


def _parse_arm(robot: ET.Element) -> _Arm:
    links, joints, root, parent_joint = read_tree(robot, TWO_LINK_JOINTS)
    poses = _world_poses(root, links, parent_joint)
    shoulder, elbow = _arm_joints(root, joints, parent_joint)
    return _Arm(links, parent_joint, poses, shoulder, elbow)


def _world_poses(
    root: str, links: dict[str, ET.Element], parent_joint: dict[str, _Joint]
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(rotation, position) of every link frame in the world at ``q = 0``; the
    root is welded to the world at the identity (``models.plant``)."""
    poses = {root: (np.eye(3), np.zeros(3))}
    for name in links:
        chain: list[str] = []
        while name not in poses:
            if name in chain:
                raise ValueError(
                    f"link {name!r} is in a loop of joints; a tree from the base {root!r} is "
                    "required"
                )
            chain.append(name)
            name = parent_joint[name].parent
        for child in reversed(chain):
            joint = parent_joint[child]
            rotation, position = poses[joint.parent]
            poses[child] = (rotation @ joint.rotation, position + rotation @ joint.xyz)
    return poses


def _arm_joints(
    root: str, joints: list[_Joint], parent_joint: dict[str, _Joint]
) -> tuple[_Joint, _Joint]:
    arm = [joint for joint in joints if joint.kind != "fixed"]
    if len(arm) != 2:
        listed = ", ".join(joint.name for joint in arm) or "none"
        raise ValueError(
            f"revolute/continuous joints = {len(arm)} ({listed}); exactly two are required "
            "(joint 1 on the base, joint 2 on joint 1's child link), each with "
            "posfb:coulomb_friction and a transmission actuator with posfb:motor_constant"
        )
    on_base = [joint for joint in arm if _carrier(joint.parent, parent_joint) == root]
    if len(on_base) != 1:
        raise ValueError(
            f"joints on the base {root!r} = {', '.join(j.name for j in on_base)}; one is "
            "required: the arm is a serial chain base -> link 1 -> link 2"
        )
    shoulder = on_base[0]
    elbow = arm[1] if arm[0] is shoulder else arm[0]
    if elbow.parent != shoulder.child:
        raise ValueError(
            f"joint {elbow.name!r} parent link = {elbow.parent}; {shoulder.child} (the child of "
            f"joint {shoulder.name!r}) is required: the arm is a serial chain base -> link 1 -> "
            "link 2"
        )
    return shoulder, elbow


# --- what models.plant reads --------------------------------------------------


def finite_number(text: str | None) -> float | None:
    """``text`` as a finite number, ``None`` where it is absent or not one (the check
    refuses it; ``scenario init``'s rules pass on to the next source)."""
    try:
        value = float(text)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def posfb_value(parent: ET.Element, tag: str, label: str) -> float | None:
    """The number of ``parent``'s ``<posfb:tag value>`` (``None`` if it has none or it is
    not a finite number); a ``<tag>`` in another namespace is refused as the check does."""
    return finite_number(_value(_posfb_element(parent, tag, label)))


def _check_drives(robot: ET.Element, joints: list[_Joint]) -> list[tuple[float, float]]:
    """Each arm joint's Coulomb level (N m) and motor constant (N m/V), checked with its
    damping, rotor inertia and gear ratio (``_check_drive``); the elements missing on
    any joint are refused together, in one line."""
    checked = [_check_drive(robot, joint) for joint in joints]
    missing: dict[str, list[str]] = {}
    for joint, (_, _, absent) in zip(joints, checked, strict=True):
        for element in absent:
            missing.setdefault(element, []).append(joint.name)
    if missing:
        listed = "; ".join(
            f"{element} of joints {', '.join(names)}" for element, names in missing.items()
        )
        raise ValueError(
            f"{listed} = (missing); each arm joint needs a Coulomb level and a motor "
            "constant: a scenario's plant.drives (posfb scenario init writes them from the "
            "file's <limit effort> and <dynamics>), or posfb:coulomb_friction on the joint and "
            "a <transmission> whose <actuator> carries posfb:motor_constant; a joint that is "
            "not the arm's (a gripper) is welded with scenario init --weld NAME or plant.weld"
        )
    return [(coulomb, motor) for coulomb, motor, _ in checked]


def _check_drive(robot: ET.Element, joint: _Joint) -> tuple[float, float, list[str]]:
    """Coulomb level, damping and the actuator's motor constant, rotor inertia
    and gear ratio of one arm joint; returns its Coulomb level (N m), motor
    constant (N m/V) and the required elements it lacks (NaN values where missing)."""
    label = f"joint {joint.name!r}"
    missing = []
    element = _posfb_element(joint.element, "coulomb_friction", label)
    coulomb = math.nan
    if element is None:
        missing.append("posfb:coulomb_friction")
    else:
        coulomb = _scalar(_value(element), f"{label} posfb:coulomb_friction value", False, "N m")
    dynamics = joint.element.find("dynamics")
    if dynamics is not None and "damping" in dynamics.attrib:
        _scalar(dynamics.get("damping"), f"{label} dynamics damping", False, "N m s/rad")
    actuator = actuator_of(robot, joint.name)
    if actuator is None:
        return coulomb, math.nan, [*missing, "transmission actuator"]
    name = f"actuator {actuator.get('name')!r}"
    motor = _posfb_element(actuator, "motor_constant", name)
    motor_constant = math.nan
    if motor is None:
        missing.append("actuator posfb:motor_constant")
    else:
        motor_constant = _scalar(_value(motor), f"{name} posfb:motor_constant value", True, "N m/V")
    for tag, positive, unit in (
        ("rotor_inertia", False, "kg m^2"),
        ("gear_ratio", True, "dimensionless"),
    ):
        element = actuator.find(f"{{{DRAKE_NS}}}{tag}")
        if element is not None:
            _scalar(_value(element), f"{name} drake:{tag} value", positive, unit)
    return coulomb, motor_constant, missing


# --- masses and inertias ------------------------------------------------------


def _bodies(
    links: dict[str, ET.Element],
    parent_joint: dict[str, _Joint],
    poses: dict[str, tuple[np.ndarray, np.ndarray]],
    moving: tuple[str, ...] = (),
) -> list[_Body]:
    """Every link with an ``<inertial>`` (finite mass >= 0, a physically valid inertia),
    in the frame of the link that moves it; each of the ``moving`` links must have one
    with mass > 0."""
    bodies = []
    for name, element in links.items():
        inertial = element.find("inertial")
        if inertial is None:
            if name in moving:
                raise ValueError(
                    f"link {name!r} mass = (missing: no <inertial>); a finite value > 0 (kg) is "
                    "required for an arm link"
                )
            continue
        label = f"link {name!r}"
        mass = _scalar(_value(inertial.find("mass")), f"{label} mass", name in moving, "kg")
        origin = inertial.find("origin")
        com = _triple(origin, "xyz", "0 0 0", f"{label} inertial origin xyz")
        rotation = _rotation(_triple(origin, "rpy", "0 0 0", f"{label} inertial origin rpy"))
        inertia = rotation @ _inertia(label, inertial.find("inertia")) @ rotation.T
        carrier = _carrier(name, parent_joint)
        to_carrier, offset = _relative_pose(poses, carrier, name)
        bodies.append(
            _Body(
                link=name,
                mass=mass,
                com=offset + to_carrier @ com,
                inertia=to_carrier @ inertia @ to_carrier.T,
            )
        )
    return bodies


def _inertia(label: str, element: ET.Element | None) -> np.ndarray:
    """The rotational inertia about the centre of mass; physically valid."""
    names = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
    text = " ".join("0" if element is None else element.get(n, "0") for n in names)
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) != len(names) or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{label} inertia {' '.join(names)} = {text}; finite numbers are required")
    xx, yy, zz, xy, xz, yz = values
    matrix = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    moments = np.linalg.eigvalsh(matrix)
    slack = INERTIA_TOLERANCE * float(np.abs(moments).max())
    if moments[0] < -slack or moments[2] > moments[0] + moments[1] + slack:
        raise ValueError(
            f"{label} inertia {' '.join(names)} = {text} (principal moments "
            f"{_vector(moments)}); a physically valid inertia is required: principal moments "
            ">= 0, each at most the sum of the other two"
        )
    return matrix


def _relative_pose(
    poses: dict[str, tuple[np.ndarray, np.ndarray]], frame: str, link: str
) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and origin of ``link``'s frame expressed in ``frame``'s, at ``q = 0``."""
    frame_rotation, frame_position = poses[frame]
    rotation, position = poses[link]
    return frame_rotation.T @ rotation, frame_rotation.T @ (position - frame_position)


# --- axes and geometry ----------------------------------------------------------


def _unit_axis(joint: _Joint) -> np.ndarray:
    norm = float(np.linalg.norm(joint.axis))
    if norm == 0.0:
        raise ValueError(
            f"joint {joint.name!r} axis xyz = {_vector(joint.axis)}; a nonzero direction is "
            "required"
        )
    return joint.axis / norm


def _world_axis(arm: _Arm, joint: _Joint) -> np.ndarray:
    return arm.poses[joint.child][0] @ _unit_axis(joint)


def _check_axes(arm: _Arm) -> None:
    """Both axes horizontal, parallel with the same sense, and (0, +-1, 0) locally."""
    shoulder, elbow = arm.shoulder, arm.elbow
    axis = _world_axis(arm, shoulder)
    if abs(axis @ UP) > TOLERANCE:
        raise ValueError(
            f"joint {shoulder.name!r} axis in the world at q = 0 = {_vector(axis)}; an axis "
            "perpendicular to gravity (-z) is required: the model of Sec. 4.1 is an arm in a "
            "vertical plane, and with the axes along gravity it gets no gravity torque "
            "(theta4 = 0)"
        )
    elbow_axis = _world_axis(arm, elbow)
    if np.linalg.norm(elbow_axis - axis) > TOLERANCE:
        raise ValueError(
            f"joint {elbow.name!r} axis in the world at q = 0 = {_vector(elbow_axis)}; "
            f"{_vector(axis)} as for joint {shoulder.name!r} is required (parallel, same "
            "sense): the model of Sec. 4.1 is a planar arm whose q2 turns the way q1 does"
        )
    for joint in (shoulder, elbow):
        local = _unit_axis(joint)
        if abs(abs(local @ Y_AXIS) - 1.0) > TOLERANCE:
            raise ValueError(
                f"joint {joint.name!r} axis xyz = {_vector(joint.axis)}; (0, 1, 0) or "
                "(0, -1, 0) is required: posfb reads a link's inertia about its frame's y "
                "axis (turn the link frame with the joint's origin rpy instead)"
            )


def _check_geometry(arm: _Arm, bodies: list[_Body]) -> None:
    """Link 1 horizontal along x, raised by q1, continued by link 2; masses on the line."""
    shoulder, elbow = arm.shoulder, arm.elbow
    l1 = float(np.linalg.norm(elbow.xyz))
    if l1 == 0.0 or np.linalg.norm(elbow.xyz[1:]) > TOLERANCE * l1:
        raise ValueError(
            f"joint {elbow.name!r} origin xyz = {_vector(elbow.xyz)}; (l1, 0, 0) or (-l1, 0, 0) "
            f"with l1 > 0 is required: link 1 runs along the x axis of link {shoulder.child!r}, "
            "where posfb reads l1 and the centre of mass"
        )
    rotation = arm.poses[shoulder.child][0]
    along = rotation @ (elbow.xyz / l1)
    if abs(along @ UP) > TOLERANCE:
        raise ValueError(
            f"joint {shoulder.name!r} origin rpy = {_vector(shoulder.rpy)} (link 1 points "
            f"{_vector(along)} at q = 0); link 1 horizontal at q = 0 is required (the model's "
            "theta4 cos q1)"
        )
    if np.cross(_world_axis(arm, shoulder), along) @ UP <= 0.0:
        raise ValueError(
            f"joint {shoulder.name!r} axis xyz = {_vector(shoulder.axis)} (link 1 along "
            f"{_vector(along)}); an axis about which positive q1 raises link 1 is required "
            "(theta4 > 0, gravity on joint 2 as +cos(q1 + q2)): reverse both joint axes"
        )
    link2 = arm.poses[elbow.child][0] @ X_AXIS
    if np.linalg.norm(np.cross(link2, along)) > TOLERANCE:
        raise ValueError(
            f"joint {elbow.name!r} origin rpy = {_vector(elbow.rpy)} (link 2's x axis points "
            f"{_vector(link2)} at q = 0); link 2's x axis along link 1's line {_vector(along)} "
            "is required (the model's cos q2)"
        )
    for body in bodies:
        carrier = _carrier(body.link, arm.parent_joint)
        if body.mass > 0.0 and carrier in (shoulder.child, elbow.child):
            _check_on_line(f"link {body.link!r} centre of mass", body.com, carrier, l1)
    _check_link2_inertia(arm, bodies)


def _check_on_line(label: str, point: np.ndarray, link: str, l1: float) -> None:
    """``point`` (in ``link``'s frame) on the link's line: no in-plane offset."""
    if abs(point[2]) > TOLERANCE * l1:
        raise ValueError(
            f"{label} in the frame of link {link!r} = {_vector(point)}; z = 0 is required: the "
            "model of Sec. 4.1 has every mass on the line through its link's joint axes"
        )


def _check_payload(arm: _Arm, payload: str) -> None:
    """The tip payload (a point mass at the link's origin) rides on link 2's line."""
    link2 = arm.elbow.child
    carrier = _carrier(payload, arm.parent_joint)
    if carrier != link2:
        raise ValueError(
            f"link {payload!r} moves with {carrier!r}; welded to {link2!r} is required: the "
            "tip payload rides on link 2"
        )
    _, origin = _relative_pose(arm.poses, link2, payload)
    _check_on_line(f"link {payload!r} origin", origin, link2, float(np.linalg.norm(arm.elbow.xyz)))


def _check_link2_inertia(arm: _Arm, bodies: list[_Body]) -> None:
    """theta7 > 0: link 2 (with what is welded to it) has inertia about joint 2."""
    elbow = arm.elbow
    axis = _unit_axis(elbow)
    moment = 0.0
    for body in bodies:
        if _carrier(body.link, arm.parent_joint) == elbow.child:
            radial = body.com - (body.com @ axis) * axis
            moment += float(axis @ body.inertia @ axis) + body.mass * float(radial @ radial)
    if moment <= 0.0:
        raise ValueError(
            f"link {elbow.child!r} moment of inertia about the axis of joint {elbow.name!r} = "
            f"{moment:g} kg m^2; > 0 is required (theta7 > 0): link 2 cannot be a point mass "
            "on joint 2's axis"
        )


# --- any serial arm -------------------------------------------------------------


@dataclass(frozen=True)
class SerialChain:
    """A checked serial arm: its ``base`` link, the arm ``joints`` from the base to the tip,
    per joint the Coulomb level (N m) and motor constant (N m/V) of its motor stage, and
    the names of all its ``links``."""

    base: str
    joints: tuple[str, ...]
    coulomb: tuple[float, ...]
    motor_constant: tuple[float, ...]
    links: tuple[str, ...] = ()


def check_serial_urdf(path: str | Path, description: Description | None = None) -> SerialChain:
    """Refuse a URDF that is not a serial chain of actuated revolute joints; return its
    base link and the arm joints' names from the base to the tip.

    Accepted: one root link (the base, welded to the world), any number of revolute
    or continuous joints in one chain (each hanging from the previous joint's child
    link or a body welded to it), fixed joints for welded bodies anywhere. Each arm
    joint needs its motor stage (``posfb:coulomb_friction``, a transmission actuator
    with ``posfb:motor_constant``; ``drake:rotor_inertia``, ``drake:gear_ratio`` and
    ``<dynamics damping>`` where given are checked as for the two-link arm) and the
    link it moves must have mass (a massless link makes the mass matrix singular).
    What the two-link check makes of any arm is made here too: every ``<inertial>``'s
    mass finite and >= 0 and its rotational inertia physically valid (principal moments
    >= 0, each at most the sum of the other two: the triangle inequality), every arm
    joint's axis nonzero, and each arm joint moving some inertia about its axis (the
    two-link arm's theta7 > 0: the diagonal of the mass matrix without rotor inertia).
    The file is checked as ``models.description.prepare_urdf`` hands it to Drake, with
    what ``description`` (the scenario's) adds. Raises as ``check_arm_urdf``: one line
    naming the element; drive data missing on several joints are named at once."""
    path = Path(path)
    return _check_serial(path, prepare_urdf(path, description).text.encode())


@functools.lru_cache(maxsize=64)
def _check_serial(path: Path, text: bytes) -> SerialChain:
    """``check_serial_urdf`` on the bytes ``text`` of ``path``."""
    robot = parse_robot(path, text)
    try:
        links, joints, root, parent_joint = read_tree(robot, SERIAL_JOINTS)
        poses = _world_poses(root, links, parent_joint)  # refuses loops
        chain = serial_chain(root, joints, parent_joint)
        drives = _check_drives(robot, chain)
        bodies = _bodies(links, parent_joint, poses)
        _check_moving_masses(links, chain, parent_joint)
        _check_joint_inertias(robot, chain, bodies, parent_joint, poses)
    except ValueError as error:
        raise ValueError(f"URDF {path}: {error}") from None
    coulomb, motor_constant = zip(*drives, strict=True)
    return SerialChain(
        root, tuple(joint.name for joint in chain), coulomb, motor_constant, tuple(links)
    )


def _check_moving_masses(
    links: dict[str, ET.Element], chain: list[_Joint], parent_joint: dict[str, _Joint]
) -> None:
    """The bodies each arm joint moves directly (its child link and what is welded to
    it) have a total mass > 0."""
    for joint in chain:
        carried = [name for name in links if _carrier(name, parent_joint) == joint.child]
        total = 0.0
        for name in carried:
            inertial = links[name].find("inertial")
            if inertial is not None:
                label = f"link {name!r} mass"
                total += _scalar(_value(inertial.find("mass")), label, False, "kg")
        if total <= 0.0:
            raise ValueError(
                f"link {joint.child!r} mass = {total:g} (with what is welded to it); a total "
                f"> 0 (kg) is required for the link joint {joint.name!r} moves"
            )


def _outboard(link: str, joint: _Joint, parent_joint: dict[str, _Joint]) -> bool:
    """Whether ``link`` moves with ``joint``: it is the joint's child or hangs from it."""
    while link in parent_joint:
        if parent_joint[link] is joint:
            return True
        link = parent_joint[link].parent
    return False


def _reflected_rotor_inertia(robot: ET.Element, joint: _Joint) -> float:
    """``drake:rotor_inertia * drake:gear_ratio^2`` of the joint's actuator (kg m^2; 0
    without a rotor inertia), as Drake adds it to the mass matrix; both checked already."""
    actuator = actuator_of(robot, joint.name)
    rotor = _value(actuator.find(f"{{{DRAKE_NS}}}rotor_inertia"))
    ratio = _value(actuator.find(f"{{{DRAKE_NS}}}gear_ratio"))
    return (0.0 if rotor is None else float(rotor)) * (1.0 if ratio is None else float(ratio)) ** 2


def _check_joint_inertias(
    robot: ET.Element,
    chain: list[_Joint],
    bodies: list[_Body],
    parent_joint: dict[str, _Joint],
    poses: dict[str, tuple[np.ndarray, np.ndarray]],
) -> None:
    """Each arm joint moves a moment of inertia > 0 about its own axis at ``q = 0``: the
    bodies outboard of it and its reflected rotor inertia, as ``_check_link2_inertia``
    asks of the two-link arm's joint 2. That moment is the joint's diagonal entry of
    ``M(q)``: at 0 the mass matrix is singular."""
    for joint in chain:
        rotation, origin = poses[joint.child]
        axis = rotation @ _unit_axis(joint)
        moment = _reflected_rotor_inertia(robot, joint)
        for body in bodies:
            if not _outboard(body.link, joint, parent_joint):
                continue
            carrier_rotation, carrier_origin = poses[_carrier(body.link, parent_joint)]
            offset = carrier_origin + carrier_rotation @ body.com - origin
            radial = offset - (offset @ axis) * axis
            inertia = carrier_rotation @ body.inertia @ carrier_rotation.T
            moment += float(axis @ inertia @ axis) + body.mass * float(radial @ radial)
        if moment <= 0.0:
            raise ValueError(
                f"joint {joint.name!r} moment of inertia about its axis at q = 0 (the links it "
                f"moves and its reflected rotor inertia) = {moment:g} kg m^2; > 0 is required: "
                "the mass matrix is singular when a joint moves only point masses on its axis"
            )
