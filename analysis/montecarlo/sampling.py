"""One sampled plant per sample index, reproducible from ``(seed, index)`` alone.

Every scalar of a sample (each parameter of each joint, the payload, the encoder
resolution, then each ``draws`` key in file order) has its own random stream,
seeded with ``SeedSequence(seed, spawn_key=(index, slot))`` where ``slot`` is the
scalar's fixed position in ``SLOTS`` (``draws`` keys follow them). A sample's
draw therefore does not depend on which worker draws it, in which order, or on
how many samples the study has; and
changing one parameter's distribution leaves every other draw unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from posfb.analysis.montecarlo.config import (
    Distribution,
    Fixed,
    Normal,
    Study,
    Uniform,
    UniformDiscrete,
)
from posfb.diagrams.scenario import Scenario, apply_setting, get_setting
from posfb.models.plant import JOINT_PARAMETERS, ArmParameters

#: The scalars of one sample, in stream order: (name, joint). Append only: a slot's
#: position seeds its stream.
SLOTS = (
    *((name, joint) for name in JOINT_PARAMETERS for joint in (0, 1)),
    ("payload_mass", 0),
    ("encoder_counts", 0),
)

#: Draws per batch when rejecting outside a truncated normal's ``[low, high]``.
_BATCH = 64


@dataclass(frozen=True)
class SampledPlant:
    """The plant and encoder of sample ``index`` (``encoder_counts`` ``None``: the
    scenario's)."""

    index: int
    parameters: ArmParameters
    encoder_counts: int | None


def stream(seed: int, index: int, slot: int) -> np.random.Generator:
    """The random stream of scalar ``slot`` of sample ``index``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index, slot)))


def _draw_normal(distribution: Normal, rng: np.random.Generator) -> float:
    """A normal draw, by rejection when truncated (validation keeps >= 0.1 % of the mass)."""
    low = -np.inf if distribution.low is None else distribution.low
    high = np.inf if distribution.high is None else distribution.high
    while True:
        batch = rng.normal(distribution.mean, distribution.std, _BATCH)
        kept = batch[(batch >= low) & (batch <= high)]
        if kept.size:
            return float(kept[0])


def draw(distribution: Distribution, nominal: float, rng: np.random.Generator) -> float:
    """One value of a parameter whose URDF value is ``nominal``."""
    if isinstance(distribution, Fixed):
        return nominal if distribution.value is None else float(distribution.value)
    if isinstance(distribution, UniformDiscrete):
        return float(distribution.values[int(rng.integers(len(distribution.values)))])
    if isinstance(distribution, Uniform):
        x = float(rng.uniform(distribution.low, distribution.high))
    else:
        x = _draw_normal(distribution, rng)
    return nominal * (1.0 + x) if distribution.relative else x


def sample_plant(study: Study, nominal: ArmParameters, index: int) -> SampledPlant:
    """The plant of sample ``index``: draws from ``study.parameters`` around ``nominal``
    (the URDF's values), the encoder resolution, then ``study.overrides``."""
    values: dict[str, list[float]] = {name: [0.0, 0.0] for name in JOINT_PARAMETERS}
    for slot, (name, joint) in enumerate(SLOTS):
        rng = stream(study.seed, index, slot)
        if name == "payload_mass":
            payload = draw(study.parameters.payload_mass, nominal.payload_mass, rng)
        elif name == "encoder_counts":
            choices = study.encoder_counts
            counts = choices[int(rng.integers(len(choices)))] if choices else None
        else:
            distribution = study.parameters.for_joint(name, joint)
            values[name][joint] = draw(distribution, getattr(nominal, name)[joint], rng)
    for override in study.overrides:
        if override.sample != index:
            continue
        for name, pinned in override.values.items():
            if name == "payload_mass":
                payload = float(pinned[0])
            elif name == "encoder_counts":
                counts = int(pinned[0])
            else:
                values[name] = [float(v) for v in pinned]
    parameters = ArmParameters(
        **{name: (v[0], v[1]) for name, v in values.items()}, payload_mass=payload
    )
    return SampledPlant(
        index=index, parameters=parameters, encoder_counts=None if counts is None else int(counts)
    )


def sample_scenario(study: Study, index: int) -> tuple[Scenario, dict[str, float]]:
    """The scenario of sample ``index``: the study's base with every ``draws`` key drawn
    (relative draws around the base value), and the drawn values by key."""
    base = study.base_scenario()
    scenario, drawn = base, {}
    for position, (key, distribution) in enumerate(study.draws.items()):
        current = get_setting(base, key)
        nominal = float(current[0] if isinstance(current, list) else current)
        value = draw(distribution, nominal, stream(study.seed, index, len(SLOTS) + position))
        integer = isinstance(current[0] if isinstance(current, list) else current, int)
        text = repr(int(value)) if integer else repr(value)
        scenario = apply_setting(scenario, f"{key}={text}")
        drawn[key] = int(value) if integer else value
    return scenario, drawn
