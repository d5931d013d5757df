"""Plausibility of an identified arm (issue 42, item 7): a joint frame a file rounds is read
exact (``models.description._snap_joint_frames``), and first moments and inertias beyond
what the description's links allow are flagged by name
(``models.identification.plausible``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from helpers.planar_arm import planar_arm_text
from helpers.published import SO101, published_urdf
from posfb.models.description import SNAP_TOLERANCE, Description, Drives, prepare_urdf
from posfb.models.identification.consistent import pseudo_inertia
from posfb.models.identification.plausible import (
    PLAUSIBLE_FACTOR,
    implausible,
    link_extents,
    standard_bounds,
)
from posfb.models.identification.serial import SerialModel
from posfb.models.identification.serial_regressor import SerialRegressor, base_parameters
from posfb.models.package_data import package_path
from posfb.models.plant import PlantConfig, build_arm_diagram
from posfb.models.urdf_tree import parse_robot


def _joint_values(text: str, joint: str) -> tuple[list[float], list[float]]:
    element = parse_robot(Path("arm.urdf"), text.encode()).find(f"joint[@name='{joint}']")
    rpy = [float(v) for v in element.find("origin").get("rpy").split()]
    return rpy, [float(v) for v in element.find("axis").get("xyz").split()]


def test_a_rounded_pi_and_a_near_axis_are_read_exact_and_a_real_tilt_is_kept(tmp_path):
    text = planar_arm_text(3)
    text = text.replace(  # joint2: a yaw of pi to 5 digits (2.7e-6 rad off), an axis 1e-6 off
        '<origin xyz="0.34 0 0" rpy="0 0 0"/>\n    <axis xyz="0 -1 0"/>',
        '<origin xyz="0.34 0 0" rpy="0 0 3.14159"/>\n    <axis xyz="0 -1 1e-6"/>',
    ).replace(  # joint3: 1.5709 is 1.04e-4 rad from pi/2 and an axis 1e-4 off: both real
        '<origin xyz="0.315 0 0" rpy="0 0 0"/>\n    <axis xyz="0 -1 0"/>',
        '<origin xyz="0.315 0 0" rpy="-1.5709 0 0"/>\n    <axis xyz="0 -1 1e-4"/>',
    )
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(text)
    prepared = prepare_urdf(urdf)
    assert _joint_values(prepared.text, "joint2") == ([0.0, 0.0, math.pi], [0.0, -1.0, 0.0])
    assert _joint_values(prepared.text, "joint3") == ([-1.5709, 0.0, 0.0], [0.0, -1.0, 1e-4])
    assert prepared.snapped == 2
    assert f"read 2 joint angles or axes within {SNAP_TOLERANCE:g} rad" in prepared.note()


@pytest.mark.parametrize("name", ["two_link_arm", "three_link_arm", "six_joint_arm"])
def test_the_shipped_arms_have_nothing_to_snap(name):
    assert prepare_urdf(package_path("posfb.urdf", f"{name}.urdf")).snapped == 0


def test_a_published_file_has_the_base_parameters_of_its_exact_geometry(tmp_path):
    """example-robot-data's SO-101 writes pi/2 as 1.5708 and pi as 3.14159. Read literally,
    its base joint tilts a few micro-radians from the vertical, and the base link's first
    moments (``shoulder_link.mcx``, ``.mcy``) become base parameters a log can barely
    excite (44 of them; the issue's -9.7 +- 2.3 kg m for a 0.1 kg link). The same file with
    pi written to 16 digits has 42, and so has the file as posfb reads it."""
    source = published_urdf(SO101)
    exact = source.read_text()
    for rounded, full in (("1.5708", repr(math.pi / 2)), ("3.14159", repr(math.pi))):
        exact = exact.replace(rounded, full)
    copy = source.parent / f"_exact_{tmp_path.name}.urdf"  # beside it: its package:// URIs
    copy.write_text(exact)
    drives = Drives(motor_constant=(1.0,), coulomb=(0.02,), damping=(0.01,))
    description = Description(welds=(("gripper", None),), drives=drives)
    try:
        names = []
        for urdf in (source, copy):
            config = PlantConfig(urdf=str(urdf), description=description)
            _, arm, context = build_arm_diagram(config)
            names.append(base_parameters(SerialRegressor.of_arm(arm, context)).names)
    finally:
        copy.unlink()
    assert names[0] == names[1]
    assert len(names[0]) == 42 and "shoulder_link.mcx" not in names[0]


@pytest.fixture(scope="module")
def six_joint() -> SerialModel:
    urdf = package_path("posfb.urdf", "six_joint_arm.urdf")
    _, arm, context = build_arm_diagram(PlantConfig(urdf=str(urdf)))
    return SerialModel.of_arm(arm, context, str(urdf))


def test_each_links_extent_holds_its_nominal_mass_and_the_next_joint(six_joint):
    extents = link_extents(six_joint.regressor, six_joint.nominal)
    for i, extent in enumerate(extents):
        J = pseudo_inertia(six_joint.nominal[10 * i : 10 * i + 10])
        # sum m r r^T within a ball of radius r: its trace is at most m r^2
        assert np.trace(J[:3, :3]) <= J[3, 3] * extent**2 * (1 + 1e-12)
        if i + 1 < len(extents):
            assert extent >= np.linalg.norm(six_joint.regressor.parent_position[i + 1])


def test_the_nominal_arm_and_its_3x_heavier_twin_pass_and_a_wild_first_moment_is_named(six_joint):
    base = six_joint.base
    bounds = standard_bounds(six_joint.regressor, six_joint.nominal)
    nominal = base.combine(six_joint.nominal)
    small = 1e-6 * (np.abs(nominal) + 1e-6)
    assert implausible(base, bounds, nominal, small, six_joint.nominal) == []
    heavier = six_joint.nominal.copy()
    for i in range(six_joint.regressor.size):  # every link PLAUSIBLE_FACTOR times heavier
        heavier[10 * i : 10 * i + 10] *= PLAUSIBLE_FACTOR
    assert implausible(base, bounds, base.combine(heavier), small, heavier) == []
    wrist = base.names.index("wrist_3_link.mcx")
    wild = nominal.copy()
    wild[wrist] = -9.7  # kg m: the figure, on a 0.1 kg link
    (warning,) = implausible(base, bounds, wild, small, six_joint.nominal)
    assert warning.startswith("wrist_3_link.mcx = -9.7 +- ")
    # within its standard errors of the bound: not flagged
    assert implausible(base, bounds, wild, np.full_like(small, 10.0), six_joint.nominal) == []


def test_a_written_link_beyond_its_bound_is_named(six_joint):
    base = six_joint.base
    bounds = standard_bounds(six_joint.regressor, six_joint.nominal)
    standard = six_joint.nominal.copy()
    index = base.standard_names.index("forearm_link.Ixx")
    standard[index] = 2.0 * bounds[index]
    (warning,) = implausible(base, bounds, base.combine(six_joint.nominal),
                             np.ones(base.size), standard)  # fmt: skip
    assert "the model written" in warning and "forearm_link.Ixx" in warning
