"""``posfb codegen``: the scenario's designed controller as C99 (``analysis.codegen``):
``NAME.h``, ``NAME.c``, an example ``main.c`` with a ``Makefile`` and a ``README.md`` in
``--out``; with ``--check LOG``, the code compiled by the ``cc`` on the PATH and replayed
on the log, the largest difference from its commanded voltages printed."""

from __future__ import annotations

import argparse
import json

from posfb.analysis.cli.commands.scenario_args import add_scenario_arguments, scenario_from_args
from posfb.analysis.common.errors import UsageError


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
                        ".csv, .parquet or .npz) through it")  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.codegen.package import generate
    from posfb.analysis.common.outputs import output_folder, staged_folder
    from posfb.diagrams.resolve import resolve

    out = output_folder("--out", args.out)
    table = None
    if args.check is not None:
        from posfb.analysis.codegen.build import compiler
        from posfb.analysis.common.export import read_run

        try:
            compiler()
            table = read_run(args.check)
        except (ValueError, OSError) as error:
            raise UsageError(f"--check {args.check}: {error}") from None
    resolved = resolve(scenario_from_args(args))
    try:
        package = generate(resolved, args.name, args.precision)
    except ValueError as error:
        raise UsageError(str(error)) from None
    if table is not None:  # a log of another arm is refused before anything is written
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
            result = check(package, table)
        except ValueError as error:
            raise UsageError(f"--check {args.check}: {error}") from None
        found["check"] = {"log": args.check, **vars(result)}
    if args.json:
        print(json.dumps(found))
        return 0
    print(f"wrote {', '.join(found['files'])}")
    if table is not None:
        print(
            f"check {args.check}: {result.samples} samples; largest difference from the "
            f"log's commanded voltage {result.largest_difference_V:.3g} V "
            f"({result.largest_relative:.3g} of its largest), at sample {result.at_sample}"
        )
    return 0
