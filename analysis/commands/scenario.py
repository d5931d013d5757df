"""``posfb scenario dump|check``: the settings tree of a run, written out in full
or validated with the design verdict (Sec. 3 checks, sampled-data radius)."""

from __future__ import annotations

import argparse
import sys

from posfb.analysis.commands.design import format_report
from posfb.analysis.commands.scenario_args import SHORTCUTS, scenario_from_args
from posfb.analysis.experiment import CASES
from posfb.analysis.feasibility import trajectory_warnings
from posfb.diagrams.scenario import dump_scenario, load_scenario, resolve
from posfb.models.controllers import CONTROLLER_KINDS, cached_design

#: Exit code of a scenario whose design fails a check.
EXIT_FAILED_CHECK = 1


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("scenario", help="print or check a scenario file")
    actions = parser.add_subparsers(dest="action", required=True, parser_class=type(parser))
    dump = actions.add_parser("dump", help="print a complete scenario, every default written")
    dump.add_argument("--case", choices=CASES, default="nominal", help="shipped paper case")
    dump.add_argument("--controller", choices=CONTROLLER_KINDS, help="controller kind")
    dump.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="settings")
    dump.set_defaults(handler=run_dump, scenario=None)
    check = actions.add_parser("check", help="validate a scenario and print its design verdict")
    check.add_argument("file", help="scenario YAML")
    check.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="settings")
    check.set_defaults(handler=run_check)


def run_dump(args: argparse.Namespace) -> int:
    loaded = scenario_from_args(
        argparse.Namespace(**{**vars(args), **{n: None for n in SHORTCUTS if n != "controller"}})
    )
    sys.stdout.write(dump_scenario(loaded.scenario))
    return 0


def run_check(args: argparse.Namespace) -> int:
    loaded = load_scenario(args.file, args.settings)
    config = resolve(loaded).config
    print(f"{args.file}: valid; controller {config.controller}, T_s = {config.sample_time:g} s, "
          f"{config.duration:g} s")  # fmt: skip
    for warning in trajectory_warnings(loaded):
        print(f"warning: {warning}")
    design = cached_design(config.design)
    print(format_report(design))
    if config.controller != "pid" and design.warnings:
        return EXIT_FAILED_CHECK
    return 0
