"""Simulated seconds per wall second of one closed-loop run, per controller.

    .venv/bin/python bench/bench_closed_loop.py [--duration 20] [--repeat 5]

Paper settings (``diagrams.closed_loop.ClosedLoopConfig`` defaults: T_s = 0.01 s,
RK3 at accuracy 3e-3, 20000-count encoder) on the nominal and the payload arm,
plus the proposed controller with the second study's alpha* = 2.75. The
diagram is built once per controller (build time printed separately); each
figure is the best of ``--repeat`` runs on fresh Contexts (the run's own
``wall_time_s``: Initialize + AdvanceTo, logging included).
"""

from __future__ import annotations

import argparse
import statistics
import time

from posfb.analysis.experiment import case_parameters
from posfb.diagrams.closed_loop import ClosedLoopConfig, ClosedLoopRunner
from posfb.models.controllers import CONTROLLER_KINDS
from posfb.models.design import ControllerConfig


def _variants() -> list[tuple[str, str, ControllerConfig | None]]:
    fixed = ControllerConfig().with_alpha_star(2.75)
    return [(kind, kind, None) for kind in CONTROLLER_KINDS] + [
        ("proposed, alpha*=2.75", "proposed", fixed)
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    print(f"{args.duration:g} s runs, best and median of {args.repeat}")
    print("| controller | case | build s | wall s (best) | wall s (median) | sim s / wall s |")
    print("|---|---|---:|---:|---:|---:|")
    for label, kind, controller_config in _variants():
        start = time.perf_counter()
        runner = ClosedLoopRunner(
            ClosedLoopConfig(controller=kind, duration=args.duration),
            controller_config=controller_config,
        )
        build = time.perf_counter() - start
        for case in ("nominal", "payload"):
            parameters = case_parameters(runner.arm, case)
            walls = [runner.run(parameters).metrics.wall_time_s for _ in range(args.repeat)]
            best = min(walls)
            print(
                f"| {label} | {case} | {build:.2f} | {best:.3f} | "
                f"{statistics.median(walls):.3f} | {args.duration / best:.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
