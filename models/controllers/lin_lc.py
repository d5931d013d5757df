"""``tau_Lin + tau_LC``: the paper's ablation without the nonlinear torque (Sec. 4.2).

``tau_LC = tau_d + eta~`` (Eq. 13) with ``eta~`` from the position-only, FOH-
discretised filter of ``models.design.realisation`` (state ``w = eta~ + K2 q~``),
initialised at rest (``eta~(0) = 0``) from the first measurement.
"""

from __future__ import annotations

import numpy as np

from posfb.models.controllers.base import SampledController
from posfb.models.controllers.feedforward import NominalTorques
from posfb.models.design import Design
from posfb.models.lumped import LumpedModel

#: Columns of the ``internals`` output.
LIN_LC_INTERNALS = ("tau_lin_1", "tau_lin_2", "tau_lc_1", "tau_lc_2")


class LinLcController(SampledController):
    """``u = tau_Lin + tau_LC`` (Eq. 3 without ``tau_NC``); refuses a failed LQR design."""

    def __init__(self, design: Design) -> None:
        design.require_linear_torque()
        self._filter = design.lin_lc_filter
        super().__init__(design.config.sample_time, LIN_LC_INTERNALS, len(self._filter.A))
        self.set_name("lin_lc_controller")
        self._torques = NominalTorques(LumpedModel(design.config.nominal))

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        return self._filter.initial @ (q - desired[0:2])

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        error, qd_dot, qd_ddot = q - desired[0:2], desired[2:4], desired[4:6]
        f = self._filter
        eta = f.C @ memory + f.D @ error
        memory[:] = f.A @ memory + f.B @ error
        tau_lin = self._torques.linearization(q, qd_dot, qd_ddot)
        tau_lc = self._torques.desired(qd_dot, qd_ddot) + eta
        return tau_lin + tau_lc, np.concatenate([tau_lin, tau_lc])
