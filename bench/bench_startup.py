"""Start-up time of the ``posfb`` command line (issue 19, item 7).

    .venv/bin/python bench/bench_startup.py [--repeat 5]

Each command runs ``--repeat`` times in a fresh process (nothing imported, the
operating system's file cache warm after the first), and the wall time from
start to exit is reported, median and min: the interpreter alone, ``import posfb``,
``posfb --help``, a command's ``--help``, one refusal of each kind of bad input (an
argparse type error, which must not import the models; a missing scenario file
and an unknown ``--set`` key, which need the scenario loader) and a real 1 s run
(``posfb simulate --duration 1 --json``: imports, design, diagram build and the
simulation). The exit column is the code every repeat returned; ``!`` marks one that
was not the expected code.

A second table splits a 1 s run on the shipped three-link arm (issue 27) into the time
outside the simulation (imports, scenario, design, diagram build: the process's wall
time less the run's own ``wall_time_s``) and the simulation, per controller: Lin+LC
never computes the Assumption-1 bounds, and the paper's controller reads them from the
on-disk cache (``models.disk_cache``) after the first run, which the ``cold`` row pays
(a fresh, empty cache folder).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The ``posfb`` console script of this interpreter's environment, else the module.
_SCRIPT = Path(sys.executable).with_name("posfb")
POSFB = [str(_SCRIPT)] if _SCRIPT.is_file() else [sys.executable, "-m", "posfb.analysis.cli"]

#: (what, command, expected exit code) of every row.
CASES = [
    ("interpreter alone", [sys.executable, "-c", "pass"], 0),
    ("import posfb", [sys.executable, "-c", "import posfb"], 0),
    ("posfb --help", [*POSFB, "--help"], 0),
    ("posfb simulate --help", [*POSFB, "simulate", "--help"], 0),
    ("refusal: argparse type", [*POSFB, "design", "--sample-time", "abc"], 2),
    ("refusal: argparse type", [*POSFB, "montecarlo", "run", "s.yaml", "--workers", "x"], 2),
    ("refusal: missing scenario", [*POSFB, "simulate", "--scenario", "/nonexistent.yaml"], 2),
    (
        "refusal: unknown --set key",
        [*POSFB, "simulate", "--set", "timing.nope=1", "--duration", "1"],
        2,
    ),
    ("1 s run", [*POSFB, "simulate", "--duration", "1", "--json"], 0),
]


THREE_LINK = Path(__file__).resolve().parent.parent / "analysis/scenarios/three_link_nominal.yaml"

#: (what, controller, whether each repeat starts with an empty cache) of the split rows.
SPLIT_CASES = [
    ("Lin+LC", "lin_lc", True),
    ("proposed, cold cache", "proposed", True),
    ("proposed, warm cache", "proposed", False),
]


def timed(command: list[str], env: dict[str, str] | None = None) -> tuple[float, int]:
    """Wall seconds of one fresh process running ``command``, and its exit code."""
    start = time.perf_counter()
    result = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    return time.perf_counter() - start, result.returncode


def split_run(controller: str, cache: str) -> tuple[float, float]:
    """Wall seconds of a fresh ``posfb simulate`` of the three-link arm with
    ``controller`` for 1 s, outside the simulation and in it (the run's ``wall_time_s``)."""
    command = [
        *POSFB, "simulate", "--scenario", str(THREE_LINK), "--controller", controller,
        "--duration", "1", "--json",
    ]  # fmt: skip
    env = {**os.environ, "POSFB_CACHE_DIR": cache}
    start = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True, env=env, check=True)
    total = time.perf_counter() - start
    simulation = float(json.loads(result.stdout)["wall_time_s"])
    return total - simulation, simulation


def print_split(repeat: int) -> None:
    """The table of ``SPLIT_CASES`` (module docstring)."""
    print("\n| three-link arm, 1 s run | outside the simulation, median s | simulation s |")
    print("|---|---:|---:|")
    with tempfile.TemporaryDirectory() as warm:
        split_run("proposed", warm)  # fills the warm cache
        for what, controller, cold in SPLIT_CASES:
            rows = []
            for _ in range(repeat):
                with tempfile.TemporaryDirectory() as fresh:
                    rows.append(split_run(controller, fresh if cold else warm))
            outside, simulation = (statistics.median(column) for column in zip(*rows, strict=True))
            print(f"| {what} | {outside:.3f} | {simulation:.3f} |", flush=True)


def shown(command: list[str]) -> str:
    """``command`` as a user types it (the interpreter and the script by name)."""
    words = ["python" if word == sys.executable else word for word in command]
    if command[: len(POSFB)] == POSFB:
        words = ["posfb", *command[len(POSFB) :]]
    return shlex.join(words)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    print(
        f"Python {platform.python_version()}, {os.cpu_count()} cores; wall seconds of a "
        f"fresh process, median and min of {args.repeat}"
    )
    print("| what | command | exit | median s | min s |")
    print("|---|---|---:|---:|---:|")
    for what, command, expected in CASES:
        times, codes = [], set()
        for _ in range(args.repeat):
            seconds, code = timed(command)
            times.append(seconds)
            codes.add(code)
        exit_text = ",".join(str(code) for code in sorted(codes))
        if codes != {expected}:
            exit_text += " !"
        print(
            f"| {what} | `{shown(command)}` | {exit_text} | {statistics.median(times):.3f} | "
            f"{min(times):.3f} |",
            flush=True,
        )
    print_split(args.repeat)


if __name__ == "__main__":
    main()
