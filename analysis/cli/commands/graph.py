"""``posfb graph``: the closed-loop Drake diagram as a picture (Graphviz)."""

from __future__ import annotations

import argparse
import shutil
import sys

from posfb.analysis.cli.commands.scenario_args import add_scenario_arguments, scenario_from_args


def configure(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser, ("controller",))
    parser.add_argument(
        "--out", required=True, help="file to write, e.g. closed_loop.svg (an existing file "
        "only with --force)",
    )  # fmt: skip
    parser.add_argument("--force", action="store_true", help="overwrite an existing --out")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.common.outputs import atomic_file, output_file
    from posfb.diagrams.graph import GRAPH_SUFFIXES, INSTALL_HINT, graphviz_source, render
    from posfb.diagrams.resolve import resolve
    from posfb.diagrams.runner import ClosedLoopRunner

    out = output_file("--out", args.out, GRAPH_SUFFIXES, args.force)
    # Without Graphviz, ``render`` writes the ``.dot`` text: that is the file checked.
    target = out if shutil.which("dot") else output_file(
        "--out", str(out.with_suffix(".dot")), force=args.force
    )  # fmt: skip
    diagram = ClosedLoopRunner(resolve(scenario_from_args(args)).config).diagram
    with atomic_file(target) as temporary:
        render(graphviz_source(diagram), temporary)
    if target != out:
        sys.stderr.write(f"posfb graph: Graphviz 'dot' not found: wrote {target}; {INSTALL_HINT}\n")
    print(target)
    return 0
