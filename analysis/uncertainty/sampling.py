"""One sampled plant per sample index, reproducible from ``(seed, index)`` alone.

The scalars of a sample are each parameter of each joint, the payload, the encoder
resolution, then each ``draws`` key in file order; ``slot`` is a scalar's fixed
position in that order (``slots(n)``, then ``draws``). How they are drawn is the
study's ``sampling`` design (``SAMPLING_DESIGNS``):

* ``random``: every scalar has its own random stream, seeded with
  ``SeedSequence(seed, spawn_key=(index, slot))``; changing one parameter's
  distribution leaves every other draw unchanged.
* ``latin_hypercube``, ``sobol`` (scrambled), ``saltelli`` (SALib's Saltelli/Sobol'
  design for first- and total-order indices): one point of a design over the
  *varied* scalars (``varied_scalars``) in ``[0, 1)^d``, mapped through each
  distribution's inverse CDF (a truncated normal through its truncated CDF). The
  design is built from ``seed`` alone, so sample ``index`` is row ``index``.

Either way a sample's draw is a pure function of the study and ``index``: it does
not depend on which worker draws it or in which order. ``random`` and ``sobol``
and ``saltelli`` are sequences (a sample does not depend on how many samples the
study has); a ``latin_hypercube`` design is built for ``samples`` rows, so
``samples`` is part of such a study's identity.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from posfb.analysis.uncertainty.statistics import saltelli_unit_design
from posfb.analysis.uncertainty.study import (
    Deterministic,
    Distribution,
    Gaussian,
    Study,
    Uniform,
    UniformDiscrete,
    saltelli_rows,
    slots,
    study_joints,
    varied_scalars,
)
from posfb.diagrams.scenario import Scenario, apply_setting, get_setting
from posfb.models.plant import JOINT_PARAMETERS, ArmParameters

#: Draws per batch when rejecting outside a truncated normal's ``[min, max]``.
_BATCH = 64

#: The spawn key of a design's own random stream (sample streams use ``(index, slot)``).
_DESIGN_STREAM = (2**32 - 1,)


def _power_of_two_at_least(count: int) -> int:
    return 1 << max(0, int(count - 1).bit_length())


@functools.lru_cache(maxsize=8)
def _design(sampling: str, seed: int, samples: int, dimensions: int) -> np.ndarray:
    """The ``(rows, dimensions)`` unit design of a study, at least ``samples`` rows. The
    Sobol' and Saltelli designs are prefix stable (more rows keep the first ones)."""
    from scipy.stats import qmc  # on use: a command that samples nothing pays nothing for it

    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=_DESIGN_STREAM))
    if sampling == "latin_hypercube":
        return qmc.LatinHypercube(dimensions, rng=rng).random(samples)
    if sampling == "sobol":
        return qmc.Sobol(dimensions, scramble=True, rng=rng).random(_power_of_two_at_least(samples))
    base = _power_of_two_at_least(-(-samples // saltelli_rows(dimensions)))
    return saltelli_unit_design(dimensions, base, seed=int(rng.integers(2**31)))


def unit_point(study: Study, index: int) -> dict[int, float]:
    """The design's coordinates of sample ``index`` by slot (empty for ``random``)."""
    varied = varied_scalars(study)
    if study.sampling == "random" or not varied:
        return {}
    samples = max(study.samples, index + 1)
    row = _design(study.sampling, study.seed, samples, len(varied))[index]
    return {scalar.slot: float(u) for scalar, u in zip(varied, row, strict=True)}


def _inverse_cdf(distribution: Distribution, u: float) -> float:
    """The value at probability ``u`` of ``distribution`` (before ``relative``)."""
    if isinstance(distribution, UniformDiscrete):
        values = distribution.values
        return float(values[min(int(u * len(values)), len(values) - 1)])
    if isinstance(distribution, Uniform):
        return distribution.min + u * (distribution.max - distribution.min)
    if distribution.stddev == 0.0:
        return distribution.mean
    low = -np.inf if distribution.min is None else distribution.min
    high = np.inf if distribution.max is None else distribution.max
    a = (low - distribution.mean) / distribution.stddev
    b = (high - distribution.mean) / distribution.stddev
    import scipy.stats  # on use (see _design)

    return float(distribution.mean + distribution.stddev * scipy.stats.truncnorm.ppf(u, a, b))


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


def _draw_gaussian(distribution: Gaussian, rng: np.random.Generator) -> float:
    """A normal draw, by rejection when truncated (validation keeps >= 0.1 % of the mass)."""
    low = -np.inf if distribution.min is None else distribution.min
    high = np.inf if distribution.max is None else distribution.max
    while True:
        batch = rng.normal(distribution.mean, distribution.stddev, _BATCH)
        kept = batch[(batch >= low) & (batch <= high)]
        if kept.size:
            return float(kept[0])


def draw(
    distribution: Distribution, nominal: float, rng: np.random.Generator, u: float | None = None
) -> float:
    """One value of a parameter whose base (URDF) value is ``nominal``: from the random
    stream ``rng``, or at the design's probability ``u`` where given."""
    if isinstance(distribution, Deterministic):
        return nominal if distribution.value is None else float(distribution.value)
    if u is not None:
        x = _inverse_cdf(distribution, u)
        if isinstance(distribution, UniformDiscrete):
            return x
    elif isinstance(distribution, UniformDiscrete):
        return float(distribution.values[int(rng.integers(len(distribution.values)))])
    elif isinstance(distribution, Uniform):
        x = float(rng.uniform(distribution.min, distribution.max))
    else:
        x = _draw_gaussian(distribution, rng)
    return nominal * (1.0 + x) if distribution.relative else x


def _draw_posterior(
    study: Study, nominal: ArmParameters, index: int, values: dict[str, list[float]]
) -> None:
    """Replace the posterior's keys in ``values`` by one correlated log-normal draw
    around ``nominal`` (``Study.posterior``), from a stream of its own (the slot after
    every scalar's and ``draws``')."""
    posterior = study.posterior
    slot = len(slots(study_joints(study))) + len(study.draws)
    normal = stream(study.seed, index, slot).standard_normal(len(posterior.keys))
    covariance = np.asarray(posterior.covariance, dtype=float)
    eigenvalues, vectors = np.linalg.eigh(covariance)
    root = vectors * np.sqrt(np.clip(eigenvalues, 0.0, None))
    logs = np.asarray(posterior.mean, dtype=float) + root @ normal
    for (name, joint), log in zip(posterior.entries(), logs, strict=True):
        values[name][joint] = float(getattr(nominal, name)[joint] * np.exp(log))


def sample_plant(
    study: Study, nominal: ArmParameters, index: int, point: dict[int, float] | None = None
) -> SampledPlant:
    """The plant of sample ``index``: draws from ``study.parameters`` around ``nominal``
    (the URDF's values), the encoder resolution, ``study.posterior``'s correlated draw,
    then ``study.overrides``. ``point`` (probabilities by slot) replaces the study's own
    design point: the plant at that point of the parameter box."""
    joints = study_joints(study)
    values: dict[str, list[float]] = {name: [0.0] * joints for name in JOINT_PARAMETERS}
    point = unit_point(study, index) if point is None else point
    for slot, (name, joint) in enumerate(slots(joints)):
        rng, u = stream(study.seed, index, slot), point.get(slot)
        if name == "payload_mass":
            payload = draw(study.parameters.payload_mass, nominal.payload_mass, rng, u)
        elif name == "encoder_counts":
            choices = study.encoder_counts
            pick = int(rng.integers(len(choices))) if u is None and choices else None
            if u is not None:
                pick = min(int(u * len(choices)), len(choices) - 1)
            counts = choices[pick] if choices else None
        else:
            distribution = study.parameters.for_joint(name, joint)
            values[name][joint] = draw(distribution, getattr(nominal, name)[joint], rng, u)
    if study.posterior is not None:
        _draw_posterior(study, nominal, index, values)
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
        **{name: tuple(v) for name, v in values.items()}, payload_mass=payload
    )
    return SampledPlant(
        index=index, parameters=parameters, encoder_counts=None if counts is None else int(counts)
    )


def sample_scenario(study: Study, index: int) -> tuple[Scenario, dict[str, float]]:
    """The scenario of sample ``index``: the study's base with every ``draws`` key drawn
    (relative draws around the base value), and the drawn values by key."""
    base = study.base_scenario()
    scenario, drawn, point = base, {}, unit_point(study, index)
    for position, (key, distribution) in enumerate(study.draws.items()):
        current = get_setting(base, key)
        nominal = float(current[0] if isinstance(current, list) else current)
        slot = len(slots(study_joints(study))) + position
        value = draw(distribution, nominal, stream(study.seed, index, slot), point.get(slot))
        integer = isinstance(current[0] if isinstance(current, list) else current, int)
        text = repr(int(value)) if integer else repr(value)
        scenario = apply_setting(scenario, f"{key}={text}")
        drawn[key] = int(value) if integer else value
    return scenario, drawn
