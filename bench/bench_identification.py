"""What ``posfb identify --log`` spends on a log of a six-joint arm (issue 42, item 8):

    .venv/bin/python bench/bench_identification.py [--scenario six_joint_nominal|FILE]
        [--duration 60] [--repeat 3]

A log of the scenario's own trajectory (Lin+LC, ``--duration`` s, with the reference
columns ``posfb simulate --out`` writes) is simulated once; then the identification is
timed (median and smallest of ``--repeat``), in this process after a first untimed run
(imports and caches warm). ``--profile`` prints the 15 functions of the largest
cumulative time of one more run (``cProfile``).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import tempfile
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="six_joint_nominal",
                        help="a shipped scenario's name or a scenario file")  # fmt: skip
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()

    import posfb
    from posfb.analysis.api import shipped_scenarios

    source = shipped_scenarios().get(args.scenario, args.scenario)
    loaded = posfb.load_scenario(source, set={"timing.duration": args.duration})
    log = Path(tempfile.mkdtemp(prefix="posfb-bench-")) / "log.csv"
    began = time.perf_counter()
    posfb.simulate(loaded, "lin_lc").save(log)
    print(f"{platform.node()}: {args.scenario}, a {args.duration:g} s log simulated in "
          f"{time.perf_counter() - began:.1f} s")  # fmt: skip
    posfb.identify(log, loaded)
    times = []
    for _ in range(args.repeat):
        began = time.perf_counter()
        result = posfb.identify(log, loaded)
        times.append(time.perf_counter() - began)
    print(f"identify: median {statistics.median(times):.2f} s, smallest {min(times):.2f} s "
          f"({result.estimate.values.size} values, cutoff "
          f"{result.estimate.cutoff_rule})")  # fmt: skip
    if args.profile:
        import cProfile
        import pstats

        profile = cProfile.Profile()
        profile.runcall(posfb.identify, log, loaded)
        pstats.Stats(profile).sort_stats("cumulative").print_stats(15)


if __name__ == "__main__":
    main()
