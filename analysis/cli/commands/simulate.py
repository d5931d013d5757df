"""``posfb simulate``: one closed-loop run of a scenario (default: the paper's
nominal experiment), its metrics, and optionally its time series as a file.

It is ``posfb.simulate`` (``analysis.api``) with the scenario from the command line:
the same numbers as a script. Exit codes: 0 for a run that finished ``ok``, 4
(``analysis.common.errors.EXIT_DIVERGED``) for one that diverged, 5 (``EXIT_NOT_TRACKED``)
for one that finished ``saturated`` or ``lost``; a run that is not ``ok`` gets a warning
line on stderr saying why (``analysis.common.metrics.run_verdict``); the metrics and time
series are written in every case. 2 for bad input."""

from __future__ import annotations

import argparse
import json
import sys

from posfb.analysis.cli.commands.scenario_args import (
    add_scenario_arguments,
    add_sil_argument,
    scenario_from_args,
)
from posfb.analysis.cli.commands.warnings_io import printed_warnings
from posfb.analysis.common.errors import run_exit_code
from posfb.analysis.common.outputs import EXPORT_FORMATS, output_file, output_folder, staged_folder


def configure(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(
        parser,
        ("controller", "duration", "sample_time", "encoder_counts", "payload", "alpha_star",
         "voltage_limit"),
    )  # fmt: skip
    parser.add_argument(
        "--out", help=f"write the time series ({', '.join(EXPORT_FORMATS)} by suffix; an "
        "existing file only with --force)",
    )  # fmt: skip
    parser.add_argument("--force", action="store_true", help="overwrite an existing --out")
    parser.add_argument(
        "--figure", metavar="DIR", help="write positions/voltages and errors (PNG, SVG) into DIR"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    add_sil_argument(parser)
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    out = None if args.out is None else output_file("--out", args.out, EXPORT_FORMATS, args.force)
    figures = None if args.figure is None else output_folder("--figure", args.figure)
    loaded = scenario_from_args(args)
    from posfb.analysis.api import simulate
    from posfb.analysis.common import progress

    with printed_warnings("simulate"):
        run = simulate(loaded, progress=progress.wanted(args.no_progress), sil=args.sil)
    written = run.save(out) if out else None
    if figures:
        from posfb.analysis.common import plots

        title = f"{run.label}, scenario {loaded.source}"
        with staged_folder(figures) as staged:
            plots.save(run.plot("positions", title), staged.path, "positions")
            plots.save(run.plot("errors", title), staged.path, "errors")
    summary = run.summary()
    if written:
        summary["out"] = str(written)
    if args.json:
        print(json.dumps(summary))
    else:
        _print_summary(run, written)
    return run_exit_code([run.status])


def _print_summary(run: object, written: object) -> None:
    config, m = run.result.config, run.metrics
    print(f"{run.label}, {run.scenario.source}, {config.timing.duration:g} s: {run.status}")
    if run.message:
        print(f"  {run.message}")
    rms_q = ", ".join(f"{v:.5f}" for v in m.rms_q)
    rms_u = ", ".join(f"{v:.3f}" for v in m.rms_u)
    print(f"  RMS(q~) = ({rms_q}) rad, max |q~| = {m.max_abs_q_err:.5f}")
    measured = ", ".join(f"{v:.5f}" for v in m.rms_q_measured)
    print(f"  RMS(q_m - q_d) = ({measured}) rad, as the encoder reads it")
    print(f"  RMS(u)  = ({rms_u}) V applied")
    print(f"  saturated: {100 * m.saturated_fraction:.1f} % of the samples")
    rate = config.timing.duration / m.wall_time_s
    print(f"  wall time {m.wall_time_s:.2f} s ({rate:.1f} simulated s per wall s)")
    if written:
        print(f"  time series: {written}")
    sys.stdout.flush()
