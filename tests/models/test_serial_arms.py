"""The n-joint path (issue 13) on the shipped three-link and six-joint arms: the true
plant keeps the URDF's dynamics through posfb's per-Context parameters, the paper's
convergence claim holds on three joints, every controller tracks the shipped
three-link scenario, and mismatched sizes are refused by name."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from posfb.analysis.common.export import run_table
from posfb.analysis.common.plots import positions_and_voltages, tracking_errors
from posfb.diagrams.resolve import load_scenario, run_scenario
from posfb.models.controllers import PAPER_CONTROLLERS
from posfb.models.controllers.feedforward import nominal_torques
from posfb.models.design import ControllerConfig, compute_design
from posfb.models.design.loop_context import LoopContext
from posfb.models.nominal import UrdfNominal
from posfb.models.plant import (
    DEFAULT_URDF,
    PlantConfig,
    apply_parameters,
    build_arm_diagram,
    read_parameters,
)
from posfb.models.theta_of_plant import identify_urdf
from posfb.models.urdf_check import check_serial_urdf

URDF_DIR = DEFAULT_URDF.parent
ARMS = ("three_link_arm.urdf", "six_joint_arm.urdf")
THREE_LINK_SCENARIO = "analysis/scenarios/three_link_nominal.yaml"


def _urdf_mass_matrix(urdf: Path, q: np.ndarray) -> np.ndarray:
    """The mass matrix of the URDF as Drake loads it, without posfb."""
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(urdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(check_serial_urdf(urdf).base))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    return plant.CalcMassMatrix(context)


@pytest.mark.parametrize("name", ARMS)
def test_default_parameters_keep_the_urdf_dynamics(name):
    diagram, arm, context = build_arm_diagram(PlantConfig(urdf=str(URDF_DIR / name)))
    plant_context = arm.plant.GetMyMutableContextFromRoot(context)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-np.pi, np.pi, arm.size)
        arm.plant.SetPositions(plant_context, q)
        ours = arm.plant.CalcMassMatrix(plant_context)
        expected = _urdf_mass_matrix(URDF_DIR / name, q)
        np.testing.assert_allclose(ours, expected, rtol=1e-12, atol=1e-14 * np.abs(expected).max())


@pytest.mark.parametrize("name", ARMS)
def test_parameters_round_trip_through_a_context(name):
    diagram, arm, context = build_arm_diagram(PlantConfig(urdf=str(URDF_DIR / name)))
    defaults = arm.default_parameters
    scaled = replace(
        defaults,
        link_mass=tuple(1.1 * m for m in defaults.link_mass),
        link_com=tuple(0.9 * c for c in defaults.link_com),
        link_inertia=tuple(1.2 * i for i in defaults.link_inertia),
        damping=tuple(0.8 * b for b in defaults.damping),
        coulomb=tuple(1.3 * c for c in defaults.coulomb),
        motor_constant=tuple(0.95 * k for k in defaults.motor_constant),
    )
    apply_parameters(arm, context, scaled)
    back = read_parameters(arm, context)
    for field in ("link_mass", "link_com", "link_inertia", "damping", "coulomb", "motor_constant"):
        np.testing.assert_allclose(getattr(back, field), getattr(scaled, field), rtol=1e-12)


def _zero_coulomb_urdf(tmp_path: Path) -> Path:
    text = (URDF_DIR / "three_link_arm.urdf").read_text()
    path = tmp_path / "three_link_no_friction.urdf"
    path.write_text(re.sub(r'coulomb_friction value="[0-9.]+"', 'coulomb_friction value="0"', text))
    return path


@pytest.mark.slow
def test_three_link_proposed_converges_below_lin_lc(tmp_path):
    """Sec. 3 on three joints: exact nominal model (the same frictionless URDF), ideal
    encoders, no saturation, T_s = 2 ms, a T_s = 1: over the last 5 s of 10 s the
    proposed controller's largest error is small and below Lin+LC's."""
    urdf = _zero_coulomb_urdf(tmp_path)
    settings = [
        f"plant.urdf={urdf}",
        f"nominal_model=!UrdfModel {{urdf: {urdf}}}",
        "timing.sample_time=0.002",
        "timing.duration=10",
        "sensor.encoder_counts=0",
        "actuator.voltage_limit=1000",
        "controller.filter_a=500",
    ]
    worst = {}
    for kind in ("lin_lc", "proposed"):
        loaded = load_scenario(THREE_LINK_SCENARIO, [*settings, f"controller.kind={kind}"])
        run = run_scenario(loaded)
        assert run.status == "ok", run.message
        worst[kind] = float(np.abs(run.q_error[run.times >= 5.0]).max())
    assert worst["proposed"] < 1e-4, worst
    assert worst["proposed"] < 0.5 * worst["lin_lc"], worst


@pytest.mark.slow
@pytest.mark.parametrize("kind", PAPER_CONTROLLERS)
def test_every_controller_tracks_the_three_link_scenario(kind):
    """Quantised encoders and saturated voltages, the shipped scenario: each run
    finishes with every joint's error bounded well inside the divergence bound."""
    run = run_scenario(load_scenario(THREE_LINK_SCENARIO, [f"controller.kind={kind}"]))
    assert run.status == "ok", run.message
    assert run.q_true.shape[1] == 3
    assert float(np.abs(run.q_error).max()) < 0.5


@pytest.mark.parametrize(
    ("settings", "needle"),
    [
        (["plant.urdf=package://posfb/three_link_arm.urdf"], "nominal_model has 2 joints"),
        (
            ["controller.lambdas=[10, 10]"],
            "lambdas = [10.0, 10.0]; one number for all joints or 3",
        ),
        (["plant.payload_mass=0.1", "plant.parameters.damping=[1, 2]"], "damping"),
    ],
)
def test_mismatched_sizes_are_refused_by_name(settings, needle):
    scenario = None if settings[0].startswith("plant.urdf") else THREE_LINK_SCENARIO
    with pytest.raises(ValueError, match=needle.replace("[", r"\[").replace("]", r"\]")):
        load_scenario(scenario, settings)


def test_a_three_link_run_exports_and_plots_every_joint():
    """A short three-link run: the export has one column per joint for every signal and
    per-joint internal, and the run figures have one column of panels per joint."""
    loaded = load_scenario(THREE_LINK_SCENARIO, ["timing.duration=0.2", "controller.kind=lin_lc"])
    run = run_scenario(loaded)
    table = run_table(run)
    for j in range(1, 4):
        for column in (f"q{j}_rad", f"q{j}_desired_rad", f"u{j}_applied_V", f"tau_lin_{j}_V"):
            assert column in table, column
    np.testing.assert_array_equal(table["q3_measured_rad"], run.q_measured[:, 2])
    for figure in (
        positions_and_voltages({"lin_lc": run}, "three"),
        tracking_errors({"lin_lc": run}, "three"),
    ):
        assert len(figure.axes) == 2 * 3


def test_the_urdf_nominal_model_of_the_paper_arm_equals_its_identified_theta():
    """Two independent paths to the same nominal model of the shipped two-link arm:
    Table 1's closed forms of the identified theta, and Drake's MultibodyPlant of the
    URDF. Their torques (Eq. 4, 7, 18), designs and sampled-data radii agree."""
    identified = identify_urdf(str(DEFAULT_URDF))
    urdf = UrdfNominal(str(DEFAULT_URDF))
    closed_form, drake = nominal_torques(identified), nominal_torques(urdf)
    rng = np.random.default_rng(5)
    for _ in range(20):
        q, v, a = (rng.uniform(-3.0, 3.0, 2) for _ in range(3))
        np.testing.assert_allclose(
            drake.linearization(q, v, a), closed_form.linearization(q, v, a), rtol=1e-9, atol=1e-12
        )
        np.testing.assert_allclose(drake.desired(v, a), closed_form.desired(v, a), rtol=1e-9)
        assert drake.M1_norm(q) == pytest.approx(closed_form.M1_norm(q), rel=1e-9, abs=1e-14)
    ours, theirs = (
        compute_design(ControllerConfig(LoopContext(urdf))),
        compute_design(ControllerConfig(LoopContext(identified))),
    )
    assert ours.sampled_data_spectral_radius == pytest.approx(
        theirs.sampled_data_spectral_radius, rel=1e-9
    )
    np.testing.assert_allclose(ours.K, theirs.K, rtol=1e-7, atol=1e-9)
