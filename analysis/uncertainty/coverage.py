"""Is a sampled plant inside the Assumption-1 bounds the controllers were designed with?

Assumption 1 (Sec. 2) bounds the differences between the nominal model ``*``
(Table 1, what the controllers use) and the true plant, both written as the
lumped model of Sec. 4.1 (the true plant's theta identified exactly,
``models.theta_of_plant``)::

    ||dM0|| <= D_M0,  ||dM1(q)|| <= D_M1,  ||dC(q, q')|| <= D_C ||q'||,
    ||dG(q)|| <= D_G,  ||dB|| <= D_B,  ||dF(q')|| <= D_F     for all q, q'

with ``D_*`` from ``models.design.bounds.resolve_bounds`` (the same numbers the
proposed controller's Eq. 18 uses). Each left side is the *smallest* constant
that holds for all ``q, q'``, computed in closed form:

* ``dM1(q) = cos q2 [[2 d3, d3], [d8, 0]]``: largest at ``|cos q2| = 1``;
* ``dC`` has the structure of ``C*`` with ``(d3, d8)``, so its constant is
  ``k_C1`` of that difference (``coriolis_bound``);
* ``dG(q) = [d4 cos q1 + e3 cos(q1 + q2), e8 cos(q1 + q2)]`` with
  ``e3, e8`` the differences of ``(g/l1) theta3, (g/l1) theta8``: the two
  cosines are independent, so the maximum is ``hypot(|d4| + |e3|, |e8|)``;
* ``dB = diag(d5, d10)``; ``dF(q') = diag(d6, d11) sgn q'``, largest at
  ``|sgn| = 1``: ``hypot(d6, d11)``.

``dF`` compares the two models' Coulomb levels: the plant's ``tanh``
regularisation of ``sgn`` (``models.plant``) is numerical smoothing of the same
law, not a parameter difference. The sample is *inside* when every ratio
``||dX|| / D_X`` is at most 1.

For a study whose nominal model is a URDF's (any serial arm), the same constants
come from ``models.serial_bounds.uncertainty_constants`` between the sampled plant's
model and the nominal one (``serial_coverage``): ``dM0``, ``dB``, ``dF`` exactly,
``dM1``, ``dC``, ``dG`` as maxima over ``COVERAGE_POINTS`` sampled joint angles
refined by a short local search (``COVERAGE_SEARCH_STEPS``): lower bounds of the true
maxima, cheap enough to run per sample (``models.serial_bounds`` has the full search).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from posfb.models import serial_bounds
from posfb.models.design.bounds import ResolvedBounds, coriolis_bound
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.serial_model import SerialArmModel

#: Workspace points per sample of ``serial_coverage`` (a power of 2) and iterations of
#: each local search: a per-sample cost of about a controller run's on six joints
#: (the design's own bounds use ``models.serial_bounds``' defaults).
COVERAGE_POINTS = 32
COVERAGE_SEARCH_STEPS = 50

#: The constants of Assumption 1, in the paper's order.
BOUND_NAMES = ("delta_M0", "delta_M1", "delta_C", "delta_G", "delta_B", "delta_F")


@dataclass(frozen=True)
class Coverage:
    """``ratios[name] = ||dX|| / D_X`` per Assumption-1 constant; ``inside`` iff all <= 1."""

    ratios: dict[str, float]

    @property
    def inside(self) -> bool:
        return all(ratio <= 1.0 for ratio in self.ratios.values())


def uncertainty_norms(true: LumpedParameters, nominal: LumpedParameters) -> dict[str, float]:
    """The smallest constants of Assumption 1 for ``true`` against ``nominal``."""
    d = nominal.theta - true.theta  # d[0] is theta1's difference
    d3, d4, d8 = d[2], d[3], d[7]
    e3 = nominal.g / nominal.l1 * nominal.theta3 - true.g / true.l1 * true.theta3
    e8 = nominal.g / nominal.l1 * nominal.theta8 - true.g / true.l1 * true.theta8
    dM0 = LumpedModel(nominal).M0() - LumpedModel(true).M0()
    return {
        "delta_M0": float(np.linalg.norm(dM0, 2)),
        "delta_M1": float(np.linalg.norm(np.array([[2.0 * d3, d3], [d8, 0.0]]), 2)),
        "delta_C": coriolis_bound(replace(nominal, theta3=float(d3), theta8=float(d8))),
        "delta_G": math.hypot(abs(d4) + abs(e3), abs(e8)),
        "delta_B": max(abs(d[4]), abs(d[9])),
        "delta_F": math.hypot(d[5], d[10]),
    }


def _ratio(norm: float, bound: float) -> float:
    if bound > 0.0:
        return norm / bound
    return 0.0 if norm == 0.0 else math.inf


def _coverage(norms: dict[str, float], bounds: ResolvedBounds) -> Coverage:
    return Coverage(
        {name: float(_ratio(norms[name], getattr(bounds, name))) for name in BOUND_NAMES}
    )


def coverage(true: LumpedParameters, nominal: LumpedParameters, bounds: ResolvedBounds) -> Coverage:
    """Where ``true`` lies relative to the bounds ``bounds`` around ``nominal``."""
    return _coverage(uncertainty_norms(true, nominal), bounds)


def serial_coverage(
    true: SerialArmModel, nominal: SerialArmModel, bounds: ResolvedBounds
) -> Coverage:
    """``coverage`` for serial-arm models (module docstring)."""
    norms = serial_bounds.uncertainty_constants(
        true, nominal, samples=COVERAGE_POINTS, steps=COVERAGE_SEARCH_STEPS
    )
    return _coverage(norms, bounds)
