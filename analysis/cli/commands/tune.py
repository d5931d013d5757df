"""``posfb tune SCENARIO``: a robust design of the paper's controller and Lin+LC for the
scenario's arm (``analysis.design``), verified on fresh plants with a stated guarantee,
written as a tuned scenario.

It is ``posfb.tune`` (``analysis.api``) with the scenario and settings from the command
line. Exit codes: 0 tuned and written; 1 no design meets the constraints, or the tuning
ran out of ``--budget`` or would (an estimate before a set of plants is drawn), or the
tuned design is worse than the scenario's own and ``--accept-worse`` is not given (one
line says which; nothing is written); 2 bad input (a bad study, e.g. of another arm, an
option out of range or over its ceiling, an ``--out`` that exists or is the scenario
itself without ``--force``: refused before the search). A tuned value within 2 % of its
search box's edge gets a warning line on stderr, as an accepted worse design does, and
so does a tuned entry whose check run is not ``ok``: its report states no guarantee
(``TunedController.not_certified``). The tuned file is written atomically
(``analysis.common.outputs.atomic_file``)."""

from __future__ import annotations

import argparse
import json
import re
import sys
from dataclasses import fields

from posfb.analysis.common.shipped import scenario_argument, study_argument

#: Exit code when no design is found (infeasible, or not within the budget).
EXIT_NOT_FOUND = 1

#: The options that set a ``TuneSettings`` field of the same name, and their help.
SETTING_OPTIONS = {
    "seed": (int, "seed of the design plants (the fresh plants of round r use seed + 1 + r)"),
    "budget": (float, "wall-clock seconds the whole tuning may take (checked inside the work)"),
    "plants": (int, "design plants the search requires to be stable"),
    "margin": (float, "required rho <= 1 - margin"),
    "epsilon": (float, "probability of instability the verification bounds"),
    "beta": (float, "1 - confidence of the verified bound"),
    "generations": (int, "generations of the search's fixed schedule"),
    "rounds": (int, "design-and-verify rounds at most (each on twice the plants)"),
    "workers": (int, "processes tuning the controllers side by side (default: one per "
                "controller, at most the cores available; the result is the same)"),
}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "scenario", type=scenario_argument,
        help="scenario YAML of the arm to tune for, or a shipped scenario's name",
    )  # fmt: skip
    parser.add_argument(
        "--study", metavar="STUDY", type=study_argument,
        help="Monte-Carlo study (YAML, or a shipped study's name) whose parameters give the plants "
        "(default: +-20 %% on every link, rotor, damping and friction value, 5 %% motor constants)",
    )  # fmt: skip
    parser.add_argument(
        "--out", required=True, metavar="TUNED.yaml",
        help="tuned scenario (an existing file, or the scenario itself, only with --force)",
    )  # fmt: skip
    parser.add_argument(
        "--force", action="store_true", help="overwrite an existing --out (or the input)"
    )
    parser.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", dest="settings",
        help="change one scenario key before tuning (repeatable)",
    )  # fmt: skip
    from posfb.analysis.design.settings import TuneSettings  # light: dataclasses only

    defaults = TuneSettings()
    for name, (kind, text) in SETTING_OPTIONS.items():
        default = getattr(defaults, name)  # None: the help text says what it means
        parser.add_argument(
            f"--{name}", type=kind, help=text if default is None else f"{text} (default: {default})"
        )
    parser.add_argument(
        "--accept-worse", action="store_true",
        help="write the tuned design even when its predicted error or its check run is worse "
        "than the scenario's own (default: refused, exit 1)",
    )  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--no-progress", action="store_true",
        help="no progress line on stderr (none with --json either)",
    )  # fmt: skip
    parser.set_defaults(handler=run)


def tune_settings(args: argparse.Namespace) -> object:
    """The ``TuneSettings`` of the command line (validated, naming each option: a
    setting's ``name = value`` in the message reads ``--name = value``)."""
    from posfb.analysis.design.settings import TuneSettings

    given = {f.name: getattr(args, f.name) for f in fields(TuneSettings)
             if getattr(args, f.name, None) is not None}  # fmt: skip
    try:
        return TuneSettings(**given)
    except ValueError as error:
        names = "|".join(SETTING_OPTIONS)
        raise ValueError(re.sub(rf"\b({names}) = ", r"--\1 = ", str(error))) from None


def run(args: argparse.Namespace) -> int:
    from posfb.analysis.common.outputs import output_file

    inputs = (args.scenario,) if args.study is None else (args.scenario, args.study)
    out = output_file("--out", args.out, (".yaml", ".yml"), force=args.force, inputs=inputs)
    settings = tune_settings(args)
    from posfb.analysis.api import tune
    from posfb.analysis.design.search import TuneError

    try:
        result = tune(args.scenario, study=args.study, settings=settings, set=args.settings,
                      out=out, accept_worse=args.accept_worse,
                      progress=not (args.no_progress or args.json))  # fmt: skip
    except TuneError as failure:
        sys.stderr.write(f"posfb tune: {failure}\n")
        return EXIT_NOT_FOUND
    for edge in result.at_edge:
        sys.stderr.write(f"posfb tune: warning: {edge.sentence()}\n")
    if result.left_out:
        from posfb.analysis.common.loop_effects import left_out_note

        sys.stderr.write(f"posfb tune: {left_out_note(result.left_out)}\n")
    if result.not_certified:
        sys.stderr.write(f"posfb tune: warning: no guarantee stated: {result.not_certified}\n")
    if result.worse:
        sys.stderr.write(
            f"posfb tune: warning: written as --accept-worse asks, though worse than the "
            f"scenario's own: {result.worse}\n"
        )
    result.save(out)
    if args.json:
        from posfb.analysis.design.tune_report import result_dict

        print(json.dumps(result_dict(result) | {"out": str(out), "left_out": result.left_out}))
    else:
        from posfb.analysis.design.tune_report import text_report

        print(text_report(result))
        print(f"wrote {out} ({result.wall_time_s:.0f} s)")
    return 0
