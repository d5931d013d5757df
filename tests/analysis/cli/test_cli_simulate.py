"""``posfb simulate``, ``graph`` and ``animate`` as a user runs them."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from posfb.analysis.cli import EXIT_BAD_INPUT, EXIT_INTERNAL_ERROR, main
from posfb.analysis.common.errors import EXIT_DIVERGED, EXIT_NOT_TRACKED, run_exit_code
from posfb.diagrams import graph

CLI = [sys.executable, "-m", "posfb.analysis.cli"]


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120)


@pytest.mark.slow
def test_simulate_json_has_the_documented_keys():
    result = _run(
        "simulate", "--controller", "pid", "--case", "payload", "--duration", "1", "--json"
    )
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert {"rms_q", "rms_u", "max_abs_q_err", "saturated_fraction", "wall_time_s"} <= set(data)
    assert len(data["rms_q"]) == len(data["rms_u"]) == 2
    assert data["status"] == "ok" and data["scenario"] == "payload"
    # The measured error under the store's and compare's spelling, and its earlier name.
    assert len(data["rms_measured_q"]) == 2 and data["rms_q_measured"] == data["rms_measured_q"]


def test_simulate_prints_a_summary(capsys):
    assert main(["simulate", "--controller", "lin_lc", "--duration", "0.5"]) == 0
    assert "RMS(q~)" in capsys.readouterr().out


def test_bad_input_from_a_shell_is_one_line_and_exit_2():
    result = _run("simulate", "--duration", "1.005")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "duration" in lines[0] and "Traceback" not in result.stderr


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["simulate", "--sample-time", "-0.01"], "sample_time"),
        (["simulate", "--encoder-counts", "-3"], "encoder_counts"),
        (["simulate", "--sample-time", "0.005", "--duration", "1"], "filter_a"),
        (["graph", "--out", "graph.txt"], "out"),
        (["animate", "--out", "arm.txt"], "html"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args, needle, capsys):
    assert main(args) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0]


def test_unknown_controller_is_refused_in_one_line(capsys):
    # No argparse choices (they would import the controllers): the scenario refuses it.
    assert main(["simulate", "--controller", "lqr"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "controller.kind = 'lqr'" in lines[0]


def test_graph_renders_svg(tmp_path, capsys):
    out = tmp_path / "loop.svg"
    assert main(["graph", "--controller", "pid", "--out", str(out)]) == 0
    if graph.shutil.which("dot"):
        assert ET.parse(out).getroot().tag.endswith("svg")
    else:
        assert "digraph" in out.with_suffix(".dot").read_text()


@pytest.mark.skipif(not graph.shutil.which("dot"), reason="needs Graphviz (bin/setup installs it)")
def test_graph_png_fits_a_page_width(tmp_path, capsys):
    out = tmp_path / "loop.png"
    assert main(["graph", "--controller", "proposed", "--out", str(out)]) == 0
    width, _ = struct.unpack(">II", out.read_bytes()[16:24])  # the PNG header's IHDR
    assert width <= 1200


def test_graph_without_graphviz_writes_dot_text(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(graph.shutil, "which", lambda name: None)
    out = tmp_path / "loop.svg"
    assert main(["graph", "--out", str(out)]) == 0
    assert "digraph" in out.with_suffix(".dot").read_text()
    assert "apt-get install graphviz" in capsys.readouterr().err


def test_animate_writes_a_self_contained_html(tmp_path, capsys):
    out = tmp_path / "arm.html"
    assert main(["animate", "--out", str(out), "--duration", "0.5"]) == 0
    text = out.read_text()
    assert text.lstrip().lower().startswith("<!doctype html") or "<html" in text[:2000].lower()
    assert "<script" in text and len(text) > 100_000


def test_a_diverged_run_exits_4_and_still_prints_its_metrics(capsys):
    # A bound far below any tracking error stops the first check as diverged.
    code = main(["simulate", "--controller", "lin_lc", "--duration", "0.5", "--json",
                 "--set", "timing.divergence_bound=1e-9"])  # fmt: skip
    assert code == 4
    assert json.loads(capsys.readouterr().out)["status"] == "diverged"


def _run_warnings(stderr: str) -> list[str]:
    """The warning lines about a run's verdict (``saturated``, ``lost``, ``diverged``) on
    stderr."""
    return [line for line in stderr.splitlines() if ": warning: the " in line and " run " in line]


@pytest.mark.slow
def test_a_collapsed_arm_is_lost_with_one_warning_line_and_exit_5(weak_shoulder):
    # Issue 27, item 5: under the divergence bound all along, yet far from its path.
    result = _run("simulate", "--duration", "4", "--json", "--set", weak_shoulder)
    assert result.returncode == EXIT_NOT_TRACKED, result.stderr
    data = json.loads(result.stdout)
    assert data["status"] == "lost" and data["max_abs_q_err"] < 1.0  # the divergence bound
    assert "timing.lost_bound" in data["message"]
    (warning,) = _run_warnings(result.stderr)
    assert warning.startswith("posfb simulate: warning: ") and "lost its path" in warning


@pytest.mark.slow
def test_a_nominal_run_stays_ok_with_no_verdict_warning():
    result = _run("simulate", "--controller", "lin_lc", "--duration", "4", "--json")
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["status"] == "ok"
    assert _run_warnings(result.stderr) == []


@pytest.mark.slow
def test_compare_warns_about_the_lost_run_and_exits_with_the_worst_runs_code(weak_shoulder):
    result = _run("compare", "--controllers", "lin_lc,pid", "--duration", "4", "--json",
                  "--set", weak_shoulder)  # fmt: skip
    statuses = {kind: run["status"] for kind, run in json.loads(result.stdout).items()}
    assert statuses == {"lin_lc": "lost", "pid": "diverged"}
    assert result.returncode == EXIT_DIVERGED  # the worse of the two
    lost, diverged = _run_warnings(result.stderr)
    assert lost.startswith("posfb compare: warning: the Lin + LC run lost its path")
    assert diverged.startswith("posfb compare: warning: the computed torque + PID run diverged: ")


def test_compare_names_every_run_that_is_not_ok_and_exits_with_the_worst_code(capsys):
    # Issue 40: a diverged run gets its line too (as a saturated or lost one does).
    code = main(["compare", "--controllers", "lin_lc,pid", "--duration", "0.5", "--set",
                 "timing.divergence_bound=1e-9", "--no-progress"])  # fmt: skip
    assert code == EXIT_DIVERGED
    warnings = _run_warnings(capsys.readouterr().err)
    assert len(warnings) == 2, warnings
    for warning, label in zip(warnings, ("Lin + LC", "computed torque + PID"), strict=True):
        assert warning.startswith(f"posfb compare: warning: the {label} run diverged: |q~| = ")
        assert "exceeds divergence_bound = 1e-09 rad" in warning


def test_the_exit_code_of_runs_is_the_worst_runs():
    assert run_exit_code(["ok", "ok"]) == 0
    assert run_exit_code(["ok", "saturated"]) == run_exit_code(["lost"]) == EXIT_NOT_TRACKED
    assert run_exit_code(["saturated", "diverged", "ok"]) == EXIT_DIVERGED
    assert len({0, EXIT_DIVERGED, EXIT_NOT_TRACKED, EXIT_BAD_INPUT, EXIT_INTERNAL_ERROR}) == 5


def test_the_filter_a_that_a_refusal_suggests_runs(capsys):
    assert main(["simulate", "--sample-time", "0.005", "--duration", "0.5"]) == 2
    error = capsys.readouterr().err
    suggestion = error.rsplit("--set ", 1)[1].rstrip(")\n")
    assert suggestion.startswith("controller.filter_a=")
    assert main(["simulate", "--sample-time", "0.005", "--duration", "0.5", "--json",
                 "--set", suggestion]) == 0  # fmt: skip


def test_numpy_scalars_in_messages_are_plain_numbers():
    from posfb.analysis.cli import plain_numbers

    assert plain_numbers("x = np.float64(1.5); y = [np.int64(3)]") == "x = 1.5; y = [3]"
