"""The report: statistics against numpy on made-up results, files, Markdown, CLI."""

from __future__ import annotations

import numpy as np
import pytest

from helpers.montecarlo_helpers import TINY_STUDY, make_result, run_into_store
from posfb.analysis.cli import main
from posfb.analysis.montecarlo.records import STATUSES, ControllerRun, SampleResult, metric_columns
from posfb.analysis.montecarlo.results import beats, joint_stats, load, status_counts
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.montecarlo.study_report import FIGURES, markdown
from posfb.analysis.uncertainty.coverage import BOUND_NAMES
from posfb.analysis.uncertainty.study import study_from_text

#: rms_q per sample: (proposed joint 1, joint 2), (pid joint 1, joint 2); None: diverged.
TABLE = [
    ((0.001, 0.010), (0.002, 0.050)),
    ((0.002, 0.008), (0.001, 0.004)),
    ((0.003, 0.020), None),
    (None, (0.004, 0.030)),
    ((0.004, 0.012), (0.003, 0.060)),
]


def _run(controller: str, rms: tuple[float, float] | None) -> ControllerRun:
    if rms is None:
        return ControllerRun(controller, "diverged", "|q~| = 1.2 rad exceeds 1 rad", {})
    metrics = dict.fromkeys(metric_columns(2), 0.5)
    metrics.update(rms_q1=rms[0], rms_q2=rms[1])
    return ControllerRun(controller, "ok", "", metrics)


@pytest.fixture()
def store(tmp_path):
    study = study_from_text(TINY_STUDY)
    with ResultStore.create_or_resume(tmp_path / "r.sqlite", study, "test") as store:
        for i, (ours, theirs) in enumerate(TABLE):
            store.write(
                SampleResult(
                    index=i,
                    parameters={"payload_mass": 0.1 * i},
                    encoder_counts=20000,
                    theta={},
                    bound_ratios={**dict.fromkeys(BOUND_NAMES, 0.5), "delta_M1": 0.5 + 0.4 * i},
                    inside_bounds=0.5 + 0.4 * i <= 1.0,
                    runs=(_run("proposed", ours), _run("pid", theirs)),
                ),
                "test",
            )
        yield store


def test_statistics_match_numpy(store):
    stats = {(s.controller, s.joint): s for s in joint_stats(load(store))}
    for k, controller in enumerate(("proposed", "pid")):
        for joint in (1, 2):
            values = np.array([row[k][joint - 1] for row in TABLE if row[k] is not None])
            s = stats[(controller, joint)]
            assert s.count == len(values) == 4
            assert s.mean == pytest.approx(values.mean())
            assert s.median == pytest.approx(np.median(values))
            assert s.p95 == pytest.approx(np.percentile(values, 95))
            assert s.max == pytest.approx(values.max())


def test_failures_share_and_coverage(store):
    data = load(store)
    assert status_counts(data)["pid"] == {"ok": 4, "saturated": 0, "lost": 0, "diverged": 1,
                                          "error": 0}  # fmt: skip
    # proposed wins on samples 0 (smaller norm), 2 (PID diverged) and 4; not 1 or 3.
    assert beats(data) == (3, 5)
    assert data.inside.tolist() == [True, True, False, False, False]
    assert data.exceeded["delta_M1"] == 3 and data.exceeded["delta_M0"] == 0


#: The statuses of ``_judged``'s samples, one per sample for both controllers.
JUDGED = ("ok", "saturated", "lost", "diverged", "saturated")


@pytest.fixture()
def judged(tmp_path):
    """A store whose samples end ``JUDGED`` (made-up numbers, ``make_result``)."""
    study = study_from_text(TINY_STUDY)
    with ResultStore.create_or_resume(tmp_path / "judged.sqlite", study, "test") as store:
        for index, status in enumerate(JUDGED):
            store.write(make_result(index, status=status), "test")
        yield store


def test_saturated_and_lost_runs_are_counted_and_keep_their_rms(judged):
    data = load(judged)
    expected = {status: JUDGED.count(status) for status in STATUSES}
    assert status_counts(data) == {"proposed": expected, "pid": expected}
    # A saturated or lost run finished: its RMS covers the whole run and enters the
    # statistics (dropping it would flatter the controller); a diverged one does not.
    finished = [i for i, status in enumerate(JUDGED) if status != "diverged"]
    stats = {(s.controller, s.joint): s for s in joint_stats(data)}
    assert stats[("proposed", 1)].count == len(finished)
    stored = [row["rms_q1"] for row in judged.run_rows() if row["controller"] == "proposed"]
    assert stats[("proposed", 1)].max == max(stored[i] for i in finished)


def test_the_report_has_a_column_per_status_and_fails_only_unfinished_runs(judged):
    lines = markdown(load(judged)).splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("| controller | ok |"))
    assert lines[at].split(" | ")[1 : 1 + len(STATUSES)] == list(STATUSES)
    row = next(line for line in lines[at:] if line.startswith("| pid | "))
    cells = [cell.strip() for cell in row.strip("|").split("|")]
    assert cells[1 : 1 + len(STATUSES)] == [str(JUDGED.count(s)) for s in STATUSES]
    failed_percent = float(cells[1 + len(STATUSES)].split(" %")[0])
    assert failed_percent == pytest.approx(100 * JUDGED.count("diverged") / len(JUDGED))


def test_a_study_of_a_collapsed_arm_stores_its_runs_as_lost(tmp_path, weak_shoulder):
    # The real loop through the worker: the weak shoulder's run finishes under the
    # divergence bound, and the store says it lost its path.
    study = "seed: 0\nsamples: 1\nduration: 4.0\ncontrollers: [lin_lc]\n"
    study += f"settings: ['{weak_shoulder}']\n"
    with ResultStore.open_existing(run_into_store(tmp_path / "weak.sqlite", study)) as store:
        (run,) = store.run_rows()
        counts = status_counts(load(store))
    assert run["status"] == "lost" and "timing.lost_bound" in run["message"]
    assert run["max_abs_q_err"] < 1.0  # under the divergence bound
    assert counts["lin_lc"]["lost"] == 1


def test_report_command_writes_markdown_and_figures(store, tmp_path, capsys):
    out = tmp_path / "report"
    assert main(["montecarlo", "report", "--db", str(store.path), "--out", str(out)]) == 0
    assert "report.md" in capsys.readouterr().out
    text = (out / "report.md").read_text()
    assert "| proposed | 2 | 4 |" in text
    assert "**3 of 5**" in text and "60.0 %" in text
    assert "2 of 5 plants lie inside" in text
    for name in FIGURES:
        assert (out / f"{name}.png").stat().st_size > 1000
        assert (out / f"{name}.svg").read_text().startswith("<?xml")
        assert f"({name}.png)" in text


def test_report_of_a_missing_store_is_one_line(tmp_path, capsys):
    code = main(["montecarlo", "report", "--db", str(tmp_path / "no.sqlite"), "--out", "x"])
    assert code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def _synthetic_store(path, study, error_of):
    """A store whose sampled plants are the study's own draws and whose RMS errors are
    ``error_of(plant parameters)`` (no simulation)."""
    from posfb.analysis.uncertainty.sampling import sample_plant
    from posfb.models.plant import build_arm_diagram

    nominal = build_arm_diagram()[1].default_parameters
    with ResultStore.create_or_resume(path, study, "test") as store:
        for i in range(study.samples):
            plant = sample_plant(study, nominal, i).parameters
            rms = error_of(plant)
            metrics = dict.fromkeys(metric_columns(2), 0.5)
            metrics.update(rms_q1=rms, rms_q2=rms)
            parameters = {
                k: list(v) if isinstance(v, tuple) else v for k, v in plant.__dict__.items()
            }
            store.write(
                SampleResult(
                    index=i,
                    parameters=parameters,
                    encoder_counts=20000,
                    theta={},
                    bound_ratios=dict.fromkeys(BOUND_NAMES, 0.5),
                    inside_bounds=True,
                    runs=(ControllerRun("proposed", "ok", "", metrics, 1.0 + 0.01 * rms),),
                ),
                "test",
            )
    return ResultStore.open_existing(path)


def test_sensitivity_ranks_the_one_parameter_that_matters_first(tmp_path):
    from posfb.analysis.montecarlo.sensitivity import sensitivities

    text = TINY_STUDY.replace("samples: 4", "samples: 120")
    study = study_from_text(text.replace("[proposed, pid]", "[proposed]"))
    store = _synthetic_store(
        tmp_path / "s.sqlite", study, lambda plant: 0.01 * (1.0 + plant.link_com[1] ** 3)
    )
    with store:
        found = sensitivities(load(store))
    for entry in found:
        assert entry.ranking[0].parameter == "link_com_2_m"
        assert entry.ranking[0].rho > 0.9 and entry.ranking[0].p_value < 1e-6
        assert all(abs(rank.rho) < 0.35 for rank in entry.ranking[1:])


@pytest.mark.slow  # over 10 s on 2 cores (issue 45, item 4)
def test_a_saltelli_study_reports_sobol_indices_of_the_parameter_that_matters(tmp_path):
    from posfb.analysis.montecarlo.sensitivity import sensitivities

    text = """
seed: 3
samples: 256
sampling: saltelli
controllers: [proposed]
parameters:
  coulomb: [!Uniform {min: -0.2, max: 0.2, relative: true}, !Deterministic {}]
  payload_mass: !Uniform {min: 0.0, max: 0.5}
"""
    study = study_from_text(text)
    store = _synthetic_store(tmp_path / "s.sqlite", study, lambda plant: plant.payload_mass)
    with store:
        data = load(store)
        (entry, _) = sensitivities(data)
        out = tmp_path / "report"
        main(["montecarlo", "report", "--db", str(store.path), "--out", str(out)])
    indices = {index.parameter: index for index in entry.sobol}
    payload, coulomb = indices["payload_mass_kg"], indices["coulomb_1_N_m"]
    assert abs(payload.first - 1.0) <= max(payload.first_conf, 0.05)
    assert abs(payload.total - 1.0) <= max(payload.total_conf, 0.05)
    assert abs(coulomb.total) <= max(coulomb.total_conf, 0.05)
    assert "Sobol' indices" in (out / "report.md").read_text()


def test_the_report_has_the_answer_sections_and_every_figure(store, tmp_path):
    out = tmp_path / "report"
    assert main(["montecarlo", "report", "--db", str(store.path), "--out", str(out)]) == 0
    text = (out / "report.md").read_text()
    for heading in (
        "## Sensitivity", "## Were there enough samples?", "median [95 % CI]",
        "failed share [95 % CI]", "Wilson 95 % interval",
    ):  # fmt: skip
        assert heading in text, heading
    for name in FIGURES:
        assert (out / f"{name}.png").is_file(), name


@pytest.mark.slow
@pytest.mark.parametrize("samples", [1, 3])
def test_a_study_where_no_run_finished_still_reports(tmp_path, samples):
    from posfb.analysis.montecarlo.study_report import write_report

    study = study_from_text(TINY_STUDY)
    with ResultStore.create_or_resume(tmp_path / "d.sqlite", study, "test") as store:
        for i in range(samples):
            store.write(make_result(i, status="diverged"), "test")
    lines: list[str] = []  # issue 45, item 3: montecarlo report's progress line
    with ResultStore.open_existing(tmp_path / "d.sqlite") as store:
        path = write_report(store, tmp_path / "report", progress=lines.append)
    figures = [line for line in lines if line.startswith("figure ")]
    assert figures == [f"figure {k} of {len(figures)}" for k in range(1, len(figures) + 1)]
    # the figures this process draws, then the wait for the work beside them
    assert len(figures) >= 4 and lines[0].startswith("reading ")
    assert lines[-1] == "the margins and the sensitivity figure"
    counts = {**dict.fromkeys(STATUSES, 0), "diverged": samples}
    assert f"| proposed | {' | '.join(str(counts[s]) for s in STATUSES)} |" in path.read_text()
    for name in FIGURES:
        assert (tmp_path / "report" / f"{name}.png").is_file(), name


@pytest.mark.slow  # over 10 s on 2 cores (issue 45, item 4)
def test_a_report_on_too_few_runs_gives_no_interval_and_no_p_value(store, tmp_path, capsys):
    # The fixture's 4 samples are below MIN_INFERENCE_ROWS: the estimates are printed, no
    # bootstrap interval, no Spearman p-value, nothing in bold.
    out = tmp_path / "report"
    assert main(["montecarlo", "report", "--db", str(store.path), "--out", str(out)]) == 0
    text = (out / "report.md").read_text()
    assert "(no CI, n < 10)" in text and "too few runs for an interval" in text
    sensitivity = text.split("## Sensitivity", 1)[1].split("\n## ", 1)[0]
    assert "**" not in sensitivity.split("|---", 1)[1]
