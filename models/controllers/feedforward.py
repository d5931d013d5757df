"""Model-based torques shared by the proposed controller and Lin+LC::

    tau_Lin = M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)      (Eq. 4)
    tau_d   = M0* qdd_d + B* qd_d                                     (Eq. 7)

with ``||M1*(q)||_2`` for Eq. 18. Two implementations of one interface:
``NominalTorques`` for the paper's two-link theta model, written out with ``math``
on the two joints (they run once per control period; the tests check them against
the matrices of ``models.lumped.LumpedModel``), and ``SerialTorques`` for any
serial arm, from Drake's ``MultibodyPlant`` (``models.serial_model``).
``nominal_torques`` picks the one for a nominal model.
"""

from __future__ import annotations

import math

import numpy as np

from posfb.models.lumped import LumpedModel
from posfb.models.nominal import NominalModel, UrdfNominal, nominal_model
from posfb.models.serial_model import SerialArmModel


def _sign(x: float) -> float:
    return (x > 0.0) - (x < 0.0)


class NominalTorques:
    """``tau_Lin`` (Eq. 4) and ``tau_d`` (Eq. 7) of the nominal lumped model, and
    ``||M1*(q)||_2`` (Eq. 18), evaluated without temporary matrices."""

    def __init__(self, model: LumpedModel) -> None:
        p = model.parameters
        self._t = (p.theta3, p.theta4, p.theta6, p.theta8, p.theta11)
        self._gravity_ratio = p.g / p.l1
        self._M0 = model.M0()
        self._B = model.B()

    def linearization(self, q: np.ndarray, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 4: ``M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)`` at the measured ``q``."""
        theta3, theta4, theta6, theta8, theta11 = self._t
        q1, q2 = float(q[0]), float(q[1])
        v1, v2 = float(qd_dot[0]), float(qd_dot[1])
        a1, a2 = float(qd_ddot[0]), float(qd_ddot[1])
        c2, s2, c12 = math.cos(q2), math.sin(q2), math.cos(q1 + q2)
        inertia = (2.0 * theta3 * c2 * a1 + theta3 * c2 * a2, theta8 * c2 * a1)
        coriolis = (
            -theta3 * v2 * s2 * v1 + -theta3 * (v1 + v2) * s2 * v2,
            theta8 * v1 * s2 * v1,
        )
        gravity = (
            theta4 * math.cos(q1) + self._gravity_ratio * theta3 * c12,
            self._gravity_ratio * theta8 * c12,
        )
        friction = (theta6 * _sign(v1), theta11 * _sign(v2))
        return np.array(
            [
                inertia[0] + coriolis[0] + gravity[0] + friction[0],
                inertia[1] + coriolis[1] + gravity[1] + friction[1],
            ]
        )

    def desired(self, qd_dot: np.ndarray, qd_ddot: np.ndarray) -> np.ndarray:
        """Eq. 7: ``tau_d = M0* qdd_d + B* qd_d``."""
        return self._M0 @ qd_ddot + self._B @ qd_dot

    def M1_norm(self, q: np.ndarray) -> float:
        """``||M1*(q)||_2`` of ``M1* = cos q2 [[2 theta3, theta3], [theta8, 0]]`` in closed form."""
        theta3, theta8 = self._t[0], self._t[3]
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
