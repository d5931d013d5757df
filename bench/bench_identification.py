"""What ``posfb identify --log`` spends on a log of a six-joint arm (issue 42, item 8):

    .venv/bin/python bench/bench_identification.py [--scenario six_joint_nominal|FILE]
        [--duration 60] [--sample-time 0.001] [--without-reference] [--validate]
        [--repeat 3]

A log of the scenario's own trajectory (Lin+LC, ``--duration`` s, with the reference
columns ``posfb simulate --out`` writes; ``--sample-time`` sets ``timing.sample_time``, the
log's row spacing, where given; ``--without-reference`` drops the reference columns, as
a user's own log may lack them: least squares and the coarse-encoder refit instead of
instrumental variables) is simulated once; then the identification is
timed (median and smallest of ``--repeat``), in this process after a first untimed run
(imports and caches warm). ``--profile`` prints the 15 functions of the largest
cumulative time of one more run (``cProfile``). ``--validate`` times ``identify
--validate`` with the same log as the second one (its windowed output-error simulation
included).
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
    parser.add_argument("--sample-time", type=float, default=None)
    parser.add_argument("--without-reference", action="store_true")
    parser.add_argument("--validate", action="store_true")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()

    import posfb
    from posfb.analysis.api import shipped_scenarios

    source = shipped_scenarios().get(args.scenario, args.scenario)
    settings = {"timing.duration": args.duration}
    if args.sample_time is not None:
        settings["timing.sample_time"] = args.sample_time
    loaded = posfb.load_scenario(source, set=settings)
    log = Path(tempfile.mkdtemp(prefix="posfb-bench-")) / "log.csv"
    began = time.perf_counter()
    posfb.simulate(loaded, "lin_lc").save(log)
    if args.without_reference:
        import pandas as pd

        table = pd.read_csv(log)
        table.drop(columns=[c for c in table.columns if "_desired" in c]).to_csv(log, index=False)
    print(f"{platform.node()}: {args.scenario}, a {args.duration:g} s log at "
          f"{loaded.scenario.timing.sample_time:g} s simulated in "
          f"{time.perf_counter() - began:.1f} s")  # fmt: skip
    second = log if args.validate else None
    posfb.identify(log, loaded, validate=second)
    times = []
    for _ in range(args.repeat):
        began = time.perf_counter()
        result = posfb.identify(log, loaded, validate=second)
        times.append(time.perf_counter() - began)
    print(f"identify: median {statistics.median(times):.2f} s, smallest {min(times):.2f} s "
          f"({result.estimate.values.size} values, cutoff "
          f"{result.estimate.cutoff_rule})")  # fmt: skip
    if args.profile:
        import cProfile
        import pstats

        profile = cProfile.Profile()
        profile.runcall(posfb.identify, log, loaded, validate=second)
        pstats.Stats(profile).sort_stats("cumulative").print_stats(15)


if __name__ == "__main__":
    main()
