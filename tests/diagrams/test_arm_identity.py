"""The identity of a scenario's arm (``diagrams.arm``) and its use: a study, a tuned
design or a marked point of another arm is refused, also when the joint count and the
joint names match (issue 27, items 3 and 9), and before the study's own checks."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import posfb
from helpers.planar_arm import planar_arm_urdf
from posfb.analysis.uncertainty import study as study_file
from posfb.diagrams.arm import arm_identity
from posfb.diagrams.scenario import PlantSettings, Scenario
from posfb.models.plant import DEFAULT_URDF

SHIPPED = Path(posfb.__file__).resolve().parent.parent
THREE_LINK_URDF = DEFAULT_URDF.parent / "three_link_arm.urdf"
THREE_LINK = SHIPPED / "analysis" / "scenarios" / "three_link_nominal.yaml"
THREE_LINK_STUDY = SHIPPED / "analysis" / "studies" / "three_link_uncertainty.yaml"


def _identity(urdf: Path):
    return arm_identity(Scenario(plant=PlantSettings(urdf=str(urdf))), urdf.parent)


def _copy(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text)
    return path


def test_an_arm_is_what_its_urdf_describes_not_how_the_file_is_written(tmp_path):
    text = THREE_LINK_URDF.read_text()
    shipped = _identity(THREE_LINK_URDF)
    # comments gone, indentation changed, a number spelled another way: the same arm
    reformatted = re.sub(r"<!--.*?-->", "", text, flags=re.S).replace("  ", "\t")
    reformatted = reformatted.replace('<mass value="3.0"/>', '<mass value="30e-1"/>')
    assert reformatted != text
    assert _identity(_copy(tmp_path, "same.urdf", reformatted)) == shipped
    # one link 10 % heavier, or the joints renamed: another arm, named by its file
    heavier = _identity(_copy(tmp_path, "heavier.urdf", text.replace(
        '<mass value="3.0"/>', '<mass value="3.3"/>')))  # fmt: skip
    assert heavier != shipped and "heavier.urdf" in str(heavier)
    renamed = _identity(_copy(tmp_path, "renamed.urdf", text.replace('"joint3"', '"elbow"')))
    assert renamed != shipped and renamed.joints[-1] == "elbow"
    # another arm of the same joint count and joint names (a generated planar arm)
    planar = _identity(planar_arm_urdf(3, tmp_path))
    assert planar.joints == shipped.joints and planar != shipped


def test_a_study_of_another_arm_is_refused_before_the_study_is_checked(tmp_path, monkeypatch):
    planar = _identity(planar_arm_urdf(3, tmp_path))

    def checked(study):  # the study's own checks design every controller: the costly part
        raise AssertionError("the study was checked before its arm")

    monkeypatch.setattr(study_file, "validate_study", checked)
    with pytest.raises(ValueError) as refused:
        study_file.load_study(THREE_LINK_STUDY, arm=planar)
    message = str(refused.value)
    assert "\n" not in message and "a study of the scenario's arm is required" in message
    assert "three_link_arm.urdf" in message and "planar_arm_3.urdf" in message


def test_tune_refuses_a_study_of_another_arm_with_the_same_joints(tmp_path):
    urdf = planar_arm_urdf(3, tmp_path)
    scenario = posfb.load_scenario(THREE_LINK, set={"plant.urdf": str(urdf)})
    with pytest.raises(ValueError, match="a study of the scenario's arm is required"):
        posfb.tune(scenario, study=THREE_LINK_STUDY, out=tmp_path / "t.yaml")
    assert not (tmp_path / "t.yaml").exists()
    # a study given as a loaded Study is refused the same way (where the plants are drawn)
    study = study_file.load_study(THREE_LINK_STUDY)
    with pytest.raises(ValueError, match="planar_arm_3.urdf"):
        posfb.tune(scenario, study=study)
