"""Model-based torques shared by the proposed controller and Lin+LC."""

from __future__ import annotations

import numpy as np

from posfb.models.lumped import LumpedModel


class NominalTorques:
    """``tau_Lin`` (Eq. 4) and ``tau_d`` (Eq. 7) of the nominal lumped model."""

    def __init__(self, model: LumpedModel) -> None:
        self._model = model
        self._M0 = model.M0()
        self._B = model.B()

    def linearization(self, q: np.ndarray, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 4: ``M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)`` at the measured ``q``."""
        model = self._model
        return model.M1(q) @ qd_ddot + model.C(q, qd_dot) @ qd_dot + model.G(q) + model.F(qd_dot)

    def desired(self, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 7: ``tau_d = M0* qdd_d + B* qd_d``."""
        return self._M0 @ qd_ddot + self._B @ qd_dot
