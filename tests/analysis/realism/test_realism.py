"""The "How far from hardware?" study (analysis.realism): its arithmetic against closed
forms, the shipped study file, and a small study end to end (run, resume, report,
replay), its ideal arm checked against an independent ``posfb.simulate`` run."""

from __future__ import annotations

import json
import math
import sqlite3

import numpy as np
import pytest
import yaml

import posfb
from helpers.slow import heavy
from posfb.analysis.cli import main
from posfb.analysis.cli.commands.realism import DEFAULT_STUDY
from posfb.analysis.common.tables import PAPER_TABLE3
from posfb.analysis.realism.findings import gap_share, paper_pairs, ranking_agreement
from posfb.analysis.realism.realism_report import _draws_text
from posfb.analysis.realism.spec import COMBINED, IDEAL, load_realism
from posfb.analysis.uncertainty.study import Gaussian, UniformDiscrete
from posfb.diagrams.scenario import get_setting


@pytest.mark.parametrize(
    ("simulated", "expected"),
    [(0.5e-3, 0.0), (4e-3, 1.0), (math.sqrt(0.5e-3 * 4e-3), 0.5), (0.5e-3**2 / 4e-3, -1.0)],
)
def test_gap_share_is_the_log_fraction_of_the_way_to_the_paper(simulated, expected):
    # ideal 0.5 mrad, paper 4 mrad: the geometric mean is half-way on a log scale.
    assert gap_share(simulated, 0.5e-3, 4e-3) == pytest.approx(expected, abs=1e-12)


def test_gap_share_is_undefined_without_a_gap_or_a_positive_value():
    assert math.isnan(gap_share(1e-3, 2e-3, 2e-3))
    assert math.isnan(gap_share(0.0, 2e-3, 4e-3))
    assert math.isnan(gap_share(math.nan, 2e-3, 4e-3))


def test_table_3_ranks_every_pair_but_the_joint_2_tie():
    # Table 3: joint 1 proposed 0.0021 < PID 0.0026 < Lin+LC 0.0037; joint 2 proposed
    # 0.0032, Lin+LC 0.0059 and PID 0.0060 (a tie within 10 %, not a ranking).
    joint = {j: {c: values[j] for c, values in PAPER_TABLE3.items()} for j in (0, 1)}
    assert set(paper_pairs(joint[0])) == {
        ("proposed", "pid"), ("proposed", "lin_lc"), ("pid", "lin_lc")
    }  # fmt: skip
    assert set(paper_pairs(joint[1])) == {("proposed", "pid"), ("proposed", "lin_lc")}


def test_a_run_that_did_not_finish_ranks_last():
    errors = {"a": np.array([1.0, np.nan, 1.0, np.nan]), "b": np.array([2.0, 2.0, np.nan, np.nan])}
    assert ranking_agreement(errors, [("a", "b")]).tolist() == [True, False, True, False]


def test_the_shipped_study_has_a_source_per_effect_and_changes_no_default():
    studies = load_realism(DEFAULT_STUDY)
    spec = studies.spec
    assert [*studies.studies][0] == IDEAL and [*studies.studies][-1] == COMBINED
    for effect in spec.effects:
        assert len(effect.source.split()) >= 10, effect.name  # a real citation, not a word
        assert effect.draws, effect.name  # every effect is drawn over a range
    # The ideal arm is the paper's nominal scenario: every effect off.
    paper = posfb.load_scenario(posfb.shipped_scenarios()["paper_nominal"]).scenario
    ideal = studies.studies[IDEAL].base
    for key in (
        "actuator.electrical_time_constant", "actuator.dac_bits", "actuator.compute_delay",
        "plant.gear_stiffness", "plant.backlash", "sensor.location", "timing.sample_time",
    ):  # fmt: skip
        assert get_setting(ideal, key) == get_setting(paper, key), key
    assert type(ideal.plant.friction) is type(paper.plant.friction)
    combined = studies.studies[COMBINED]
    assert list(combined.draws) == [
        key for name in spec.combined for key in studies.effect(name).draws
    ]


@pytest.mark.slow
def test_the_table_4_study_is_the_table_3_study_on_the_payload_arm():
    table4 = load_realism(DEFAULT_STUDY.with_name("paper_table4.yaml"))
    table3 = load_realism(DEFAULT_STUDY)
    assert table4.spec.paper_table == "payload" and table3.spec.paper_table == "nominal"
    assert table4.spec.effects == table3.spec.effects
    assert table4.spec.stand_ins == table3.spec.stand_ins
    assert list(table4.studies) == list(table3.studies)
    payload = posfb.load_scenario(posfb.shipped_scenarios()["paper_payload"]).scenario
    for name, study in table4.studies.items():
        nominal = table3.studies[name]
        assert study.base.plant.payload_mass == payload.plant.payload_mass == 0.288
        # with the payload taken away, each study is the Table 3 one, key for key
        study.base.plant.payload_mass = nominal.base.plant.payload_mass
        assert (study.seed, study.samples, study.draws) == (
            nominal.seed, nominal.samples, nominal.draws
        )
        assert study.base == nominal.base, name


def test_extends_refuses_a_cycle_and_a_missing_file(tmp_path):
    (tmp_path / "a.yaml").write_text("extends: b.yaml\n")
    (tmp_path / "b.yaml").write_text("extends: a.yaml\n")
    with pytest.raises(ValueError, match="extends: 'a.yaml' extends this file again"):
        load_realism(tmp_path / "a.yaml")
    (tmp_path / "c.yaml").write_text("extends: gone.yaml\n")
    with pytest.raises(FileNotFoundError, match="extends: realism study .*gone.yaml does not"):
        load_realism(tmp_path / "c.yaml")


SMALL = """\
study:
  seed: 7
  sampling: latin_hypercube
  scenario: {scenario}
  duration: 0.2
  controllers: [lin_lc, pid, lin_lc_again]
  entries:
    lin_lc_again: !LinLc {{}}
paper_table: nominal
stand_ins: {{lin_lc_again: lin_lc}}
effects:
  - name: delay
    label: computation delay
    source: Astrom and Wittenmark, Computer-Controlled Systems, 1997, computational delay
    samples: 2
    draws:
      actuator.compute_delay: !Uniform {{min: 0.0, max: 0.01}}
  - name: gear
    label: gear compliance, encoder on the motor
    source: Harmonic Drive CSF catalogue, torsional stiffness K1 to K3 of the small sizes
    samples: 2
    settings: [sensor.location=motor, plant.gear_stiffness=3000]
    draws:
      plant.gear_stiffness: !Uniform {{min: 2000.0, max: 4000.0}}
      plant.backlash: !Uniform {{min: 0.0, max: 0.0005}}
combined: [delay, gear]
combined_samples: 1
"""


@pytest.fixture(scope="module")
@heavy
def small_study(tmp_path_factory):
    folder = tmp_path_factory.mktemp("realism")
    scenario = posfb.shipped_scenarios()["paper_nominal"]
    spec = folder / "realism.yaml"
    spec.write_text(SMALL.format(scenario=scenario))
    out = folder / "out"
    args = ["realism", str(spec), "--out", str(out), "--workers", "1", "--no-progress"]
    assert main(args) == 0
    return spec, out


def test_the_small_study_writes_its_report_and_figure(small_study):
    _, out = small_study
    text = (out / "report.md").read_text()
    for heading in (
        "## The effects and their ranges", "## RMS tracking error with each effect",
        "## How much of the gap each effect closes", "## Does the paper's ranking survive?",
        "## Verdict per effect", "## Which drawn value matters",
        "## The error the encoder reads",
    ):  # fmt: skip
        assert heading in text
    assert "Incomplete" not in text
    assert "recorded)" not in text  # a fresh store records the measured error of every run
    assert "Astrom and Wittenmark" in text
    assert (out / "errors.png").stat().st_size > 0


def test_the_ideal_arm_of_the_study_is_an_independent_simulate_run(small_study):
    _, out = small_study
    with sqlite3.connect(out / "stores" / f"{IDEAL}.sqlite") as db:
        rows = dict(db.execute("SELECT controller, rms_q2 FROM runs").fetchall())
    paper = posfb.shipped_scenarios()["paper_nominal"]
    run = posfb.simulate(posfb.load_scenario(paper, set={"timing.duration": 0.2}), "lin_lc")
    assert rows["lin_lc"] == run.rms_q[1]  # the worker's path and simulate's, to the bit
    with sqlite3.connect(out / "stores" / f"{IDEAL}.sqlite") as db:
        measured = dict(db.execute("SELECT controller, rms_measured_q2 FROM runs").fetchall())
    assert measured["lin_lc"] == run.rms_q_measured[1]
    assert rows["lin_lc_again"] == rows["lin_lc"]  # the same controller under two names


@pytest.mark.parametrize(
    ("study", "key"), [("gear", "plant.backlash"), ("delay", "actuator.compute_delay")]
)
@pytest.mark.slow
def test_the_draws_reach_the_runs_and_replay(small_study, tmp_path, study, key):
    _, out = small_study
    store = out / "stores" / f"{study}.sqlite"
    with sqlite3.connect(store) as db:
        drawn = [json.loads(row[0])[key] for row in db.execute("SELECT parameters FROM samples")]
    assert len(set(drawn)) == 2  # two samples, two values
    # Replay reruns a sample from the store alone and exits 1 if any number differs.
    assert main(["montecarlo", "replay", "--db", str(store), "--sample", "1",
                 "--controller", "pid", "--out", str(tmp_path)]) == 0  # fmt: skip


@pytest.mark.slow
def test_a_second_run_resumes_and_runs_nothing(small_study, capsys):
    spec, out = small_study
    assert main(["realism", str(spec), "--out", str(out), "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert err.count("(0 new in") == 4  # ideal, delay, gear, combined
    assert main(["realism", str(spec), "--out", str(out), "--only", "gear", "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "gear: 2 of 2 samples (0 new in" in err and err.count("new in") == 1


def test_the_report_writes_any_distribution_as_the_study_file_does():
    # The report's "drawn" column is the flow map of the study file: it reads back.
    draws = {
        "plant.backlash": Gaussian(mean=5e-4, stddev=1e-4, min=0.0, max=1e-3),
        "actuator.dac_bits": UniformDiscrete(values=[12, 14]),
    }
    for part, distribution in zip(_draws_text(draws).split("; "), draws.values(), strict=True):
        tag, _, flow = part.split("`")[3].partition(" ")
        assert tag == f"!{type(distribution).__name__}"
        read = yaml.safe_load(flow)
        assert all(read[k] == v for k, v in vars(distribution).items() if v not in (None, False))


@pytest.mark.slow
def test_the_error_figure_has_a_title_and_its_legend_below_the_data(small_study, tmp_path):
    """Issue 27's figures: the realism report's error figure is titled and its legend
    covers no panel (read back from the drawn figure)."""
    from helpers.figure_checks import legend_labels, legends_over_axes, suptitle
    from posfb.analysis.realism.findings import findings
    from posfb.analysis.realism.realism_report import plot_errors
    from posfb.analysis.realism.spec import load_realism

    spec, out = small_study
    figure = plot_errors(findings(load_realism(spec), out / "stores"), tmp_path)
    assert suptitle(figure)
    assert legends_over_axes(figure) == []
    assert legend_labels(figure)


@pytest.mark.slow
def test_a_store_of_an_earlier_posfb_is_reported_as_not_resumable(small_study, tmp_path):
    """An unfinished study whose store holds another identity (written by an earlier
    posfb) is not offered ``--only NAME`` as the way to complete it, since a resume into
    it is refused; one of this version is."""
    import shutil
    import sqlite3

    from posfb.analysis.realism.findings import findings
    from posfb.analysis.realism.realism_report import markdown
    from posfb.analysis.realism.spec import load_realism

    spec, out = small_study
    stores = tmp_path / "stores"
    shutil.copytree(out / "stores", stores)
    studies = load_realism(spec)
    name = next(n for n in studies.studies if n != "ideal")
    path = next(stores.glob(f"{name}.*"))
    with sqlite3.connect(path) as connection:
        connection.execute("DELETE FROM runs WHERE sample = 0")
        connection.execute("DELETE FROM samples WHERE sample = 0")
    text = markdown(findings(studies, stores), "posfb realism")
    assert f"`--only {name}` completes it" in text
    with sqlite3.connect(path) as connection:
        connection.execute("UPDATE meta SET value = 'earlier' WHERE key = 'identity'")
    text = markdown(findings(studies, stores), "posfb realism")
    assert "stored by an earlier posfb, which cannot be resumed" in text
