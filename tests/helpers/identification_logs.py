"""Logs for the identification tests: the paper's arm with every physical parameter
perturbed (seeded), run by posfb along a planned excitation, and the theta of that
perturbed arm computed from the plant as ``posfb identify --urdf`` does (the truth)."""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path

import numpy as np

import posfb
from posfb.models.plant import ArmParameters, PlantConfig, build_arm_diagram
from posfb.models.theta_of_plant import identify


def perturbed_parameters(
    seed: int, spread: float = 0.15, urdf: Path | None = None
) -> ArmParameters:
    """The parameters of the arm ``urdf`` (default: the shipped two-link arm), each
    per-joint value times ``1 + U(-spread, spread)`` (seeded; the payload stays 0)."""
    _, arm, _ = build_arm_diagram(None if urdf is None else PlantConfig(urdf=str(urdf)))
    defaults = arm.default_parameters
    rng = np.random.default_rng(seed)
    changes = {}
    for field in fields(defaults):
        if field.name == "payload_mass":
            continue
        values = np.asarray(getattr(defaults, field.name), dtype=float)
        changes[field.name] = tuple(
            float(x) for x in values * (1.0 + rng.uniform(-spread, spread, values.size))
        )
    return replace(defaults, **changes)


def true_theta(parameters: ArmParameters) -> np.ndarray:
    """theta_1..theta_11 of the arm with ``parameters`` (``models.theta_of_plant.identify``)."""
    _, arm, context = build_arm_diagram(parameters=parameters)
    return identify(arm, context).theta


def scenario_text(
    trajectory: Path, parameters: ArmParameters, counts: int, duration: float, base: str = ""
) -> str:
    """A scenario running ``trajectory`` (a ``!CsvFile``) on the arm with ``parameters``,
    after the text ``base`` (e.g. a scenario of another arm, without those keys)."""
    overrides = ", ".join(
        f"{f.name}: {list(getattr(parameters, f.name))}"
        for f in fields(parameters)
        if f.name != "payload_mass"
    )
    return base + (
        f"trajectory: !CsvFile {{path: {trajectory}}}\n"
        f"timing: {{duration: {duration}}}\n"
        f"sensor: {{encoder_counts: [{counts}]}}\n"
        f"plant:\n  parameters: {{{overrides}}}\n"
    )


def simulated_log(
    folder: Path,
    name: str,
    trajectory: Path,
    parameters: ArmParameters,
    *,
    counts: int = 20000,
    duration: float = 60.0,
    controller: str = "lin_lc",
    base: str = "",
) -> Path:
    """Run the scenario with ``controller`` and write its log ``folder/name.csv``."""
    scenario = folder / f"{name}.yaml"
    scenario.write_text(scenario_text(trajectory, parameters, counts, duration, base))
    log = folder / f"{name}.csv"
    posfb.simulate(scenario, controller).save(log)
    return log
