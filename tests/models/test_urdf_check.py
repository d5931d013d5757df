"""A user's URDF is checked where it enters: one line naming the element and its
value for anything the model of Sec. 4.1 cannot represent, and the payload
mass is bounded where it enters."""

from __future__ import annotations

import dataclasses
import logging
import re

import numpy as np
import pytest

from posfb.analysis.cli import EXIT_BAD_INPUT, main
from posfb.models.plant import (
    DEFAULT_URDF,
    MAX_PAYLOAD_MASS,
    PAYLOAD_BODY,
    PlantConfig,
    build_arm_diagram,
)
from posfb.models.serial_model import SerialArmModel
from posfb.models.theta_of_plant import identify
from posfb.models.urdf_check import check_arm_urdf, check_serial_urdf
from posfb.models.urdf_tree import POSFB_NS

SHIPPED = DEFAULT_URDF.read_text()

JOINT1_ORIGIN = '<origin xyz="0 0 0" rpy="0 0 0"/>\n    <axis'
JOINT2_AXIS = '<origin xyz="0.25 0 0" rpy="0 0 0"/>\n    <axis xyz="0 -1 0"/>'
LINK2_COM = '<origin xyz="0.15 0 0" rpy="0 0 0"/>\n      <mass'
LINK2_INERTIAL = """    <inertial>
      <origin xyz="0.15 0 0" rpy="0 0 0"/>
      <mass value="0.873"/>
      <inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0094575" iyz="0" izz="0.0094575"/>
    </inertial>
"""

LINK3 = """
  <link name="link3">
    <inertial><origin xyz="0.1 0 0"/><mass value="0.2"/>
      <inertia ixx="1e-5" ixy="0" ixz="0" iyy="1e-3" iyz="0" izz="1e-3"/></inertial>
  </link>
  <joint name="joint3" type="revolute">
    <parent link="link2"/><child link="link3"/>
    <origin xyz="0.30 0 0"/><axis xyz="0 -1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="10"/>
  </joint>
</robot>"""


def _edit(*replacements: tuple[str, str], text: str = SHIPPED) -> str:
    """The shipped URDF (or ``text``) with each ``(old, new)`` replaced; ``old`` must occur."""
    for old, new in replacements:
        assert old in text, old
        text = text.replace(old, new)
    return text


def _write(tmp_path, text: str, name: str = "arm.urdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


BAD = {
    "prismatic": (
        _edit(
            ('<joint name="joint2" type="continuous">', '<joint name="joint2" type="prismatic">')
        ),
        ["joint 'joint2' type = prismatic", "revolute or continuous"],
    ),
    "negative link mass": (
        _edit(('<mass value="0.873"/>', '<mass value="-0.873"/>')),
        ["link 'link2' mass = -0.873", "> 0"],
    ),
    "negative payload body mass": (
        _edit(('<mass value="0"/>', '<mass value="-1"/>')),
        ["link 'payload' mass = -1", ">= 0"],
    ),
    "link without inertial": (
        _edit((LINK2_INERTIAL, "")),
        ["link 'link2' mass = (missing", "> 0"],
    ),
    "negative principal moment": (
        _edit(('iyy="0.05"', 'iyy="-0.05"')),
        ["link 'link1' inertia", "-0.05", "physically valid"],
    ),
    "indefinite products of inertia": (
        _edit(('ixx="0.001" ixy="0"', 'ixx="0.001" ixy="0.1"')),
        ["link 'link1' inertia", "0.1", "physically valid"],
    ),
    "triangle inequality": (
        _edit(('iyy="0.05" iyz="0" izz="0.05"', 'iyy="0.05" iyz="0" izz="0.5"')),
        ["link 'link1' inertia", "0.5", "sum of the other two"],
    ),
    "z-axis arm": (
        _edit(('<axis xyz="0 -1 0"/>', '<axis xyz="0 0 1"/>')),
        ["joint 'joint1' axis in the world at q = 0 = (0, 0, 1)", "gravity", "theta4 = 0"],
    ),
    "zero axis": (
        _edit(('<axis xyz="0 -1 0"/>', '<axis xyz="0 0 0"/>')),
        ["joint 'joint1' axis xyz = (0, 0, 0)", "nonzero"],
    ),
    "axes not parallel": (
        _edit((JOINT2_AXIS, JOINT2_AXIS.replace("0 -1 0", "1 0 0"))),
        ["joint 'joint2' axis in the world at q = 0 = (1, 0, 0)", "parallel"],
    ),
    "axes opposite": (
        _edit((JOINT2_AXIS, JOINT2_AXIS.replace("0 -1 0", "0 1 0"))),
        ["joint 'joint2' axis in the world at q = 0 = (0, 1, 0)", "same sense"],
    ),
    "axis off the link frame's y": (
        # Turned so that the axes are -y in the world, but z in the link frames.
        _edit(
            (JOINT1_ORIGIN, JOINT1_ORIGIN.replace('rpy="0 0 0"', 'rpy="1.5707963267948966 0 0"')),
            ('<axis xyz="0 -1 0"/>', '<axis xyz="0 0 1"/>'),
        ),
        ["joint 'joint1' axis xyz = (0, 0, 1)", "(0, 1, 0) or (0, -1, 0)"],
    ),
    "q1 lowers the arm": (
        _edit(('<axis xyz="0 -1 0"/>', '<axis xyz="0 1 0"/>')),
        ["joint 'joint1' axis xyz = (0, 1, 0)", "raises link 1"],
    ),
    "link 1 tilted at q = 0": (
        _edit((JOINT1_ORIGIN, JOINT1_ORIGIN.replace('rpy="0 0 0"', 'rpy="0 0.3 0"'))),
        ["joint 'joint1' origin rpy = (0, 0.3, 0)", "horizontal"],
    ),
    "elbow off link 1's x axis": (
        _edit(('<origin xyz="0.25 0 0"', '<origin xyz="0.25 0 0.05"')),
        ["joint 'joint2' origin xyz = (0.25, 0, 0.05)", "(l1, 0, 0)"],
    ),
    "link 2 turned at q2 = 0": (
        _edit(('<origin xyz="0.25 0 0" rpy="0 0 0"/>', '<origin xyz="0.25 0 0" rpy="0 0.4 0"/>')),
        ["joint 'joint2' origin rpy = (0, 0.4, 0)", "cos q2"],
    ),
    "centre of mass off the line": (
        _edit((LINK2_COM, LINK2_COM.replace("0.15 0 0", "0.15 0 0.02"))),
        ["link 'link2' centre of mass in the frame of link 'link2' = (0.15, 0, 0.02)", "z = 0"],
    ),
    "payload off the line": (
        _edit(('<origin xyz="0.30 0 0" rpy="0 0 0"/>', '<origin xyz="0.30 0 0.05" rpy="0 0 0"/>')),
        ["link 'payload' origin in the frame of link 'link2' = (0.3, 0, 0.05)", "z = 0"],
    ),
    "link 2 a point on joint 2's axis": (
        _edit(
            (LINK2_COM, LINK2_COM.replace("0.15 0 0", "0 0 0")),
            (
                'ixx="0.0001" ixy="0" ixz="0" iyy="0.0094575" iyz="0" izz="0.0094575"',
                'ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"',
            ),
        ),
        ["link 'link2' moment of inertia about the axis of joint 'joint2' = 0", "theta7 > 0"],
    ),
    "three links": (
        _edit(("</robot>", LINK3)),
        ["revolute/continuous joints = 3 (joint1, joint2, joint3)", "exactly two"],
    ),
    "two joints on the base": (
        _edit(
            (
                '<parent link="link1"/>\n    <child link="link2"/>',
                '<parent link="base"/>\n    <child link="link2"/>',
            )
        ),
        ["joints on the base 'base' = joint1, joint2", "serial chain"],
    ),
    "unattached link": (
        _edit(("</robot>", '<link name="loose"/>\n</robot>')),
        ["root links = base, loose", "exactly one"],
    ),
    "joint to a missing link": (
        _edit(('<child link="payload"/>', '<child link="tool"/>')),
        ["joint 'tip' child link = tool", "<link> of this URDF"],
    ),
    "missing motor constant": (
        _edit(('<posfb:motor_constant value="1.19085"/>', "")),
        ["actuator posfb:motor_constant of joints joint2 = (missing)", "plant.drives"],
    ),
    "zero motor constant": (
        _edit(('<posfb:motor_constant value="6.0625"/>', '<posfb:motor_constant value="0"/>')),
        ["actuator 'motor1' posfb:motor_constant value = 0", "> 0"],
    ),
    "negative Coulomb level": (
        _edit(
            ('<posfb:coulomb_friction value="9.20106"/>', '<posfb:coulomb_friction value="-9"/>')
        ),
        ["joint 'joint1' posfb:coulomb_friction value = -9", ">= 0"],
    ),
    "zero gear ratio": (
        _edit(('<drake:gear_ratio value="10"/>', '<drake:gear_ratio value="0"/>')),
        ["actuator 'motor2' drake:gear_ratio value = 0", "> 0"],
    ),
    "not a number": (
        _edit(('<mass value="5.53671"/>', '<mass value="heavy"/>')),
        ["link 'link1' mass = heavy", "finite"],
    ),
    "not a robot": ("<sdf version='1.7'/>", ["root element = <sdf>", "<robot>"]),
    "malformed XML": (SHIPPED[: len(SHIPPED) // 2], ["not well-formed XML"]),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_urdf_is_refused_in_one_line_naming_element_and_value(tmp_path, case):
    text, needles = BAD[case]
    path = _write(tmp_path, text)
    with pytest.raises(ValueError) as error:
        check_arm_urdf(path, payload_link=PAYLOAD_BODY)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(f"URDF {path}")
    for needle in needles:
        assert needle in message, message


def test_the_shipped_urdf_passes():
    check_arm_urdf(DEFAULT_URDF, payload_link=PAYLOAD_BODY)


def test_a_directory_is_named_as_such(tmp_path):
    with pytest.raises(ValueError, match=r"is a directory; a file is required"):
        check_arm_urdf(tmp_path)


def test_a_missing_file_does_not_exist(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nope\.urdf does not exist"):
        check_arm_urdf(tmp_path / "nope.urdf")


def test_checked_where_the_plant_loads_it(tmp_path):
    path = _write(tmp_path, BAD["prismatic"][0].replace('"prismatic"', '"spherical"'))
    with pytest.raises(ValueError, match="joint 'joint2' type = spherical"):
        build_arm_diagram(PlantConfig(urdf=str(path)))


def _theta(path) -> np.ndarray:
    _, arm, context = build_arm_diagram(PlantConfig(urdf=str(path)))
    return identify(arm, context).theta


@pytest.mark.parametrize(
    "replacements",
    [
        # The arm in another vertical plane, and facing -x (axes +y there).
        [(JOINT1_ORIGIN, JOINT1_ORIGIN.replace('rpy="0 0 0"', 'rpy="0 0 0.7"'))],
        [(JOINT1_ORIGIN, JOINT1_ORIGIN.replace('rpy="0 0 0"', 'rpy="0 0 3.14159"'))],
        # Link 2 as a thin rod (a singular, valid inertia) and its centre of mass
        # offset along the axis.
        [
            ('ixx="0.0001" ixy="0"', 'ixx="0" ixy="0"'),
            (LINK2_COM, LINK2_COM.replace("0.15 0 0", "0.15 0.05 0")),
        ],
    ],
    ids=["yawed plane", "facing -x", "thin rod with axial offset"],
)
def test_valid_arms_pass_and_identify_like_the_shipped_one(tmp_path, replacements):
    theta = _theta(_write(tmp_path, _edit(*replacements)))
    np.testing.assert_allclose(theta, _theta(DEFAULT_URDF), rtol=2e-5)


@pytest.mark.parametrize(
    ("case", "needle"),
    [("three links", "revolute/continuous joints = 3"), ("prismatic", "type = prismatic")],
)
def test_identify_refuses_a_bad_urdf_in_one_line(tmp_path, capsys, case, needle):
    path = _write(tmp_path, BAD[case][0])
    assert main(["identify", "--urdf", str(path)]) == EXIT_BAD_INPUT
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert needle in lines[0] and str(path) in lines[0]
    assert captured.out == ""


def test_identify_names_a_directory(tmp_path, capsys):
    assert main(["identify", "--urdf", str(tmp_path)]) == EXIT_BAD_INPUT
    assert "is a directory" in capsys.readouterr().err


@pytest.mark.parametrize("payload", [1e6, 1e308])
def test_absurd_payload_is_refused_naming_payload_mass(arm_diagram, capsys, payload):
    _, arm, _ = arm_diagram
    expected = f"payload_mass = {payload!r} kg; 0 <= payload_mass <= 100 kg is allowed"
    with pytest.raises(ValueError, match=re.escape(expected)):
        arm.default_parameters.with_payload(payload)
    assert main(["identify", "--payload", repr(payload)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "payload_mass" in err and "theta" not in err


def test_the_heaviest_payload_is_accepted(arm_diagram):
    _, arm, _ = arm_diagram
    heavy = dataclasses.replace(arm.default_parameters, payload_mass=MAX_PAYLOAD_MASS)
    assert heavy.payload_mass == MAX_PAYLOAD_MASS


# --- any serial arm: the shipped three-link arm, edited -------------------------------

THREE_LINK = (DEFAULT_URDF.parent / "three_link_arm.urdf").read_text()
LINK2_INERTIA = 'ixx="0.0002" ixy="0" ixz="0" iyy="0.01125" iyz="0" izz="0.01125"'
LINK3_INERTIAL = """<origin xyz="0.1 0 0" rpy="0 0 0"/>
      <mass value="0.5"/>
      <inertia ixx="0.00005" ixy="0" ixz="0" iyy="0.0016667" iyz="0" izz="0.0016667"/>"""
#: Link 3 as a point mass on joint 3's axis.
LINK3_ON_AXIS = """<origin xyz="0 0 0"/>
      <mass value="0.5"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>"""
JOINT2_SERIAL_AXIS = '<origin xyz="0.40 0 0" rpy="0 0 0"/>\n    <axis xyz="0 -1 0"/>'
OTHER_NS = "https://posfb.org/urdf"


def _three_link(*replacements: tuple[str, str]) -> str:
    return _edit(*replacements, text=THREE_LINK)


SERIAL_BAD = {
    "triangle inequality": (
        _three_link((LINK2_INERTIA, LINK2_INERTIA.replace('izz="0.01125"', 'izz="0.03"'))),
        ["link 'link2' inertia", "principal moments (0.0002, 0.01125, 0.03)",
         "each at most the sum of the other two"],
    ),
    "negative principal moment": (
        _three_link((LINK2_INERTIA, LINK2_INERTIA.replace('ixx="0.0002"', 'ixx="-0.0002"'))),
        ["link 'link2' inertia", "principal moments >= 0"],
    ),
    "indefinite products of inertia": (
        _three_link((LINK2_INERTIA, LINK2_INERTIA.replace('ixy="0"', 'ixy="0.05"'))),
        ["link 'link2' inertia", "a physically valid inertia is required"],
    ),
    "inertia not a number": (
        _three_link((LINK2_INERTIA, LINK2_INERTIA.replace('ixx="0.0002"', 'ixx="big"'))),
        ["link 'link2' inertia ixx iyy izz ixy ixz iyz = big", "finite numbers are required"],
    ),
    "inertial origin not three numbers": (
        _three_link(('<origin xyz="0.2 0 0" rpy="0 0 0"/>\n      <mass value="3.0"/>',
                     '<origin xyz="0.2 0" rpy="0 0 0"/>\n      <mass value="3.0"/>')),
        ["link 'link1' inertial origin xyz = 0.2 0", "three finite numbers"],
    ),
    "negative base mass": (
        _three_link(('<link name="base"/>',
                     '<link name="base"><inertial><mass value="-2"/></inertial></link>')),
        ["link 'base' mass = -2", "a finite value >= 0 (kg)"],
    ),
    "zero axis": (
        _three_link((JOINT2_SERIAL_AXIS, JOINT2_SERIAL_AXIS.replace("0 -1 0", "0 0 0"))),
        ["joint 'joint2' axis xyz = (0, 0, 0)", "a nonzero direction is required"],
    ),
    "last joint moves only a point on its axis": (
        _three_link(
            (LINK3_INERTIAL, LINK3_ON_AXIS),
            ('<drake:rotor_inertia value="0.00002"/>', ""),
        ),
        ["joint 'joint3' moment of inertia about its axis at q = 0", "= 0 kg m^2; > 0"],
    ),
    "posfb elements in another namespace": (
        _three_link((f'xmlns:posfb="{POSFB_NS}"', f'xmlns:posfb="{OTHER_NS}"')),
        ["joint 'joint1' posfb:coulomb_friction = (missing)", f"in namespace {OTHER_NS}",
         f'xmlns:posfb="{POSFB_NS}"'],
    ),
    "posfb element in no namespace": (
        _three_link(('<posfb:motor_constant value="6.0"/>', '<motor_constant value="6.0"/>')),
        ["actuator 'motor1' posfb:motor_constant = (missing)", "in no namespace", POSFB_NS],
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", list(SERIAL_BAD))
def test_a_bad_serial_urdf_is_refused_as_the_two_link_one_is(tmp_path, case):
    text, needles = SERIAL_BAD[case]
    path = _write(tmp_path, text)
    with pytest.raises(ValueError) as error:
        check_serial_urdf(path)
    message = str(error.value)
    assert "\n" not in message and message.startswith(f"URDF {path}: "), message
    for needle in needles:
        assert needle in message, message


def test_the_two_link_check_names_another_namespace_too(tmp_path):
    path = _write(tmp_path, _edit((f'xmlns:posfb="{POSFB_NS}"', f'xmlns:posfb="{OTHER_NS}"')))
    needle = f"coulomb_friction = (missing): its <coulomb_friction> is in namespace {OTHER_NS}"
    with pytest.raises(ValueError, match=re.escape(needle)):
        check_arm_urdf(path)


def test_a_valid_edge_of_the_serial_checks_passes(tmp_path):
    # A point-mass last link on its axis still moves its rotor (Drake's reflected inertia
    # keeps the mass matrix regular), and a massless welded body is allowed.
    text = _three_link((LINK3_INERTIAL, LINK3_ON_AXIS))
    assert check_serial_urdf(_write(tmp_path, text)).joints == ("joint1", "joint2", "joint3")


def test_drakes_parser_warnings_are_shown_once_as_one_line(tmp_path, caplog):
    # A triangle inequality broken by round-off only: inside posfb's tolerance, but Drake
    # warns, on several lines, each time it parses the file.
    path = _write(tmp_path, _three_link(
        (LINK2_INERTIA, LINK2_INERTIA.replace('izz="0.01125"', 'izz="0.01145000000001"'))
    ))  # fmt: skip
    with caplog.at_level(logging.WARNING, logger="drake"):
        for _ in range(2):
            build_arm_diagram(PlantConfig(urdf=str(path)))
        SerialArmModel(path)
    shown = [record.getMessage() for record in caplog.records if record.name == "drake"]
    assert len(shown) == 1, shown
    assert "\n" not in shown[0] and str(path) in shown[0], shown[0]
    assert "do not satisfy the triangle inequality" in shown[0], shown[0]


def test_a_file_is_checked_once_per_content_and_again_when_edited(tmp_path):
    """The checks keep their result for a file's bytes: a second check of the same file
    is a cache hit, while an edit (same path, other bytes) is checked afresh."""
    from posfb.models import urdf_check

    urdf = tmp_path / "arm.urdf"
    urdf.write_text(SHIPPED)
    before = urdf_check._check_serial.cache_info()
    check_serial_urdf(urdf)
    check_serial_urdf(str(urdf))
    after = urdf_check._check_serial.cache_info()
    assert (after.misses - before.misses, after.hits - before.hits) == (1, 1)
    urdf.write_text(SHIPPED.replace('type="continuous"', 'type="spherical"', 1))
    with pytest.raises(ValueError, match="spherical"):
        check_serial_urdf(urdf)
