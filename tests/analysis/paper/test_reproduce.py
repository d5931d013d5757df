"""``posfb reproduce`` end to end on a short horizon: every artefact is written and
opens; ``results.json`` has the documented shape and is written incrementally."""

from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from matplotlib.image import imread

from helpers.paths import REPO
from helpers.slow import heavy
from posfb.analysis.cli import main
from posfb.analysis.paper.experiment import ResultsFile
from posfb.models.controllers import PAPER_CONTROLLERS

FIGURES = [f"fig{n}{suffix}" for n in (4, 5, 6, 7) for suffix in ("", "_alpha_star")]


@pytest.fixture(scope="module")
@heavy
def reproduction(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(["reproduce", "--out", str(out), "--duration", "1"])
    return code, out, printed.getvalue().splitlines()


def test_exit_code_and_progress(reproduction):
    code, _, lines = reproduction
    assert code == 0
    assert any(line.startswith("[ 1] paper settings | nominal | pid") for line in lines)
    assert any(line.startswith("done in") for line in lines)


def test_results_json_has_the_documented_shape(reproduction):
    _, out, _ = reproduction
    data = json.loads((out / "results.json").read_text())
    for case in ("nominal", "payload"):
        assert set(data[case]) == set(PAPER_CONTROLLERS)
        for entry in data[case].values():
            assert len(entry["rms_q"]) == len(entry["rms_u"]) == 2
            assert all(isinstance(v, float) and v >= 0 for v in entry["rms_q"] + entry["rms_u"])
            assert entry["status"] == "ok"
    assert data["design"]["chosen_alpha_star"] is not None
    assert set(data["studies"]) >= {"alpha_star", "no_coulomb", "ideal_encoder"}


def test_true_arm_is_identified_beside_table1(reproduction):
    """The report states the plant the runs used: its theta in both cases; the
    payload raises link 2's inertia (theta2) and nothing in the motor rows' damping."""
    _, out, lines = reproduction
    identified = json.loads((out / "results.json").read_text())["identification"]
    assert set(identified) == {"nominal", "payload"}
    for theta in identified.values():
        assert set(theta) == {f"theta{i}" for i in range(1, 12)} | {"l1"}
    assert identified["payload"]["theta2"] > identified["nominal"]["theta2"]
    assert identified["payload"]["theta5"] == pytest.approx(identified["nominal"]["theta5"])
    report = (out / "report.md").read_text()
    assert "## The simulated arm" in report and "| theta11 |" in report
    assert any("identified" in line for line in lines)


def test_every_figure_opens(reproduction):
    _, out, _ = reproduction
    for stem in FIGURES:
        image = imread(out / f"{stem}.png")
        assert image.ndim == 3 and image.shape[0] > 400 and image.shape[1] > 600
        root = ET.parse(out / f"{stem}.svg").getroot()
        assert root.tag.endswith("svg")


def test_diagram_graph_is_written(reproduction):
    _, out, _ = reproduction
    if shutil.which("dot"):
        root = ET.parse(out / "closed_loop_proposed.svg").getroot()
        text = ET.tostring(root, encoding="unicode")
        assert "encoder" in text and "proposed_controller" in text
    else:
        assert "digraph" in (out / "closed_loop_proposed.dot").read_text()


def test_report_and_tables_link_existing_files(reproduction):
    _, out, _ = reproduction
    report = (out / "report.md").read_text()
    for heading in ("Table 3", "Table 4", "Differences from the paper", "Second study"):
        assert heading in report
    for link in re.findall(r"\]\(([^)]+)\)", report):
        assert (out / link).exists(), link
    tables = (out / "tables.md").read_text()
    assert "| 0.0026 |" in tables and "| 0.0058 |" in tables  # Table 3 PID, Table 4 proposed


def test_results_file_is_rewritten_after_every_entry(tmp_path):
    path = tmp_path / "results.json"
    results = ResultsFile(path, {"settings": {"duration": 1.0}})
    results.set(("nominal", "pid"), {"rms_q": [1.0, 2.0]})
    assert json.loads(path.read_text())["nominal"]["pid"]["rms_q"] == [1.0, 2.0]
    results.set(("nominal", "lin_lc"), {"rms_q": [3.0, 4.0]})
    assert set(json.loads(path.read_text())["nominal"]) == {"pid", "lin_lc"}
    assert not list(tmp_path.glob("*.partial"))


@pytest.mark.slow  # over 10 s on 2 cores (issue 45, item 4)
def test_experiment_script_runs_directly(tmp_path):
    script = REPO / "analysis" / "paper" / "payload_experiment.py"
    result = subprocess.run(
        [sys.executable, str(script), "--out", str(tmp_path), "--duration", "0.5"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert "Table 4" in result.stdout
    for name in ("fig6.png", "fig6.svg", "fig7.png", "fig7.svg", "table4.md"):
        assert (tmp_path / name).stat().st_size > 0
