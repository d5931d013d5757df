"""A published arm description enters posfb as it is (issue 41): ``scenario init`` ->
``design`` -> ``simulate`` with no edit of the file, the drive data in the scenario."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.multibody.tree import JointActuatorIndex

import posfb
from helpers.published import VOLTS, featured_description
from posfb.analysis.design.scenario_init import InitOptions, write_scenario
from posfb.models.description import Description, Drives, prepare_urdf
from posfb.models.plant import DEFAULT_URDF, PlantConfig, build_arm_diagram
from posfb.models.serial_model import SerialArmModel


@pytest.fixture(scope="module")
def featured(tmp_path_factory):
    """The featured description, its bytes, and the scenario init writes for it."""
    folder = tmp_path_factory.mktemp("published")
    urdf = featured_description(folder)
    before = urdf.read_bytes()
    out = folder / "arm.yaml"
    result = write_scenario(
        InitOptions(urdf=urdf, out=out, voltage_limit=VOLTS, welds=("gripper_turn",))
    )
    return urdf, before, out, result


def test_init_design_and_simulate_take_the_file_unedited(featured):
    urdf, before, out, result = featured
    assert result.joints == 3  # the fingers and the gripper joint welded
    design = posfb.design(out, "lin_lc")
    assert design is not None
    run = posfb.simulate(posfb.load_scenario(out, set={"timing.duration": 1.0}), "lin_lc")
    assert len(run.result.times) > 1
    assert urdf.read_bytes() == before  # posfb never edits the user's file


def test_the_scenario_states_the_welds_and_the_derived_drives(featured):
    _, _, out, _ = featured
    scenario = posfb.load_scenario(out).scenario
    welds = {"gripper_turn": 0.0, "finger1_joint": 0.01, "finger2_joint": 0.01}
    assert scenario.plant.weld == welds
    drives = scenario.plant.drives
    # The rules of models/drive_rules.py on the file's own numbers (featured_description):
    # kappa = effort / voltage limit, Coulomb = <dynamics friction>, gear = mechanicalReduction.
    assert drives.motor_constant == pytest.approx([150 / VOLTS, 80 / VOLTS, 40 / VOLTS])
    assert drives.coulomb == pytest.approx([3.0, 1.6, 0.8])  # 0.02 x effort
    assert drives.gear_ratio == pytest.approx([50.0] * 3)
    assert drives.damping is None  # the file's <dynamics damping>, read by Drake itself
    text = out.read_text()
    assert "<limit effort> / the voltage limit" in text and "<dynamics friction>" in text


def test_the_prepared_text_resolves_welds_orders_and_drops(featured):
    urdf, _, _, _ = featured
    prepared = prepare_urdf(urdf, Description(welds=(("gripper_turn", None),)))
    welds = {w.joint: (w.position, w.reason) for w in prepared.welds}
    # 0 clipped into the fingers' limits [0.01, 0.04]; the mimic joint follows its leader.
    assert welds == {
        "gripper_turn": (0.0, "asked"),
        "finger1_joint": (0.01, "prismatic"),
        "finger2_joint": (0.01, "prismatic"),
    }
    # Per arm link: the missing visual, the .stl and the .dae collision meshes.
    assert len(prepared.dropped) == 9
    assert prepared.text.count("file://") == 3  # the visual .obj of each link kept
    note = prepared.note()
    assert "\n" not in note and "3 visual meshes: not found" in note


def test_transmissions_out_of_order_drive_their_own_joints(featured):
    urdf, _, _, _ = featured
    description = Description(
        welds=(("gripper_turn", None),), drives=Drives(motor_constant=(1.0,), coulomb=(0.0,))
    )
    _, arm, _ = build_arm_diagram(PlantConfig(urdf=str(urdf), description=description))
    for j, joint in enumerate(arm.layout.joints):
        assert arm.plant.get_joint_actuator(JointActuatorIndex(j)).joint().name() == joint


def test_a_package_path_and_ros_package_path_resolve_meshes(tmp_path, monkeypatch):
    urdf = featured_description(tmp_path / "src")
    moved = tmp_path / "elsewhere" / "arm.urdf"  # outside the package: no ancestor serves
    moved.parent.mkdir()
    moved.write_bytes(urdf.read_bytes())
    welds = (("gripper_turn", None),)
    assert "file://" not in prepare_urdf(moved, Description(welds=welds)).text
    found = prepare_urdf(moved, Description(package_paths=(str(tmp_path / "src"),), welds=welds))
    assert found.text.count("file://") == 3
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "src"))
    assert prepare_urdf(moved, Description(welds=welds)).text.count("file://") == 3


def test_drives_override_the_urdfs_posfb_values_in_plant_and_nominal_model():
    drives = Drives(motor_constant=(2.0, 3.0), coulomb=(0.5,), damping=(0.25,))
    description = Description(drives=drives)
    _, arm, _ = build_arm_diagram(PlantConfig(description=description))
    parameters = arm.default_parameters
    assert parameters.motor_constant == (2.0, 3.0)
    assert parameters.coulomb == (0.5, 0.5)
    assert parameters.damping == (0.25, 0.25)
    model = SerialArmModel(DEFAULT_URDF, description)
    # Eq. 2 in volts: the Coulomb level F* = f_c / kappa, the damping B* = b / kappa.
    assert model.coulomb_levels() == pytest.approx([0.5 / 2.0, 0.5 / 3.0])
    assert np.diag(model.B()) == pytest.approx([0.25 / 2.0, 0.25 / 3.0])


def test_every_missing_drive_element_is_named_at_once(featured):
    urdf, _, _, _ = featured
    from posfb.models.urdf_check import check_serial_urdf

    with pytest.raises(ValueError) as error:
        check_serial_urdf(urdf, Description(welds=(("gripper_turn", None),)))
    message = str(error.value)
    assert "\n" not in message
    assert "posfb:coulomb_friction of joints joint1, joint2, joint3" in message
    assert "actuator posfb:motor_constant of joints joint3, joint1, joint2" in message or (
        "actuator posfb:motor_constant of joints joint1, joint2, joint3" in message
    )


def test_identification_reads_the_description_and_writes_a_self_contained_model(
    featured, tmp_path
):
    """``identify`` on a log of the featured arm (its drives only in the scenario): the
    written ``MODEL.urdf`` is posfb's complete file (welds fixed, meshes absolute, the
    drives written in), loads with no description, and an ``!Identified`` scenario's
    controllers take its identified drives, not the scenario's ``plant.drives``."""
    from posfb.diagrams.resolve import resolve
    from posfb.models.urdf_check import check_serial_urdf

    _, _, out, _ = featured
    log = tmp_path / "log.csv"
    posfb.simulate(posfb.load_scenario(out, set={"timing.duration": 10.0}), "lin_lc").save(log)
    result = posfb.identify(log, out)
    result.save(tmp_path / "model.yaml")
    written = tmp_path / "model.urdf"  # beside the model file (Identification.save)
    assert check_serial_urdf(written).joints == ("joint1", "joint2", "joint3")
    identified = SerialArmModel(written).motor_constant
    # The log's arm is the description with init's drives: kappa = effort / voltage limit.
    np.testing.assert_allclose(identified, [150 / VOLTS, 80 / VOLTS, 40 / VOLTS], rtol=0.02)
    model = f"!Identified {{file: {tmp_path / 'model.yaml'}}}"
    loaded = posfb.load_scenario(out, set={"nominal_model": model, "timing.duration": 1.0})
    nominal = resolve(loaded).config.design.nominal
    assert nominal.description == Description()  # the file holds the welds and drives
    np.testing.assert_array_equal(SerialArmModel(nominal.urdf).motor_constant, identified)
    assert posfb.simulate(loaded, "lin_lc").verdict.status == "ok"


def test_generated_code_takes_the_scenarios_drives(featured, tmp_path):
    """The C law of a scenario whose drives live only in ``plant.drives`` replays that
    scenario's log to round-off, and not a log whose drives (so whose nominal Coulomb
    compensation, Eq. 2's F*) are others."""
    from posfb.analysis.codegen.check import check
    from posfb.analysis.codegen.package import generate
    from posfb.diagrams.resolve import LoadedScenario, resolve
    from posfb.diagrams.scenario import with_controller

    _, _, out, _ = featured

    def lin_lc(settings):
        loaded = posfb.load_scenario(out, set={"timing.duration": 1.0, **settings})
        return LoadedScenario(with_controller(loaded.scenario, "lin_lc"), loaded.base_dir)

    package = generate(resolve(lin_lc({})), None, "double")
    own = posfb.simulate(lin_lc({})).frame()
    assert check(package, own).largest_difference_V <= 1e-12
    other = lin_lc({"plant.drives.coulomb": [6.0, 3.2, 1.6]})
    assert not check(package, posfb.simulate(other).frame()).passed
