"""The nominal model of Eq. 2 as the laws' building block (``models.nominal``'s two forms):

* ``ThetaModel``: the paper's two-link theta model (``models.lumped``) written out;
* ``UrdfModel``: a serial URDF arm's model (``models.serial_model``), its rigid-body terms
  by the recursive Newton-Euler algorithm on the Drake plant
  (``models.laws.serial_dynamics``).

Both are CasADi ``SX`` expressions, which the simulation evaluates and the generated C
prints.

Both give the terms the controllers use::

    tau_Lin = M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)      (Eq. 4)
    tau_d   = M0* qdd_d + B* qd_d                                     (Eq. 7)
    u       = M*(q) a + C*(q, v) v + G*(q) + B* v + F*(v)             (Eq. 2, inverse dynamics)

with ``M1* = M* - M0*`` and ``F*(v) = f_c* sgn v`` (``sgn 0 = 0``).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from posfb.models.laws.serial_dynamics import SerialArmDynamics
from posfb.models.laws.spectral_norm import NORMS
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.nominal import LinearPart, NominalModel, nominal_model
from posfb.models.serial_model import SerialArmModel

#: A CasADi symbol or expression.
Symbolic = ca.SX


def desired_torque(M0: np.ndarray, B: np.ndarray, qd_dot: Symbolic, qd_ddot: Symbolic) -> Symbolic:
    """Eq. 7: ``M0* qdd_d + B* qd_d``."""
    return ca.mtimes(ca.DM(M0), qd_ddot) + ca.mtimes(ca.DM(B), qd_dot)


class ThetaModel:
    """The theta model of ``parameters`` as ``SX`` expressions (module docstring)."""

    def __init__(self, parameters: LumpedParameters) -> None:
        self.parameters = parameters
        lumped = LumpedModel(parameters)
        self.M0, self.B = lumped.M0(), lumped.B()
        self.joints = 2

    def _terms(self, q: Symbolic, v: Symbolic) -> tuple[Symbolic, ...]:
        """``cos q2``, the Coriolis/centrifugal vector ``C*(q, v) v``, ``G*(q)``, ``F*(v)``."""
        p = self.parameters
        c2, s2, c12 = ca.cos(q[1]), ca.sin(q[1]), ca.cos(q[0] + q[1])
        ratio = p.g / p.l1
        coriolis = ca.vertcat(
            -p.theta3 * v[1] * s2 * v[0] - p.theta3 * (v[0] + v[1]) * s2 * v[1],
            p.theta8 * v[0] * s2 * v[0],
        )
        gravity = ca.vertcat(p.theta4 * ca.cos(q[0]) + ratio * p.theta3 * c12,
                             ratio * p.theta8 * c12)  # fmt: skip
        friction = ca.vertcat(p.theta6 * ca.sign(v[0]), p.theta11 * ca.sign(v[1]))
        return c2, coriolis, gravity, friction

    def gravity(self, q: Symbolic) -> Symbolic:
        """``G*(q)``."""
        return self._terms(q, q)[2]

    def _M1(self, c2: Symbolic, a: Symbolic) -> Symbolic:
        """``M1*(q) a`` with ``M1* = cos q2 [[2 theta3, theta3], [theta8, 0]]``."""
        p = self.parameters
        return ca.vertcat(2.0 * p.theta3 * c2 * a[0] + p.theta3 * c2 * a[1], p.theta8 * c2 * a[0])

    def M1_norm(self, q: Symbolic, norm: str = "spectral") -> Symbolic:
        """``||M1*(q)||`` (Eq. 18; ``norm`` one of ``NORMS``, the spectral norm by default)
        of ``M1* = cos q2 [[2 theta3, theta3], [theta8, 0]]``."""
        p, c2 = self.parameters, ca.cos(q[1])
        return NORMS[norm](ca.blockcat([[2.0 * p.theta3 * c2, p.theta3 * c2],
                                        [p.theta8 * c2, ca.SX(0.0)]]))  # fmt: skip

    def linearization(self, q: Symbolic, qd_dot: Symbolic, qd_ddot: Symbolic) -> Symbolic:
        """Eq. 4 at the measured ``q``."""
        c2, coriolis, gravity, friction = self._terms(q, qd_dot)
        return self._M1(c2, qd_ddot) + coriolis + gravity + friction

    def inverse_dynamics(self, q: Symbolic, v: Symbolic, a: Symbolic) -> Symbolic:
        """Eq. 2's voltage for ``(q, v, a)``, Coulomb friction included."""
        c2, coriolis, gravity, friction = self._terms(q, v)
        return (ca.mtimes(ca.DM(self.M0), a) + self._M1(c2, a) + coriolis + gravity
                + ca.mtimes(ca.DM(self.B), v) + friction)  # fmt: skip


class UrdfModel:
    """A serial URDF arm's model (``SerialArmModel``) as ``SX`` expressions: the rigid-body
    terms by the recursive Newton-Euler algorithm on its Drake plant
    (``models.laws.serial_dynamics``), each joint's row divided by its motor constant
    (Eq. 2 in volts), with ``B*`` and ``F*``."""

    def __init__(self, model: SerialArmModel) -> None:
        self.M0, self.B = model.M0(), model.B()
        self.joints = model.size
        self._dynamics = SerialArmDynamics(model.plant, model.context, model.joints)
        self._scale = ca.DM(1.0 / model.motor_constant)
        self._coulomb = ca.DM(model.coulomb_levels())

    def _friction(self, v: Symbolic) -> Symbolic:
        """``F*(v) = diag(f_c*) sgn v``."""
        return self._coulomb * ca.sign(v)

    def linearization(self, q: Symbolic, qd_dot: Symbolic, qd_ddot: Symbolic) -> Symbolic:
        """Eq. 4 at the measured ``q``: ``M*(q) qdd_d + C*(q, qd_d) qd_d + G*(q)`` less
        ``M0* qdd_d``, plus ``F*(qd_d)``."""
        rigid = self._scale * self._dynamics.torques(q, qd_dot, qd_ddot)
        return rigid - ca.mtimes(ca.DM(self.M0), qd_ddot) + self._friction(qd_dot)

    def inverse_dynamics(self, q: Symbolic, v: Symbolic, a: Symbolic) -> Symbolic:
        """Eq. 2's voltage for ``(q, v, a)``, Coulomb friction included."""
        rigid = self._scale * self._dynamics.torques(q, v, a)
        return rigid + ca.mtimes(ca.DM(self.B), v) + self._friction(v)

    def M1_norm(self, q: Symbolic, norm: str = "spectral") -> Symbolic:
        """``||M*(q) - M0*||`` (Eq. 18; ``norm`` one of ``NORMS``, the spectral norm by
        default)."""
        mass = self._scale * self._dynamics.mass_matrix(q)  # row j divided by kappa_j
        return NORMS[norm](mass - ca.DM(self.M0))

    def gravity(self, q: Symbolic) -> Symbolic:
        """``G*(q)``."""
        zero = ca.SX.zeros(self.joints)
        return self._scale * self._dynamics.torques(q, zero, zero)


class LinearModel:
    """The nominal linear part (``models.nominal.LinearPart``: Eq. 2 with ``h = 0``) as
    ``SX`` expressions: ``tau_Lin = 0``, ``||M1*|| = 0``, ``u = M0* a + B* v``."""

    def __init__(self, model: LinearPart) -> None:
        self.M0, self.B = model.M0(), model.B()
        self.joints = model.size

    def linearization(self, q: Symbolic, qd_dot: Symbolic, qd_ddot: Symbolic) -> Symbolic:
        """Eq. 4 on the linear part: 0."""
        return ca.SX.zeros(self.joints)

    def inverse_dynamics(self, q: Symbolic, v: Symbolic, a: Symbolic) -> Symbolic:
        """``M0* a + B* v``."""
        return desired_torque(self.M0, self.B, v, a)

    def M1_norm(self, q: Symbolic, norm: str = "spectral") -> Symbolic:
        """0 in any norm: ``M*(q) = M0*``."""
        return ca.SX(0.0)

    def gravity(self, q: Symbolic) -> Symbolic:
        """0: ``G*`` belongs to ``h``."""
        return ca.SX.zeros(self.joints)


#: A law's form of a nominal model.
SymbolicModel = ThetaModel | UrdfModel | LinearModel


def symbolic_model(nominal: NominalModel, linear_part: bool = False) -> SymbolicModel:
    """The law's form of ``nominal`` (module docstring), or of its linear part."""
    model = nominal_model(nominal)
    return symbolic_of(LinearPart(model) if linear_part else model)


def symbolic_of(model: LumpedModel | SerialArmModel | LinearPart) -> SymbolicModel:
    """The law's form of a numeric nominal model (``models.nominal.nominal_model``'s, or
    its ``LinearPart``)."""
    if isinstance(model, LinearPart):
        return LinearModel(model)
    if isinstance(model, LumpedModel):
        return ThetaModel(model.parameters)
    return UrdfModel(model)


def torque_functions(model: SymbolicModel) -> tuple[ca.Function, ...]:
    """``(q, qd_d, qdd_d) -> tau_Lin`` (Eq. 4), ``(qd_d, qdd_d) -> tau_d`` (Eq. 7) and ``q
    -> ||M1*(q)||`` (Eq. 18) of ``model`` as CasADi functions
    (``models.controllers.feedforward.NominalTorques``)."""
    n = model.joints
    q, velocity, acceleration = (ca.SX.sym(name, n) for name in ("q", "qd_dot", "qd_ddot"))
    return (
        ca.Function("tau_lin", [q, velocity, acceleration],
                    [model.linearization(q, velocity, acceleration)]),
        ca.Function("tau_d", [velocity, acceleration],
                    [desired_torque(model.M0, model.B, velocity, acceleration)]),
        ca.Function("M1_norm", [q], [model.M1_norm(q)]),
    )  # fmt: skip
