"""The plants a robust design is checked on: i.i.d. draws of the arm from a study's
distributions, reduced to the linear part ``M0, B`` that the sampled-data loop of
Sec. 3 sees (``models.design.closed_loop``).

The draws are those of a Monte-Carlo study (``analysis.uncertainty.sampling``) around
the tuned scenario's own arm, with two changes that the guarantees of
``analysis.design.guarantee`` need: the draws are independent random ones
(``sampling: random`` whatever the study says; a Sobol' or Latin-hypercube design is
not i.i.d.), and the seed is the tuner's, so that the plants a design is chosen on and
the fresh plants it is verified on are two independent sets.

Without a study, ``DEFAULT_SPREAD`` gives the spread: the same +-20 % on every link's
mass, centre of mass and inertia, rotor inertia, damping and Coulomb level and the same
5 % motor-constant tolerance as the shipped studies (``analysis/studies/*.yaml``, where
each is justified), with no payload (its size is the arm's).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np

from posfb.analysis.common.loop_effects import loop_effects, rigid_plant
from posfb.analysis.uncertainty.sampling import sample_plant
from posfb.analysis.uncertainty.study import Study, require_study_arm, study_from_text
from posfb.diagrams.arm import arm_identity
from posfb.diagrams.resolve import LoadedScenario, ResolvedScenario, self_contained
from posfb.models.design.closed_loop import HeldPlant, LoopEffects, held_plant
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.nominal import nominal_model
from posfb.models.plant import apply_parameters, build_arm_diagram
from posfb.models.theta_of_plant import linear_part_model

#: The spread of ``posfb tune`` without ``--study`` (the shipped studies' spreads).
DEFAULT_SPREAD = """\
parameters:
  link_mass: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  link_com: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  link_inertia: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  rotor_inertia: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  damping: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  coulomb: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  motor_constant: [!Gaussian {mean: 0.0, stddev: 0.05, relative: true, min: -0.15, max: 0.15}]
"""


#: The most trajectory instants at which a plant's model error is evaluated (evenly
#: spaced sample instants).
ERROR_INSTANTS = 400


@dataclass(frozen=True, eq=False)
class LinearPlant:
    """The linear part of one drawn arm: ``M0`` (V s^2/rad), ``B`` (V s/rad), the
    scenario's linear effects on it (``effects``, ``analysis.common.loop_effects``), that part
    held over the scenario's sample time with them (``held``, the same for every design),
    the
    model error along the trajectory (``torque_error``: the plant's inverse dynamics
    minus the nominal model's, V, one row per instant of ``error_instants``; empty when
    not asked for), and the plant's linear part with its own ``M*(q)`` frozen at each
    configuration asked for (``M_at``, V s^2/rad, and ``held_at``, held likewise;
    ``models.design.configurations``)."""

    index: int
    M0: np.ndarray
    B: np.ndarray
    effects: LoopEffects
    held: HeldPlant
    torque_error: np.ndarray
    held_at: tuple[HeldPlant, ...] = ()
    M_at: tuple[np.ndarray, ...] = ()


def error_instants(resolved: ResolvedScenario) -> np.ndarray:
    """At most ``ERROR_INSTANTS`` evenly spaced sample instants of the run (s)."""
    config = resolved.config
    step = max(1, -(-config.samples // ERROR_INSTANTS))
    return np.arange(0, config.samples + 1, step) * config.sample_time


def plant_family(study: Study | None, loaded: LoadedScenario) -> Study:
    """The distributions of ``study`` (``DEFAULT_SPREAD`` when ``None``) as a family of
    i.i.d. plants around the arm of the scenario ``loaded``. A study of another arm
    (``diagrams.arm``: another URDF content, not only another joint count) is refused
    (``ValueError`` naming both arms)."""
    base = self_contained(loaded)
    if study is None:
        study = study_from_text(DEFAULT_SPREAD, source="posfb tune's default spread")
    else:
        require_study_arm(study, arm_identity(loaded.scenario, loaded.base_dir))
    return replace(study, base=base, sampling="random", overrides=[], draws={})


def linear_plants(
    family: Study, resolved: ResolvedScenario, seed: int, count: int, errors: bool = False
) -> list[LinearPlant]:
    """``count`` plants drawn from ``family`` (seed ``seed``, sample indices
    ``0..count-1``) around the scenario's true arm, each as its linear part in the form
    of the scenario's nominal model (``models.theta_of_plant.linear_part_model``, on the arm
    with a rigid gear: a compliant one is the plant's ``effects``); with
    ``errors``, also its model error along the trajectory at ``error_instants``."""
    return list(draw_plants(family, resolved, seed, count, errors))


def draw_plants(
    family: Study, resolved: ResolvedScenario, seed: int, count: int, errors: bool = False,
    configurations: tuple[tuple[float, ...], ...] = (),
) -> Iterator[LinearPlant]:  # fmt: skip
    """The plants of ``linear_plants``, drawn one at a time as they are asked for (so
    that a caller can time, bound or stop the drawing); ``configurations`` (joint angles,
    rad): where each plant's ``held_at`` freezes its ``M*(q)``."""
    config = resolved.config
    _, arm, context = build_arm_diagram(rigid_plant(config.plant))
    around = resolved.true_parameters(arm.default_parameters)
    family = replace(family, seed=seed, samples=max(count, 1))
    states = [config.trajectory.evaluate(float(t)) for t in error_instants(resolved)]
    nominal = nominal_model(config.design.nominal)
    needed = np.array([nominal.inverse_dynamics(*state) for state in states]) if errors else None
    for index in range(count):
        parameters = sample_plant(family, around, index).parameters
        apply_parameters(arm, context, parameters)
        model = linear_part_model(arm, context, config.design.nominal)
        if isinstance(model, LumpedParameters):
            model = LumpedModel(model)
        M0, B = model.M0(), model.B()
        error = (
            np.array([model.inverse_dynamics(*state) for state in states]) - needed
            if errors
            else np.empty((0, len(M0)))
        )
        effects = loop_effects(config, parameters)
        held = held_plant(M0, B, config.sample_time, effects)
        M_at = tuple(np.asarray(model.M(np.asarray(q)), dtype=float) for q in configurations)
        held_at = tuple(held_plant(M, B, config.sample_time, effects) for M in M_at)
        yield LinearPlant(index, M0, B, effects, held, error, held_at, M_at)
