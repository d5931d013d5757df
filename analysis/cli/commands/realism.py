"""``posfb realism [STUDY] --out DIR``: the "How far from hardware?" study (issue 21).

Runs (or resumes) one Monte-Carlo study per effect of the realism file, the ideal arm
and the combination (``analysis.realism``), each into ``STORES/NAME.sqlite``, then
writes ``DIR/report.md`` and its figures. ``--report-only`` writes the report from the
stores as they are.
"""

from __future__ import annotations

import argparse
import sys

from posfb.analysis.cli.commands.montecarlo import _positive_int, available_cores, worker_died_note
from posfb.analysis.common.errors import EXIT_WORKER_DIED
from posfb.analysis.common.outputs import output_folder, staged_folder
from posfb.analysis.common.shipped import REALISM_DIR, realism_argument, shipped_files

#: The shipped realism study run by default (Tables 3 and 4's nominal case).
DEFAULT_STUDY = REALISM_DIR / "paper_table3.yaml"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "study", nargs="?", default=str(DEFAULT_STUDY), type=realism_argument,
        help="realism study YAML, or a shipped one's name: "
        f"{', '.join(shipped_files('realism study'))} (default: {DEFAULT_STUDY.stem})",
    )  # fmt: skip
    parser.add_argument("--out", required=True, help="folder of report.md and its figures")
    parser.add_argument(
        "--stores", help="folder of the studies' SQLite stores (default: OUT/stores)"
    )
    parser.add_argument(
        "--workers", type=_positive_int, default=1,
        help="local worker processes (at most the cores available)",
    )  # fmt: skip
    parser.add_argument(
        "--only", metavar="NAME[,NAME]",
        help="run only these studies (ideal, an effect's name, combined); report every store",
    )  # fmt: skip
    parser.add_argument(
        "--report-only", action="store_true", help="run nothing; report the stores as they are"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    parser.set_defaults(handler=realism_command)


def realism_command(args: argparse.Namespace) -> int:
    from posfb.analysis.realism.realism_report import write_report
    from posfb.analysis.realism.run import run_realism
    from posfb.analysis.realism.spec import load_realism

    studies = load_realism(args.study)
    out = output_folder("--out", args.out)
    stores = out / "stores" if args.stores is None else output_folder("--stores", args.stores)
    died = {}
    if not args.report_only:
        workers = min(args.workers, available_cores())
        chosen = None if args.only is None else args.only.split(",")
        died = run_realism(studies, stores, workers, not args.no_progress, chosen)
    with staged_folder(out) as staged:  # the report's files; the stores are written as they run
        (path,) = staged.final([write_report(studies, stores, staged.path, command=_command(args))])
    print(f"report written to {path}")
    for name, samples in died.items():
        sys.stderr.write(f"posfb realism: warning: {name}: {worker_died_note(samples)}\n")
    return EXIT_WORKER_DIED if died else 0


def _command(args: argparse.Namespace) -> str:
    """The command that regenerates the report (in the report's header)."""
    study = "" if args.study == str(DEFAULT_STUDY) else f" {args.study}"
    stores = "" if args.stores is None else f" --stores {args.stores}"
    return f"posfb realism{study} --out {args.out}{stores} --workers {args.workers}"
