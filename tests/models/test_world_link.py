"""A URDF whose root is a ``world`` link welded to the arm's base by a fixed joint (as
published descriptions are written) loads as it is: Drake takes the link for its world
body, posfb does not weld it to itself, and the arm is the same as the file without it
(issue 41)."""

from __future__ import annotations

import numpy as np

import posfb
from helpers.planar_arm import planar_arm_urdf
from posfb.models.serial_model import SerialArmModel

WORLD = ('  <link name="world"/>\n  <joint name="world_joint" type="fixed">\n'
         '    <parent link="world"/>\n    <child link="base"/>\n'
         '    <origin xyz="0 0 0" rpy="0 0 0"/>\n  </joint>\n')  # fmt: skip


def test_a_world_link_is_the_world(tmp_path):
    plain = planar_arm_urdf(2, tmp_path, name="plain")
    text = plain.read_text()
    with_world = tmp_path / "with_world.urdf"
    with_world.write_text(text.replace('  <link name="base"/>', WORLD + '  <link name="base"/>'))
    before = with_world.read_bytes()
    q = np.array([0.3, -1.1])
    assert np.allclose(SerialArmModel(with_world).M(q), SerialArmModel(plain).M(q), rtol=1e-12)
    scenario = tmp_path / "arm.yaml"
    scenario.write_text(f"plant: {{urdf: {with_world}}}\nnominal_model: !UrdfModel "
                        f"{{urdf: {with_world}}}\ntiming: {{duration: 0.5}}\n"
                        "sensor: {encoder_counts: [20000, 20000]}\n"
                        "controller: !LinLc {}\n")  # fmt: skip
    run = posfb.simulate(posfb.load_scenario(scenario))
    assert run.status == "ok", run.message
    assert with_world.read_bytes() == before  # posfb never edits the user's file
