"""Reading a URDF's XML tree: the primitives both the URDF check (``models.urdf_check``)
and the prepared text (``models.description.prepare_urdf``) read a file with.

* the file: ``read_urdf_bytes`` (its bytes, or one-line errors) and ``parse_robot`` (its
  ``<robot>`` element);
* the tree: ``read_tree`` (links, joints, the root link and each link's parent joint) and
  ``serial_chain`` (the arm joints from the base to the tip);
* the drive elements: ``actuator_of`` (a joint's transmission actuator) and
  ``drive_element`` (a ``posfb:`` or ``drake:`` element), in the namespaces ``POSFB_NS``
  (and ``EARLIER_POSFB_NS``) and ``DRAKE_NS``.

Errors are raised as ``ValueError`` with one line naming the element, its value and what
is allowed, as ``models.urdf_check`` describes.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from posfb.models.validation import require_regular_file

#: XML namespace of posfb's own URDF elements (motor constants, Coulomb levels): a URN,
#: a fixed identifier that nothing resolves (XML compares it character by character).
POSFB_NS = "urn:posfb:urdf"

#: The namespace of posfb's URDF elements before ``POSFB_NS``, a placeholder web address;
#: still read, so that files written with it keep loading.
EARLIER_POSFB_NS = "https://posfb.example/urdf"

#: Every namespace posfb reads its elements in, the documented one first.
POSFB_NAMESPACES = (POSFB_NS, EARLIER_POSFB_NS)

#: XML namespace of Drake's URDF extensions.
DRAKE_NS = "http://drake.mit.edu"

ARM_JOINT_TYPES = ("revolute", "continuous")
JOINT_TYPES = (*ARM_JOINT_TYPES, "fixed")

#: What a serial arm accepts as joints (in messages).
SERIAL_JOINTS = (
    "revolute or continuous is required for an arm joint (posfb drives rotary joints "
    "through motors) and fixed for a welded body (prismatic, planar, floating and mimic "
    "joints are welded, models.description)"
)


# --- the file ----------------------------------------------------------------


def read_urdf_bytes(path: Path) -> bytes:
    require_regular_file("URDF", path, FileNotFoundError)
    try:
        return path.read_bytes()
    except OSError as error:
        raise ValueError(
            f"URDF {path} cannot be read ({error.strerror}); a readable file is required"
        ) from None


def parse_robot(path: Path, text: bytes, *, comments: bool = False) -> ET.Element:
    """The ``<robot>`` element of the URDF text ``text`` (read from ``path``), with the
    comments inside it where ``comments``."""
    try:
        parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=comments))
        robot = ET.fromstring(text, parser)
    except ET.ParseError as error:
        raise ValueError(f"URDF {path} is not well-formed XML: {error}") from None
    if robot.tag != "robot":
        raise ValueError(f"URDF {path}: root element = <{robot.tag}>; <robot> is required")
    return robot


# --- numbers --------------------------------------------------------------


def _shown(value: str | None) -> str:
    return "(missing)" if value is None else value


def _attribute(element: ET.Element | None, name: str) -> str | None:
    return None if element is None else element.get(name)


def _triple(element: ET.Element | None, attribute: str, default: str, name: str) -> np.ndarray:
    """Three finite numbers from ``attribute`` of ``element`` (``default`` if absent)."""
    text = default if element is None else element.get(attribute, default)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        values = np.array([])
    if values.shape != (3,) or not np.all(np.isfinite(values)):
        raise ValueError(f"{name} = {text}; three finite numbers are required")
    return values


def _rotation(rpy: np.ndarray) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw: ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    (cr, cp, cy), (sr, sp, sy) = np.cos(rpy), np.sin(rpy)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


# --- the tree ---------------------------------------------------------------


@dataclass(frozen=True)
class _Joint:
    """One URDF ``<joint>``; ``axis`` is in the joint (= child link) frame."""

    name: str
    kind: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray
    element: ET.Element

    @property
    def rotation(self) -> np.ndarray:
        return _rotation(self.rpy)


def read_tree(
    robot: ET.Element, rule: str
) -> tuple[dict[str, ET.Element], list[_Joint], str, dict[str, _Joint]]:
    """Links, joints (each of a type ``rule`` allows), the root link and each link's
    parent joint; refuses ``<drake:joint>``, repeated names, a forest and loops."""
    drake_joint = robot.find(f"{{{DRAKE_NS}}}joint")
    if drake_joint is not None:
        raise ValueError(
            f"drake:joint {drake_joint.get('name')!r} type = {_shown(drake_joint.get('type'))}; "
            f"only URDF <joint> elements are supported: {rule}"
        )
    links = _links(robot)
    joints = [_joint(element, links, rule) for element in robot.findall("joint")]
    names = [joint.name for joint in joints]
    for name in names:
        if names.count(name) > 1:
            raise ValueError(f"joint name = {name!r} appears twice; unique names are required")
    root, parent_joint = _tree(links, joints)
    return links, joints, root, parent_joint


def _links(robot: ET.Element) -> dict[str, ET.Element]:
    links: dict[str, ET.Element] = {}
    for element in robot.findall("link"):
        name = element.get("name")
        if not name:
            raise ValueError("link name = (missing); every <link> needs a unique name")
        if name in links:
            raise ValueError(f"link name = {name!r} appears twice; unique names are required")
        links[name] = element
    return links


def _joint(element: ET.Element, links: dict[str, ET.Element], rule: str) -> _Joint:
    name = element.get("name")
    if not name:
        raise ValueError("joint name = (missing); every <joint> needs a unique name")
    label = f"joint {name!r}"
    kind = element.get("type")
    if kind not in JOINT_TYPES:
        raise ValueError(f"{label} type = {_shown(kind)}; {rule}")
    ends = {}
    for end in ("parent", "child"):
        link = _shown(_attribute(element.find(end), "link"))
        if link not in links:
            raise ValueError(f"{label} {end} link = {link}; a <link> of this URDF is required")
        ends[end] = link
    origin = element.find("origin")
    return _Joint(
        name=name,
        kind=kind,
        parent=ends["parent"],
        child=ends["child"],
        xyz=_triple(origin, "xyz", "0 0 0", f"{label} origin xyz"),
        rpy=_triple(origin, "rpy", "0 0 0", f"{label} origin rpy"),
        axis=_triple(element.find("axis"), "xyz", "1 0 0", f"{label} axis xyz"),
        element=element,
    )


def _tree(links: dict[str, ET.Element], joints: list[_Joint]) -> tuple[str, dict[str, _Joint]]:
    """The root link and, for every other link, the joint it hangs from."""
    parent_joint: dict[str, _Joint] = {}
    for joint in joints:
        if joint.child in parent_joint:
            raise ValueError(
                f"link {joint.child!r} parent joints = {parent_joint[joint.child].name}, "
                f"{joint.name}; one parent joint per link is required (a tree)"
            )
        parent_joint[joint.child] = joint
    roots = [name for name in links if name not in parent_joint]
    if len(roots) != 1:
        raise ValueError(
            f"root links = {', '.join(roots) or '(none)'}; exactly one (the base) is required, "
            "every other link hangs from a joint"
        )
    return roots[0], parent_joint


def _carrier(link: str, parent_joint: dict[str, _Joint]) -> str:
    """The link that moves ``link``: itself, or what it is welded to."""
    while link in parent_joint and parent_joint[link].kind == "fixed":
        link = parent_joint[link].parent
    return link


def serial_chain(root: str, joints: list[_Joint], parent_joint: dict[str, _Joint]) -> list[_Joint]:
    """The arm joints from the base to the tip; refuses a branch or no arm joint."""
    movable = [joint for joint in joints if joint.kind != "fixed"]
    if not movable:
        raise ValueError(
            "revolute/continuous joints = 0; at least one arm joint is required, each with "
            "posfb:coulomb_friction and a transmission actuator with posfb:motor_constant"
        )
    chain, carrier = [], root
    while True:
        hanging = [joint for joint in movable if _carrier(joint.parent, parent_joint) == carrier]
        if len(hanging) > 1:
            raise ValueError(
                f"link {carrier!r} carries the arm joints {', '.join(j.name for j in hanging)}; "
                "one is required: a serial chain base -> link 1 -> ... -> link n (a branched "
                "tree is not supported)"
            )
        if not hanging:
            break
        chain.append(hanging[0])
        carrier = hanging[0].child
    if len(chain) != len(movable):
        left = [joint.name for joint in movable if joint not in chain]
        raise ValueError(
            f"arm joints {', '.join(left)} are not on the chain from the base "
            f"({' -> '.join(j.name for j in chain)}); one serial chain is required"
        )
    return chain


# --- drive elements -----------------------------------------------------------


def actuator_of(robot: ET.Element, joint: str) -> ET.Element | None:
    for transmission in robot.findall("transmission"):
        driven = transmission.find("joint")
        if driven is not None and driven.get("name") == joint:
            return transmission.find("actuator")
    return None


def _posfb_element(parent: ET.Element, tag: str, label: str) -> ET.Element | None:
    """``parent``'s ``<posfb:tag>`` in one of ``POSFB_NAMESPACES`` (``None`` if it has
    none); a ``<tag>`` child in another XML namespace, or in none, is refused naming the
    namespace posfb reads."""
    for namespace in POSFB_NAMESPACES:
        element = parent.find(f"{{{namespace}}}{tag}")
        if element is not None:
            return element
    for child in parent:
        if not isinstance(child.tag, str):  # a comment
            continue
        namespace, _, local = child.tag.rpartition("}")
        if local == tag:
            where = f"namespace {namespace[1:]}" if namespace else "no namespace"
            raise ValueError(
                f"{label} posfb:{tag} = (missing): its <{tag}> is in {where}; posfb reads "
                f'it in the namespace {POSFB_NS} (declare xmlns:posfb="{POSFB_NS}" on '
                f"<robot> and write <posfb:{tag}>)"
            )
    return None


def drive_element(parent: ET.Element, tag: str) -> ET.Element | None:
    """``parent``'s drive element ``tag``, written ``posfb:NAME`` (in any of
    ``POSFB_NAMESPACES``) or ``drake:NAME``; ``None`` if it has none."""
    prefix, _, local = tag.partition(":")
    if prefix == "drake":
        return parent.find(f"{{{DRAKE_NS}}}{local}")
    return _posfb_element(parent, local, f"{parent.tag} {parent.get('name')!r}")
