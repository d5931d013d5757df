"""The nominal model's torques of the paper's two-link theta model (``models.lumped``),
written once as CasADi expressions: the simulated controllers evaluate them
(``models.controllers.feedforward.NominalTorques``) and the generated C prints them::

    tau_Lin = M1*(q) qdd_d + C*(q, qd_d) qd_d + G*(q) + F*(qd_d)      (Eq. 4)
    tau_d   = M0* qdd_d + B* qd_d                                     (Eq. 7)

with ``M1*(q) = cos q2 [[2 theta3, theta3], [theta8, 0]]``, ``C*``, ``G*`` and ``F*`` of
``models.lumped`` (``sgn 0 = 0``).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from posfb.models.lumped import LumpedParameters


def theta_linearization(
    parameters: LumpedParameters, q: ca.SX, qd_dot: ca.SX, qd_ddot: ca.SX
) -> ca.SX:
    """Eq. 4 of the theta model at the measured ``q`` (2-vectors of symbols)."""
    p = parameters
    q1, q2 = q[0], q[1]
    v1, v2 = qd_dot[0], qd_dot[1]
    a1, a2 = qd_ddot[0], qd_ddot[1]
    c2, s2, c12 = ca.cos(q2), ca.sin(q2), ca.cos(q1 + q2)
    ratio = p.g / p.l1
    inertia = ca.vertcat(2.0 * p.theta3 * c2 * a1 + p.theta3 * c2 * a2, p.theta8 * c2 * a1)
    coriolis = ca.vertcat(
        -p.theta3 * v2 * s2 * v1 - p.theta3 * (v1 + v2) * s2 * v2, p.theta8 * v1 * s2 * v1
    )
    gravity = ca.vertcat(p.theta4 * ca.cos(q1) + ratio * p.theta3 * c12, ratio * p.theta8 * c12)
    friction = ca.vertcat(p.theta6 * ca.sign(v1), p.theta11 * ca.sign(v2))
    return inertia + coriolis + gravity + friction


def desired_torque(M0: np.ndarray, B: np.ndarray, qd_dot: ca.SX, qd_ddot: ca.SX) -> ca.SX:
    """Eq. 7: ``M0* qdd_d + B* qd_d``."""
    return ca.mtimes(ca.DM(M0), qd_ddot) + ca.mtimes(ca.DM(B), qd_dot)


def theta_linearization_function(parameters: LumpedParameters) -> ca.Function:
    """``(q, qd_d, qdd_d) -> tau_Lin`` (Eq. 4) as a CasADi function."""
    q, velocity, acceleration = (ca.SX.sym(name, 2) for name in ("q", "qd_dot", "qd_ddot"))
    return ca.Function(
        "tau_lin", [q, velocity, acceleration],
        [theta_linearization(parameters, q, velocity, acceleration)],
    )  # fmt: skip


def desired_torque_function(M0: np.ndarray, B: np.ndarray) -> ca.Function:
    """``(qd_d, qdd_d) -> tau_d`` (Eq. 7) as a CasADi function."""
    n = len(M0)
    velocity, acceleration = ca.SX.sym("qd_dot", n), ca.SX.sym("qd_ddot", n)
    return ca.Function(
        "tau_d", [velocity, acceleration], [desired_torque(M0, B, velocity, acceleration)]
    )
