"""The public API (``posfb``, ``analysis.api``): one code path with the command line,
every scenario setting applied, and the runner that cannot drop the true arm."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

import posfb
from posfb.analysis.api import yaml_value
from posfb.analysis.cli import main
from posfb.analysis.common.errors import run_exit_code
from posfb.diagrams.resolve import resolve
from posfb.diagrams.runner import ClosedLoopRunner

#: Short runs: the property (equality to the bit) does not depend on the length.
SHORT = {"timing.duration": 2}

#: Every shipped scenario, and the paper's with a plant-parameter override.
CASES = [
    *[(name, ()) for name in sorted(posfb.shipped_scenarios())],
    ("paper_nominal", ("plant.parameters.link_mass=[1.2, 0.9]", "plant.parameters.coulomb=0.2")),
]


def _cli_json(capsys: pytest.CaptureFixture, *args: str) -> dict:
    code = main(["simulate", *args, "--json", "--no-progress"])
    summary = json.loads(capsys.readouterr().out)
    # The labelled, untuned three-link scenario's run is saturated (exit 5); the rest ok.
    assert code == run_exit_code([summary["status"]]) and summary["status"] != "diverged"
    return summary


def _without_timing(summary: dict) -> dict:
    return {key: value for key, value in summary.items() if key != "wall_time_s"}


@pytest.mark.slow
@pytest.mark.parametrize(("name", "settings"), CASES)
def test_simulate_equals_the_command_bit_for_bit(name, settings, capsys):
    path = str(posfb.shipped_scenarios()[name])
    sets = [f"{key}={value}" for key, value in SHORT.items()] + list(settings)
    command = _cli_json(capsys, "--scenario", path, *[arg for s in sets for arg in ("--set", s)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", posfb.ScenarioWarning)
        run = posfb.simulate(posfb.load_scenario(path, set=sets))
    # json.dumps writes floats as repr: the parsed numbers are the run's to the bit.
    assert _without_timing(json.loads(json.dumps(run.summary()))) == _without_timing(command)


def test_a_runner_built_from_a_resolved_config_keeps_the_payload_and_overrides():
    # The trap of issue 19: ClosedLoopRunner(resolve(...).config).run() used to run the
    # URDF's arm, ignoring the scenario's payload and parameter overrides.
    scenario = posfb.load_scenario(
        posfb.shipped_scenarios()["paper_payload"],
        set={**SHORT, "controller.kind": "lin_lc", "plant.parameters.damping": [0.05, 0.02]},
    )
    expected = posfb.simulate(scenario)
    direct = ClosedLoopRunner(resolve(scenario).config).run()
    np.testing.assert_array_equal(direct.q_true, expected.result.q_true)
    urdf_arm = ClosedLoopRunner(resolve(scenario).config)
    plain = urdf_arm.run(urdf_arm.arm.default_parameters)
    assert not np.array_equal(plain.q_true, expected.result.q_true)


def test_build_runs_like_simulate_and_collects_a_run_advanced_by_hand():
    scenario = posfb.load_scenario(set={**SHORT, "controller.kind": "pid"})
    expected = posfb.simulate(scenario)
    built = posfb.build(scenario)
    assert built.run().rms_q == expected.rms_q
    by_hand = posfb.build(scenario)
    by_hand.simulator.AdvanceTo(1.0)
    partial = by_hand.collect()
    # Rows 0..K-1 at t_k <= 1 s are the same samples as the full run's.
    rows = len(partial.result.times)
    assert 90 <= rows <= 101
    np.testing.assert_array_equal(partial.result.q_true, expected.result.q_true[:rows])
    with pytest.raises(ValueError, match="run\\(\\) starts at t = 0"):
        by_hand.run()


def test_build_names_its_subsystems_and_extend_sees_them_before_the_build():
    seen = {}

    def extend(builder, systems):
        seen["names"] = {s.get_name() for s in builder.GetSystems()}
        seen["systems"] = systems

    built = posfb.build(posfb.load_scenario(set=SHORT), "lin_lc", extend=extend)
    assert {"arm", "voltage_saturation", "log", "encoder_hold", "desired_hold"} <= seen["names"]
    assert seen["systems"].controller is built.systems.controller
    assert built.diagram.GetSystems()


def test_compare_runs_each_controller_as_simulate_does():
    scenario = posfb.load_scenario(set=SHORT)
    comparison = posfb.compare(scenario, ["lin_lc", "pid"])
    table = comparison.table()
    assert table["controller"].tolist() == ["lin_lc", "pid"]
    for kind in ("lin_lc", "pid"):
        alone = posfb.simulate(scenario, kind)
        row = table[table["controller"] == kind].iloc[0]
        assert (row["rms_q1_rad"], row["rms_q2_rad"]) == alone.rms_q


@pytest.mark.slow
def test_compare_writes_its_table_summaries_and_figures(tmp_path):
    comparison = posfb.compare(posfb.load_scenario(set={"timing.duration": 0.5}), ["lin_lc"])
    names = {path.name for path in comparison.save(tmp_path)}
    assert {"comparison.csv", "comparison.md", "comparison.json", "errors.png",
            "positions.svg"} <= names  # fmt: skip
    stored = json.loads((tmp_path / "comparison.json").read_text())
    assert stored["lin_lc"]["rms_q"] == list(comparison.runs["lin_lc"].rms_q)


@pytest.mark.parametrize(
    ("arguments", "needle"),
    [
        ((["lin_lc", "lin_lc"],), "lin_lc named twice"),
        (([],), "at least one controller"),
        ((["nope"],), "controller.kind = 'nope'"),
    ],
)
def test_compare_refuses_bad_controller_lists(arguments, needle):
    with pytest.raises(ValueError, match=needle):
        posfb.compare(posfb.load_scenario(set={"timing.duration": 0.1}), *arguments)


def test_run_frame_save_and_plot(tmp_path):
    run = posfb.simulate(posfb.load_scenario(set={"timing.duration": 0.5}), "lin_lc")
    frame = run.frame()
    assert len(frame) == len(run.result.times)
    saved = run.save(tmp_path / "run.csv")
    assert saved.exists()
    figure = run.plot()
    assert figure._suptitle.get_text() == run.label
    with pytest.raises(ValueError, match="figure = 'nope'"):
        run.plot("nope")


def test_load_scenario_from_a_mapping_with_settings_as_values():
    scenario = posfb.load_scenario(
        {"timing": {"duration": 1.0}, "sensor": {"noise_seed": 3}},
        set={"sensor.encoder_counts": np.int64(4096), "actuator.voltage_limit": np.array([12.0]),
             "controller.kind": "pid"},  # fmt: skip
    )
    assert scenario.get("controller.kind") == "pid"
    assert scenario.get("sensor.encoder_counts") == [4096]
    assert scenario.get("actuator.voltage_limit") == [12.0]
    assert "duration: 1.0" in scenario.dump()


@pytest.mark.parametrize(
    ("value", "text"),
    [(0.005, "0.005"), (np.float64(1e-3), "0.001"), ([1, 2.5], "[1, 2.5]"), ((3,), "[3]"),
     (True, "true"), ("!Theta {theta6: 0}", "!Theta {theta6: 0}"),
     (np.array([[1, 2]]), "[[1, 2]]")],
)  # fmt: skip
def test_yaml_value_writes_python_and_numpy_values_as_yaml(value, text):
    assert yaml_value(value) == text


def test_load_scenario_refuses_bad_input_naming_the_key():
    with pytest.raises(ValueError, match="timing.nope"):
        posfb.load_scenario(set={"timing.nope": 1})


def test_scenario_warnings_are_python_warnings():
    scenario = posfb.load_scenario(set={"timing.duration": 0.1, "actuator.voltage_limit": 1.0})
    with pytest.warns(posfb.ScenarioWarning, match="voltage"):
        posfb.simulate(scenario, "lin_lc")


def test_import_posfb_is_light_and_every_public_name_resolves():
    probe = (
        "import sys, posfb; heavy = {'pydrake', 'numpy', 'matplotlib', 'pandas'} & "
        "{m.split('.')[0] for m in sys.modules}; print(sorted(heavy))"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert done.stdout.strip() == "[]"
    for name in posfb.__all__:
        assert getattr(posfb, name) is not None


def test_compare_runs_a_named_entry_beside_its_kind(tmp_path):
    path = tmp_path / "twice.yaml"
    path.write_text("timing: {duration: 1.0}\n"
                    "controllers: {proposed_275: !Proposed {alpha_star: 2.75}}\n")  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", posfb.ScenarioWarning)
        comparison = posfb.compare(path, ["proposed", "proposed_275"])
        alone = posfb.simulate(posfb.load_scenario(path, set={"controller.alpha_star": 2.75}))
    assert comparison.runs["proposed_275"].rms_q == alone.rms_q
    assert comparison.runs["proposed"].rms_q != alone.rms_q
    legend = [t.get_text() for t in comparison.figure().legends[0].get_texts()]
    assert legend == ["Lin + LC + NC (paper)", "proposed_275: Lin + LC + NC (own settings)"]


@pytest.mark.parametrize(
    ("call", "needle"),
    [
        (lambda: posfb.load_scenario(set=[("timing.duration", 1)]), "set item = ('timing"),
        (lambda: posfb.load_scenario(set="timing.duration=1"), "set = 'timing.duration=1'"),
        (lambda: posfb.load_scenario(set={"timing.duration": object()}), "timing.duration = <"),
        (lambda: posfb.load_scenario(5), "source = 5"),
        (lambda: posfb.load_scenario().get(5), "key = 5"),
        (lambda: posfb.compare(None, "pid,lin_lc"), "controllers = 'pid,lin_lc'"),
        (lambda: posfb.compare(None, ["pid", 3]), "controllers item = 3"),
        (lambda: posfb.simulate(None, 3), "controller = 3"),
        (lambda: posfb.tune(None, study=123), "study = 123"),
        (lambda: posfb.tune(None, settings={"plants": 3}), "settings = {'plants': 3}"),
        (lambda: posfb.tune(None, out=7), "out = 7"),
    ],
)
def test_an_argument_of_the_wrong_type_is_named(call, needle):
    """A wrong type where an argument enters is a ``TypeError`` naming the argument, not
    an internal ``AttributeError`` or a string iterated by its characters (issue 27)."""
    with pytest.raises(TypeError) as raised:
        call()
    assert needle in str(raised.value)
    assert "\n" not in str(raised.value)


def test_tune_checks_out_before_the_search(tmp_path, monkeypatch):
    """An ``out`` that cannot be written is refused before any tuning work: the search
    is replaced by one that fails the test if reached."""
    from posfb.analysis.design import tune as tune_module

    def no_search(*_args, **_kwargs):
        raise AssertionError("tune searched although out cannot be written")

    monkeypatch.setattr(tune_module, "tune", no_search)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    with pytest.raises(ValueError, match="out"):
        posfb.tune(None, out=blocker / "tuned.yaml")
