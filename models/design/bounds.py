"""The bounds used by the nonlinear torque gain (Eq. 17-18, 21, 23-25).

* ``G(s) = a/(s + a)`` of Sec. 3.4: ``abar = exp(-a T_s)``, ``c = 1 - 2 abar``;
  the bounds (24)-(25) need ``abar < 1/2``, i.e. ``a > ln 2 / T_s``.
* The constants of Assumption 1 and ``k_C1`` (Remark of Sec. 2), resolved from
  ``UncertaintyBounds`` and the nominal model.
* ``delta_bar`` (Eq. 18), the bound on the residual ``tau_Lin - h + Delta tau_d``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from posfb.models.design.config import UncertaintyBounds
from posfb.models.disk_cache import cached_floats, file_digest
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.nominal import NominalModel, UrdfNominal, nominal_model
from posfb.models.serial_bounds import (
    MODEL_NORM_SAMPLES,
    MODEL_NORM_SEED,
    SEARCH_STEPS,
    STARTS,
    model_norms,
)
from posfb.models.serial_model import SerialArmModel


@dataclass(frozen=True)
class BoundFilterConstants:
    """``abar``, ``c`` and the smallest admissible pole ``min_a = ln 2 / T_s`` (Sec. 3.4)."""

    a: float
    sample_time: float
    abar: float
    c: float
    min_a: float

    @property
    def valid(self) -> bool:
        """``a > ln 2 / T_s``, i.e. ``abar < 1/2`` (Eq. 24 needs ``c > 0``)."""
        return self.a > self.min_a


def bound_filter_constants(a: float, sample_time: float) -> BoundFilterConstants:
    abar = math.exp(-a * sample_time)
    return BoundFilterConstants(
        a=a,
        sample_time=sample_time,
        abar=abar,
        c=1.0 - 2.0 * abar,
        min_a=math.log(2.0) / sample_time,
    )


def coriolis_bound(parameters: LumpedParameters) -> float:
    """The smallest ``k_C1`` with ``||C*(q, x) y|| <= k_C1 ||x|| ||y||`` for all q, x, y.

    ``C*`` scales with ``sin q2`` (Sec. 4.1), so the worst case is ``|sin q2| = 1``
    and ``k_C1 = max_{||x|| = 1} ||C*(q, x)||_2`` there: a 1-D search over the
    direction of ``x`` (grid, then a bounded refinement around the best point).
    """
    model = LumpedModel(parameters)
    q = np.array([0.0, 0.5 * np.pi])

    def norm_at(angle: float) -> float:
        return float(np.linalg.norm(model.C(q, np.array([np.cos(angle), np.sin(angle)])), 2))

    grid = np.linspace(0.0, np.pi, 721)
    best = grid[int(np.argmax([norm_at(angle) for angle in grid]))]
    step = grid[1] - grid[0]
    import scipy.optimize  # on use: the CLI's start-up does not pay for it

    result = scipy.optimize.minimize_scalar(
        lambda angle: -norm_at(angle),
        bounds=(best - step, best + step),
        method="bounded",
        options={"xatol": 1e-10},
    )
    return max(-float(result.fun), norm_at(best))


@dataclass(frozen=True)
class ResolvedBounds:
    """Numbers of Assumption 1, ``k_C1`` and ``||F*||`` (the largest ``||F*(q')||``)."""

    delta_M0: float
    delta_M1: float
    delta_C: float
    delta_G: float
    delta_B: float
    delta_F: float
    k_C1: float
    F_norm: float

    def delta_bar(
        self, M1_norm: float, U1: float, U2: float, qd_dot_norm: float, qd_ddot_norm: float
    ) -> float:
        """Eq. 18 with ``M1_norm = ||M1*(q)||``, ``U1 >= ||q~'||``, ``U2 >= ||q~''||``."""
        return (
            M1_norm * U2
            + (self.delta_M1 + self.delta_M0) * (U2 + qd_ddot_norm)
            + self.delta_B * (U1 + qd_dot_norm)
            + (self.k_C1 + self.delta_C) * U1 * (U1 + 2.0 * qd_dot_norm)
            + self.delta_C * qd_dot_norm**2
            + self.delta_G
            + self.delta_F
            + 2.0 * self.F_norm
        )


def _lumped_norms(parameters: LumpedParameters, k_C1: float) -> dict[str, float]:
    """The nominal norms of the two-link theta model. ``M1*(q)`` is linear in
    ``cos q2`` and ``G*(q)`` reaches ``|G1| = theta4 + (g/l1)|theta3|`` and
    ``|G2| = (g/l1)|theta8|`` at one configuration, so their maxima over ``q`` are
    taken in closed form."""
    model = LumpedModel(parameters)
    p = parameters
    ratio = p.g / p.l1
    return {
        "delta_M0": float(np.linalg.norm(model.M0(), 2)),
        "delta_M1": float(np.linalg.norm(model.M1(np.zeros(2)), 2)),
        "delta_C": k_C1,
        "delta_G": math.hypot(p.theta4 + ratio * abs(p.theta3), ratio * abs(p.theta8)),
        "delta_B": float(np.linalg.norm(model.B(), 2)),
    }


def _serial_norms(
    nominal: UrdfNominal, model: SerialArmModel, k_C1: float | None
) -> tuple[dict[str, float], float]:
    """The nominal norms of a serial arm: ``M1*``, ``C*`` and ``G*`` maximised over a
    sampled workspace (``models.serial_bounds.model_norms``), kept in the on-disk cache
    (``models.disk_cache``) under the URDF's content and the search's settings, so a
    second command on an unchanged arm does not search again."""
    sampled = cached_floats(
        "model_norms",
        {
            "urdf_sha256": file_digest(nominal.urdf),
            "samples": MODEL_NORM_SAMPLES,
            "seed": MODEL_NORM_SEED,
            "steps": SEARCH_STEPS,
            "starts": STARTS,
            "search": "bfgs",
        },
        lambda: model_norms(model, MODEL_NORM_SAMPLES, MODEL_NORM_SEED),
    )
    k_C1 = sampled["delta_C"] if k_C1 is None else k_C1
    return {
        "delta_M0": float(np.linalg.norm(model.M0(), 2)),
        "delta_M1": sampled["delta_M1"],
        "delta_C": k_C1,
        "delta_G": sampled["delta_G"],
        "delta_B": float(np.linalg.norm(model.B(), 2)),
    }, k_C1


@functools.lru_cache(maxsize=32)
def resolve_bounds(bounds: UncertaintyBounds, nominal: NominalModel) -> ResolvedBounds:
    """Fill each ``None`` of ``bounds`` with ``relative`` times the nominal norm: closed
    forms for the two-link theta model, a sampled workspace search for a URDF model
    (seconds for six joints: cached, since designs that differ only in their weights, as
    a tuner's do, share the bounds)."""
    model = nominal_model(nominal)
    if isinstance(nominal, LumpedParameters):
        k_C1 = coriolis_bound(nominal) if bounds.k_C1 is None else bounds.k_C1
        norms = _lumped_norms(nominal, k_C1)
    else:
        norms, k_C1 = _serial_norms(nominal, model, bounds.k_C1)
    F_norm = float(np.linalg.norm(model.coulomb_levels()))
    norms["delta_F"] = F_norm
    resolved = {
        name: bounds.relative * norm if getattr(bounds, name) is None else getattr(bounds, name)
        for name, norm in norms.items()
    }
    return ResolvedBounds(**resolved, k_C1=k_C1, F_norm=F_norm)
