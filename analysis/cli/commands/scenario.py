"""``posfb scenario dump|check|init``: the settings tree of a run, written out in full,
validated with the design verdict (Sec. 3 checks, sampled-data radius over the path's
configurations) and the margins of the controller's sampled loop (``posfb design
--margins``), confirmed on the exact arm (``analysis.design.exact_arm``; ``--no-sim``
skips it; a run that is not ``ok`` sets the exit code as ``simulate``'s does), or derived
for a
new arm from its URDF (``analysis.design.scenario_init``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from posfb.analysis.cli.commands.design import EXIT_FAILED_CHECK, scenario_design
from posfb.analysis.cli.commands.scenario_args import add_scenario_arguments, scenario_from_args
from posfb.analysis.design.design_report import format_report

if TYPE_CHECKING:
    from posfb.diagrams.resolve import ResolvedScenario


def configure(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, parser_class=type(parser))
    dump = actions.add_parser("dump", help="print a complete scenario, every default written")
    add_scenario_arguments(dump, ("controller",))
    dump.set_defaults(handler=run_dump)
    check = actions.add_parser("check", help="validate a scenario and print its design verdict")
    check.add_argument("file", help="scenario YAML")
    check.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="settings")
    check.add_argument(
        "--strict", action="store_true", help="exit 1 when any design check fails, not only "
        "those of the scenario's controller",
    )  # fmt: skip
    check.add_argument(
        "--no-sim", action="store_true", help="skip the simulation of the scenario's arm "
        "that confirms the linear verdict",
    )  # fmt: skip
    check.set_defaults(handler=run_check)
    init = actions.add_parser(
        "init", help="write a complete, commented scenario for the serial arm of a URDF"
    )
    init.add_argument("--urdf", required=True, type=Path, help="the arm (urdf/README.md)")
    init.add_argument("--out", required=True, type=Path, help="the scenario YAML to write")
    init.add_argument(
        "--sample-time",
        type=float,
        metavar="TS",
        help="T_s in seconds (default: timing.sample_time's)",
    )
    init.add_argument(
        "--encoder-counts",
        type=int,
        metavar="N",
        help="encoder counts per revolution (default: sensor.encoder_counts')",
    )
    init.add_argument(
        "--voltage-limit",
        type=float,
        metavar="V",
        help="armature-voltage limit, V (default: actuator.voltage_limit's)",
    )
    init.add_argument(
        "--duration", type=float, metavar="D", help="simulated seconds (default: timing.duration's)"
    )
    init.add_argument(
        "--package-path", action="append", default=[], type=Path, metavar="DIR",
        dest="package_paths", help="a folder that resolves the URDF's package:// meshes (a "
        "package.xml in it or below it, or a folder named as the package); repeatable",
    )  # fmt: skip
    init.add_argument(
        "--weld", action="append", default=[], metavar="NAME[=POSITION]", dest="welds",
        help="weld a joint that is not the arm's (a gripper) at POSITION (rad or m; default "
        "0 within its limits); repeatable",
    )  # fmt: skip
    init.add_argument(
        "--drives", type=Path, metavar="FILE.yaml", help="the drives' datasheet values "
        "(plant.drives' keys: motor_constant, gear_ratio, rotor_inertia, damping, coulomb)",
    )  # fmt: skip
    init.add_argument("--force", action="store_true", help="overwrite an existing --out")
    init.set_defaults(handler=run_init)  # fmt: skip


def run_dump(args: argparse.Namespace) -> int:
    from posfb.diagrams.scenario import dump_scenario

    sys.stdout.write(dump_scenario(scenario_from_args(args).scenario))
    return 0


def run_check(args: argparse.Namespace) -> int:
    from posfb.analysis.common.feasibility import trajectory_warnings
    from posfb.diagrams.resolve import load_scenario, resolve
    from posfb.models.controllers import design_checks

    loaded = load_scenario(args.file, args.settings)
    resolved = resolve(loaded)
    config = resolved.config
    print(f"{args.file}: valid; controller {config.controller}, T_s = {config.sample_time:g} s, "
          f"{config.timing.duration:g} s")  # fmt: skip
    for warning in trajectory_warnings(resolved):
        print(f"warning: {warning}")
    if not design_checks(config.controller):  # PID or a plug-in (built once by resolve)
        print(margins_text(resolved))
        print(f"verdict: {config.spec.label} has no Sec. 3 design; it was built with the "
              "scenario's settings")  # fmt: skip
        return 0
    design = scenario_design(resolved, "scenario check")
    print(format_report(design, design_checks(config.controller)))
    print(margins_text(resolved))
    relevant = design_checks(config.controller) if args.strict else config.spec.checks
    failed = [c.name for c in design.checks if c.name in relevant and not c.passed]
    whose = "the design" if args.strict else f"the {config.controller} controller"
    if failed:
        print(f"verdict: {whose} fails {', '.join(failed)}")
    else:
        print(f"verdict: every check of {whose} passed")
    code = EXIT_FAILED_CHECK if failed else 0
    if not args.no_sim:
        from posfb.analysis.common.errors import run_exit_code
        from posfb.analysis.design.exact_arm import REFUSED, agreement, exact_arm_run

        run = exact_arm_run(resolved)
        print(agreement(not failed, run))
        if run.verdict.status != REFUSED:  # a refusal is the design report's failed check
            code = code or run_exit_code([run.verdict.status])
    return code


def margins_text(resolved: ResolvedScenario) -> str:
    """The margins of the scenario controller's sampled loop in words
    (``analysis.design.margins_report``), or one line saying why it has none."""
    from posfb.analysis.design.linear_loop import linear_design
    from posfb.analysis.design.margins_report import format_margins

    try:
        linear = linear_design(resolved)
    except ValueError as error:
        return f"margins: none ({error})"
    return format_margins(linear, linear.margins(), linear.frozen_margins())


def run_init(args: argparse.Namespace) -> int:
    from posfb.analysis.design.scenario_init import InitOptions, write_scenario

    result = write_scenario(
        InitOptions(
            urdf=args.urdf,
            out=args.out,
            sample_time=args.sample_time,
            encoder_counts=args.encoder_counts,
            voltage_limit=args.voltage_limit,
            duration=args.duration,
            force=args.force,
            package_paths=tuple(args.package_paths),
            welds=tuple(args.welds),
            drives=args.drives,
        )  # fmt: skip
    )
    print(
        f"{result.path}: {result.joints} joints; trajectory at {result.scale:.3g} of the rule's "
        f"motion, nominal peak {result.peak_fraction:.0%} of the voltage limit; LQR bandwidth "
        f"{result.bandwidth_scale:.4g} x the paper's per sample; alpha* = "
        f"{result.alpha_star:g} (sampled-data radius over the path's configurations "
        f"{result.radius:.4f}, Lin+LC {result.radius_lin_lc:.4f})"
    )
    if result.reason:
        print(f"warning: {result.reason}")
    print(f"next: posfb scenario check {result.path}")
    return 0
