"""Simulated seconds per wall second of one closed-loop run, per controller.

    .venv/bin/python bench/bench_closed_loop.py [--duration 20] [--repeat 5]

The shipped paper scenarios (``analysis/scenarios/paper_*.yaml``: T_s = 0.01 s,
RK3 at accuracy 3e-3, 20000-count encoder) on the nominal and the payload arm,
plus the proposed controller with the second study's alpha* = 2.75. The
diagram is built once per controller and case (build time printed separately);
each figure is the best of ``--repeat`` runs on fresh Contexts (the run's own
``wall_time_s``: Initialize + AdvanceTo, logging included).
"""

from __future__ import annotations

import argparse
import statistics
import time

from posfb.analysis.experiment import case_scenario
from posfb.diagrams.closed_loop import ClosedLoopRunner
from posfb.diagrams.resolve import resolve
from posfb.models.controllers import CONTROLLER_KINDS

#: (label, scenario settings) of every benchmarked variant.
VARIANTS = [(kind, (f"controller.kind={kind}",)) for kind in CONTROLLER_KINDS] + [
    ("proposed, alpha*=2.75", ("controller.kind=proposed", "controller.alpha_star=2.75"))
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    print(f"{args.duration:g} s runs, best and median of {args.repeat}")
    print("| controller | case | build s | wall s (best) | wall s (median) | sim s / wall s |")
    print("|---|---|---:|---:|---:|---:|")
    for label, settings in VARIANTS:
        for case in ("nominal", "payload"):
            loaded = case_scenario(case, (*settings, f"timing.duration={args.duration}"))
            resolved = resolve(loaded)
            start = time.perf_counter()
            runner = ClosedLoopRunner(resolved.config)
            build = time.perf_counter() - start
            parameters = resolved.true_parameters(runner.arm.default_parameters)
            walls = [runner.run(parameters).wall_time_s for _ in range(args.repeat)]
            best = min(walls)
            print(
                f"| {label} | {case} | {build:.2f} | {best:.3f} | "
                f"{statistics.median(walls):.3f} | {args.duration / best:.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
