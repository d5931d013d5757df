"""The scenario options every run command shares: ``--scenario FILE``, ``--set
KEY=VALUE`` and shortcut flags for the most used keys (``--duration`` is
``--set timing.duration=...``). Shortcuts apply first, then ``--set`` in order.

Adding the options is cheap (no Drake, no numpy): the scenario is loaded, and the
models imported, by ``scenario_from_args`` when a command runs."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from posfb.analysis.common.cases import CASE_FILES, CASES
from posfb.analysis.common.errors import UsageError
from posfb.analysis.common.shipped import scenario_argument, shipped_files

if TYPE_CHECKING:
    from posfb.diagrams.resolve import LoadedScenario

#: Shortcut flag -> (scenario key, argparse type, help). ``--controller`` takes any name
#: (no argparse ``choices``: they would import the controllers): the scenario's validation
#: refuses an unknown kind, naming ``controller.kind``.
SHORTCUTS = {
    "controller": ("controller.kind", str, "controller kind, e.g. proposed, lin_lc, pid"),
    "duration": ("timing.duration", float, "simulated seconds"),
    "sample_time": ("timing.sample_time", float, "T_s in seconds"),
    "encoder_counts": ("sensor.encoder_counts", int, "encoder counts per revolution (0: ideal)"),
    "payload": ("plant.payload_mass", float, "tip payload mass of the true arm, kg"),
    "alpha_star": ("controller.alpha_star", float, "alpha* of Eq. 21"),
    "voltage_limit": ("actuator.voltage_limit", float, "armature-voltage limit, V"),
}


def add_scenario_arguments(parser: argparse.ArgumentParser, shortcuts: tuple[str, ...]) -> None:
    """``--scenario``, ``--case``, ``--set`` and the named ``shortcuts`` (keys of ``SHORTCUTS``)."""
    parser.add_argument(
        "--scenario", metavar="FILE", type=scenario_argument,
        help="scenario YAML (posfb scenario dump), or a shipped scenario's name: "
        f"{', '.join(shipped_files('scenario'))}",
    )  # fmt: skip
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
        metavar = "KIND" if name == "controller" else None
        parser.add_argument(flag, type=kind, metavar=metavar, help=f"{text} (= --set {key}=...)")


def add_sil_argument(parser: argparse.ArgumentParser) -> None:
    """``--sil [double|float]``: software in the loop (``posfb.simulate``'s ``sil``)."""
    parser.add_argument(
        "--sil", nargs="?", const="double", choices=("double", "float"), metavar="PRECISION",
        help="software in the loop: the controller generated as C (posfb codegen) in "
        "PRECISION (double, the default, or float), compiled by the cc on the PATH and run "
        "in the diagram",
    )  # fmt: skip


def scenario_from_args(args: argparse.Namespace) -> LoadedScenario:
    """The scenario the command line describes, validated."""
    if args.scenario and args.case:
        raise UsageError("--scenario and --case both given; choose one")
    path = args.scenario or CASE_FILES[args.case or "nominal"]
    from posfb.diagrams.yaml_schema import read_text

    read_text(Path(path), "scenario")  # a missing file is refused before the models load
    from posfb.diagrams.resolve import load_scenario

    settings = [
        f"{SHORTCUTS[name][0]}={getattr(args, name)!r}"
        for name in SHORTCUTS
        if getattr(args, name, None) is not None
    ]
    loaded = load_scenario(path, [*settings, *args.settings])
    loaded.source = str(args.scenario or args.case or "nominal")
    return loaded
