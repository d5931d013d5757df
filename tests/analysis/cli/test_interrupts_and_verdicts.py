"""Verdicts usable in scripts (``--strict``, warnings for a failed design), Ctrl-C on a
Monte-Carlo run, and the set-up's Python check."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers.paths import REPO
from posfb.analysis.cli import main
from posfb.models.controllers import design_checks, spec

ROOT = REPO
CLI = [sys.executable, "-m", "posfb.analysis.cli"]


def test_design_strict_exits_1_only_when_a_check_fails(capsys):
    # --no-sim here and below: the exit code of the checks is the property; the exact arm's
    # run and its code are tests/analysis/cli/test_cli_design.py's and test_configurations.py's
    assert main(["design", "--no-sim"]) == 0  # the report is the result
    assert main(["design", "--strict", "--no-sim"]) == 1  # the paper's alpha* = 4 fails at 100 Hz
    assert main(["design", "--strict", "--alpha-star", "2.75", "--no-sim"]) == 0
    capsys.readouterr()


def test_scenario_check_strict_looks_at_every_check_of_the_entry(capsys):
    # A Lin+LC entry determines Lin+LC's checks only; the paper's controller's entry holds
    # Lin+LC's inputs too, so --strict adds Lin+LC's sampled loop to its own checks.
    nominal = str(ROOT / "analysis" / "scenarios" / "paper_nominal.yaml")
    assert main(["scenario", "check", nominal, "--set", "controller.kind=lin_lc", "--strict",
                 "--no-sim"]) == 0
    assert "every check of the design passed" in capsys.readouterr().out
    assert main(["scenario", "check", nominal, "--strict", "--no-sim"]) == 1
    assert "fails sampled_data" in capsys.readouterr().out
    assert set(design_checks("proposed")) == set(design_checks("lin_lc")) | set(
        spec("proposed").checks
    ) and "sampled_data_lin_lc" not in spec("proposed").checks


def test_simulate_warns_when_its_design_fails_a_check(capsys):
    assert main(["simulate", "--duration", "0.5"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "warning" in err[0] and "spectral radius 1.0426" in err[0]
    assert main(["simulate", "--duration", "0.5", "--alpha-star", "2.75"]) == 0
    assert capsys.readouterr().err == ""


STUDY = """\
seed: 5
samples: 40
duration: 2.0
controllers: [lin_lc]
parameters:
  payload_mass: !Uniform {min: 0.0, max: 0.3}
"""


def _stored(db: Path) -> list[tuple]:
    with sqlite3.connect(db) as connection:
        return connection.execute(
            "SELECT sample, controller, status, rms_q1, rms_q2 FROM runs ORDER BY sample"
        ).fetchall()


@pytest.mark.slow
def test_ctrl_c_keeps_finished_samples_says_so_and_the_same_command_resumes(tmp_path):
    study, db = tmp_path / "study.yaml", tmp_path / "store.sqlite"
    study.write_text(STUDY)
    command = [*CLI, "montecarlo", "run", str(study), "--db", str(db), "--no-progress"]
    process = subprocess.Popen(
        [*command, "--workers", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, start_new_session=True,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (db.exists() and _count(db) >= 2):
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGINT)  # Ctrl-C reaches the whole process group
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130
    lines = err.strip().splitlines()
    assert "samples are saved in" in lines[-1] and "run the same command again" in lines[-1]
    assert "Traceback" not in err
    saved = _count(db)
    assert saved >= 2
    report = subprocess.run(
        [*CLI, "montecarlo", "report", "--db", str(db), "--out", str(tmp_path / "report")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert report.returncode == 0 and f"{40 - saved} of 40 samples are missing" in report.stderr
    assert "Unfinished study" in (tmp_path / "report" / "report.md").read_text()
    resumed = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    rows = _stored(db)
    assert [row[0] for row in rows] == list(range(40))  # every sample once


def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (from ``/proc``: parent ids)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            parents[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier}
        found |= frontier
    return found


def _running(pid: int) -> bool:
    """Whether ``pid`` exists and is not a zombie (dead, waiting to be reaped)."""
    try:
        return (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.slow
def test_a_run_killed_by_sigterm_leaves_no_worker_behind(tmp_path):
    """The forkserver's workers are not the run's children: killed outright, the run
    cannot stop them, so they end themselves (``analysis.montecarlo.watchdog``)."""
    study, db = tmp_path / "study.yaml", tmp_path / "store.sqlite"
    study.write_text(STUDY)
    process = subprocess.Popen(
        [*CLI, "montecarlo", "run", str(study), "--db", str(db), "--no-progress",
         "--workers", "2"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (db.exists() and _count(db) >= 1):
        time.sleep(0.2)
    below = _descendants(process.pid)
    assert len(below) >= 3  # the forkserver and two workers (and the resource tracker)
    process.terminate()  # SIGTERM to the run alone, not its process group
    process.wait(timeout=60)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(_running(pid) for pid in below):
        time.sleep(0.2)
    assert not [pid for pid in below if _running(pid)]


def _count(db: Path) -> int:
    try:
        with sqlite3.connect(db) as connection:
            return connection.execute("SELECT COUNT(*) FROM samples").fetchone()[0]
    except sqlite3.Error:
        return 0


def test_setup_refuses_an_old_python_before_doing_anything(tmp_path):
    fake = tmp_path / "python3.10"
    fake.write_text('#!/bin/sh\ncase "$2" in *exit*) exit 1;; *) echo 3.10.14;; esac\n')
    fake.chmod(0o755)
    result = subprocess.run(
        ["bash", str(ROOT / "bin" / "setup")], env={**os.environ, "PYTHON": str(fake)},
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert result.returncode == 2
    assert "needs Python >= 3.11" in result.stderr and "found 3.10.14" in result.stderr
