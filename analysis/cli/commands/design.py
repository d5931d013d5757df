"""``posfb design``: the controller design of Sec. 3 at the paper's Sec. 4.2
settings (``K``, ``P``, ``E``, ``Gamma``, poles, bounds) and its checks.

The sampled-data spectral radius is that of the nominal linear plant
``M0* q'' + B* q' = u`` held over ``T_s`` with the discretised ``tau_LC + tau_NC``
filters at ``alpha = alpha*``, with the scenario's linear effects (compute and sensor
delay, lag, compliant gear: ``analysis.common.loop_effects``; the nonlinear settings it leaves
out are named in one note on stderr and under ``left_out`` in JSON), at ``M0*`` and with
``M*(q)`` frozen at the configurations of the path (the worst reported). A failed check is
reported (``warnings`` in JSON, ``FAILED`` in the text) and the command exits 0 (the
report is the result), or 1 with ``--strict``. The report ends with a run of the
scenario's arm (``analysis.design.exact_arm``; ``exact_arm`` in JSON; ``--no-sim``
skips it): a run that is not ``ok`` sets the exit code as ``simulate``'s does.

``--margins`` adds the margins of the scenario's controller's sampled loop (gain, phase,
delay and disk margins, sensitivity peaks: ``analysis.design.margins_report``; in JSON the
object ``margins``); a controller without a linear design (a plug-in) is refused. With
``--out DIR`` it writes ``margins.json`` and the figures of
``analysis.design.margins_figures`` (PNG and SVG) there.

``--map`` draws the stability map instead (``analysis.design.stability_map``): the nominal
loop's spectral radius and the share of sampled plants robustly stable over a grid of
two design keys, and the largest sample time with a robust design.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING

from posfb.analysis.cli.commands.montecarlo import _positive_int, _seed
from posfb.analysis.cli.commands.scenario_args import add_scenario_arguments, scenario_from_args
from posfb.analysis.common.errors import UsageError
from posfb.analysis.common.shipped import study_argument
from posfb.analysis.design.design_report import (
    design_to_dict,
    format_report,
    nominal_design,
    relevant_checks,
)
from posfb.analysis.design.settings import DEFAULT_MARGIN, TuneSettings

#: ``--generations``' default (``analysis.design.worst_case.DEFAULT_GENERATIONS``, restated
#: so that the parser does not import the search; a test checks the two agree).
DEFAULT_GENERATIONS = 15

if TYPE_CHECKING:
    from pathlib import Path

    from posfb.analysis.design.linear_loop import LinearDesign
    from posfb.analysis.design.stability_map import MapAxis
    from posfb.diagrams.resolve import LoadedScenario, ResolvedScenario
    from posfb.models.design import Design
    from posfb.models.design.margins import LoopMargins

#: Exit code of ``--strict`` when a check fails.
EXIT_FAILED_CHECK = 1


def configure(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser, ("controller", "sample_time", "alpha_star"))
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--strict", action="store_true", help="exit 1 when any design check fails (for scripts)"
    )
    parser.add_argument(
        "--margins", action="store_true", help="add the gain, phase, delay and disk margins "
        "of the scenario controller's sampled loop",
    )  # fmt: skip
    parser.add_argument(
        "--worst-case", action="store_true", help="search --study's parameter box for the "
        "plants with the largest rho and the smallest disk margin of the scenario "
        "controller's loop (with --plants, --seed, --generations)",
    )  # fmt: skip
    parser.add_argument(
        "--generations", type=_positive_int, metavar="G",
        help=f"--worst-case: generations of the search (default {DEFAULT_GENERATIONS})",
    )  # fmt: skip
    parser.add_argument(
        "--no-progress", action="store_true",
        help="--worst-case: no progress line on stderr (none with --json either)",
    )  # fmt: skip
    parser.add_argument(
        "--no-sim", action="store_true", help="skip the simulation of the scenario's arm "
        "that confirms the linear verdict (analysis/design/exact_arm.py)",
    )  # fmt: skip
    add_map_arguments(parser)
    parser.set_defaults(handler=run)


#: The ``--map`` options (argparse dest -> flag), refused without ``--map``.
MAP_OPTIONS = {"map_axes": "--map-axes", "map_range": "--map-range", "map_points": "--map-points",
               "study": "--study", "plants": "--plants", "seed": "--seed", "margin": "--margin",
               "mark": "--mark", "out": "--out"}  # fmt: skip


def add_map_arguments(parser: argparse.ArgumentParser) -> None:
    """``--map`` and its options. The defaults are ``analysis.design.settings``' and
    ``analysis.design.stability_map``'s; the help restates the latter's without importing it (it
    loads Drake), and ``tests/analysis/design/test_stability_map.py`` keeps the two equal."""
    defaults = TuneSettings()
    group = parser.add_argument_group(
        "stability map (--map)",
        "the nominal loop's sampled-data spectral radius rho and the share of sampled "
        "plants with rho <= 1 - margin over a grid of two design keys; prints the largest "
        "sample time with a robust design on the map",
    )
    group.add_argument("--map", action="store_true", help="draw the stability map")
    group.add_argument(
        "--map-axes", nargs=2, metavar="KEY",
        help="x and y keys: timing.sample_time or a numeric key of the controller entry "
        "(default: timing.sample_time controller.alpha_star)",
    )  # fmt: skip
    group.add_argument(
        "--map-range", nargs=4, type=float, metavar=("XLOW", "XHIGH", "YLOW", "YHIGH"),
        help="grid ranges, each holding the scenario's value (default: T_s/4 .. 4 T_s for the "
        "sample time, value/16 .. 2 value for another key, e.g. alpha* 0.25 .. 8 for "
        "alpha* = 4)",
    )  # fmt: skip
    group.add_argument("--map-points", type=int, metavar="N",
                       help="grid points per axis, log-spaced, the scenario's value one of "
                       "them (default 25, 3 .. 201)")  # fmt: skip
    group.add_argument("--study", metavar="STUDY.yaml", type=study_argument,
                       help="draw the plants from a study's distributions (a YAML file or a "
                       "shipped study's name; default: +-20 %% on "
                       "every link and drive parameter, motor constants 5 %%)")  # fmt: skip
    group.add_argument(
        "--plants", type=int, metavar="N", help=f"sampled plants (default {defaults.plants})"
    )
    group.add_argument(
        "--seed", type=_seed, metavar="S", help=f"seed of the plants (default {defaults.seed})"
    )
    group.add_argument(
        "--margin", type=float, metavar="M", help=f"robust: rho <= 1 - M (default {DEFAULT_MARGIN})"
    )
    group.add_argument("--mark", metavar="TUNED.yaml",
                       help="also mark this scenario's values of the two keys (e.g. posfb "
                       "tune's output)")  # fmt: skip
    group.add_argument(
        "--out",
        metavar="DIR",
        help="write stability_map.png, .svg and .json into DIR (with "
        "--margins: margins.json and the Bode, Nyquist and sensitivity figures)",
    )


def design_config(args: argparse.Namespace) -> tuple[ResolvedScenario, tuple[str, ...]]:
    """The scenario the command line describes, resolved, and the design checks its
    controller entry determines (``relevant_checks``)."""
    from posfb.diagrams.resolve import resolve

    resolved = resolve(scenario_from_args(args))
    return resolved, relevant_checks(resolved.config)


def scenario_design(resolved: ResolvedScenario, command: str = "design") -> Design:
    """``design.design_report.nominal_design`` of the scenario, the settings it leaves out noted on
    stderr first (``posfb COMMAND: note: ...``)."""
    from posfb.analysis.common.loop_effects import left_out, left_out_note

    note = left_out_note(left_out(resolved.config))
    if note:
        sys.stderr.write(f"posfb {command}: {note}\n")
    return nominal_design(resolved)


def loop_design(resolved: ResolvedScenario, flag: str = "--margins") -> LinearDesign:
    """The scenario controller's linear sampled loop; a controller without one is refused
    naming ``flag``."""
    from posfb.analysis.design.linear_loop import linear_design

    try:
        return linear_design(resolved)
    except ValueError as error:
        raise UsageError(f"{flag}: {error}") from None


#: The options each of ``--margins`` and ``--worst-case`` takes from the map's group.
SHARED_OPTIONS = {"margins": ("out",), "worst_case": ("study", "plants", "seed")}


def run(args: argparse.Namespace) -> int:
    modes = [flag for flag, on in (("--map", args.map), ("--margins", args.margins),
                                   ("--worst-case", args.worst_case)) if on]  # fmt: skip
    if len(modes) > 1:
        raise UsageError(f"{modes[0]} and {modes[1]} are separate reports; give one of them")
    if args.generations is not None and not args.worst_case:
        raise UsageError("--generations applies to --worst-case")
    if args.map:
        return run_map(args)
    shared = SHARED_OPTIONS["margins" if args.margins else "worst_case"] if modes else ()
    given = [flag for dest, flag in MAP_OPTIONS.items() if getattr(args, dest) is not None
             and dest not in shared]  # fmt: skip
    if given:
        raise UsageError(f"{given[0]} applies to the stability map; add --map")
    if args.worst_case:
        return run_worst_case(args)
    from posfb.analysis.common.loop_effects import left_out
    from posfb.analysis.common.outputs import output_folder
    from posfb.diagrams.resolve import resolve
    from posfb.models.controllers import design_checks

    out = None if args.out is None else output_folder("--out", args.out)
    resolved = resolve(scenario_from_args(args))
    linear = loop_design(resolved) if args.margins else None
    # A controller without a Sec. 3 design (PID, a plug-in) has only its margins to show.
    relevant = relevant_checks(resolved.config) if linear is None else (
        design_checks(resolved.config.controller))  # fmt: skip
    design = scenario_design(resolved) if relevant else None
    failed = [] if design is None else [
        c for c in design.checks if c.name in relevant and not c.passed]  # fmt: skip
    found = {} if design is None else design_to_dict(design, relevant)
    found["left_out"] = left_out(resolved.config)
    text = [] if design is None else [format_report(design, relevant)]
    if linear is not None:
        from posfb.analysis.design.margins_report import format_margins, margins_to_dict

        margins, frozen = linear.margins(), linear.frozen_margins()
        found["margins"] = margins_to_dict(linear, margins, frozen)
        text.append(format_margins(linear, margins, frozen))
        if out is not None:
            found["files"] = write_margins(out, linear, margins, found["margins"])
            text.append("wrote " + ", ".join(found["files"]))
    code = EXIT_FAILED_CHECK if args.strict and failed else 0
    if not args.no_sim:
        from posfb.analysis.common.errors import run_exit_code
        from posfb.analysis.design.exact_arm import REFUSED, agreement, exact_arm_run

        run = exact_arm_run(resolved)
        found["exact_arm"] = run.to_dict()
        text.append(agreement(not failed, run))
        if run.verdict.status != REFUSED:  # a refusal is the design report's failed check
            code = code or run_exit_code([run.verdict.status])
    print(json.dumps(found, allow_nan=False) if args.json else "\n".join(text))
    return code


def run_worst_case(args: argparse.Namespace) -> int:
    """``posfb design --worst-case --study STUDY``: print (or ``--json``) the worst plants
    of the study's box (``analysis.design.worst_case``)."""
    from posfb.analysis.common import progress
    from posfb.analysis.design.worst_case import (
        DEFAULT_PLANTS,
        DEFAULT_SEED,
        check_search_size,
        format_worst_case,
        worst_case,
        worst_case_to_dict,
    )
    from posfb.analysis.uncertainty.study import load_study
    from posfb.diagrams.arm import arm_identity
    from posfb.diagrams.resolve import resolve

    if args.strict:
        raise UsageError("--strict applies to the design report, not to --worst-case")
    if args.study is None:
        raise UsageError("--worst-case needs --study STUDY.yaml (the parameter box to search)")
    plants = DEFAULT_PLANTS if args.plants is None else args.plants
    generations = DEFAULT_GENERATIONS if args.generations is None else args.generations
    try:
        check_search_size(plants, generations)
    except ValueError as error:
        raise UsageError(f"--worst-case --{error}") from None
    loaded = scenario_from_args(args)
    study = load_study(args.study, arm=arm_identity(loaded.scenario, loaded.base_dir))
    config = resolve(loaded).config
    loop_design(resolve(loaded), "--worst-case")  # a plug-in is refused before any work
    try:
        show = progress.wanted(args.no_progress or args.json)
        with progress.status_line("worst case", show) as say:
            found = worst_case(
                loaded, study, config.controller, plants=plants,
                generations=generations,
                seed=DEFAULT_SEED if args.seed is None else args.seed, progress=say,
            )  # fmt: skip
    except ValueError as error:
        raise UsageError(f"--worst-case: {error}") from None
    if args.json:
        print(json.dumps(worst_case_to_dict(found), allow_nan=False))
    else:
        print(format_worst_case(found, config.spec.label_for(config.design)))
    return 0


def write_margins(
    out: Path, linear: LinearDesign, margins: LoopMargins, data: dict[str, object]
) -> list[str]:
    """``margins.json`` and the figures of ``analysis.design.margins_figures`` in ``out``,
    staged (a failed write leaves ``out`` as it was); the paths written."""
    from posfb.analysis.common.outputs import staged_folder
    from posfb.analysis.design.margins_figures import write_margin_figures

    with staged_folder(out) as staged:
        path = staged.path / "margins.json"
        path.write_text(json.dumps(data, allow_nan=False, indent=1) + "\n")
        paths = [path, *write_margin_figures(staged.path, linear, margins)]
    return [str(p) for p in staged.final(paths)]


def _map_settings(args: argparse.Namespace) -> TuneSettings:
    """``--plants``, ``--seed``, ``--margin`` over ``TuneSettings``' defaults, validated
    (the map draws its plants once: one round, for the plants' ceiling)."""
    defaults = TuneSettings()
    try:
        settings = TuneSettings(
            margin=defaults.margin if args.margin is None else args.margin,
            plants=defaults.plants if args.plants is None else args.plants,
            seed=defaults.seed if args.seed is None else args.seed,
            rounds=1,
        )
    except ValueError as error:
        raise UsageError(f"--{error}") from None
    return settings


def _map_axes(args: argparse.Namespace, loaded: LoadedScenario) -> list[MapAxis]:
    """The two ``MapAxis`` of the command line (``stability_map.make_axis``: log-spaced,
    the scenario's value a grid point), keys, ranges and ends validated."""
    from posfb.analysis.design import stability_map as sm

    keys = tuple(args.map_axes or sm.DEFAULT_AXES)
    if keys[0] == keys[1]:
        raise UsageError(f"--map-axes {keys[0]} {keys[1]}: two different keys are required")
    points = sm.DEFAULT_POINTS if args.map_points is None else args.map_points
    sm.check_points(points)
    values = [sm.key_value(loaded, key) for key in keys]
    ranges = (
        [sm.default_range(k, v) for k, v in zip(keys, values, strict=True)]
        if args.map_range is None
        else [tuple(args.map_range[:2]), tuple(args.map_range[2:])]
    )
    axes = [
        sm.make_axis(key, low, high, points, value)
        for key, value, (low, high) in zip(keys, values, ranges, strict=True)
    ]
    sm.check_endpoints(loaded, axes)
    return axes


def run_map(args: argparse.Namespace) -> int:
    """``posfb design --map``: compute, print (or ``--json``), and with ``--out`` write the
    figure and the JSON."""
    from posfb.analysis.common.outputs import output_folder, staged_folder
    from posfb.analysis.design import stability_map as sm
    from posfb.diagrams.resolve import resolve

    if args.strict:
        raise UsageError("--strict applies to the design report, not to --map")
    out = None if args.out is None else output_folder("--out", args.out)
    settings = _map_settings(args)
    loaded = scenario_from_args(args)
    study = None
    if args.study is not None:  # first: a study of another arm is refused before any work
        from posfb.analysis.uncertainty.study import load_study
        from posfb.diagrams.arm import arm_identity

        study = load_study(args.study, arm=arm_identity(loaded.scenario, loaded.base_dir))
    from posfb.analysis.common.loop_effects import left_out, left_out_note

    resolved = resolve(loaded)
    relevant = relevant_checks(resolved.config)
    note = left_out_note(left_out(resolved.config))
    if note:
        sys.stderr.write(f"posfb design --map: {note}\n")
    x, y = _map_axes(args, loaded)
    marks = {"scenario": {x.key: x.scenario_value, y.key: y.scenario_value}}
    if args.mark is not None:
        marks["marked"] = sm.mark_values(args.mark, (x.key, y.key), loaded)
    x, y = sm.with_marks(x, y, marks.values())
    sm.check_size(x, y, settings.plants)  # before the plants are drawn
    setup = sm.map_setup(loaded, relevant, study, settings.plants, settings.seed, settings.margin)
    smap = sm.compute_map(setup, x, y)
    robust = sm.largest_robust_sample_time(setup, smap)
    verdicts = sm.mark_verdicts(setup, smap, marks)
    data = sm.map_to_dict(setup, smap, robust, verdicts, settings.seed, args.study)
    data["left_out"] = left_out(resolved.config)
    if out is not None:
        with staged_folder(out) as staged:
            paths = sm.write_map(staged.path, sm.plot_map(setup, smap, verdicts, robust), data)
        data["files"] = [str(p) for p in staged.final(paths)]
    if args.json:
        print(json.dumps(data, allow_nan=False))
    else:
        print(sm.format_map(setup, smap, robust, verdicts))
        if out is not None:
            print(f"wrote {', '.join(data['files'])}")
    return 0
