"""``posfb tune SCENARIO``: a robust design of the paper's controller and Lin+LC for the
scenario's arm (``analysis.tuning``), verified on fresh plants with a stated guarantee,
written as a tuned scenario.

It is ``posfb.tune`` (``analysis.api``) with the scenario and settings from the command
line. Exit codes: 0 tuned and written; 1 no design meets the constraints, or the search
would overrun ``--budget`` (one line says which); 2 bad input (a bad study, an option
out of range)."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import fields

#: Exit code when no design is found (infeasible, or not within the budget).
EXIT_NOT_FOUND = 1

#: The options that set a ``TuneSettings`` field of the same name, and their help.
SETTING_OPTIONS = {
    "seed": (int, "seed of the design plants (the fresh plants of round r use seed + 1 + r)"),
    "budget": (float, "wall-clock seconds the search may take"),
    "plants": (int, "design plants the search requires to be stable"),
    "margin": (float, "required rho <= 1 - margin"),
    "epsilon": (float, "probability of instability the verification bounds"),
    "beta": (float, "1 - confidence of the verified bound"),
    "generations": (int, "generations of the search's fixed schedule"),
    "rounds": (int, "design-and-verify rounds at most (each on twice the plants)"),
}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", help="scenario YAML of the arm to tune for")
    parser.add_argument(
        "--study", metavar="STUDY", help="Monte-Carlo study whose parameters give the plants "
        "(default: +-20 %% on every link, rotor, damping and friction value, 5 %% motor constants)",
    )  # fmt: skip
    parser.add_argument("--out", required=True, metavar="TUNED.yaml", help="tuned scenario")
    parser.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", dest="settings",
        help="change one scenario key before tuning (repeatable)",
    )  # fmt: skip
    from posfb.analysis.tuning.settings import TuneSettings  # light: dataclasses only

    defaults = TuneSettings()
    for name, (kind, text) in SETTING_OPTIONS.items():
        parser.add_argument(
            f"--{name}", type=kind, help=f"{text} (default: {getattr(defaults, name)})"
        )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.set_defaults(handler=run)


def tune_settings(args: argparse.Namespace) -> object:
    """The ``TuneSettings`` of the command line (validated, naming the option)."""
    from posfb.analysis.tuning.settings import TuneSettings

    given = {f.name: getattr(args, f.name) for f in fields(TuneSettings)
             if getattr(args, f.name, None) is not None}  # fmt: skip
    try:
        return TuneSettings(**given)
    except ValueError as error:
        raise ValueError(f"--{error}") from None


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.outputs import output_file

    out = output_file("--out", args.out, (".yaml", ".yml"))
    settings = tune_settings(args)
    from posfb.analysis.api import tune
    from posfb.analysis.tuning.search import TuneError

    try:
        result = tune(args.scenario, study=args.study, settings=settings,
                      set=args.settings, out=out)  # fmt: skip
    except TuneError as failure:
        sys.stderr.write(f"posfb tune: {failure}\n")
        return EXIT_NOT_FOUND
    result.save(out)
    if args.json:
        from posfb.analysis.tuning.report import result_dict

        print(json.dumps(result_dict(result) | {"out": str(out)}))
    else:
        from posfb.analysis.tuning.report import text_report

        print(text_report(result))
        print(f"wrote {out} ({result.wall_time_s:.0f} s)")
    return 0
