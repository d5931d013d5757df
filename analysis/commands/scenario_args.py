"""The scenario options every run command shares: ``--scenario FILE``, ``--set
KEY=VALUE`` and shortcut flags for the most used keys (``--duration`` is
``--set timing.duration=...``). Shortcuts apply first, then ``--set`` in order."""

from __future__ import annotations

import argparse

from posfb.analysis.errors import UsageError
from posfb.analysis.experiment import CASE_FILES, CASES
from posfb.diagrams.resolve import LoadedScenario, load_scenario
from posfb.models.controllers import CONTROLLER_KINDS

#: Shortcut flag -> (scenario key, argparse type, help).
SHORTCUTS = {
    "controller": ("controller.kind", str, "controller kind"),
    "duration": ("timing.duration", float, "simulated seconds"),
    "sample_time": ("timing.sample_time", float, "T_s in seconds"),
    "encoder_counts": ("sensor.encoder_counts", int, "encoder counts per revolution (0: ideal)"),
    "payload": ("plant.payload_mass", float, "tip payload mass of the true arm, kg"),
    "alpha_star": ("controller.alpha_star", float, "alpha* of Eq. 21"),
    "voltage_limit": ("actuator.voltage_limit", float, "armature-voltage limit, V"),
}


def add_scenario_arguments(parser: argparse.ArgumentParser, shortcuts: tuple[str, ...]) -> None:
    """``--scenario``, ``--case``, ``--set`` and the named ``shortcuts`` (keys of ``SHORTCUTS``)."""
    parser.add_argument("--scenario", metavar="FILE", help="scenario YAML (posfb scenario dump)")
    parser.add_argument(
        "--case", choices=CASES, help="a shipped paper scenario instead of --scenario "
        "(default: nominal)",
    )  # fmt: skip
    parser.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", dest="settings",
        help="change one scenario key, e.g. --set timing.sample_time=0.005 (repeatable)",
    )  # fmt: skip
    for name in shortcuts:
        key, kind, text = SHORTCUTS[name]
        flag = "--" + name.replace("_", "-")
        choices = CONTROLLER_KINDS if name == "controller" else None
        parser.add_argument(flag, type=kind, choices=choices, help=f"{text} (= --set {key}=...)")


def scenario_from_args(args: argparse.Namespace) -> LoadedScenario:
    """The scenario the command line describes, validated."""
    if args.scenario and args.case:
        raise UsageError("--scenario and --case both given; choose one")
    path = args.scenario or CASE_FILES[args.case or "nominal"]
    settings = [
        f"{SHORTCUTS[name][0]}={getattr(args, name)!r}"
        for name in SHORTCUTS
        if getattr(args, name, None) is not None
    ]
    return load_scenario(path, [*settings, *args.settings])
