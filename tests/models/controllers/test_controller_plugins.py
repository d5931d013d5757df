"""Controller plug-ins (``models.controllers.plugin``): a user's own controller file in a
scenario, the contract's refusals, and the two baselines written against it (PD +
gravity, ``models.controllers.pd_gravity``; linear ADRC, ``models.controllers.adrc``)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.tree import MultibodyForces

import posfb
from helpers.loop_checks import assert_position_only
from helpers.plugin_helpers import P_GRAVITY, write_plugin
from posfb.analysis.cli import main
from posfb.models.controllers import ControllerSetup, PluginError
from posfb.models.controllers.adrc import AdrcController
from posfb.models.controllers.plugin import NominalDynamics
from posfb.models.design.loop_context import LoopContext
from posfb.models.lumped import TABLE1, LumpedModel
from posfb.models.nominal import UrdfNominal, nominal_model
from posfb.models.plant import DEFAULT_URDF, PlantConfig, build_arm_diagram
from posfb.models.theta_of_plant import identify_urdf


def test_a_user_controller_file_runs_in_simulate_and_compare(tmp_path, capsys):
    path = write_plugin(tmp_path)
    run = posfb.simulate(path)
    assert run.status == "ok" and run.controller == "PGravity" and run.label == "PGravity"
    # The memory advanced once per sample after the first: the internals count samples.
    counts = np.arange(1, len(run.result.times) + 1, dtype=float)
    np.testing.assert_array_equal(run.result.internals[:, -1], counts)
    assert list(run.frame().columns[-3:]) == ["gravity_1_V", "gravity_2_V", "k_count"]
    assert_position_only(posfb.build(path).systems)
    comparison = posfb.compare(path, ["PGravity", "lin_lc"])
    assert comparison.runs["PGravity"].rms_q == run.rms_q
    assert main(["compare", "--scenario", path, "--controllers", "PGravity,pid", "--json"]) == 0
    assert "PGravity" in capsys.readouterr().out


def test_the_settings_reach_the_plugin_and_survive_a_dump(tmp_path):
    path = write_plugin(tmp_path, settings="{Kp: 150}")
    scenario = posfb.load_scenario(path)
    built = posfb.build(scenario)
    np.testing.assert_array_equal(built.systems.controller.plugin.Kp, [150.0, 150.0])
    dumped = tmp_path / "dumped.yaml"
    dumped.write_text(scenario.dump())
    again = posfb.build(posfb.load_scenario(dumped))
    np.testing.assert_array_equal(again.systems.controller.plugin.Kp, [150.0, 150.0])


def _tunable(boxes: str) -> str:
    """``P_GRAVITY`` with the class attribute ``tunable = boxes``."""
    size = "    memory_size = 1\n"
    return P_GRAVITY.replace(size, f"{size}    tunable = {boxes}\n")


@pytest.mark.parametrize(
    ("body", "class_name", "settings", "needle"),
    [
        (P_GRAVITY, "Nope", "{}", "has no class 'Nope'; it defines PGravity"),
        ("class NotOne:\n    pass\n", "NotOne", "{}", "NotOne is not a posfb.Controller"),
        (P_GRAVITY, "PGravity", "{Ki: 1}", "unexpected keyword argument 'Ki'"),
        (P_GRAVITY.replace("return self.Kp", "return [1.0] * 3 or self.Kp"), "PGravity", "{}",
         "step returned 3 voltage values; 2 are required"),
        (P_GRAVITY.replace("+ gravity, [", "* np.inf, ["), "PGravity", "{}",
         "step returned a non-finite voltage"),
        ("def broken(:\n", "X", "{}", "line 1"),
        (_tunable("{'Kd': (1, 2)}"), "PGravity", "{}",
         "PGravity.tunable names 'Kd', which is no keyword argument"),
        (_tunable("{'Kp': (2, 1)}"), "PGravity", "{}",
         "PGravity.tunable['Kp'] = (2, 1); a search box (low, high) with 0 < low < high"),
    ],
)  # fmt: skip
def test_a_plugin_that_breaks_the_contract_is_one_line_naming_its_file(
    tmp_path, capsys, body, class_name, settings, needle
):
    path = write_plugin(tmp_path, body, class_name=class_name, settings=settings)
    assert main(["simulate", "--scenario", path, "--no-progress"]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1, error
    assert needle in error and ("my_controller.py" in error or class_name in error)


def test_a_missing_plugin_file_names_the_key(tmp_path, capsys):
    scenario = tmp_path / "s.yaml"
    scenario.write_text("controller: !Python {file: gone.py, class: X}\n")
    assert main(["simulate", "--scenario", str(scenario)]) == 2
    assert "controller.file = 'gone.py'" in capsys.readouterr().err


def test_an_exception_in_the_users_step_shows_the_users_frames(tmp_path, capsys):
    body = P_GRAVITY.replace("memory[0] += 1.0", "memory[0] += helper()") + (
        "\n\ndef helper():\n    raise RuntimeError('my bug')\n"
    )
    path = write_plugin(tmp_path, body)
    assert main(["simulate", "--scenario", path, "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert "my_controller.py" in error and "raise RuntimeError('my bug')" in error
    assert "posfb/" not in error.replace(str(tmp_path), "") and "analysis" not in error
    with pytest.raises(RuntimeError, match="my bug"):
        posfb.simulate(path)


def test_switching_kinds_keeps_or_replaces_the_controller_entry(tmp_path):
    path = write_plugin(tmp_path)
    scenario = posfb.load_scenario(path)
    assert posfb.load_scenario(scenario, set={"controller.kind": "adrc"}).get(
        "controller.observer_ratio") == 5.0  # fmt: skip
    with pytest.raises(ValueError, match="controller.kind = 'nope'.*PGravity"):
        posfb.load_scenario(scenario, set={"controller.kind": "nope"})
    flat = posfb.load_scenario(set={"controller.kind": "pd_gravity"})
    assert flat.get("controller.filter_ratio") == 5.0
    with pytest.raises(ValueError, match="controller.kind: the controller section is now one"):
        posfb.load_scenario({"controller": {"kind": "adrc"}})


# --- the nominal model a plug-in sees -------------------------------------------------


def _plant_terms(urdf: Path) -> tuple[int, Callable[..., tuple[np.ndarray, ...]]]:
    """The joint count and Eq. 2's terms (V) at ``(q, v, a)`` of the plant ``models.plant``
    builds from ``urdf``, from Drake's own dynamics and the plant's parameters:
    ``(M a + C v + G, B v, F(v))``, each joint's row divided by its motor constant."""
    _, arm, root = build_arm_diagram(PlantConfig(urdf=str(urdf)))
    plant = arm.plant
    context = plant.GetMyContextFromRoot(root)
    parameters = arm.default_parameters
    kappa = np.asarray(parameters.motor_constant)

    def terms(q: np.ndarray, v: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, ...]:
        plant.SetPositions(context, q)
        plant.SetVelocities(context, v)
        rigid = plant.CalcInverseDynamics(context, a, MultibodyForces(plant))
        rigid = rigid - plant.CalcGravityGeneralizedForces(context)
        viscous = np.asarray(parameters.damping) * v
        coulomb = np.asarray(parameters.coulomb) * np.sign(v)
        return rigid / kappa, viscous / kappa, coulomb / kappa

    return plant.num_positions(), terms


@pytest.mark.parametrize(
    ("urdf", "form"),
    [("two_link_arm.urdf", "table1"), ("two_link_arm.urdf", "urdf"),
     ("three_link_arm.urdf", "urdf")],
)  # fmt: skip
def test_each_term_of_the_nominal_model_is_the_plants_own(urdf, form):
    path = DEFAULT_URDF.parent / urdf
    # Table 1's closed form with the plant's identified theta, or Drake's URDF model.
    if form == "table1":
        nominal = NominalDynamics(LumpedModel(identify_urdf(str(path))))
    else:
        nominal = NominalDynamics(nominal_model(UrdfNominal(str(path))))
    n, plant_terms = _plant_terms(path)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q, v, a = rng.uniform(-np.pi, np.pi, n), rng.uniform(-3, 3, n), rng.uniform(-9, 9, n)
        rigid, viscous, coulomb = plant_terms(q, v, a)
        scale = np.abs(rigid).max()
        np.testing.assert_allclose(nominal.rigid_body(q, v, a), rigid, atol=1e-9 * scale)
        np.testing.assert_allclose(nominal.viscous_friction(v), viscous, rtol=1e-12)
        np.testing.assert_allclose(nominal.coulomb_friction(v), coulomb, rtol=1e-12)
        # The documented sum: Coulomb friction included.
        np.testing.assert_allclose(
            nominal.inverse_dynamics(q, v, a), rigid + viscous + coulomb, atol=1e-9 * scale
        )
    # Coulomb friction is 0 for a joint at rest (sgn 0 = 0).
    np.testing.assert_array_equal(nominal.coulomb_friction(np.zeros(n)), 0.0)


# --- the baselines -----------------------------------------------------------------


def test_adrc_disturbance_estimate_converges_to_a_constant_torque():
    # An independent plant: joint j of the nominal lumped model at a fixed pose is a double
    # integrator m_j qddot = u + d (V), simulated exactly with the held voltage.
    T_s, d = 0.01, np.array([0.7, -0.4])
    nominal = LumpedModel(TABLE1)
    setup = ControllerSetup(LoopContext(TABLE1, T_s), (24.0, 24.0), NominalDynamics(nominal))
    adrc = AdrcController(setup)
    m = np.diag(nominal.M0())
    q, v = np.zeros(2), np.zeros(2)
    desired = np.zeros(6)
    memory = adrc.start(q, desired)
    for _ in range(300):
        voltage, internals = adrc.step(q.copy(), desired, memory)
        acceleration = (np.clip(voltage, -24, 24) + d) / m
        q, v = q + v * T_s + 0.5 * acceleration * T_s**2, v + acceleration * T_s
    # internals: disturbance_j_V (the estimate of f / b0 = d), then the velocity estimate
    np.testing.assert_allclose(internals[:2], d, rtol=1e-6)
    np.testing.assert_allclose(q, 0.0, atol=1e-8)


def test_pd_gravity_holds_a_pose_with_zero_error_when_its_gravity_is_exact():
    # The nominal model is the plant's own URDF model (exact gravity); no Coulomb friction
    # and an ideal encoder: Kelly's PD + gravity drives the set-point error to zero.
    scenario = posfb.load_scenario(
        set={
            "nominal_model": "!UrdfModel {}",
            "plant.parameters.coulomb": 0.0,
            "sensor.encoder_counts": 0,
            # A soft-started step from (-1.2, 0.4) to (-0.8, 0.9) rad, held from about 2 s.
            "trajectory": "!Wave {joints: [{offset: -1.2, amplitude: 0.4}, "
            "{offset: 0.4, amplitude: 0.5}]}",
            "timing.duration": 6.0,
            "controller.kind": "pd_gravity",
        },
    )
    run = posfb.simulate(scenario)
    assert run.status == "ok"
    np.testing.assert_allclose(run.result.q_desired[-1], [-0.8, 0.9], atol=1e-12)
    np.testing.assert_allclose(run.result.q_error[-1], 0.0, atol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["pd_gravity", "adrc"])
@pytest.mark.parametrize("case", ["paper_nominal", "paper_payload"])
def test_the_baselines_stay_bounded_on_the_papers_cases(kind, case):
    run = posfb.simulate(posfb.shipped_scenarios()[case], kind)
    # Bounded: well inside the divergence bound (1 rad) over the paper's 20 s, within
    # the +-24 V range most of the time.
    assert run.status == "ok"
    assert run.metrics.max_abs_q_err < 0.25
    assert run.metrics.saturated_fraction < 0.05


@pytest.mark.parametrize(
    ("settings", "needle"),
    [
        ({"controller.kind": "adrc", "controller.bandwidth": -1.0}, "controller.bandwidth = -1.0"),
        ({"controller.kind": "adrc", "controller.observer_ratio": 20.0}, "Nyquist"),
        ({"controller.kind": "pd_gravity", "controller.damping_ratio": math.nan},
         "controller.damping_ratio = nan"),
    ],
)  # fmt: skip
def test_bad_baseline_settings_are_refused_naming_the_key(settings, needle):
    with pytest.raises(PluginError, match=needle.replace("(", "\\(")):
        posfb.load_scenario(set=settings)


@pytest.mark.slow
def test_a_user_controller_runs_in_a_study_export_and_replay(tmp_path, capsys):
    write_plugin(tmp_path)
    study = tmp_path / "study.yaml"
    study.write_text(
        "seed: 3\nscenario: scenario.yaml\nsamples: 2\nduration: 1.0\n"
        "controllers: [PGravity, pid]\n"
        "parameters:\n  link_mass: [!Uniform {min: -0.2, max: 0.2, relative: true}]\n"
    )
    db, out = tmp_path / "study.sqlite", tmp_path / "replay"
    assert main(["montecarlo", "run", str(study), "--db", str(db), "--workers", "1",
                 "--no-progress"]) == 0  # fmt: skip
    assert main(["montecarlo", "export", "--db", str(db), "--out", str(tmp_path / "t.csv")]) == 0
    table = (tmp_path / "t.csv").read_text()
    assert table.count("PGravity") == 2 and table.count("pid") >= 2
    capsys.readouterr()
    replay = ["montecarlo", "replay", "--db", str(db), "--sample", "1", "--out", str(out)]
    assert main(replay) == 0
    assert "note:" not in capsys.readouterr().out
    # The study stored the plug-in's source: a changed or deleted file is said in one
    # line, and the stored copy still replays the sample exactly.
    plugin = tmp_path / "my_controller.py"
    plugin.write_text(plugin.read_text() + "\n# edited after the study\n")
    assert main(replay) == 0
    notes = [line for line in capsys.readouterr().out.splitlines() if "note:" in line]
    assert len(notes) == 1 and "has changed since the study ran" in notes[0]
    plugin.unlink()
    assert main(replay) == 0
    assert "is gone since the study ran" in capsys.readouterr().out


def test_tune_refuses_a_plugin_written_as_a_step_in_one_line(tmp_path, capsys):
    path = write_plugin(tmp_path, _tunable("{'Kp': (1, 100)}"), settings="{}")
    assert main(["tune", path, "--out", str(tmp_path / "t.yaml"), "--plants", "2"]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "is written as a step (no law)" in error, error
