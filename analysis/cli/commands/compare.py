"""``posfb compare``: several controllers on one scenario, side by side: a table (CSV,
Markdown), every run's summary (JSON) and the overlaid Figs. 4/6 and 5/7. It is
``posfb.compare`` (``analysis.api``) with the scenario from the command line. Exit
code: the worst run's (``analysis.common.errors.run_exit_code``: 4 if one diverged, 5 if one
finished ``saturated`` or ``lost``); every run that is not ``ok`` gets one warning line on
stderr with its verdict's message (``analysis.common.metrics.Verdict.sentence``)."""

from __future__ import annotations

import argparse
import json

from posfb.analysis.cli.commands.scenario_args import (
    add_scenario_arguments,
    add_sil_argument,
    scenario_from_args,
)
from posfb.analysis.cli.commands.warnings_io import printed_warnings
from posfb.analysis.common.errors import UsageError, run_exit_code
from posfb.analysis.common.outputs import output_folder


def configure(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser, ("duration", "sample_time", "encoder_counts", "payload"))
    parser.add_argument(
        "--controllers", metavar="NAME,NAME,...",
        help="the controllers to run, comma-separated, in table and legend order: kinds "
        "or the scenario's named entries (default: the paper's three)",
    )  # fmt: skip
    parser.add_argument(
        "--out", metavar="DIR", help="write comparison.csv/.md/.json and the figures into DIR "
        "(created; files of those names are replaced, once all are written)",
    )  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON object per run")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars on stderr")
    add_sil_argument(parser)
    parser.set_defaults(handler=run)


def controller_list(text: str) -> list[str]:
    """The kinds of ``--controllers``, comma-separated; an empty entry is refused."""
    kinds = [kind.strip() for kind in text.split(",")]
    if not text.strip() or any(not kind for kind in kinds):
        raise UsageError(
            f"--controllers {text!r}; comma-separated controller kinds are required "
            "(e.g. pid,lin_lc,proposed)"
        )
    return kinds


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.api import DEFAULT_COMPARISON, compare
    from posfb.analysis.common import progress

    given = args.controllers is not None  # "" is refused, not the default
    kinds = controller_list(args.controllers) if given else list(DEFAULT_COMPARISON)
    folder = None if args.out is None else output_folder("--out", args.out)
    loaded = scenario_from_args(args)
    with printed_warnings("compare"):
        comparison = compare(
            loaded, kinds, progress=progress.wanted(args.no_progress), sil=args.sil
        )
    written = comparison.save(folder) if folder else []
    if args.json:
        print(json.dumps({kind: run.summary() for kind, run in comparison.runs.items()}))
    else:
        print(f"scenario {loaded.source}, {loaded.get('timing.duration'):g} s")
        print(comparison.markdown(), end="")
        if written:
            print(f"written: {', '.join(sorted({str(path.parent) for path in written}))}")
    return run_exit_code(run.status for run in comparison.runs.values())
