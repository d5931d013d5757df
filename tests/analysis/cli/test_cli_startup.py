"""``posfb`` starts fast (issue 19): building the parser imports only the chosen
command's module, and no command module loads Drake, pandas, scipy or matplotlib
before its handler runs. Structure only, no timings (``bench/bench_startup.py``
measures them)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from posfb.analysis.cli import COMMANDS

CLI = [sys.executable, "-m", "posfb.analysis.cli"]

#: Modules a parser must not import (each costs a large part of a second or more).
HEAVY = ("pydrake", "matplotlib", "pandas", "scipy")

#: ``python -c``: build the parser for ``argv[1:]``, print the heavy modules loaded.
BUILD = f"""
import sys
from posfb.analysis.cli import build_parser
build_parser(sys.argv[1:])
print(" ".join(name for name in {HEAVY!r} if name in sys.modules))
"""

#: Each nested action, with its command.
ACTIONS = [
    ("scenario", "dump"),
    ("scenario", "check"),
    ("montecarlo", "run"),
    ("montecarlo", "report"),
    ("montecarlo", "export"),
    ("montecarlo", "replay"),
]


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120)


def _heavy_after_building(*argv: str) -> str:
    result = subprocess.run(
        [sys.executable, "-c", BUILD, *argv], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    return result.stdout.strip()


def test_the_top_level_parser_imports_nothing_heavy():
    assert _heavy_after_building() == ""
    assert _heavy_after_building("--help") == ""


@pytest.mark.parametrize("name", list(COMMANDS))
def test_a_command_parser_imports_nothing_heavy(name):
    assert _heavy_after_building(name) == ""


def test_the_top_level_help_lists_every_command_with_its_help():
    result = _run("--help")
    assert result.returncode == 0, result.stderr
    words = " ".join(result.stdout.split())  # argparse wraps long help lines
    for name, text in COMMANDS.items():
        assert f"{name} {text}" in words


@pytest.mark.parametrize("args", [(name,) for name in COMMANDS] + ACTIONS, ids=" ".join)
def test_every_command_help_exits_0(args):
    result = _run(*args, "--help")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"usage: posfb {' '.join(args)}")


def test_a_refused_option_is_one_line_and_exit_2():
    result = _run("design", "--sample-time", "abc")
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        "posfb: error: argument --sample-time: invalid float value: 'abc'"
    ]
