"""``posfb identify --study-out``: a Monte-Carlo study whose plants are drawn from the
identification's uncertainty (issue 29), for the paper's arm (theta) and for a URDF arm
(its base parameters and motor-constant ratios in place of theta below).

The study's plants are physical arms (``ArmParameters``: link masses, centres of mass,
inertias, rotor inertias, damping, Coulomb levels, motor constants), so the estimate's
uncertainty, in theta, is carried over to them by the Laplace approximation: with
``x = log(p / p_0)`` (``p_0`` the scenario's true arm, every entry that is not 0) and
``theta(p)`` the arm's theta computed from the plant (``models.theta_of_plant.identify``),

    x* = argmin |L^-1 (theta(p(x)) - theta^)|^2 + |x / PRIOR_LOG_STD|^2

(``L L^T`` the estimate's covariance; scipy's ``least_squares``), and the draws are
``x ~ N(x*, (J^T J)^-1)`` with ``J`` the Jacobian of the whole residual at ``x*``. The
prior (a log-normal of ``PRIOR_LOG_STD`` about the scenario's arm) only decides the
directions that theta does not see (e.g. every physical parameter of a joint scaled with
its motor constant: the same theta); every draw is a physical arm (entries > 0). The
study is ``sampling: random`` with a ``posterior`` (``analysis.uncertainty.study``),
ready for ``posfb montecarlo run`` and ``posfb tune --study``.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import scipy.optimize
from pydrake.systems.framework import Context

from posfb.analysis.common.loop_effects import rigid_plant
from posfb.diagrams.resolve import LoadedScenario, resolve
from posfb.models.controllers import PAPER_CONTROLLERS
from posfb.models.identification.serial_regressor import true_parameters
from posfb.models.plant import (
    JOINT_PARAMETERS,
    Arm,
    ArmParameters,
    PlantConfig,
    apply_parameters,
    build_arm_diagram,
)
from posfb.models.theta_of_plant import identify

if TYPE_CHECKING:  # the result's writer: the result's module imports this one
    from posfb.analysis.identification.identify import Identification

#: Standard deviation of the prior on ``log(p / p_0)``: a factor ``e^0.5 = 1.65`` at one
#: sigma, so that what the log identifies decides the draws.
PRIOR_LOG_STD = 0.5

#: Default samples and controllers of the study written.
DEFAULT_SAMPLES = 100
DEFAULT_CONTROLLERS = tuple(reversed(PAPER_CONTROLLERS))


@dataclass(frozen=True)
class PlantPosterior:
    """``log(p / p_0) ~ N(mean, covariance)`` over ``keys`` (``link_mass[0]``, ...), the
    most probable arm ``parameters`` and the theta it has (``theta``)."""

    keys: tuple[str, ...]
    mean: np.ndarray
    covariance: np.ndarray
    parameters: ArmParameters
    theta: np.ndarray


@dataclass(frozen=True)
class TrueArm:
    """A scenario's true arm: the rigid plant it is built from (``plant``), the Drake
    ``arm`` and a ``context`` of it, and its ``parameters`` (the URDF's with the
    scenario's overrides; not yet applied to ``context``)."""

    plant: PlantConfig
    arm: Arm
    context: Context
    parameters: ArmParameters


def true_arm(loaded: LoadedScenario) -> TrueArm:
    """The true arm of ``loaded`` (rigid, as the nominal model's theta is)."""
    resolved = resolve(loaded)
    plant = rigid_plant(resolved.config.plant)
    _, arm, context = build_arm_diagram(plant)
    return TrueArm(plant, arm, context, resolved.true_parameters(arm.default_parameters))


def _entries(nominal: ArmParameters) -> list[tuple[str, int]]:
    return [
        (name, j)
        for name in JOINT_PARAMETERS
        for j, value in enumerate(getattr(nominal, name))
        if value > 0.0
    ]


def _with(nominal: ArmParameters, entries: list[tuple[str, int]], x: np.ndarray) -> ArmParameters:
    values = {name: list(getattr(nominal, name)) for name in JOINT_PARAMETERS}
    for (name, joint), log in zip(entries, x, strict=True):
        values[name][joint] = getattr(nominal, name)[joint] * float(np.exp(log))
    return replace(nominal, **{name: tuple(v) for name, v in values.items()})


def plant_posterior(identification: Identification, loaded: LoadedScenario) -> PlantPosterior:
    """The Laplace approximation of the physical arms the identification allows
    (module docstring)."""
    truth = true_arm(loaded)
    arm, context, nominal = truth.arm, truth.context, truth.parameters
    entries = _entries(nominal)
    estimate = identification.estimate
    whitening = np.linalg.inv(np.linalg.cholesky(estimate.covariance))
    serial = identification.serial

    def theta_of(x: np.ndarray) -> np.ndarray:
        parameters = _with(nominal, entries, x)
        apply_parameters(arm, context, parameters)
        if serial is None:
            return identify(arm, context).theta
        # What the log sees: the base parameters in joint 1's nominal torque units, and
        # each other joint's motor constant relative to joint 1's (models...serial).
        model = serial.model
        scale = np.asarray(parameters.motor_constant) / model.motor_constant
        beta = model.base.combine(true_parameters(arm, context)) / scale[0]
        return np.concatenate([beta, scale[1:] / scale[0]])

    def residual(x: np.ndarray) -> np.ndarray:
        return np.concatenate([whitening @ (theta_of(x) - estimate.values), x / PRIOR_LOG_STD])

    fit = scipy.optimize.least_squares(residual, np.zeros(len(entries)), x_scale=PRIOR_LOG_STD)
    covariance = np.linalg.inv(fit.jac.T @ fit.jac)
    covariance = 0.5 * (covariance + covariance.T)
    return PlantPosterior(
        keys=tuple(f"{name}[{joint}]" for name, joint in entries),
        mean=fit.x,
        covariance=covariance,
        parameters=_with(nominal, entries, fit.x),
        theta=theta_of(fit.x),
    )


def require_same_arm(identified: LoadedScenario, experiment: LoadedScenario) -> None:
    """Refuse (one ``ValueError`` line) a study ``experiment`` that is not a scenario
    file of the identified scenario's true arm: the posterior is relative to that arm
    (``PlantPosterior``), and the study names its scenario by file."""
    if not Path(experiment.source).is_file():
        raise ValueError(
            f"study scenario {experiment.source!r} is not a file; a scenario file is "
            "required (the study names it)"
        )
    own, other = true_arm(identified), true_arm(experiment)
    described = (own.plant.urdf, own.plant.description)
    if described != (other.plant.urdf, other.plant.description) or any(
        getattr(own.parameters, name) != getattr(other.parameters, name)
        for name in JOINT_PARAMETERS
    ):
        raise ValueError(
            f"study scenario {experiment.source}: its true arm (plant.urdf with its package "
            "paths, welds and drives, and plant.parameters) differs from that of the "
            f"identified scenario "
            f"{identified.source}; the same arm is required (the draws are relative to it)"
        )


def _number(value: float) -> str:
    return repr(float(value))


def write_study(
    posterior: PlantPosterior,
    loaded: LoadedScenario,
    path: Path,
    *,
    model: Path | None = None,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
) -> Path:
    """The study file: the scenario (relative to the study's folder), the identified
    model as its nominal model where ``model`` was written, the posterior. Every path
    and key is a YAML double-quoted scalar (``_quoted``): a file name cannot add keys;
    the file is written whole or not at all."""
    from posfb.analysis.common.outputs import atomic_file

    path = Path(path)
    source = Path(loaded.source)
    lines = [
        "# A Monte-Carlo study whose plants are drawn from an identification's uncertainty",
        "# (posfb identify --study-out; analysis/identification/study_out.py): log(p / p_0)",
        "# ~ N(mean, covariance) over the keys below, p_0 the scenario's true arm, the Laplace",
        f"# approximation with a log-normal prior of {PRIOR_LOG_STD:g} about p_0.",
        "#",
        f"#   posfb montecarlo run {_quoted(path.name)} --db {_quoted(path.stem + '.sqlite')}",
        f"seed: {seed}",
    ]
    if source.is_file():
        relative = os.path.relpath(source.resolve(), path.resolve().parent)
        lines.append(f"scenario: {_quoted(relative)}")
    if model is not None:
        setting = f"nominal_model=!Identified {{file: {_quoted(str(Path(model).resolve()))}}}"
        lines.append(f"settings: [{_quoted(setting)}]")
    lines += [
        f"samples: {samples}",
        f"controllers: [{', '.join(DEFAULT_CONTROLLERS)}]",
        "posterior:",
        f"  keys: [{', '.join(_quoted(k) for k in posterior.keys)}]",
        f"  mean: [{', '.join(_number(m) for m in posterior.mean)}]",
        "  covariance:",
    ]
    lines += [f"  - [{', '.join(_number(c) for c in row)}]" for row in posterior.covariance]
    with atomic_file(path) as temporary:
        temporary.write_text("\n".join(lines) + "\n")
    return path


def _quoted(text: str) -> str:
    """``text`` as a YAML double-quoted scalar (JSON's escapes are YAML's)."""
    return json.dumps(text)
