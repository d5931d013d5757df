"""The sampled loops of a study's plants: one controller's linear feedback, as designed on
the nominal model (derived from its law, ``models.controllers.linearise``), closed around
each plant's linear part ``M0, B`` with the plant's linear effects
(``analysis.common.loop_effects``). The loop a study's per-sample ``rho`` judges
(``models.design.plant_spectral_radii``, for the Sec. 3 designs), for any controller with
a linear design; its margins
(``models.design.margins``) are what ``posfb montecarlo report`` and ``posfb design
--worst-case`` report.

A plant is either sample ``index`` of the study (``StudyLoops.sample``: the draws of
``montecarlo run``) or any point of the study's parameter box (``StudyLoops.at_point``:
one probability ``u`` per varied scalar, through each distribution's inverse CDF), for the
worst-case search.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from posfb.analysis.common.configurations import scenario_configurations
from posfb.analysis.common.loop_effects import loop_effects, rigid_plant
from posfb.analysis.uncertainty.sampling import sample_plant, sample_scenario
from posfb.analysis.uncertainty.study import (
    Distribution,
    Gaussian,
    Study,
    Uniform,
    UniformDiscrete,
    VariedScalar,
    slots,
    study_joints,
    varied_scalars,
)
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.resolve import LoadedScenario, resolve
from posfb.diagrams.scenario import with_controller
from posfb.models.controllers import linear_feedback
from posfb.models.design.closed_loop import NO_EFFECTS, LoopEffects
from posfb.models.design.configurations import Configuration
from posfb.models.design.margins import SampledFeedback
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.nominal import nominal_model
from posfb.models.plant import ArmParameters, apply_parameters, build_arm_diagram
from posfb.models.theta_of_plant import linear_part_model

#: The sample index of a point of the box (``sample_plant``'s random streams need one; no
#: study's ``overrides`` reach it).
BOX_INDEX = 2**31 - 1

#: The probabilities a Gaussian without bounds is searched between (its 0.1 % and 99.9 %
#: quantiles: a box needs ends).
GAUSSIAN_TAILS = (1e-3, 1.0 - 1e-3)


@dataclass(frozen=True)
class BoxAxis:
    """One dimension of the study's parameter box: the ``scalar`` and the probabilities
    ``low .. high`` it is searched between."""

    scalar: VariedScalar
    low: float
    high: float


def nominal_loop(config: ClosedLoopConfig, effects: LoopEffects) -> SampledFeedback:
    """``config``'s controller's linear feedback (derived from its law,
    ``models.controllers.linearise``) around its nominal model's linear part with
    ``effects``; ``ValueError`` (one line) for a controller written as a step."""
    feedback = linear_feedback(config.controller, config.design,
                               settings=config.controller_settings)  # fmt: skip
    model = nominal_model(config.design.nominal)
    return SampledFeedback(model.M0(), model.B(), config.sample_time, effects, feedback)


class StudyLoops:
    """The loops of ``controller`` (a name of the study's ``controllers``) on the study's
    plants (module docstring). ``ValueError`` (one line) for a controller without a linear
    design."""

    def __init__(self, study: Study, controller: str) -> None:
        self.study = study
        self.controller = controller
        base = with_controller(study.base_scenario(), controller)
        resolved = resolve(LoadedScenario(base, Path.cwd()))  # study paths are absolute
        self.config = resolved.config
        self._feedback: dict[tuple[object, ...], SampledFeedback] = {}
        self.feedback(self.config)
        _, self._arm, self._context = build_arm_diagram(rigid_plant(self.config.plant))
        self.nominal_parameters = resolved.true_parameters(self._arm.default_parameters)

    def feedback(self, config: ClosedLoopConfig) -> SampledFeedback:
        """The feedback of ``config``'s design around its nominal linear part (cached per
        design: a study's draws may change it per sample)."""
        key = (config.design, repr(config.controller_settings), config.voltage_limit)
        if key not in self._feedback:
            self._feedback[key] = nominal_loop(config, NO_EFFECTS)
        return self._feedback[key]

    def loop(
        self, parameters: ArmParameters, config: ClosedLoopConfig | None = None,
        frozen: bool = False,
    ) -> SampledFeedback:  # fmt: skip
        """The loop on the arm with ``parameters`` (``config``: the sample's scenario's,
        default the study's base) at its ``M0*``; ``frozen``: the worst of that and its
        loops with its own ``M*(q)`` frozen at the configurations of the path
        (``analysis.common.configurations``), the radius the Monte-Carlo worker stores."""
        config = self.config if config is None else config
        angles = self.configurations(config) if frozen else ()
        return max(self.loops_at(parameters, angles, config), key=lambda loop: loop.radius())

    def configurations(self, config: ClosedLoopConfig | None = None) -> tuple[Configuration, ...]:
        """The configurations of the path of ``config`` (default the study's base)."""
        config = self.config if config is None else config
        return scenario_configurations(config).configurations

    def loops_at(
        self, parameters: ArmParameters, configurations: Sequence[Configuration] = (),
        config: ClosedLoopConfig | None = None,
    ) -> list[SampledFeedback]:  # fmt: skip
        """The loops on the arm with ``parameters``: at its ``M0*``, then with its own
        ``M*(q)`` frozen at each of ``configurations``."""
        config = self.config if config is None else config
        apply_parameters(self._arm, self._context, parameters)
        model = linear_part_model(self._arm, self._context, config.design.nominal)
        if isinstance(model, LumpedParameters):
            model = LumpedModel(model)
        effects = loop_effects(config, parameters)
        at_M0 = self.feedback(config).with_plant(model.M0(), model.B(), effects)
        return [at_M0, *(at_M0.with_plant(model.M(np.asarray(c.q)), model.B(), effects)
                         for c in configurations)]  # fmt: skip

    def sample(self, index: int, frozen: bool = False) -> SampledFeedback:
        """The loop on sample ``index`` (its plant and its drawn scenario keys); ``frozen``:
        ``loop``'s."""
        parameters = sample_plant(self.study, self.nominal_parameters, index).parameters
        config = None
        if self.study.draws:
            scenario, _ = sample_scenario(self.study, index)
            loaded = LoadedScenario(with_controller(scenario, self.controller), Path.cwd())
            config = resolve(loaded).config
        return self.loop(parameters, config, frozen)

    def box(self) -> tuple[BoxAxis, ...]:
        """The parameter box: one axis per varied arm parameter of ``study.parameters``
        (the encoder's counts and ``draws`` keys are not searched: they do not change the
        arm's linear part, or change the scenario)."""
        layout_end = len(slots(study_joints(self.study)))
        axes = []
        for scalar in varied_scalars(self.study):
            if scalar.slot >= layout_end or scalar.key == "encoder_counts":
                continue
            distribution = self._distribution(scalar)
            low, high = 0.0, 1.0
            if isinstance(distribution, Gaussian) and distribution.min is None:
                low = GAUSSIAN_TAILS[0]
            if isinstance(distribution, Gaussian) and distribution.max is None:
                high = GAUSSIAN_TAILS[1]
            axes.append(BoxAxis(scalar, low, high))
        return tuple(axes)

    def _distribution(self, scalar: VariedScalar) -> Distribution:
        if scalar.key == "payload_mass":
            return self.study.parameters.payload_mass
        return self.study.parameters.for_joint(scalar.key, scalar.joint)

    def parameters_at(self, box: tuple[BoxAxis, ...], u: np.ndarray) -> ArmParameters:
        """The arm at probabilities ``u`` (one per ``box`` axis; the other scalars at their
        fixed values)."""
        point = {axis.scalar.slot: float(value) for axis, value in zip(box, u, strict=True)}
        return sample_plant(self.study, self.nominal_parameters, BOX_INDEX, point=point).parameters

    def unit_of(self, box: tuple[BoxAxis, ...], parameters: ArmParameters) -> np.ndarray:
        """The probabilities of ``parameters``' values in ``box`` (the inverse of
        ``parameters_at``, clipped to the box)."""
        nominal = self.nominal_parameters
        values = []
        for axis in box:
            scalar = axis.scalar
            distribution = self._distribution(scalar)
            if scalar.key == "payload_mass":
                value, base = parameters.payload_mass, nominal.payload_mass
            else:
                value = getattr(parameters, scalar.key)[scalar.joint]
                base = getattr(nominal, scalar.key)[scalar.joint]
            x = value / base - 1.0 if distribution.relative else value
            values.append(float(np.clip(_cdf(distribution, x), axis.low, axis.high)))
        return np.array(values)


def _cdf(distribution: Distribution, x: float) -> float:
    """The probability of ``x`` (before ``relative``) under ``distribution``."""
    if isinstance(distribution, UniformDiscrete):
        values = np.asarray(distribution.values, dtype=float)
        return (int(np.argmin(np.abs(values - x))) + 0.5) / len(values)
    if isinstance(distribution, Uniform):
        span = distribution.max - distribution.min
        return 0.5 if span == 0.0 else (x - distribution.min) / span
    low = -np.inf if distribution.min is None else distribution.min
    high = np.inf if distribution.max is None else distribution.max
    a = (low - distribution.mean) / distribution.stddev
    b = (high - distribution.mean) / distribution.stddev
    import scipy.stats  # on use: a check that does not sample pays nothing for it

    return float(scipy.stats.truncnorm.cdf((x - distribution.mean) / distribution.stddev, a, b))
