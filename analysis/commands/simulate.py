"""``posfb simulate``: one closed-loop run of a scenario (default: the paper's
nominal experiment), its metrics, and optionally its time series as a file."""

from __future__ import annotations

import argparse
import json
import sys

from posfb.analysis import plots, progress
from posfb.analysis.commands.scenario_args import add_scenario_arguments, scenario_from_args
from posfb.analysis.experiment import CONTROLLER_LABELS, result_entry
from posfb.analysis.export import EXPORT_FORMATS, export_run
from posfb.analysis.feasibility import trajectory_warnings
from posfb.analysis.metrics import run_metrics
from posfb.analysis.outputs import output_file, output_folder
from posfb.diagrams.resolve import resolve, run_resolved
from posfb.models.controllers import failed_checks, require_design


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "simulate", help="one closed-loop run of a scenario: RMS errors and voltages"
    )
    add_scenario_arguments(
        parser,
        ("controller", "duration", "sample_time", "encoder_counts", "payload", "alpha_star",
         "voltage_limit"),
    )  # fmt: skip
    parser.add_argument(
        "--out", help=f"write the time series ({', '.join(EXPORT_FORMATS)} by suffix)"
    )
    parser.add_argument(
        "--figure", metavar="DIR", help="write positions/voltages and errors (PNG, SVG) into DIR"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    parser.set_defaults(handler=run)


def summary_name(args: argparse.Namespace) -> str:
    """The scenario's name in reports: its file, or the shipped case."""
    return str(args.scenario or args.case or "nominal")


def run(args: argparse.Namespace) -> int:
    out = output_file("--out", args.out, EXPORT_FORMATS) if args.out else None
    figures = output_folder("--figure", args.figure) if args.figure else None
    loaded = scenario_from_args(args)
    resolved = resolve(loaded)
    config = resolved.config
    require_design(config.controller, config.design)  # a refused design is bad input
    warnings = trajectory_warnings(resolved)
    warnings += [
        f"the {config.controller} design fails a check: {detail}"
        for detail in failed_checks(config.controller, config.design)
    ]
    for warning in warnings:
        sys.stderr.write(f"posfb simulate: warning: {warning}\n")
    show = progress.wanted(args.no_progress)
    with progress.run_progress(config.duration, config.controller, show) as update:
        result = run_resolved(resolved, progress=update)
    written = export_run(result, out) if out else None
    if figures:
        runs, title = {config.controller: result}, f"scenario {summary_name(args)}"
        figures.mkdir(parents=True, exist_ok=True)
        plots.save(plots.positions_and_voltages(runs, title), figures, "positions")
        plots.save(plots.tracking_errors(runs, title), figures, "errors")
    summary = {
        "controller": config.controller,
        "scenario": summary_name(args),
        "duration": config.duration,
        "sample_time": config.sample_time,
        "encoder_counts": list(config.encoder_counts),
        **result_entry(result),
    }
    if written:
        summary["out"] = str(written)
    if args.json:
        print(json.dumps(summary))
        return 0
    m, label = run_metrics(result), CONTROLLER_LABELS[config.controller]
    print(f"{label}, {summary['scenario']}, {config.duration:g} s: {result.status}")
    if result.message:
        print(f"  {result.message}")
    rms_q = ", ".join(f"{v:.5f}" for v in m.rms_q)
    rms_u = ", ".join(f"{v:.3f}" for v in m.rms_u)
    print(f"  RMS(q~) = ({rms_q}) rad, max |q~| = {m.max_abs_q_err:.5f}")
    print(f"  RMS(u)  = ({rms_u}) V applied")
    print(f"  saturated: {100 * m.saturated_fraction:.1f} % of the samples")
    rate = config.duration / m.wall_time_s
    print(f"  wall time {m.wall_time_s:.2f} s ({rate:.1f} simulated s per wall s)")
    if written:
        print(f"  time series: {written}")
    return 0
