"""What ``posfb scenario check`` spends on a scenario's verdicts (issue 40), per part:

    .venv/bin/python bench/bench_verdicts.py [--scenario six_joint_nominal|FILE] [--repeat 3]

the configuration set, the design's sampled-data checks over it (and the common-Lyapunov
certificate of the scenario controller's loop), the margins at ``M0*`` and at the frozen
configurations that bound them, and the exact arm's run. Each part is timed in this one
process (imports and the design cache warm after the first repeat); the median and the
smallest of ``--repeat`` are printed, with the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from collections.abc import Callable


def _timed(part: Callable[[], object], repeat: int) -> tuple[float, float]:
    times = []
    for _ in range(repeat):
        began = time.perf_counter()
        part()
        times.append(time.perf_counter() - began)
    return statistics.median(times), min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="six_joint_nominal",
                        help="a shipped scenario's name or a scenario file")  # fmt: skip
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()

    import posfb
    from posfb.analysis.api import shipped_scenarios
    from posfb.analysis.common.configurations import scenario_configurations
    from posfb.analysis.design.design_report import nominal_design
    from posfb.analysis.design.exact_arm import exact_arm_run
    from posfb.analysis.design.linear_loop import linear_design
    from posfb.diagrams.resolve import resolve
    from posfb.models.design.configurations import path_configurations
    from posfb.models.nominal import nominal_model

    path = shipped_scenarios().get(args.scenario, args.scenario)  # a name, or a file
    resolved = resolve(posfb.load_scenario(path))
    linear = linear_design(resolved)

    config = resolved.config

    def configurations() -> object:  # uncached: what a scenario's first verdict pays
        model = nominal_model(config.design.nominal)
        spacing = config.timing.configuration_spacing
        return path_configurations(model, config.trajectory, config.timing.duration, spacing)

    parts = {
        "configuration set": configurations,
        "design checks over it + certificate": lambda: nominal_design(resolved),
        "margins at M0*": linear.margins,
        "margins at the frozen configurations": linear.frozen_margins,
        "exact arm's run": lambda: exact_arm_run(resolved),
    }
    print(f"{args.scenario}: {len(scenario_configurations(resolved.config))} configurations; "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs")  # fmt: skip
    print("| part | median (s) | min (s) |\n|---|---:|---:|")
    total = 0.0
    for name, part in parts.items():
        median, least = _timed(part, args.repeat)
        total += median
        print(f"| {name} | {median:.3f} | {least:.3f} |")
    print(f"| total | {total:.3f} | |")


if __name__ == "__main__":
    main()
