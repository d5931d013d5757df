"""theta_1..theta_11 of Sec. 4.1 (Eq. 4, in volts) identified from a log of measured
positions and applied voltages (issue 29): ``theta_regressor`` through ``fit_log``.

What the estimate says about itself (``warnings``):

* a theta whose relative standard error exceeds ``IDENTIFIABLE_RELATIVE_STD`` is not
  identifiable from this log (Table 1's theta9 = 2e-5 V s^2/rad is one on any log:
  it is the small difference of two inertias);
* a condition number of the scaled regressor above ``POOR_CONDITION`` is poor
  excitation (Swevers et al. 1997 aim well below it);
* an encoder too coarse for this log: its quantisation biases an identifiable
  parameter by more than the parameter's standard error (``_coarse_encoder``).

The model the controllers get (``lumped``) is the weighted least-squares problem solved
again with theta's physical signs as bounds (``scipy.optimize.lsq_linear``: theta1,
theta7 > 0; theta2, 4, 5, 6, 9, 10, 11 >= 0); where a bound is active, ``warnings`` says
so. The estimate and its covariance are the unbounded ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from posfb.models.identification.estimate import (
    Estimate,
    FilterSettings,
    fit_log,
)
from posfb.models.identification.model_file import IdentifiedModelFile
from posfb.models.identification.theta_regressor import (
    COULOMB_PARAMETERS,
    THETA_NAMES,
    theta_regressor,
)
from posfb.models.lumped import LumpedParameters

#: Relative standard error above which a parameter counts as not identifiable.
IDENTIFIABLE_RELATIVE_STD = 0.10

#: Condition number of the scaled regressor above which the excitation is poor.
POOR_CONDITION = 100.0

#: theta's lower bounds for the model (theta3 and theta8 may take either sign).
_LOWER = np.array([1e-9, 0, -np.inf, 0, 0, 0, 1e-9, -np.inf, 0, 0, 0], dtype=float)


@dataclass(frozen=True)
class ThetaIdentification:
    """An identification of the two-link arm's theta: the ``estimate``, the bounded
    ``model`` values, the ``l1``, ``g`` used and the ``warnings``."""

    estimate: Estimate
    model_values: np.ndarray
    l1: float
    g: float
    warnings: tuple[str, ...]

    def lumped(self) -> LumpedParameters:
        """The identified model as the controllers take it."""
        return LumpedParameters.from_theta(self.model_values, l1=self.l1, g=self.g)

    def model_file(self, log: str) -> IdentifiedModelFile:
        """The identification as ``posfb identify --out`` writes it."""
        estimate = self.estimate
        return IdentifiedModelFile(
            kind="theta",
            names=list(estimate.names),
            values=[float(v) for v in self.model_values],
            std=[float(s) for s in estimate.std],
            covariance=[[float(c) for c in row] for row in estimate.covariance],
            l1=self.l1,
            g=self.g,
            log=log,
            condition_number=estimate.condition_number,
            cutoff_hz=estimate.cutoff_hz,
            warnings=list(self.warnings),
        )


def _coarse_encoder(
    estimate: Estimate,
    refit: Callable[[np.ndarray], Estimate],
    q_measured: np.ndarray,
    step: np.ndarray,
) -> list[str]:
    """The coarse-encoder check: the log refitted with the encoder's error added once
    more (uniform over one count, seeded). The noise in ``q''`` biases the inertias
    towards 0 by about its variance's share (errors in variables), so the shift the
    second dose causes measures the bias the first one left; a shift beyond the
    parameter's standard error means the stated interval misses it."""
    noise = np.random.default_rng(0).uniform(-0.5, 0.5, q_measured.shape) * step
    shift = np.abs(refit(q_measured + noise).values - estimate.values)
    identifiable = estimate.relative_std <= IDENTIFIABLE_RELATIVE_STD
    biased = np.flatnonzero(identifiable & (shift > estimate.std))
    if biased.size == 0:
        return []
    worst = biased[np.argmax(shift[biased] / estimate.std[biased])]
    return [
        f"encoder too coarse for this log ({', '.join(f'{s:.3g}' for s in step)} rad per "
        f"count): its quantisation biases {', '.join(estimate.names[i] for i in biased)} by "
        f"more than their standard errors (errors in the filtered q''; "
        f"{estimate.names[worst]} by about {shift[worst]:.3g}, "
        f"{shift[worst] / estimate.std[worst]:.1f} standard errors); a finer encoder, a "
        "lower cutoff_hz or faster excitation reduces it"
    ]


def bounded_model_values(estimate: Estimate) -> np.ndarray:
    """theta within ``_LOWER``: the estimate where it is inside, else the bounded
    least-squares solution of the linearised problem ``min (p - p^)^T C^-1 (p - p^)``."""
    values = estimate.values
    if np.all(values >= _LOWER):
        return values
    # The weighted least-squares cost is (p - p^)^T C^-1 (p - p^) up to a constant.
    whitening = np.linalg.cholesky(np.linalg.pinv(estimate.covariance)).T
    solution = scipy.optimize.lsq_linear(
        whitening, whitening @ values, bounds=(_LOWER, np.full(values.size, np.inf))
    )
    return solution.x


def identify_theta(
    time: np.ndarray,
    q_measured: np.ndarray,
    voltage: np.ndarray,
    *,
    l1: float,
    g: float,
    quantisation_step: np.ndarray | None = None,
    settings: FilterSettings | None = None,
) -> ThetaIdentification:
    """theta of Eq. 4 from a two-joint log (``time`` (N,), ``q_measured`` and ``voltage``
    (N, 2)); ``quantisation_step`` (rad per count, per joint) enables the coarse-encoder
    check."""
    settings = settings or FilterSettings()

    def fit(time: np.ndarray, q_measured: np.ndarray, voltage: np.ndarray) -> Estimate:
        return fit_log(
            time,
            q_measured,
            voltage,
            lambda q, v, a: theta_regressor(q, v, a, l1, g),
            THETA_NAMES,
            coulomb=COULOMB_PARAMETERS,
            settings=settings,
        )

    estimate = fit(time, q_measured, voltage)
    warnings = []
    for name, value, std, relative in zip(
        estimate.names, estimate.values, estimate.std, estimate.relative_std, strict=True
    ):
        if relative > IDENTIFIABLE_RELATIVE_STD:
            warnings.append(
                f"{name} is not identifiable from this log: {value:.4g} +- {std:.2g} "
                f"(relative standard error {100 * min(relative, 1e6):.0f} % > "
                f"{100 * IDENTIFIABLE_RELATIVE_STD:.0f} %)"
            )
    if estimate.condition_number > POOR_CONDITION:
        warnings.append(
            f"poor excitation: the scaled regressor's condition number is "
            f"{estimate.condition_number:.0f} > {POOR_CONDITION:.0f} (posfb identify plan "
            "writes an exciting trajectory)"
        )
    if quantisation_step is not None:
        warnings += _coarse_encoder(
            estimate, lambda q: fit(time, q, voltage), q_measured, quantisation_step
        )
    model_values = bounded_model_values(estimate)
    for name, value, bounded, lower in zip(
        estimate.names, estimate.values, model_values, _LOWER, strict=True
    ):
        if value < lower:
            warnings.append(
                f"{name} = {value:.4g} is outside its physical range (>= 0); the model uses "
                f"{bounded:.4g} and the others re-fitted with it (bounded least squares)"
            )
    return ThetaIdentification(estimate, model_values, float(l1), float(g), tuple(warnings))
