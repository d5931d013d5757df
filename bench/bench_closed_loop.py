"""Simulated seconds per wall second of one closed-loop run, per controller.

    .venv/bin/python bench/bench_closed_loop.py [--duration 20] [--repeat 5] [--arms | --blocks]

The shipped paper scenarios (``analysis/scenarios/paper_*.yaml``: T_s = 0.01 s,
RK3 at accuracy 3e-3, 20000-count encoder) on the nominal and the payload arm,
plus the proposed controller with the second study's alpha* = 2.75. The
diagram is built once per controller and case (build time printed separately);
each figure is the best of ``--repeat`` runs on fresh Contexts (the run's own
``wall_time_s``: Initialize + AdvanceTo, logging included).

``--arms``: the cost of a run against the number of joints ``n`` (issue 13), one
shipped scenario per arm with its own nominal model and settings
(``paper_nominal.yaml``: n = 2, ``three_link_nominal.yaml``: n = 3,
``six_joint_nominal.yaml``: n = 6). Per controller: the build time (the design
included, computed once per process), the best run, the integrator's steps and
derivative evaluations, and wall microseconds per evaluation. The arms differ in
trajectory, gains and stiffness: a row is what a user of that arm pays, not the
same motion on more joints.

``--blocks``: the paper's cases with each implementation of the motor and friction
blocks (``plant.motor_friction_blocks``, ``models.drive``): best wall time, derivative
evaluations and RMS(q~) of each, the speed-up, and the largest RMS difference,
absolute (rad) and relative, of ``perceptron`` from ``symbolic``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from posfb.analysis.common.metrics import run_metrics
from posfb.analysis.paper.experiment import case_scenario
from posfb.diagrams.resolve import LoadedScenario, load_scenario, resolve
from posfb.diagrams.runner import ClosedLoopResult, ClosedLoopRunner
from posfb.models.controllers import PAPER_CONTROLLERS
from posfb.models.drive import MOTOR_FRICTION_BLOCKS

SCENARIOS = Path(__file__).resolve().parent.parent / "analysis" / "scenarios"

#: (n, scenario file) of every arm of ``--arms``.
ARMS = ((2, "paper_nominal.yaml"), (3, "three_link_nominal.yaml"), (6, "six_joint_nominal.yaml"))

#: (label, scenario settings) of every benchmarked variant.
VARIANTS = [(kind, (f"controller.kind={kind}",)) for kind in PAPER_CONTROLLERS] + [
    ("proposed, alpha*=2.75", ("controller.kind=proposed", "controller.alpha_star=2.75"))
]


def timed_runs(loaded: LoadedScenario, repeat: int) -> tuple[float, list[ClosedLoopResult]]:
    """The build time of the scenario's closed loop and ``repeat`` runs of it."""
    resolved = resolve(loaded)
    start = time.perf_counter()
    runner = ClosedLoopRunner(resolved.config)
    build = time.perf_counter() - start
    parameters = resolved.true_parameters(runner.arm.default_parameters)
    return build, [runner.run(parameters) for _ in range(repeat)]


def paper_cases(duration: float, repeat: int) -> None:
    print(f"{duration:g} s runs, best and median of {repeat}")
    print("| controller | case | build s | wall s (best) | wall s (median) | sim s / wall s |")
    print("|---|---|---:|---:|---:|---:|")
    for label, settings in VARIANTS:
        for case in ("nominal", "payload"):
            loaded = case_scenario(case, (*settings, f"timing.duration={duration}"))
            build, runs = timed_runs(loaded, repeat)
            walls = [run.wall_time_s for run in runs]
            best = min(walls)
            print(
                f"| {label} | {case} | {build:.2f} | {best:.3f} | "
                f"{statistics.median(walls):.3f} | {duration / best:.1f} |",
                flush=True,
            )


def arms(duration: float, repeat: int) -> None:
    print(f"{duration:g} s runs, best of {repeat}")
    print("| n | controller | build s | wall s | steps | evaluations | us / evaluation |")
    print("|---:|---|---:|---:|---:|---:|---:|")
    for joints, name in ARMS:
        for kind in PAPER_CONTROLLERS:
            settings = (f"controller.kind={kind}", f"timing.duration={duration}")
            build, runs = timed_runs(load_scenario(SCENARIOS / name, settings), repeat)
            best = min(runs, key=lambda run: run.wall_time_s)
            per_evaluation = 1e6 * best.wall_time_s / max(best.derivative_evaluations, 1)
            print(
                f"| {joints} | {kind} | {build:.2f} | {best.wall_time_s:.2f} | "
                f"{best.integrator_steps} | {best.derivative_evaluations} | {per_evaluation:.1f} |",
                flush=True,
            )


def blocks(duration: float, repeat: int) -> None:
    symbolic, perceptron = MOTOR_FRICTION_BLOCKS
    print(f"{duration:g} s runs, best of {repeat}: {symbolic} against {perceptron}")
    print(
        f"| controller | case | {symbolic} s | {perceptron} s | speed-up | evaluations | "
        f"RMS q~ {symbolic} (rad) | RMS q~ {perceptron} (rad) | max abs diff (rad) | "
        "max rel diff |"
    )
    print("|---|---|---:|---:|---:|---|---|---|---:|---:|")
    for label, settings in VARIANTS:
        for case in ("nominal", "payload"):
            best = {}
            for kind in MOTOR_FRICTION_BLOCKS:
                extra = (f"timing.duration={duration}", f"plant.motor_friction_blocks={kind}")
                _, runs = timed_runs(case_scenario(case, (*settings, *extra)), repeat)
                best[kind] = min(runs, key=lambda run: run.wall_time_s)
            rms = {kind: np.array(run_metrics(run).rms_q) for kind, run in best.items()}
            difference = np.abs(rms[perceptron] - rms[symbolic])
            print(
                f"| {label} | {case} | {best[symbolic].wall_time_s:.3f} | "
                f"{best[perceptron].wall_time_s:.3f} | "
                f"{best[symbolic].wall_time_s / best[perceptron].wall_time_s:.2f} | "
                f"{best[symbolic].derivative_evaluations} / "
                f"{best[perceptron].derivative_evaluations} | "
                + " | ".join(", ".join(f"{x:.6g}" for x in rms[kind]) for kind in rms)
                + f" | {difference.max():.1e} | {(difference / rms[symbolic]).max():.1e} |",
                flush=True,
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--repeat", type=int, default=5)
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--arms", action="store_true", help="cost against the number of joints")
    mode.add_argument("--blocks", action="store_true", help="symbolic against perceptron blocks")
    args = parser.parse_args()
    run = arms if args.arms else blocks if args.blocks else paper_cases
    run(args.duration, args.repeat)


if __name__ == "__main__":
    main()
