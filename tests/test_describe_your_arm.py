"""The "Describe your arm" page (docs/guide/describe_your_arm.md) and its template URDF
(urdf/template_arm.urdf) say what posfb reads, and the template runs (issue 27)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers.paths import REPO
from posfb.models import urdf_check, urdf_tree
from posfb.models.plant import DEFAULT_URDF
from posfb.models.serial_model import SerialArmModel

ROOT = REPO
PAGE = ROOT / "docs" / "guide" / "describe_your_arm.md"
TEMPLATE = DEFAULT_URDF.with_name("template_arm.urdf")
CLI = [sys.executable, "-m", "posfb.analysis.cli"]


def test_the_page_names_the_namespace_posfb_reads() -> None:
    """The URI on the page and in the template is the one the check looks elements up
    in (copied exactly, as the page says)."""
    assert f"`{urdf_tree.POSFB_NS}`" in PAGE.read_text()
    assert f'xmlns:posfb="{urdf_tree.POSFB_NS}"' in TEMPLATE.read_text()


def test_the_page_lists_every_posfb_element_the_check_reads() -> None:
    """Each ``posfb:`` element the URDF check looks up has a row on the page, and the
    page names no other."""
    source = Path(urdf_check.__file__).read_text()
    read = set(re.findall(r"_posfb_element\([^,]+, \"(\w+)\"", source))
    listed = set(re.findall(r"`<posfb:(\w+)", PAGE.read_text()))
    assert read
    assert listed == read


def test_the_template_is_a_spatial_arm_posfb_accepts() -> None:
    """The template passes the serial-arm check, has a yaw joint (axis along gravity) and
    two pitch joints, and its physical mass matrix (each row of ``M*`` times its motor
    constant) is symmetric positive definite."""
    chain = urdf_check.check_serial_urdf(TEMPLATE)
    assert chain.joints == ("base_yaw", "shoulder", "elbow")
    model = SerialArmModel(TEMPLATE)
    rng = np.random.default_rng(0)
    for _ in range(5):
        M = model.motor_constant[:, None] * model.M(rng.uniform(-np.pi, np.pi, 3))
        np.testing.assert_allclose(M, M.T, atol=1e-12)
        assert np.linalg.eigvalsh(M).min() > 0.0
    # gravity gives no torque about the vertical yaw axis, whatever the posture
    for q in rng.uniform(-np.pi, np.pi, (5, 3)):
        assert abs(model.G(q)[0]) < 1e-12
        assert abs(model.G(q)[1]) > 0.0


@pytest.mark.slow
def test_the_template_runs_from_scenario_init(tmp_path: Path) -> None:
    """The page's route: ``scenario init`` on a copy of the template, then a short
    ``simulate`` of Lin+LC, which ends ``ok`` (exit 0, no warning)."""
    arm = tmp_path / "my_arm.urdf"
    arm.write_text(TEMPLATE.read_text())
    scenario = tmp_path / "my_arm.yaml"
    init = subprocess.run(
        [*CLI, "scenario", "init", "--urdf", str(arm), "--out", str(scenario)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert init.returncode == 0, init.stderr
    run = subprocess.run(
        [*CLI, "simulate", "--scenario", str(scenario), "--controller", "lin_lc",
         "--duration", "2", "--json"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""
    assert '"status": "ok"' in run.stdout


def test_the_earlier_namespace_still_loads(tmp_path: Path) -> None:
    """A URDF written with the earlier placeholder URI reads the same motor stages as the
    template in the documented URN (its refusal of other namespaces aside)."""
    text = TEMPLATE.read_text()
    earlier = tmp_path / "earlier.urdf"
    earlier.write_text(text.replace(urdf_tree.POSFB_NS, urdf_tree.EARLIER_POSFB_NS))
    assert urdf_tree.EARLIER_POSFB_NS in earlier.read_text()
    assert f"`{urdf_tree.EARLIER_POSFB_NS}`" in PAGE.read_text()
    assert urdf_check.check_serial_urdf(earlier) == urdf_check.check_serial_urdf(TEMPLATE)
