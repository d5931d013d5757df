"""``posfb graph``: the closed-loop Drake diagram as a picture (Graphviz)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from posfb.diagrams.closed_loop import ClosedLoopConfig, ClosedLoopRunner
from posfb.diagrams.graph import graphviz_source, render
from posfb.models.controllers import CONTROLLER_KINDS


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "graph", help="render the closed-loop diagram (.svg/.png/.pdf, or .dot text)"
    )
    parser.add_argument("--controller", choices=CONTROLLER_KINDS, default="proposed")
    parser.add_argument("--out", required=True, help="file to write, e.g. closed_loop.svg")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    diagram = ClosedLoopRunner(ClosedLoopConfig(controller=args.controller)).diagram
    path, note = render(graphviz_source(diagram), Path(args.out))
    if note:
        sys.stderr.write(f"posfb graph: {note}\n")
    print(path)
    return 0
