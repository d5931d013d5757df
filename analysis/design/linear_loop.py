"""A scenario's controller as a linear sampled loop (``posfb.design``): the nominal linear
part held over ``T_s`` with the scenario's linear effects (``analysis.common.loop_effects``)
and the controller's linear feedback (derived from its law,
``models.controllers.linearise``), its margins (``models.design.margins``) and the two
halves as python-control ``StateSpace`` and Drake ``LinearSystem`` objects.

The configurations the arm visits (``models.design.configurations``) come with it:
``frozen_radii`` is the loop's spectral radius with ``M*(q)`` frozen at each of them, and
``frozen_margins`` the loop-wide margins (on ``STUDY_GRID_POINTS`` frequencies; no
loop-at-a-time ones) at the configurations that bound them: the one with the worst radius
and the lightest and heaviest of the path.

The exported plant maps the held voltage ``u`` (V) to the reading ``y`` (rad: the
measured position error the controller takes, sensor delay included) and the
controller maps ``y`` to ``u``; the loop closes with ``u = K y``, i.e.
``control.feedback(plant, controller, sign=+1)``: a toolbox's negative-feedback loop
transfer at the plant input is ``-K P``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from posfb.analysis.common.configurations import scenario_configurations
from posfb.analysis.common.loop_effects import left_out, nominal_effects
from posfb.analysis.uncertainty.loops import nominal_loop
from posfb.diagrams.resolve import ResolvedScenario
from posfb.models.design.configurations import (
    Configuration,
    ConfigurationSet,
    FrozenFigures,
    distinct,
    frozen_figures,
)
from posfb.models.design.loop_transfer import DiscreteSystem
from posfb.models.design.margins import (
    GRID_POINTS,
    STUDY_GRID_POINTS,
    LoopMargins,
    SampledFeedback,
)

if TYPE_CHECKING:
    import control
    from pydrake.systems.primitives import LinearSystem


@dataclass(frozen=True, eq=False)
class LinearDesign:
    """The linear sampled loop of a scenario's ``controller`` (module docstring);
    ``left_out``: the scenario's nonlinear settings the loop leaves out (``key = value``);
    ``configurations``: the path's (``None``: the loop at ``M0*`` only)."""

    controller: str
    label: str
    loop: SampledFeedback
    left_out: tuple[str, ...]
    configurations: ConfigurationSet | None = None

    def at(self, M: np.ndarray) -> SampledFeedback:
        """The loop with ``M*`` frozen at ``M`` (the design's feedback, effects and ``B*``)."""
        return self.loop.with_plant(M, self.loop.B, self.loop.effects)

    def frozen_radii(self) -> FrozenFigures | None:
        """The spectral radius at every configuration (``None`` without a set; computed
        once: the margins and both of their reports read it)."""
        return self._frozen_radii

    @cached_property
    def _frozen_radii(self) -> FrozenFigures | None:
        if self.configurations is None:
            return None
        return frozen_figures(lambda M: self.at(M).radius(), self.configurations)

    def frozen_margins(
        self, points: int = STUDY_GRID_POINTS
    ) -> list[tuple[Configuration, LoopMargins]]:
        """The margins at the configurations that bound them (module docstring), each with
        its configuration; empty without a set."""
        radii = self.frozen_radii()
        if radii is None or self.configurations is None:
            return []
        chosen = [radii.worst_index] + [
            i for i, c in enumerate(self.configurations.configurations)
            if c.role in ("lightest", "heaviest")
        ]  # fmt: skip
        configurations = self.configurations.configurations
        masses = dict(zip(configurations, self.configurations.masses, strict=True))
        return [(c, self.at(masses[c]).margins(points, channels=False))
                for c in distinct([configurations[i] for i in chosen])]  # fmt: skip

    @property
    def sample_time(self) -> float:
        return self.loop.sample_time

    @property
    def joints(self) -> int:
        return len(self.loop.M0)

    def radius(self) -> float:
        """The spectral radius of the sampled loop (``< 1``: stable)."""
        return self.loop.radius()

    def margins(self, points: int = GRID_POINTS) -> LoopMargins:
        """Gain, phase, delay and disk margins and the sensitivity peaks
        (``models.design.margins``), on ``points`` frequencies up to Nyquist."""
        return self.loop.margins(points)

    def closed_loop_eigenvalues(self) -> np.ndarray:
        """The eigenvalues of the closed loop's transition matrix."""
        return np.linalg.eigvals(self.loop.closed_loop())

    def _names(self, stem: str) -> list[str]:
        return [f"{stem}{j + 1}" for j in range(self.joints)]

    def _state_space(self, system: DiscreteSystem, inputs: str, outputs: str,
                     name: str) -> control.StateSpace:  # fmt: skip
        import control

        return control.ss(
            system.A, system.B, system.C, system.D, dt=system.sample_time, name=name,
            inputs=self._names(inputs), outputs=self._names(outputs),
        )  # fmt: skip

    def controller_ss(self) -> control.StateSpace:
        """The controller, reading ``y`` (inputs ``y1..yn``, rad) to voltage (``u1..un``,
        V), as a python-control ``StateSpace`` with ``dt = T_s``."""
        return self._state_space(self.loop.controller, "y", "u", "controller")

    def plant_ss(self) -> control.StateSpace:
        """The held plant, voltage (``u1..un``) to reading (``y1..yn``), with ``dt = T_s``."""
        return self._state_space(self.loop.plant, "u", "y", "plant")

    def _drake(self, system: DiscreteSystem) -> LinearSystem:
        from pydrake.systems.primitives import LinearSystem

        return LinearSystem(system.A, system.B, system.C, system.D, system.sample_time)

    def controller_system(self) -> LinearSystem:
        """The controller as a discrete Drake ``LinearSystem`` (period ``T_s``)."""
        return self._drake(self.loop.controller)

    def plant_system(self) -> LinearSystem:
        """The held plant as a discrete Drake ``LinearSystem`` (period ``T_s``)."""
        return self._drake(self.loop.plant)


def linear_design(resolved: ResolvedScenario) -> LinearDesign:
    """The ``LinearDesign`` of the scenario's controller; ``ValueError`` (one line) for a
    controller without a linear design (a plug-in) or a design it refuses."""
    config = resolved.config
    loop = nominal_loop(config, nominal_effects(resolved))
    label = config.spec.label_for(config.design)
    return LinearDesign(config.controller, label, loop, tuple(left_out(config)),
                        scenario_configurations(config))  # fmt: skip
