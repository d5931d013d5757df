"""The configurations the arm visits, at which every linear verdict is evaluated (issue 40).

The controllers' linear feedback is designed on the constant ``M0*`` (Sec. 3: the linear
part ``M0* q~'' + B* q~' = u`` of Eq. 2). On the arm, the error dynamics that feedback
closes are ``M*(q) q~'' + B* q~' = u`` at the configuration ``q`` the arm is in: the
paper's arm hides the difference (its ``M*(q)`` barely moves with ``q``), an arm without a
gear does not (the eigenvalues of ``M0*^-1 M*(q)`` along a path span 0.02 to 4 on a
published seven-joint arm). A verdict that holds on the arm must hold with ``M*(q)``
frozen at every configuration the arm visits.

``path_configurations`` states that set: the desired path ``q_d(t)``, ``0 <= t <= T``,
sampled every ``spacing`` seconds, plus the two configurations of the path where the
generalised eigenvalues of ``(M*(q), M0*)`` are smallest and largest (found on a scan
``EXTREME_SCAN_STEPS`` times finer than ``spacing`` and refined between its neighbours with
Brent's method): the arm at its lightest and at its heaviest relative to the design.
``ConfigurationSet.masses`` holds ``M*(q)`` at each; ``worst`` and ``FrozenFigures`` say
which configuration a verdict's worst figure came from.

A frozen configuration leaves out how fast ``M*(q)`` changes (and the Coriolis terms,
friction and saturation): ``models.design.common_lyapunov`` certifies the loop for
``M*`` varying arbitrarily fast among the frozen ones.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.linalg
import scipy.optimize

from posfb.models.trajectory import Trajectory

#: Default spacing (s) of the path's configurations (``timing.configuration_spacing``): a
#: quarter of the shortest period of the paper's path (2 pi / 4 rad/s = 1.57 s) rounds
#: down to 0.25 s, so the set follows every swing of a path as fast as the paper's; the
#: extremes of ``M0*^-1 M*(q)`` are added from a finer scan whatever the spacing.
CONFIGURATION_SPACING = 0.25

#: How many times finer than the spacing the path is scanned for the extreme eigenvalues.
EXTREME_SCAN_STEPS = 10

#: The most configurations one set may hold (a spacing that asks for more is refused):
#: each costs a discretised loop per verdict (about a millisecond on a six-joint arm).
MAX_CONFIGURATIONS = 2_000


class MassModel(Protocol):
    """A nominal model as ``models.nominal`` gives it: ``M0*`` and ``M*(q)``."""

    def M0(self) -> np.ndarray: ...

    def M(self, q: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class Configuration:
    """One configuration ``q`` (rad) of the set: on the path at ``time`` (s), and ``role``
    (``path``; ``lightest``/``heaviest``: where ``M0*^-1 M*(q)`` has its smallest or
    largest eigenvalue along the path)."""

    q: tuple[float, ...]
    time: float
    role: str

    def describe(self) -> str:
        """``t = 0.41 s, q = [0.1, -1.2] rad`` (the role named unless ``path``)."""
        where = f"t = {self.time:.3g} s, q = [{', '.join(f'{v:.3g}' for v in self.q)}] rad"
        return where if self.role == "path" else f"{where} ({self.role})"


def distinct(configurations: Sequence[Configuration]) -> tuple[Configuration, ...]:
    """``configurations`` in order, the first of each ``q`` kept (the path's worst,
    lightest and heaviest configurations may be one and the same)."""
    seen: dict[tuple[float, ...], Configuration] = {}
    for configuration in configurations:
        seen.setdefault(configuration.q, configuration)
    return tuple(seen.values())


def mass_ratio_eigenvalues(M0: np.ndarray, M: np.ndarray) -> np.ndarray:
    """The eigenvalues of ``M0^-1 M``, sorted ascending. ``M0*`` and ``M*`` are the physical
    mass matrices with row ``j`` divided by ``kappa_j`` (not symmetric), so ``M0*^-1 M*`` is
    the physical ``M0^-1 M``, whose eigenvalues are real and positive: the generalised
    problem is solved as it stands and the round-off's imaginary parts dropped."""
    return np.sort(scipy.linalg.eigvals(M, M0).real)


@dataclass(frozen=True, eq=False)
class ConfigurationSet:
    """The configurations a verdict is evaluated at (module docstring), ``M*(q)`` at each
    (``masses``) and the design's ``M0``."""

    M0: np.ndarray
    configurations: tuple[Configuration, ...]
    masses: tuple[np.ndarray, ...]

    def __len__(self) -> int:
        return len(self.configurations)

    def eigenvalue_range(self) -> tuple[float, float]:
        """The smallest and largest eigenvalue of ``M0*^-1 M*(q)`` over the set."""
        values = np.concatenate([mass_ratio_eigenvalues(self.M0, M) for M in self.masses])
        return float(values.min()), float(values.max())

    def describe_range(self) -> str:
        """One line: how far ``M*(q)`` moves from ``M0*`` over the set."""
        low, high = self.eigenvalue_range()
        return (
            f"eigenvalues of M0*^-1 M*(q) span {low:.3g} to {high:.3g} over "
            f"{len(self)} configurations of the path"
        )


def path_configurations(
    model: MassModel, trajectory: Trajectory, duration: float,
    spacing: float = CONFIGURATION_SPACING,
) -> ConfigurationSet:  # fmt: skip
    """The configuration set of the path ``trajectory`` over ``[0, duration]`` (module
    docstring) on ``model``'s ``M*(q)``."""
    if not (math.isfinite(duration) and duration >= 0.0):
        raise ValueError(f"duration = {duration!r}; a finite time >= 0 s is required")
    if not (math.isfinite(spacing) and spacing > 0.0):
        raise ValueError(
            f"timing.configuration_spacing = {spacing!r}; a finite time > 0 s is required"
        )
    count = math.floor(duration / spacing + 1e-9) + 1
    if count > MAX_CONFIGURATIONS:
        raise ValueError(
            f"timing.configuration_spacing = {spacing:g} s gives {count} configurations over "
            f"{duration:g} s; at most {MAX_CONFIGURATIONS} are allowed (a larger spacing)"
        )
    M0 = np.asarray(model.M0(), dtype=float)

    def position(t: float) -> np.ndarray:
        return np.asarray(trajectory.evaluate(t)[0], dtype=float)

    configurations = [
        Configuration(tuple(float(v) for v in position(t)), float(t), "path")
        for t in spacing * np.arange(count)
    ]
    configurations += _extremes(model, M0, position, duration, spacing / EXTREME_SCAN_STEPS)
    masses = tuple(np.asarray(model.M(np.array(c.q)), dtype=float) for c in configurations)
    return ConfigurationSet(M0, tuple(configurations), masses)


def _extremes(
    model: MassModel, M0: np.ndarray, position: Callable[[float], np.ndarray],
    duration: float, step: float,
) -> list[Configuration]:  # fmt: skip
    """The path's configurations with the smallest and the largest eigenvalue of
    ``M0^-1 M*(q)``: a scan every ``step`` seconds, refined by Brent's method between the
    scan's neighbours of each extreme."""
    times = np.linspace(0.0, duration, max(2, math.ceil(duration / step) + 1))

    def lowest(t: float) -> float:
        return float(mass_ratio_eigenvalues(M0, model.M(position(t)))[0])

    def negative_highest(t: float) -> float:
        return -float(mass_ratio_eigenvalues(M0, model.M(position(t)))[-1])

    found = []
    for role, objective in (("lightest", lowest), ("heaviest", negative_highest)):
        values = np.array([objective(t) for t in times])
        k = int(np.argmin(values))
        low, high = times[max(k - 1, 0)], times[min(k + 1, len(times) - 1)]
        best, best_value = float(times[k]), float(values[k])
        if high > low:
            refined = scipy.optimize.minimize_scalar(
                objective, bounds=(low, high), method="bounded", options={"xatol": 1e-6}
            )
            if refined.fun < best_value:
                best = float(refined.x)
        found.append(Configuration(tuple(float(v) for v in position(best)), best, role))
    return found


@dataclass(frozen=True)
class FrozenFigures:
    """One figure (a spectral radius, a margin) of the loop at every configuration of a
    set, ``worse`` telling which end is worse (``max`` for a radius, ``min`` for a margin),
    and the same figure at the design's ``M0*`` (``at_M0``)."""

    values: tuple[float, ...]
    at_M0: float
    worse: str = "max"

    def __post_init__(self) -> None:
        if self.worse not in ("max", "min"):
            raise ValueError(f"worse = {self.worse!r}; 'max' or 'min' is required")
        if not self.values:
            raise ValueError("values is empty; one figure per configuration is required")

    @property
    def worst_index(self) -> int:
        """The configuration of the worst figure (NaN counts as worst)."""
        values = np.asarray(self.values, dtype=float)
        worst = np.where(np.isnan(values), -np.inf if self.worse == "min" else np.inf, values)
        return int(np.argmax(worst) if self.worse == "max" else np.argmin(worst))

    @property
    def worst(self) -> float:
        """The worst figure over the set."""
        return float(self.values[self.worst_index])


def frozen_figures(
    figure: Callable[[np.ndarray], float], configurations: ConfigurationSet, worse: str = "max"
) -> FrozenFigures:
    """``figure(M)`` at every configuration's ``M*(q)`` and at ``M0*``."""
    values = tuple(float(figure(M)) for M in configurations.masses)
    return FrozenFigures(values, float(figure(configurations.M0)), worse)
