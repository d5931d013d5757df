"""``posfb graph``: the closed-loop Drake diagram as a picture (Graphviz)."""

from __future__ import annotations

import argparse
import sys

from posfb.analysis.commands.scenario_args import add_scenario_arguments, scenario_from_args


def configure(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser, ("controller",))
    parser.add_argument("--out", required=True, help="file to write, e.g. closed_loop.svg")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.outputs import output_file
    from posfb.diagrams.closed_loop import ClosedLoopRunner
    from posfb.diagrams.graph import GRAPH_SUFFIXES, graphviz_source, render
    from posfb.diagrams.resolve import resolve

    out = output_file("--out", args.out, GRAPH_SUFFIXES)
    diagram = ClosedLoopRunner(resolve(scenario_from_args(args)).config).diagram
    path, note = render(graphviz_source(diagram), out)
    if note:
        sys.stderr.write(f"posfb graph: {note}\n")
    print(path)
    return 0
