"""``posfb simulate``, ``graph`` and ``animate`` as a user runs them."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from posfb.analysis.cli import main
from posfb.diagrams import graph

CLI = [sys.executable, "-m", "posfb.analysis.cli"]


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120)


def test_simulate_json_has_the_documented_keys():
    result = _run(
        "simulate", "--controller", "pid", "--case", "payload", "--duration", "1", "--json"
    )
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert {"rms_q", "rms_u", "max_abs_q_err", "saturated_fraction", "wall_time_s"} <= set(data)
    assert len(data["rms_q"]) == len(data["rms_u"]) == 2
    assert data["status"] == "ok" and data["scenario"] == "payload"


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
