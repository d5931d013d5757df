"""The nominal model's torques evaluated numerically::

    tau_Lin = M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)      (Eq. 4)
    tau_d   = M0* qdd_d + B* qd_d                                     (Eq. 7)

and ``||M1*(q)||_2`` (Eq. 18), from the one description the controllers' laws are built
on (``models.laws.nominal``: the theta model's or a URDF arm's expressions), for
scripts, tests and benchmarks that want the terms on their own.
``nominal_torques`` gives them for a nominal model.
"""

from __future__ import annotations

import numpy as np

from posfb.models.nominal import NominalModel


class NominalTorques:
    """``tau_Lin``, ``tau_d`` and ``||M1*(q)||_2`` of a ``models.laws.nominal`` model."""

    def __init__(self, model: object) -> None:
        from posfb.models.laws.law import Evaluator
        from posfb.models.laws.nominal import torque_functions

        self._linearization, self._desired, self._M1_norm = (
            Evaluator(f) for f in torque_functions(model))  # fmt: skip

    def linearization(self, q: np.ndarray, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 4 at the measured ``q``."""
        return self._linearization(q, qd_dot, qd_ddot)[0]

    def desired(self, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 7: ``tau_d = M0* qdd_d + B* qd_d``."""
        return self._desired(qd_dot, qd_ddot)[0]

    def M1_norm(self, q: np.ndarray) -> float:
        """``||M1*(q)||_2`` (Eq. 18)."""
        return float(self._M1_norm(q)[0][0])


def nominal_torques(nominal: NominalModel) -> NominalTorques:
    """The torques of Eq. 4, 7 and 18 for ``nominal`` (either form of ``models.nominal``)."""
    from posfb.models.laws.nominal import symbolic_model

    return NominalTorques(symbolic_model(nominal))
