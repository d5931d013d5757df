"""Model-based torques shared by the proposed controller and Lin+LC::

    tau_Lin = M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)      (Eq. 4)
    tau_d   = M0* qdd_d + B* qd_d                                     (Eq. 7)

with ``||M1*(q)||_2`` for Eq. 18. Two implementations of one interface:
``NominalTorques`` for the paper's two-link theta model, the CasADi expressions of
``models.laws.nominal`` (the generated C prints the same ones; the tests check them
against the matrices of ``models.lumped.LumpedModel``), and ``SerialTorques`` for any
serial arm, from Drake's ``MultibodyPlant`` (``models.serial_model``).
``nominal_torques`` picks the one for a nominal model.
"""

from __future__ import annotations

import math

import numpy as np

from posfb.models.lumped import LumpedModel
from posfb.models.nominal import NominalModel, UrdfNominal, nominal_model
from posfb.models.serial_model import SerialArmModel


class NominalTorques:
    """``tau_Lin`` (Eq. 4) and ``tau_d`` (Eq. 7) of the nominal lumped model, and
    ``||M1*(q)||_2`` (Eq. 18), evaluated without temporary matrices."""

    def __init__(self, model: LumpedModel) -> None:
        from posfb.models.laws.law import Evaluator
        from posfb.models.laws.nominal import theta_functions

        p = model.parameters
        self.parameters = p
        self._t = (p.theta3, p.theta8)
        self._M0 = model.M0()
        self._B = model.B()
        linearization, desired = theta_functions(p)
        self._linearization, self._desired = Evaluator(linearization), Evaluator(desired)

    def linearization(self, q: np.ndarray, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 4: ``M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)`` at the measured ``q``
        (``models.laws.nominal``, the expression the generated C prints)."""
        return self._linearization(q, qd_dot, qd_ddot)[0]

    def desired(self, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 7: ``tau_d = M0* qdd_d + B* qd_d`` (``models.laws.nominal``)."""
        return self._desired(qd_dot, qd_ddot)[0]

    def M1_norm(self, q: np.ndarray) -> float:
        """``||M1*(q)||_2`` of ``M1* = cos q2 [[2 theta3, theta3], [theta8, 0]]`` in closed form."""
        theta3, theta8 = self._t
        c2 = math.cos(float(q[1]))
        m11, m12, m21 = 2.0 * theta3 * c2, theta3 * c2, theta8 * c2
        frobenius2 = m11 * m11 + m12 * m12 + m21 * m21
        det = -m12 * m21
        return math.sqrt(0.5 * (frobenius2 + math.sqrt(max(frobenius2**2 - 4.0 * det * det, 0.0))))


class SerialTorques:
    """``tau_Lin`` (Eq. 4), ``tau_d`` (Eq. 7) and ``||M1*(q)||_2`` of a serial arm's
    nominal model: ``M1*(q) = M*(q) - M0*`` and ``C*(q, qd_d) qd_d`` is Drake's bias
    term at ``(q, qd_d)``."""

    def __init__(self, model: SerialArmModel) -> None:
        self._model = model
        self._M0 = model.M0()
        self._B = model.B()

    def linearization(self, q: np.ndarray, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 4 at the measured ``q``."""
        model = self._model
        return (
            (model.M(q) - self._M0) @ qd_ddot
            + model.coriolis(q, qd_dot)
            + model.G(q)
            + model.F(qd_dot)
        )

    def desired(self, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 7: ``tau_d = M0* qdd_d + B* qd_d``."""
        return self._M0 @ qd_ddot + self._B @ qd_dot

    def M1_norm(self, q: np.ndarray) -> float:
        """``||M*(q) - M0*||_2``."""
        return float(np.linalg.norm(self._model.M(q) - self._M0, 2))


def nominal_torques(nominal: NominalModel) -> NominalTorques | SerialTorques:
    """The torques of Eq. 4 and 7 for ``nominal`` (either form of ``models.nominal``)."""
    if isinstance(nominal, UrdfNominal):
        return SerialTorques(nominal_model(nominal))
    return NominalTorques(LumpedModel(nominal))
