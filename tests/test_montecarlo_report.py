"""The report: statistics against numpy on made-up results, files, Markdown, CLI."""

from __future__ import annotations

import numpy as np
import pytest
from montecarlo_helpers import TINY_STUDY

from posfb.analysis.cli import main
from posfb.analysis.montecarlo.config import study_from_text
from posfb.analysis.montecarlo.coverage import BOUND_NAMES
from posfb.analysis.montecarlo.records import METRIC_COLUMNS, ControllerRun, SampleResult
from posfb.analysis.montecarlo.report import FIGURES, beats, joint_stats, load, status_counts
from posfb.analysis.montecarlo.store import ResultStore

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
    metrics = dict.fromkeys(METRIC_COLUMNS, 0.5)
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
    assert status_counts(data)["pid"] == {"ok": 4, "diverged": 1, "error": 0}
    # proposed wins on samples 0 (smaller norm), 2 (PID diverged) and 4; not 1 or 3.
    assert beats(data) == (3, 5)
    assert data.inside.tolist() == [True, True, False, False, False]
    assert data.exceeded["delta_M1"] == 3 and data.exceeded["delta_M0"] == 0


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
