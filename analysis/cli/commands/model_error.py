"""``posfb model-error [STUDY] --out DIR``: the model-error study (issue 29, item 5).

Identifies the paper's arm from planned excitations at each encoder resolution (part
a), runs Tables 3-4 on arms drawn from those identifications' uncertainty (part b) and
a scan of model-error sizes (part c), each resumable, then writes ``DIR/report.md``
and ``DIR/results.json`` (``analysis.model_error``). ``--report-only`` writes the
report from what ``DIR`` holds.
"""

from __future__ import annotations

import argparse
import sys

from posfb.analysis.cli.commands.montecarlo import _positive_int, available_cores, worker_died_note
from posfb.analysis.common.errors import EXIT_WORKER_DIED
from posfb.analysis.common.outputs import output_folder, staged_folder
from posfb.analysis.common.shipped import STUDY_DIR

#: The shipped model-error study run by default.
DEFAULT_STUDY = STUDY_DIR / "model_error" / "paper.yaml"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "study",
        nargs="?",
        default=str(DEFAULT_STUDY),
        help="model-error study YAML (default: the shipped paper.yaml)",
    )
    parser.add_argument(
        "--out", required=True, help="folder of the records, stores, report.md and results.json"
    )
    parser.add_argument(
        "--workers",
        type=_positive_int,
        default=1,
        help="local worker processes (at most the cores available)",
    )
    parser.add_argument(
        "--report-only", action="store_true", help="run nothing; report what --out holds"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    parser.set_defaults(handler=model_error_command)  # fmt: skip


def model_error_command(args: argparse.Namespace) -> int:
    from posfb.analysis.model_error.model_error_report import write_report
    from posfb.analysis.model_error.run import run_model_error
    from posfb.analysis.model_error.spec import load_model_error

    spec = load_model_error(args.study)
    out = output_folder("--out", args.out)
    died = {}
    if not args.report_only:
        workers = min(args.workers, available_cores())
        died = run_model_error(spec, out, workers, not args.no_progress)
    study = "" if args.study == str(DEFAULT_STUDY) else f" {args.study}"
    command = f"posfb model-error{study} --out {args.out} --workers {args.workers}"
    with staged_folder(out) as staged:
        written = staged.final(write_report(spec, out, staged.path, command))
    print(f"report written to {written[0]}")
    for name, samples in died.items():
        sys.stderr.write(f"posfb model-error: warning: {name}: {worker_died_note(samples)}\n")
    return EXIT_WORKER_DIED if died else 0
