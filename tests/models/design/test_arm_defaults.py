"""A controller entry's left-out per-joint settings come from the arm it runs on
(``models.design.settings``): on a three-joint arm exactly what ``posfb scenario init``
writes for it, on the paper's two-joint arm exactly the paper's Sec. 4.2 values; a
nominal model of another joint count is refused pointing to ``!UrdfModel`` and
``scenario init``."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import posfb
from helpers.slow import heavy
from posfb.diagrams.resolve import resolve
from posfb.diagrams.scenario import with_controller
from posfb.models.design import ControllerConfig
from posfb.models.design.loop_context import LoopContext
from posfb.models.design.settings import LinLc, Pid, Proposed
from posfb.models.lumped import TABLE1
from posfb.models.plant import DEFAULT_URDF

CLI = [sys.executable, "-m", "posfb.analysis.cli"]
THREE_LINK = "package://posfb/three_link_arm.urdf"


@pytest.fixture(scope="module")
@heavy
def initialised(tmp_path_factory) -> Path:
    """The shipped three-link arm's scenario as ``scenario init`` writes it."""
    folder = tmp_path_factory.mktemp("arm_defaults")
    urdf = DEFAULT_URDF.parent / "three_link_arm.urdf"
    result = subprocess.run(
        [*CLI, "scenario", "init", "--urdf", str(urdf), "--out", "three.yaml"],
        capture_output=True, text=True, cwd=folder, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return folder / "three.yaml"


@pytest.mark.parametrize(
    ("entry", "written", "keys"),
    [
        ("!LinLc {}", "lin_lc", ("Q1", "Q2", "R", "lambdas")),
        ("!Pid {}", "pid", ("Kp", "Kv", "KI")),
        ("!Proposed {}", None, ("Q1", "Q2", "R", "lambdas", "H")),
    ],
)
def test_an_empty_entry_on_three_joints_gets_what_scenario_init_writes(
    initialised, entry, written, keys
):
    init = posfb.load_scenario(initialised).scenario
    reference = init.controller if written is None else init.controllers[written]
    # An entry of the file's own kind would keep the file's values (--set merges into
    # it), so the entry replaces one of another kind.
    other = "!LinLc {lambdas: [1]}" if entry == "!Pid {}" else "!Pid {Kp: [1], Kv: [1], KI: [1]}"
    settings = [f"controller={other}", f"controller={entry}"]
    loaded = posfb.load_scenario(initialised, settings).scenario.controller
    for key in keys:
        assert getattr(loaded, key) == getattr(reference, key), key
    assert len(loaded.lambdas if hasattr(loaded, "lambdas") else loaded.Kp) == 3


def test_a_partial_entry_keeps_what_it_gives_and_takes_the_rest_from_the_arm(initialised):
    init = posfb.load_scenario(initialised).scenario.controllers["lin_lc"]
    loaded = posfb.load_scenario(initialised, ["controller=!LinLc {lambdas: [5]}"])
    entry = loaded.scenario.controller
    assert entry.lambdas == [5.0]
    assert entry.Q1 == init.Q1 and entry.R == init.R
    design = resolve(loaded).config.design
    assert design.lqr.lambdas == (5.0,) * 3
    assert tuple(tuple(row) for row in init.Q1) == design.lqr.Q1


def test_one_joint_of_a_left_out_list_is_set_on_the_arms_list(initialised):
    init = posfb.load_scenario(initialised).scenario.controllers["pid"]
    entry = posfb.load_scenario(initialised, ["controller=!Pid {}", "controller.Kp[2]=7"])
    assert entry.scenario.controller.Kp == [*init.Kp[:2], 7.0]


PAPER = {
    "Q1": [[32000.0, 0.0, 0.0, 0.0], [0.0, 12000.0, 0.0, 0.0], [0.0, 0.0, 10.0, 0.0],
           [0.0, 0.0, 0.0, 10.0]],
    "Q2": [[0.001, 0.0], [0.0, 0.001]],
    "R": [[0.0005, 0.0], [0.0, 0.0015]],
    "lambdas": [10.0, 10.0],
    "Kp": [800.0, 500.0],
    "Kv": [30.0, 15.0],
    "KI": [1.411, 0.3],
}  # fmt: skip


@pytest.mark.parametrize("entry", ["!LinLc {}", "!Pid {}", "!Proposed {}"])
def test_the_paper_arm_keeps_the_papers_values_exactly(entry):
    loaded = posfb.load_scenario(None, [f"controller={entry}"]).scenario.controller
    for key, value in PAPER.items():
        if hasattr(loaded, key):
            assert getattr(loaded, key) == value, key
    if hasattr(loaded, "H"):
        assert loaded.H.gamma == [10.0, 10.0]


def test_an_entry_on_its_own_is_the_papers_design_on_the_paper_arm():
    paper = ControllerConfig()
    paper_context = LoopContext(TABLE1, 0.01)
    assert replace(Proposed().config(paper_context), pid=paper.pid) == paper  # no PID in it
    assert LinLc().config(LoopContext(TABLE1, 0.01)).lqr == ControllerConfig().lqr
    assert Pid().config(LoopContext(TABLE1, 0.01)).pid == ControllerConfig().pid


def test_an_ideal_encoder_gives_pid_the_sampling_rule_alone(initialised):
    nominal = resolve(posfb.load_scenario(initialised)).config.design.nominal
    sample_time = 0.01
    gains = Pid().with_arm_defaults(LoopContext(nominal, sample_time))
    omega = 2 * np.pi / (20 * sample_time)  # 20 samples per period of the bandwidth
    # (s + omega)^2 (s + omega / 10): Kp = 1.2 omega^2, Kv = 2.1 omega, KI = 0.1 omega^3
    np.testing.assert_allclose(gains.Kp, [1.2 * omega**2] * 3, rtol=1e-5)
    np.testing.assert_allclose(gains.Kv, [2.1 * omega] * 3, rtol=1e-5)
    np.testing.assert_allclose(gains.KI, [0.1 * omega**3] * 3, rtol=1e-5)


def test_a_nominal_model_of_other_joints_points_to_urdf_model_and_init():
    with pytest.raises(ValueError) as refused:
        posfb.load_scenario(None, [f"plant.urdf={THREE_LINK}"])
    message = str(refused.value)
    assert "nominal_model has 2 joints (!Table1)" in message
    assert f"nominal_model: !UrdfModel {{urdf: {THREE_LINK}}}" in message
    assert f"posfb scenario init --urdf {THREE_LINK}" in message
    assert "\n" not in message


def test_a_new_entry_for_another_kind_takes_the_loaded_arms_values(initialised):
    # with_controller's fresh entry (what tune and compare switch to) shares nothing with
    # a PD + gravity entry: every list comes from the arm the scenario was loaded for
    init = posfb.load_scenario(initialised).scenario.controller
    loaded = posfb.load_scenario(initialised, ["controller=!PdGravity {}"]).scenario
    entry = with_controller(loaded, "proposed").controller
    for key in ("Q1", "Q2", "R", "lambdas", "H"):
        assert getattr(entry, key) == getattr(init, key), key
    paper = with_controller(posfb.load_scenario(None, ["controller=!Pid {}"]).scenario, "lin_lc")
    assert PAPER["Q1"] == paper.controller.Q1 and paper.controller.lambdas == PAPER["lambdas"]
