"""``posfb reproduce``: the paper's Sec. 4 in simulation with every artefact
(``analysis.paper.reproduce``)."""

from __future__ import annotations

import argparse


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", default="results", help="output folder (default: results)")
    parser.add_argument(
        "--duration", type=float, default=20.0, help="simulated seconds per run (paper: 20)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bars on stderr")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.common import progress
    from posfb.analysis.common.outputs import output_folder
    from posfb.analysis.paper.reproduce import reproduce

    out = output_folder("--out", args.out)
    artefacts = reproduce(
        out,
        args.duration,
        progress=lambda line: print(line, flush=True),
        bars=progress.wanted(args.no_progress),
    )
    print(f"{len(artefacts)} files in {args.out}/")
    return 0
