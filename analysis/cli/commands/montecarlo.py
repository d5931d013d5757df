"""``posfb montecarlo run|report|export|replay``: robustness over a population of sampled
plants.

``run`` evaluates every sample of a study (each controller on the same sampled
plant) on local worker processes or a Dask cluster and stores each finished
sample in SQLite; running it again resumes. ``report`` turns a store into
statistics, figures and a Markdown report; ``export`` into one tidy table.
``replay`` runs one stored sample again from the store alone, checks that it
reproduces the stored rows bit for bit and writes its time series, figures and
animations (``analysis.montecarlo.replay``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from posfb.analysis.common.errors import EXIT_WORKER_DIED, UsageError
from posfb.analysis.common.outputs import output_file, output_folder, staged_folder
from posfb.analysis.common.shipped import shipped_files, study_argument
from posfb.analysis.common.side_by_side import available_cores

if TYPE_CHECKING:
    from posfb.analysis.uncertainty.study import Study


def _integer_at_least(minimum: int):
    """An argparse type: an integer ``>= minimum``, refused in one line otherwise."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = _integral_float(text)
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value} is not >= {minimum}")
        return value

    return parse


def _integral_float(text: str) -> int:
    """``1e6`` as 1000000; refuses what is not a whole number."""
    try:
        number = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not number.is_integer():
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer")
    return int(number)


_positive_int = _integer_at_least(1)
_seed = _integer_at_least(0)


def configure(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, parser_class=type(parser))

    run = actions.add_parser("run", help="run (or resume) a study into an SQLite store")
    run.add_argument(
        "study", type=study_argument,
        help=f"study YAML, or a shipped study's name: {', '.join(shipped_files('study'))}",
    )  # fmt: skip
    run.add_argument("--db", required=True, help="SQLite results file (created or resumed)")
    run.add_argument("--samples", type=_positive_int, help="override the study's sample count")
    run.add_argument(
        "--workers", type=_positive_int, default=1,
        help="local worker processes (capped at the cores available unless --oversubscribe)",
    )  # fmt: skip
    run.add_argument("--oversubscribe", action="store_true", help="allow more --workers than cores")
    run.add_argument("--seed", type=_seed, help="override the study's seed")
    run.add_argument(
        "--dask-scheduler", metavar="ADDRESS", help="run on this Dask cluster (tcp://host:port)"
    )
    run.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    run.add_argument(
        "--dry-run", action="store_true",
        help="calibrate on a few samples and print the predicted time and memory; store nothing",
    )  # fmt: skip
    run.set_defaults(handler=run_command)

    report = actions.add_parser("report", help="statistics, figures and Markdown from a store")
    report.add_argument("--db", required=True, help="SQLite results file")
    report.add_argument("--out", required=True, help="output folder")
    report.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    report.set_defaults(handler=report_command)

    export = actions.add_parser(
        "export", help="one tidy table, a row per (sample, controller): Parquet or CSV"
    )
    export.add_argument("--db", required=True, help="SQLite results file")
    export.add_argument(
        "--out", required=True, help="FILE.parquet or FILE.csv (an existing file only with --force)"
    )
    export.add_argument("--force", action="store_true", help="overwrite an existing --out")
    export.set_defaults(handler=export_command)

    replay = actions.add_parser(
        "replay",
        help="run one stored sample again, check it against the store, write its time series",
    )
    replay.add_argument("--db", required=True, help="SQLite results file")
    replay.add_argument("--sample", required=True, type=_seed, help="the sample's index")
    replay.add_argument("--controller", help="replay only this controller (default: all)")
    replay.add_argument("--out", required=True, help="output folder")
    replay.add_argument(
        "--animate", action="store_true", help="also an HTML animation per controller"
    )
    replay.set_defaults(handler=replay_command)


def run_command(args: argparse.Namespace) -> int:
    from posfb.analysis.common.provenance import code_version
    from posfb.analysis.montecarlo.scheduler import interrupted, run_study
    from posfb.analysis.montecarlo.store import ResultStore
    from posfb.analysis.uncertainty.study import load_study, with_overrides

    study = with_overrides(load_study(args.study), samples=args.samples, seed=args.seed)
    output_file("--db", args.db, force=True)  # an existing store is resumed, never replaced
    if args.dask_scheduler and args.workers != 1:
        raise UsageError("--workers applies to local runs; a Dask cluster brings its own workers")
    notes = []
    if study.samples > 1 and not study.draws_anything():
        notes.append(
            "warning: the study draws nothing at random (every distribution is a single "
            "value): all samples are the same plant"
        )
    workers, cores = args.workers, available_cores()
    if workers > cores and not args.oversubscribe:
        notes.append(
            f"--workers {workers} capped at the {cores} cores available (--oversubscribe to "
            "allow more)"
        )
        workers = cores
    if args.dry_run:
        return dry_run(study, args.db, workers, cores)
    version = code_version()
    with ResultStore.create_or_resume(args.db, study, version) as store:
        for note in notes:  # once the store is known to be usable
            sys.stderr.write(f"posfb montecarlo: {note}\n")
        try:
            summary = run_study(
                study,
                store,
                version,
                workers=workers,
                dask_scheduler=args.dask_scheduler,
                progress=not args.no_progress,
            )
        except KeyboardInterrupt:
            raise interrupted(store, study, args.db) from None
    statuses = ", ".join(f"{k} {v}" for k, v in sorted(summary.statuses.items())) or "none"
    print(
        f"{args.db}: {summary.already_done + summary.written} of {summary.requested} samples "
        f"({summary.written} new in {summary.elapsed_s:.1f} s, "
        f"{summary.samples_per_second:.2f} samples/s; runs: {statuses})"
    )
    if summary.worker_died:
        sys.stderr.write(f"posfb montecarlo: warning: {worker_died_note(summary.worker_died)}\n")
        return EXIT_WORKER_DIED
    return 0


def worker_died_note(samples: tuple[int, ...]) -> str:
    """The warning of a run whose worker died on ``samples`` (``scheduler.WORKER_DIED``)."""
    listed = ", ".join(str(index) for index in samples)
    return (
        f"a worker process died on sample{'s' if len(samples) > 1 else ''} {listed} and on "
        "the retry (killed, e.g. out of memory); recorded as that sample's error, the run "
        "went on"
    )


def dry_run(study: Study, db: str, workers: int, cores: int) -> int:
    """Print the cost model's prediction for the samples ``db`` does not hold yet."""
    from posfb.analysis.montecarlo.cost import advice, calibrate
    from posfb.analysis.montecarlo.store import ResultStore

    finished = 0
    if Path(db).is_file() and Path(db).stat().st_size:
        with ResultStore.open_existing(db) as store:
            finished = sum(1 for index in store.finished() if index < study.samples)
    estimate = calibrate(study, study.samples - finished)
    for line in advice(estimate, workers, cores):
        print(line)
    return 0


def export_command(args: argparse.Namespace) -> int:
    from posfb.analysis.common.export import write_table
    from posfb.analysis.montecarlo.store import ResultStore
    from posfb.analysis.montecarlo.table import TABLE_FORMATS, study_table

    out = output_file("--out", args.out, TABLE_FORMATS, args.force, inputs=(args.db,))
    with ResultStore.open_existing(args.db) as store:
        table = study_table(store)
    write_table(table, out)
    print(f"{len(table)} rows ({table['sample'].nunique()} samples) written to {out}")
    return 0


#: The module that writes the report (``analysis.montecarlo.study_report``), by name: its
#: workers' forkserver imports it.
REPORT_MODULE = "posfb.analysis.montecarlo.study_report"


def report_command(args: argparse.Namespace) -> int:
    from posfb.analysis.common import progress
    from posfb.analysis.common.side_by_side import start_forkserver

    # the report's workers (its margins, a figure) import it while this process does
    start_forkserver([REPORT_MODULE])
    from posfb.analysis.montecarlo.store import ResultStore
    from posfb.analysis.montecarlo.study_report import write_report

    out = output_folder("--out", args.out)
    with (
        ResultStore.open_existing(args.db) as store,
        staged_folder(out) as staged,
        progress.status_line("montecarlo report", progress.wanted(args.no_progress)) as say,
    ):
        (path,) = staged.final([write_report(store, staged.path, say)])
        expected, finished = store.study().samples, len(store.finished())
    if finished < expected:
        sys.stderr.write(
            f"posfb montecarlo: warning: {expected - finished} of {expected} samples are "
            f"missing or lack a run (unfinished run); the report covers the {finished} "
            "complete ones\n"
        )
    print(f"report written to {path}")
    return 0


def replay_command(args: argparse.Namespace) -> int:
    """Rebuild sample ``--sample`` from the store's study, compare it with the stored rows
    (one line each), write its files; 0 if every row matches, 1 if any differs."""
    from posfb.analysis.common.provenance import code_version
    from posfb.analysis.montecarlo.replay import (
        chosen_controllers,
        compare,
        require_stored,
        write_outputs,
    )
    from posfb.analysis.montecarlo.store import ResultStore
    from posfb.analysis.montecarlo.worker import ClosedLoopEvaluator
    from posfb.diagrams.resolve import plugin_file_changed

    out = output_folder("--out", args.out)
    with ResultStore.open_existing(args.db) as store:
        study = store.study()
        require_stored(args.sample, store.finished(), args.db)
        unrecorded = store.unrecorded(args.sample)
        controllers = chosen_controllers(study, args.controller, args.db)
        (stored_sample,) = store.sample_rows(args.sample)
        stored_runs = store.run_rows(args.sample)
    print(
        f"sample {args.sample} of --db {args.db} (seed {study.seed}, stored by "
        f"{stored_sample['code_version']}): replaying {', '.join(controllers)}",
        flush=True,
    )
    changed = plugin_file_changed(study.base)
    if changed:
        print(f"  note: {changed}", flush=True)
    replayed, results = ClosedLoopEvaluator(study).evaluate(args.sample, controllers)
    comparisons = compare(stored_sample, stored_runs, replayed, unrecorded)
    for comparison in comparisons:
        print(f"  {comparison.line()}")
    matches = all(comparison.matches for comparison in comparisons)
    if not matches:
        stored_by, current = stored_sample["code_version"], code_version()
        if current != stored_by:
            print(f"  note: the sample was stored by {stored_by}; this is {current}")
    try:
        with staged_folder(out) as staged:
            paths = write_outputs(args.sample, results, staged.path, animate=args.animate)
    except RuntimeError as error:  # Meshcat could not start (as ``posfb animate``)
        raise UsageError(str(error)) from None
    print(f"{len(paths)} files written to {out}")
    return 0 if matches else 1
