"""What ``posfb tune`` may vary of a controller (``ControllerSpec.tuning``): its decision
variables (``Knob``: a setting or a multiplier of one, its search box and its start), how
a point of the search becomes a settings entry, and which settings a report shows beside
their former value. The tuning itself (``analysis.design.tune``) reads only this and the
controller's linear feedback; it spells no controller's name.

``lqr_knobs`` and ``with_lqr_knobs`` are the Sec. 3.2 weights that Lin+LC and the paper's
controller share: multipliers ``10^-2 .. 10^2`` of the ``Q1`` position and velocity blocks
and of ``R`` (``lambdas``: ``10^-1 .. 10^1``) of the entry's own weights, so that the
search keeps their per-joint proportions and off-diagonal structure.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Knob:
    """One decision variable: ``key`` as the report names it, searched in
    ``[log10(low), log10(high)]``; ``start`` is the entry's value (1 for a multiplier)."""

    key: str
    low: float
    high: float
    start: float


@dataclass(frozen=True)
class Tuning:
    """What tune varies of a controller: ``knobs(entry)``, the decision variables of a
    settings ``entry``; ``apply(entry, values, sample_time)``, the entry with the
    variables' actual values (in ``knobs`` order); ``shown``, the settings a report shows
    beside their former value, read by ``value(entry, name)`` (the entry's attribute;
    a plug-in's reads its ``settings`` map)."""

    knobs: Callable[[object], tuple[Knob, ...]]
    apply: Callable[[object, np.ndarray, float], object]
    shown: tuple[str, ...] = ()
    value: Callable[[object, str], object] = getattr


def lqr_knobs() -> tuple[Knob, ...]:
    """The Sec. 3.2 weights' multipliers (module docstring)."""
    return (
        Knob("Q1 position block x", 1e-2, 1e2, 1.0),
        Knob("Q1 velocity block x", 1e-2, 1e2, 1.0),
        Knob("R x", 1e-2, 1e2, 1.0),
        Knob("lambdas x", 1e-1, 1e1, 1.0),
    )


def _scaled_blocks(matrix: list[list[float]], scales: np.ndarray) -> list[list[float]]:
    """``S M S`` with ``S = diag(sqrt(scales))``: each diagonal block scaled by its factor,
    the matrix stays symmetric and keeps its definiteness."""
    root = np.sqrt(scales)
    return (np.asarray(matrix, dtype=float) * np.outer(root, root)).tolist()


def with_lqr_knobs(entry: object, values: np.ndarray) -> object:
    """``entry`` (with ``Q1``, ``R`` and ``lambdas``) with the multipliers ``values`` (in
    ``lqr_knobs`` order) applied."""
    position, velocity, r_scale, lambda_scale = values
    n = len(entry.R)
    return replace(
        entry,
        Q1=_scaled_blocks(entry.Q1, np.repeat([position, velocity], n)),
        R=(np.asarray(entry.R, dtype=float) * r_scale).tolist(),
        lambdas=[float(v) * lambda_scale for v in entry.lambdas],
    )
