"""The nominal model of Eq. 2 as the laws' building block (``models.nominal``'s two forms):

* ``ThetaModel``: the paper's two-link theta model (``models.lumped``) written out as
  CasADi ``SX`` expressions, which the generated C prints;
* ``UrdfModel``: a serial URDF arm's model evaluated by Drake (``models.serial_model``)
  inside the law, as CasADi callbacks in an ``MX`` graph; such a law runs in the
  simulation but is not printed as C (its model is Drake's code, not an expression).

Both give the terms the controllers use::

    tau_Lin = M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)      (Eq. 4)
    tau_d   = M0* qdd_d + B* qd_d                                     (Eq. 7)
    u       = M*(q) a + C*(q, v) v + G*(q) + B* v + F*(v)             (Eq. 2, inverse dynamics)

with ``M1* = M* - M0*`` and ``F*(v) = f_c* sgn v`` (``sgn 0 = 0``).
"""

from __future__ import annotations

from collections.abc import Callable

import casadi as ca
import numpy as np

from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.nominal import NominalModel, nominal_model
from posfb.models.serial_model import SerialArmModel

#: A CasADi symbol or expression of either kind.
Symbolic = ca.SX | ca.MX


def desired_torque(M0: np.ndarray, B: np.ndarray, qd_dot: Symbolic, qd_ddot: Symbolic) -> Symbolic:
    """Eq. 7: ``M0* qdd_d + B* qd_d``."""
    return ca.mtimes(ca.DM(M0), qd_ddot) + ca.mtimes(ca.DM(B), qd_dot)


class ThetaModel:
    """The theta model of ``parameters`` as ``SX`` expressions (module docstring)."""

    printable = True

    def __init__(self, parameters: LumpedParameters) -> None:
        self.parameters = parameters
        lumped = LumpedModel(parameters)
        self.M0, self.B = lumped.M0(), lumped.B()
        self.joints = 2

    @staticmethod
    def symbol(name: str, size: int) -> ca.SX:
        return ca.SX.sym(name, size)

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

    def M1_norm(self, q: Symbolic) -> Symbolic:
        """``||M1*(q)||_2`` (Eq. 18) of ``M1* = cos q2 [[2 theta3, theta3], [theta8, 0]]`` in
        closed form (the largest singular value of a 2 x 2 matrix)."""
        p = self.parameters
        c2 = ca.cos(q[1])
        m11, m12, m21 = 2.0 * p.theta3 * c2, p.theta3 * c2, p.theta8 * c2
        frobenius2 = m11 * m11 + m12 * m12 + m21 * m21
        det = -m12 * m21
        return ca.sqrt(0.5 * (frobenius2 + ca.sqrt(ca.fmax(frobenius2**2 - 4.0 * det * det, 0.0))))

    def linearization(self, q: Symbolic, qd_dot: Symbolic, qd_ddot: Symbolic) -> Symbolic:
        """Eq. 4 at the measured ``q``."""
        c2, coriolis, gravity, friction = self._terms(q, qd_dot)
        return self._M1(c2, qd_ddot) + coriolis + gravity + friction

    def inverse_dynamics(self, q: Symbolic, v: Symbolic, a: Symbolic) -> Symbolic:
        """Eq. 2's voltage for ``(q, v, a)``, Coulomb friction included."""
        c2, coriolis, gravity, friction = self._terms(q, v)
        return (ca.mtimes(ca.DM(self.M0), a) + self._M1(c2, a) + coriolis + gravity
                + ca.mtimes(ca.DM(self.B), v) + friction)  # fmt: skip


class _Numeric(ca.Callback):
    """A function of ``inputs`` n-vectors to one vector of ``outputs`` (default n),
    evaluated in Python."""

    def __init__(
        self, name: str, joints: int, inputs: int, function: Callable[..., np.ndarray],
        outputs: int | None = None,
    ) -> None:  # fmt: skip
        ca.Callback.__init__(self)
        self._joints, self._inputs, self._function = joints, inputs, function
        self._outputs = joints if outputs is None else outputs
        self.construct(name, {})

    def get_n_in(self) -> int:
        return self._inputs

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self._joints, 1)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self._outputs, 1)

    def eval(self, arguments: list[ca.DM]) -> list[ca.DM]:
        values = [np.asarray(a, dtype=float).ravel() for a in arguments]
        return [ca.DM(self._function(*values))]

    def has_eval_buffer(self) -> bool:
        return True

    def eval_buffer(self, arguments: list[memoryview], results: list[memoryview]) -> int:
        """``eval`` on CasADi's own buffers (no conversions)."""
        values = [np.frombuffer(a, dtype=float) for a in arguments]
        np.frombuffer(results[0], dtype=float)[:] = self._function(*values)
        return 0


class UrdfModel:
    """A serial arm's model (``SerialArmModel``) evaluated by Drake inside ``MX`` laws
    (module docstring). The callbacks live as long as this object: a law keeps it."""

    printable = False

    def __init__(self, model: SerialArmModel) -> None:
        self.model = model
        self.M0, self.B = model.M0(), model.B()
        self.joints = model.size
        n = model.size
        self._linearization = _Numeric("urdf_linearization", n, 3, self._eq4)
        self._inverse = _Numeric(
            "urdf_inverse_dynamics", n, 3,
            lambda q, v, a: model.inverse_dynamics(q, v, a, friction=True),
        )  # fmt: skip
        self._gravity = _Numeric("urdf_gravity", n, 1, model.G)
        self._M1_norm = _Numeric(
            "urdf_M1_norm", n, 1,
            lambda q: np.array([np.linalg.norm(model.M(q) - self.M0, 2)]), outputs=1,
        )  # fmt: skip

    def _eq4(self, q: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        model = self.model
        return ((model.M(q) - self.M0) @ acceleration + model.coriolis(q, velocity)
                + model.G(q) + model.F(velocity))  # fmt: skip

    @staticmethod
    def symbol(name: str, size: int) -> ca.MX:
        return ca.MX.sym(name, size)

    def linearization(self, q: Symbolic, qd_dot: Symbolic, qd_ddot: Symbolic) -> Symbolic:
        """Eq. 4 at the measured ``q``, by Drake."""
        return self._linearization(q, qd_dot, qd_ddot)

    def inverse_dynamics(self, q: Symbolic, v: Symbolic, a: Symbolic) -> Symbolic:
        """Eq. 2's voltage, Coulomb friction included, by Drake."""
        return self._inverse(q, v, a)

    def M1_norm(self, q: Symbolic) -> Symbolic:
        """``||M*(q) - M0*||_2`` (Eq. 18), by Drake."""
        return self._M1_norm(q)

    def gravity(self, q: Symbolic) -> Symbolic:
        """``G*(q)``, by Drake."""
        return self._gravity(q)


def symbolic_model(nominal: NominalModel) -> ThetaModel | UrdfModel:
    """The law's form of ``nominal`` (module docstring)."""
    return symbolic_of(nominal_model(nominal))


def symbolic_of(model: LumpedModel | SerialArmModel) -> ThetaModel | UrdfModel:
    """The law's form of a numeric nominal model (``models.nominal.nominal_model``'s)."""
    if isinstance(model, LumpedModel):
        return ThetaModel(model.parameters)
    return UrdfModel(model)


def torque_functions(model: ThetaModel | UrdfModel) -> tuple[ca.Function, ...]:
    """``(q, qd_d, qdd_d) -> tau_Lin`` (Eq. 4), ``(qd_d, qdd_d) -> tau_d`` (Eq. 7) and ``q
    -> ||M1*(q)||`` (Eq. 18) of ``model`` as CasADi functions
    (``models.controllers.feedforward.NominalTorques``)."""
    n = model.joints
    q, velocity, acceleration = (model.symbol(name, n) for name in ("q", "qd_dot", "qd_ddot"))
    return (
        ca.Function("tau_lin", [q, velocity, acceleration],
                    [model.linearization(q, velocity, acceleration)]),
        ca.Function("tau_d", [velocity, acceleration],
                    [desired_torque(model.M0, model.B, velocity, acceleration)]),
        ca.Function("M1_norm", [q], [model.M1_norm(q)]),
    )  # fmt: skip
