"""A new user's route through posfb, step by step, on a six- and a seven-joint arm (issue 45,
item 1):

    .venv/bin/python bench/bench_route.py [--arms six_joint,panda] [--steps check,margins,...]
        [--quick] [--warm] [--profile] [--out route.json]

The arms: ``six_joint`` is the shipped ``six_joint_tuned`` scenario; ``panda`` is the
seven-joint Franka Emika Panda description of the registry's ``example-robot-data``
package, read as published (no gear, no motor data), with the drive data a user gives
for it (per joint a Coulomb level of 2 % and a viscous damping of 1 % of its rated
effort, ``tests/helpers/published.py``'s shares) and a scenario written by ``posfb
scenario init`` (its own step, ``init``).

The steps, each one ``posfb`` command in a fresh process, timed from start to exit:
``init`` (panda), ``check`` (``scenario check``, with its run of the exact arm),
``margins`` (``design --margins``), ``tune`` (at its defaults), ``compare`` (five
controllers, 20 s), ``montecarlo`` (20 samples of 5 s, one worker per core) and
``report`` (``montecarlo report`` of them), ``plan`` (``identify plan``, 60 s) and
``identify`` (``identify --log`` of a 60 s Lin+LC log of the scenario's own trajectory
at 1 kHz, simulated first and not timed). ``--quick`` shrinks tune, compare, the study and the
log to a smoke run of the route (the figures are then not the targets').

Cold: a fresh, empty ``POSFB_CACHE_DIR`` per arm (the first command pays the Assumption-1
bounds and every other cached figure); ``--warm`` runs each step a second time on the
warm cache. ``--profile`` runs each step once more under ``cProfile`` and keeps its
``PROFILE_ENTRIES`` entries of largest cumulative time. The JSON (``--out``) holds the
machine, each arm's steps (seconds cold and warm, exit code, profile) and the command
lines; the table is printed as the steps finish.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import pstats
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

#: The package's robot descriptions (a cmeel prefix).
ROBOTS = "cmeel.prefix/share/example-robot-data/robots"
PANDA = "panda_description/urdf/panda.urdf"

#: The drive data a user writes for a joint of rated effort ``tau`` (N m): shares of it.
DRIVE_SHARES = {"coulomb": 0.02, "damping": 0.01}

#: Profile entries kept per step.
PROFILE_ENTRIES = 12

#: The controllers ``compare`` runs.
CONTROLLERS = "pid,lin_lc,proposed,pd_gravity,adrc"

#: The study of the ``montecarlo`` step (its scenario, samples and duration filled in).
STUDY = """\
seed: 1
scenario: {scenario}
samples: {samples}
duration: {duration}
controllers: [proposed, lin_lc, pid]
parameters:
  link_mass: [!Uniform {{min: -0.2, max: 0.2, relative: true}}]
"""

#: tune's options for ``--quick`` (a smoke run, not the defaults the target is for).
QUICK_TUNE = ["--plants", "2", "--generations", "3", "--rounds", "1", "--epsilon", "0.5",
              "--beta", "0.5", "--accept-worse"]  # fmt: skip


def posfb_command() -> list[str]:
    """The ``posfb`` console script of this interpreter, else the module."""
    script = Path(sys.executable).with_name("posfb")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "posfb.analysis.cli"]


def published(relative: str) -> Path:
    """The file ``relative`` of example-robot-data's robots folder."""
    root = Path(str(metadata.distribution("example-robot-data").locate_file(ROBOTS)))
    return root / relative


def write_drives(urdf: Path, target: Path) -> Path:
    """The ``--drives`` file a user writes for ``urdf`` (module docstring)."""
    efforts = [float(joint.find("limit").get("effort"))
               for joint in ET.parse(urdf).getroot().findall("joint")
               if joint.get("type") in ("revolute", "continuous")]  # fmt: skip
    target.write_text("".join(
        f"{name}: [{', '.join(f'{share * effort:g}' for effort in efforts)}]\n"
        for name, share in DRIVE_SHARES.items()
    ))  # fmt: skip
    return target


def steps(scenario: str, quick: bool) -> dict[str, list[str]]:
    """Each step's ``posfb`` arguments on ``scenario`` (module docstring)."""
    duration = "2" if quick else "20"
    return {
        "check": ["scenario", "check", scenario],
        "margins": ["design", "--scenario", scenario, "--margins", "--json"],
        "tune": ["tune", scenario, "--out", "tuned.yaml", "--force", "--no-progress",
                 *(QUICK_TUNE if quick else [])],
        "compare": ["compare", "--scenario", scenario, "--controllers", CONTROLLERS,
                    "--set", f"timing.duration={duration}", "--json", "--no-progress"],
        "montecarlo": ["montecarlo", "run", "study.yaml", "--db", "study.sqlite",
                       "--no-progress"],
        "report": ["montecarlo", "report", "--db", "study.sqlite", "--out", "report"],
        "plan": ["identify", "plan", "--scenario", scenario, "--out", "plan.csv", "--force",
                 *(["--duration", "10"] if quick else [])],
        "identify": ["identify", "--scenario", scenario, "--log", "log.csv", "--json"],
    }  # fmt: skip


def run(args: list[str], folder: Path, env: dict[str, str]) -> tuple[float, int, str]:
    """``posfb args`` in ``folder``: its wall time, exit code and the tail of stderr."""
    began = time.perf_counter()
    done = subprocess.run([*posfb_command(), *args], cwd=folder, env=env, capture_output=True,
                          text=True, check=False)  # fmt: skip
    return time.perf_counter() - began, done.returncode, done.stderr[-400:]


def profile(args: list[str], folder: Path, env: dict[str, str]) -> list[dict[str, object]]:
    """``posfb args`` once under ``cProfile``: its ``PROFILE_ENTRIES`` largest cumulative."""
    out = folder / "profile.out"
    subprocess.run([sys.executable, "-m", "cProfile", "-o", str(out), "-m",
                    "posfb.analysis.cli", *args], cwd=folder, env=env, capture_output=True,
                   check=False)  # fmt: skip
    if not out.is_file():
        return []
    stats = pstats.Stats(str(out))
    rows = sorted(stats.stats.items(), key=lambda item: item[1][3], reverse=True)
    return [{"function": f"{Path(file).name}:{line}({name})", "cumulative_s": round(row[3], 3),
             "calls": row[1]} for (file, line, name), row in rows[:PROFILE_ENTRIES]]  # fmt: skip


def prepare(arm: str, folder: Path, quick: bool, env: dict[str, str]) -> tuple[str, dict]:
    """The arm's scenario in ``folder`` (panda: written by ``scenario init``, timed as the
    ``init`` step) and the study and log its steps read."""
    timed: dict[str, dict] = {}
    if arm == "six_joint":
        shutil.copy(Path(__file__).resolve().parent.parent / "analysis/scenarios"
                    / "six_joint_tuned.yaml", folder / "arm.yaml")  # fmt: skip
        scenario = "arm.yaml"
    elif arm == "panda":
        urdf = published(PANDA)
        drives = write_drives(urdf, folder / "drives.yaml")
        seconds, code, tail = run(["scenario", "init", "--urdf", str(urdf), "--drives",
                                   str(drives), "--out", "arm.yaml"], folder, env)  # fmt: skip
        timed["init"] = {"cold_s": round(seconds, 2), "exit": code, "stderr": tail}
        scenario = "arm.yaml"
    else:
        raise SystemExit(f"--arms: {arm!r}; six_joint or panda is required")
    samples, duration = (2, 1) if quick else (20, 5)  # the report target: 20 samples
    (folder / "study.yaml").write_text(STUDY.format(scenario=scenario, samples=samples,
                                                    duration=duration))  # fmt: skip
    return scenario, timed


def make_log(scenario: str, folder: Path, quick: bool, env: dict[str, str]) -> None:
    """The log ``identify`` reads: Lin+LC on the scenario's trajectory sampled at 1 kHz, a
    drive's rate (``bench_identification.py``'s; not timed)."""
    duration = "30" if quick else "60"
    run(["simulate", "--scenario", scenario, "--controller", "lin_lc", "--set",
         f"timing.duration={duration}", "--set", "timing.sample_time=0.001", "--out", "log.csv",
         "--force", "--no-progress"], folder, env)  # fmt: skip


def route(arm: str, chosen: list[str], options: argparse.Namespace,
          report: Callable[[str], None]) -> dict[str, dict]:  # fmt: skip
    """The timed steps of one arm."""
    folder = Path(tempfile.mkdtemp(prefix=f"route-{arm}-"))
    cache = folder / "cache"
    env = {**os.environ, "POSFB_CACHE_DIR": str(cache), "MPLBACKEND": "Agg"}
    scenario, timed = prepare(arm, folder, options.quick, env)
    for name, entry in timed.items():
        report(f"{arm:10s} {name:11s} {entry['cold_s']:8.2f} s cold  exit {entry['exit']}")
    commands = steps(scenario, options.quick)
    for name in chosen:
        if name == "identify":
            make_log(scenario, folder, options.quick, env)
        seconds, code, tail = run(commands[name], folder, env)
        entry = {"command": commands[name], "cold_s": round(seconds, 2), "exit": code}
        if code != 0:
            entry["stderr"] = tail
        if options.warm:
            entry["warm_s"] = round(run(commands[name], folder, env)[0], 2)
        if options.profile:
            entry["profile"] = profile(commands[name], folder, env)
        timed[name] = entry
        warm = f"  {entry['warm_s']:8.2f} s warm" if options.warm else ""
        report(f"{arm:10s} {name:11s} {seconds:8.2f} s cold{warm}  exit {code}")
    shutil.rmtree(folder, ignore_errors=True)
    return timed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", default="six_joint,panda")
    parser.add_argument("--steps", default="check,margins,tune,compare,montecarlo,report,plan,"
                        "identify")  # fmt: skip
    parser.add_argument("--quick", action="store_true", help="a smoke run of the route")
    parser.add_argument("--warm", action="store_true", help="each step again, cache warm")
    parser.add_argument("--profile", action="store_true", help="each step under cProfile")
    parser.add_argument("--out", type=Path, help="JSON of the figures")
    options = parser.parse_args()
    chosen = options.steps.split(",")
    known = steps("arm.yaml", False)
    unknown = [name for name in chosen if name not in known]
    if unknown:
        parser.error(f"--steps: {', '.join(unknown)}; of {', '.join(known)}")
    results = {
        "machine": {"python": platform.python_version(), "cores": os.cpu_count(),
                    "processor": platform.processor() or platform.machine()},
        "quick": options.quick,
        "arms": {},
    }  # fmt: skip
    for arm in options.arms.split(","):
        results["arms"][arm] = route(arm, chosen, options, print)
    if options.out is not None:
        options.out.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
