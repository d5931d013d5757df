"""``posfb animate``: a self-contained HTML animation of one run (Meshcat)."""

from __future__ import annotations

import argparse

from posfb.analysis.cli.commands.scenario_args import add_scenario_arguments, scenario_from_args
from posfb.analysis.common.errors import UsageError


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out", required=True, help="HTML file to write, e.g. arm.html (an existing file "
        "only with --force)",
    )  # fmt: skip
    parser.add_argument("--force", action="store_true", help="overwrite an existing --out")
    add_scenario_arguments(parser, ("controller", "duration", "payload", "alpha_star"))
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.common import progress
    from posfb.analysis.common.outputs import atomic_file, output_file
    from posfb.diagrams.animate import record_animation

    out = output_file("--out", args.out, (".html", ".htm"), args.force)
    loaded = scenario_from_args(args)
    try:
        duration = loaded.scenario.timing.duration
        with (
            progress.run_progress(duration, "animate", progress.wanted(args.no_progress)) as bar,
            atomic_file(out) as temporary,
        ):
            _, result = record_animation(loaded, temporary, bar)
    except RuntimeError as error:
        raise UsageError(str(error)) from None
    from posfb.analysis.common.metrics import run_verdict

    print(f"{out} ({run_verdict(result).status}, {result.times[-1]:g} s)")
    return 0
