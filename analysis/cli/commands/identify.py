"""``posfb identify``: theta_1..theta_11 of Sec. 4.1, computed exactly from a URDF plant
(``--urdf``, no log) or identified from an encoder log with its uncertainty (``--log``,
``analysis.identification``), and ``posfb identify plan``: an exciting trajectory
for a scenario's arm."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from posfb.analysis.cli.commands.montecarlo import _positive_int, _seed
from posfb.analysis.cli.commands.number_args import nonnegative, positive
from posfb.analysis.cli.commands.scenario_args import add_scenario_arguments, scenario_from_args
from posfb.analysis.common.errors import UsageError


def configure(parser: argparse.ArgumentParser) -> None:
    # No default here: the shipped URDF's path is ``models.plant.DEFAULT_URDF``, which
    # imports Drake; ``run`` reads it.
    parser.add_argument(
        "--urdf", help="arm URDF whose theta is computed exactly (default: the shipped "
        "two-link arm); not with --log",
    )  # fmt: skip
    parser.add_argument("--payload", type=float, default=0.0, help="tip payload mass in kg")
    parser.add_argument(
        "--log", type=Path, metavar="LOG", help="identify from this log (CSV or Parquet: "
        "time_s, q<j>_measured_rad or q<j>_counts, u<j>_applied_V; posfb simulate --out "
        "writes one)",
    )  # fmt: skip
    add_scenario_arguments(parser, ())
    parser.add_argument(
        "--validate",
        type=Path,
        metavar="LOG2",
        help="a second log of the same arm to validate the model on",
    )
    parser.add_argument(
        "--out",
        type=Path,
        metavar="MODEL.yaml",
        help="write the model (nominal_model: !Identified {file: ...})",
    )
    parser.add_argument(
        "--study-out",
        type=Path,
        metavar="STUDY.yaml",
        help="write a Monte-Carlo study whose plants are drawn from the "
        "identification's uncertainty (for montecarlo run, tune --study)",
    )
    parser.add_argument(
        "--study-scenario",
        type=Path,
        metavar="S.yaml",
        help="the scenario --study-out's samples run, of the same true arm "
        "(default: --scenario, the identification's)",
    )
    parser.add_argument(
        "--study-samples",
        type=_positive_int,
        default=100,
        metavar="N",
        help="samples of --study-out's study (default 100)",
    )
    parser.add_argument(
        "--figure",
        type=Path,
        metavar="FILE",
        help="with --validate: measured against predicted (.svg or .png)",
    )
    parser.add_argument(
        "--cutoff",
        type=positive,
        metavar="HZ",
        help="the filters' cutoff in Hz (default: the rule of models.identification.estimate."
        "cutoff_rule: 10 x the motion's band, lowered for a coarse encoder; printed)",
    )
    parser.add_argument(
        "--stiction-velocity",
        type=nonnegative,
        metavar="RAD_PER_S",
        help="rows slower than this stay out of the fit (default 0.3)",
    )
    parser.add_argument(
        "--window",
        type=positive,
        metavar="S",
        help="output-error window of --validate in s (default 1)",
    )
    parser.add_argument(
        "--force", action="store_true", help="replace existing --out, --figure and --study-out "
        "files, the command's own inputs included",
    )  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress line on stderr (none with --json either)")  # fmt: skip
    parser.set_defaults(handler=run)
    actions = parser.add_subparsers(dest="action", parser_class=type(parser))
    plan = actions.add_parser(
        "plan", help="an exciting trajectory (finite Fourier series, Swevers 1997) as a "
        "CSV that trajectory: !CsvFile runs",
    )  # fmt: skip
    add_scenario_arguments(plan, ())
    plan.add_argument("--out", type=Path, required=True, metavar="TRAJ.csv")
    plan.add_argument("--duration", type=positive, default=60.0, help="seconds (default 60)")
    plan.add_argument("--harmonics", type=int, default=5, help="per joint (default 5)")
    plan.add_argument(
        "--period",
        type=positive,
        default=10.0,
        help="period of the series in s, dividing --duration (default 10)",
    )
    plan.add_argument("--seed", type=_seed, default=0, help="the optimiser's random start")
    plan.add_argument(
        "--excursion",
        type=positive,
        metavar="RAD",
        help="largest excursion from the rest position (default pi/2)",
    )
    plan.add_argument(
        "--velocity-limit",
        type=positive,
        metavar="RAD_PER_S",
        help="default: the URDF's joint velocity limits, else 2 rad/s",
    )
    plan.add_argument("--force", action="store_true", help="replace an existing --out file")
    plan.add_argument("--json", action="store_true", help="print one JSON object")
    plan.add_argument("--no-progress", action="store_true",
                      help="no progress line on stderr (none with --json either)")  # fmt: skip
    plan.set_defaults(handler=run_plan)  # fmt: skip


def _exact(args: argparse.Namespace) -> int:
    from posfb.analysis.common.tables import theta_table
    from posfb.models.plant import DEFAULT_URDF
    from posfb.models.theta_of_plant import identify_urdf

    urdf = args.urdf or str(DEFAULT_URDF)
    identified = identify_urdf(urdf, args.payload)
    if args.json:
        print(json.dumps(identified.as_dict()))
    else:
        print(f"theta identified from {urdf} with a {args.payload:g} kg tip payload")
        print(theta_table({"identified": identified}))
    return 0


def run(args: argparse.Namespace) -> int:
    if args.log is None:
        given = [f for f in ("validate", "out", "figure", "cutoff", "stiction_velocity",
                             "window", "study_out", "study_scenario")
                 if getattr(args, f) is not None]  # fmt: skip
        if given:
            raise UsageError(f"--{given[0].replace('_', '-')} needs --log")
        return _exact(args)
    if args.urdf is not None:
        raise UsageError(
            "--urdf and --log both given; the log's arm is the scenario's (--scenario)"
        )
    if args.study_scenario is not None and args.study_out is None:
        raise UsageError("--study-scenario needs --study-out (it is the study's scenario)")
    if args.figure is not None and args.validate is None:
        raise UsageError("--figure needs --validate (it draws the validation)")
    from posfb.analysis.api import identify
    from posfb.analysis.common.progress import wanted

    scenario = scenario_from_args(args)
    _check_outputs(args, scenario)
    result = identify(
        args.log,
        scenario,
        validate=args.validate,
        cutoff_hz=args.cutoff,
        stiction_velocity=args.stiction_velocity,
        window=args.window,
        progress=wanted(args.no_progress or args.json),
    )
    if args.out is not None:
        result.save(args.out)
    if args.figure is not None:
        result.figure(args.figure)
    if args.study_out is not None:
        from posfb.analysis.api import load_scenario

        experiment = None if args.study_scenario is None else load_scenario(args.study_scenario)
        result.save_study(
            args.study_out, model=args.out, samples=args.study_samples, experiment=experiment
        )
    if args.json:
        print(json.dumps(result.as_dict()))
        return 0
    print(result.report())
    for path in (args.out, args.figure, args.study_out):
        if path is not None:
            print(f"wrote {path}")
    return 0


def _inputs(args: argparse.Namespace, *names: str) -> list[Path]:
    """The command's input files among ``names`` (options holding a path) and its
    scenario's file."""
    found = [Path(getattr(args, name)) for name in names if getattr(args, name) is not None]
    scenario = getattr(args, "scenario", None)
    if scenario is not None and Path(str(scenario)).is_file():
        found.append(Path(str(scenario)))
    return found


def _check_outputs(args: argparse.Namespace, scenario) -> None:
    """Every file ``identify`` writes, checked before the work: none is an input (the
    logs, the scenario and its URDFs among them), none exists without ``--force``
    (``output_file``), no two are the same file."""
    from posfb.analysis.common.outputs import output_file
    from posfb.diagrams.resolve import resolve
    from posfb.models.lumped import LumpedParameters

    config = resolve(scenario).config
    urdfs = [Path(u) for u in (config.plant.urdf, getattr(config.design.nominal, "urdf", None))
             if u is not None]  # fmt: skip
    inputs = [*_inputs(args, "log", "validate", "study_scenario"), *urdfs]
    outputs = {}
    if args.out is not None:
        outputs["--out"] = output_file("--out", args.out, (".yaml", ".yml"), args.force, inputs)
        if not isinstance(config.design.nominal, LumpedParameters):
            urdf = str(Path(args.out).with_suffix(".urdf"))  # a URDF arm's, beside the model
            outputs["--out's URDF"] = output_file("--out's URDF", urdf, None, args.force, inputs)
    if args.figure is not None:
        outputs["--figure"] = output_file("--figure", args.figure, (".svg", ".png"), args.force,
                                          inputs)  # fmt: skip
    if args.study_out is not None:
        outputs["--study-out"] = output_file("--study-out", args.study_out, (".yaml", ".yml"),
                                             args.force, inputs)  # fmt: skip
    seen: dict[Path, str] = {}
    for option, path in outputs.items():
        same = seen.get(path.resolve())
        if same is not None:
            raise UsageError(f"{option} {path} is also {same}; a file of its own is required")
        seen[path.resolve()] = option


def run_plan(args: argparse.Namespace) -> int:
    from posfb.analysis.api import plan_excitation
    from posfb.analysis.common.outputs import output_file
    from posfb.analysis.common.progress import wanted

    output_file("--out", args.out, (".csv",), args.force, _inputs(args))
    plan = plan_excitation(
        scenario_from_args(args),
        duration=args.duration,
        harmonics=args.harmonics,
        period=args.period,
        seed=args.seed,
        excursion=args.excursion,
        velocity_limit=args.velocity_limit,
        progress=wanted(args.no_progress or args.json),
    )
    plan.save(args.out)
    if args.json:
        print(json.dumps(plan.as_dict()))
        return 0
    print(plan.report())
    print(f"wrote {args.out}")
    return 0
