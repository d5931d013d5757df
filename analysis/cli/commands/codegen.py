"""``posfb codegen``: the scenario's designed controller as C99 (``analysis.codegen``):
``NAME.h``, ``NAME.c``, an example ``main.c`` with a ``Makefile`` and a ``README.md`` in
``--out``; with ``--check LOG``, the code compiled by the ``cc`` on the PATH and replayed
on the log, judged against a tolerance (``analysis.codegen.check``): exit 0 and the
largest difference printed when every voltage is within it, ``EXIT_CHECK_FAILED`` and one
line on stderr naming the first sample and joint over it otherwise."""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING

from posfb.analysis.cli.commands.number_args import positive
from posfb.analysis.cli.commands.scenario_args import add_scenario_arguments, scenario_from_args
from posfb.analysis.common.errors import EXIT_CHECK_FAILED, UsageError

if TYPE_CHECKING:
    from posfb.analysis.codegen.check import CheckResult


def configure(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser, ("controller", "sample_time", "alpha_star"))
    parser.add_argument("--out", required=True, metavar="DIR", help="the folder to write")
    parser.add_argument(
        "--name", metavar="NAME", help="prefix of every C symbol (default: the controller's kind)"
    )
    parser.add_argument("--precision", choices=("double", "float"), default="double",
                        help="the C type throughout (default double)")  # fmt: skip
    parser.add_argument("--check", metavar="LOG",
                        help="compile the code and replay this log (posfb simulate --out: "
                        ".csv, .parquet or .npz) through it; exit 1 when a voltage "
                        "differs from the log's by more than --tolerance")  # fmt: skip
    parser.add_argument("--tolerance", type=positive, metavar="VOLTS",
                        help="the largest difference --check allows, in V (default: the "
                        "precision's round-off bound times the log's largest commanded "
                        "voltage, analysis.codegen.check.TOLERANCE)")  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.codegen.package import generate
    from posfb.analysis.common.outputs import output_folder, staged_folder
    from posfb.diagrams.resolve import resolve

    out = output_folder("--out", args.out)
    if args.tolerance is not None and args.check is None:
        raise UsageError(f"--tolerance {args.tolerance:g} applies to --check LOG")
    table = None
    if args.check is not None:
        from posfb.analysis.codegen.build import compile_timeout, compiler
        from posfb.analysis.common.export import read_run

        compiler()
        compile_timeout()
        try:
            table = read_run(args.check)
        except (ValueError, OSError) as error:
            raise UsageError(f"--check {args.check}: {error}") from None
    resolved = resolve(scenario_from_args(args))
    try:
        package = generate(resolved, args.name, args.precision)
    except ValueError as error:
        raise UsageError(str(error)) from None
    if table is not None:  # a log the replay refuses is refused before anything is written
        from posfb.analysis.codegen.check import log_inputs

        try:
            log_inputs(table, package)
        except ValueError as error:
            raise UsageError(f"--check {args.check}: {error}") from None
    with staged_folder(out) as staged:
        for name, text in package.files.items():
            (staged.path / name).write_text(text)
        written = staged.final([staged.path / name for name in package.files])
    found: dict[str, object] = {
        "controller": resolved.config.controller, "name": package.name,
        "precision": package.precision, "joints": package.law.joints,
        "memory": package.law.memory, "files": [str(p) for p in written],
    }  # fmt: skip
    if table is not None:
        from posfb.analysis.codegen.check import check

        try:
            result = check(package, table, args.tolerance)
        except ValueError as error:
            raise UsageError(f"--check {args.check}: {error}") from None
        found["check"] = {"log": args.check, **vars(result)}
    if args.json:
        print(json.dumps(found))
    else:
        print(f"wrote {', '.join(found['files'])}")
    if table is None:
        return 0
    if not result.passed:
        print(_failure(args.check, result, package.precision, args.tolerance),
              file=sys.stderr)  # fmt: skip
        return EXIT_CHECK_FAILED
    if not args.json:
        print(
            f"--check {args.check} passed: {result.samples} samples; largest difference from "
            f"the log's commanded voltage {result.largest_difference_V:.3g} V "
            f"({result.largest_relative:.3g} of its largest), at sample {result.at_sample}; "
            f"tolerance {_tolerance(result, package.precision, args.tolerance)}"
        )
    return 0


def _tolerance(result: CheckResult, precision: str, given: float | None) -> str:
    """The tolerance applied, and where it came from."""
    from posfb.analysis.codegen.check import TOLERANCE

    if given is not None:
        return f"{result.tolerance_V:.3g} V (--tolerance)"
    relative = TOLERANCE[precision]
    return (
        f"{result.tolerance_V:.3g} V ({precision}'s default: {relative:.2g} of the log's "
        f"largest commanded voltage, {result.tolerance_V / relative:.3g} V)"
    )


def _failure(log: str, result: CheckResult, precision: str, given: float | None) -> str:
    """The one line of a failed check: the first sample over the tolerance."""
    from posfb.analysis.common.export import U_COMMANDED

    return (
        f"posfb codegen: --check {log} failed: sample {result.failing_sample} (time_s = "
        f"{result.failing_time_s:g}), joint {result.failing_joint}: the C voltage differs "
        f"from {U_COMMANDED.format(j=result.failing_joint)} by "
        f"{result.failing_difference_V:.3g} V, over the tolerance "
        f"{_tolerance(result, precision, given)}; the largest difference is "
        f"{result.largest_difference_V:.3g} V, at sample {result.at_sample}"
    )
