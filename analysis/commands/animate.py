"""``posfb animate``: a self-contained HTML animation of one run (Meshcat)."""

from __future__ import annotations

import argparse
from pathlib import Path

from posfb.analysis.errors import UsageError
from posfb.analysis.experiment import CASES
from posfb.diagrams.animate import record_animation
from posfb.diagrams.closed_loop import ClosedLoopConfig
from posfb.models.controllers import CONTROLLER_KINDS


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "animate", help="write an offline HTML animation of one run (Meshcat recording)"
    )
    parser.add_argument("--out", required=True, help="HTML file to write, e.g. arm.html")
    parser.add_argument("--controller", choices=CONTROLLER_KINDS, default="proposed")
    parser.add_argument("--case", choices=CASES, default="nominal")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    if Path(args.out).suffix.lower() not in (".html", ".htm"):
        raise UsageError(f"--out {args.out!r}; an .html file name is required")
    config = ClosedLoopConfig(controller=args.controller, duration=args.duration)
    try:
        path, result = record_animation(config, args.case, Path(args.out))
    except RuntimeError as error:
        raise UsageError(str(error)) from None
    print(f"{path} ({result.status}, {result.times[-1]:g} s)")
    return 0
