"""theta_1..theta_11 of Sec. 4.1 (Eq. 4, in volts) identified from a log of measured
positions and applied voltages (issue 29): ``theta_regressor`` through ``fit_log``.

What the estimate says about itself is ``checks.estimate_warnings``'s (Table 1's
theta9 = 2e-5 V s^2/rad is not identifiable from any log: it is the small difference of
two inertias).

The model the controllers get (``lumped``) is the weighted least-squares problem solved
again with theta's physical signs as bounds (``scipy.optimize.lsq_linear``: theta1,
theta7 > 0; theta2, 4, 5, 6, 9, 10, 11 >= 0); where a bound is active, ``warnings`` says
so. The estimate and its covariance are the unbounded ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize

from posfb.models.identification.checks import estimate_warnings
from posfb.models.identification.estimate import (
    Estimate,
    FilterSettings,
    Reference,
    fit_log,
)
from posfb.models.identification.model_file import IdentifiedModelFile
from posfb.models.identification.theta_regressor import (
    COULOMB_PARAMETERS,
    THETA_NAMES,
    theta_regressor,
)
from posfb.models.lumped import LumpedParameters

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
        return IdentifiedModelFile.of_estimate(
            "theta", self.estimate, self.model_values, log, self.warnings, l1=self.l1, g=self.g
        )


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
    reference: Reference | None = None,
) -> ThetaIdentification:
    """theta of Eq. 4 from a two-joint log (``time`` (N,), ``q_measured`` and ``voltage``
    (N, 2)); ``quantisation_step`` (rad per count, per joint) enables the coarse-encoder
    check; the controller's ``reference`` makes the fit instrumental variables
    (``estimate``)."""
    settings = (settings or FilterSettings()).with_rule(
        time, q_measured, reference, quantisation_step
    )

    def fit(time: np.ndarray, q_measured: np.ndarray, voltage: np.ndarray) -> Estimate:
        return fit_log(
            time,
            q_measured,
            voltage,
            lambda q, v, a: theta_regressor(q, v, a, l1, g),
            THETA_NAMES,
            coulomb=COULOMB_PARAMETERS,
            settings=settings,
            reference=reference,
        )

    estimate = fit(time, q_measured, voltage)
    warnings = estimate_warnings(
        estimate,
        None if reference is not None else (lambda q: fit(time, q, voltage)),
        q_measured,
        quantisation_step,
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
