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
"""

from __future__ import annotations

import argparse
import os
import platform
import shlex
import statistics
import subprocess
import sys
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


def timed(command: list[str]) -> tuple[float, int]:
    """Wall seconds of one fresh process running ``command``, and its exit code."""
    start = time.perf_counter()
    result = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start, result.returncode


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


if __name__ == "__main__":
    main()
