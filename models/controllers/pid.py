"""Computed torque + PID, the paper's baseline (Eq. 26, reading note 2)::

    u = M*(q) [qdd_d - K_v (qdot - qd_d) - K_p q~ - K_I int q~] + C*(q, qdot) qdot
        + G*(q) + B* qdot + F*(qdot)

with ``qdot = (q_k - q_{k-1}) / T_s`` the backward difference of the measured
position everywhere (``F*`` uses its sign: no Coulomb term while the encoder
count does not change). At the first sample ``q_{-1} = q_0`` (zero velocity
estimate) and the integral is 0; the integral is the left-rectangle sum
``I_k = T_s (q~_0 + ... + q~_{k-1})``.

Its linear feedback (derived from the law, ``models.controllers.linearise``): on the
nominal linear part (``M* = M0*``; ``C* q'``, ``G*`` and ``F*`` belong to ``h`` of Eq. 2
and the reference terms cancel) ``u_k = M0* (-K_p q~_k - K_v d_k - K_I I_k) + B* d_k``
with ``d_k = (q~_k - q~_(k-1)) / T_s``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from posfb.models.controllers.base import joint_names
from posfb.models.controllers.registry import ControllerSpec
from posfb.models.design.config import PidGains
from posfb.models.design.settings import Pid

if TYPE_CHECKING:
    from posfb.models.laws.law import Law
    from posfb.models.laws.nominal import SymbolicModel


def pid_internals(joints: int) -> tuple[str, ...]:
    """Columns of the ``internals`` output for ``joints`` joints."""
    return joint_names("qdot_est", joints) + joint_names("error_integral", joints)


def pid_law(model: SymbolicModel, gains: PidGains, sample_time: float) -> Law:
    """Eq. 26 as a ``models.laws`` law on ``model`` (the one description the simulation
    evaluates and ``posfb codegen`` prints), memory ``[q_(k-1), I_k]``: ``qdot = (q -
    q_(k-1)) / T_s``, ``u = M*(q) (qdd_d - K_v (qdot - qd_d) - K_p q~ - K_I I) + C*(q,
    qdot) qdot + G*(q) + B* qdot + F*(qdot)`` (the nominal model's inverse dynamics,
    ``models.laws.nominal``), ``I' = I + T_s q~``."""
    import casadi as ca

    from posfb.models.laws.law import law

    n, T = model.joints, sample_time
    Kp, Kv, KI = (ca.DM(np.asarray(g, dtype=float)) for g in (gains.Kp, gains.Kv, gains.KI))

    def step(memory: ca.SX, q: ca.SX, q_d: ca.SX, qd_dot: ca.SX,
             qd_ddot: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:  # fmt: skip
        error = q - q_d
        qdot = (q - memory[:n]) / T
        integral = memory[n:]
        command = qd_ddot - Kv * (qdot - qd_dot) - Kp * error - KI * integral
        voltage = model.inverse_dynamics(q, qdot, command)
        return voltage, ca.vertcat(qdot, integral), ca.vertcat(q, integral + T * error)

    return law("pid", n, 2 * n, lambda q, q_d: ca.vertcat(q, ca.DM.zeros(n)), step)


#: Computed torque + PID (Eq. 26): the paper's baseline; no Sec. 3 design.
SPEC = ControllerSpec(
    kind="pid",
    label="computed torque + PID",
    law=lambda build: pid_law(build.symbolic_model(), build.design.pid, build.design.sample_time),
    style={"linestyle": "-", "color": "tab:blue"},
    internals=pid_internals,
    # qdot_est: the backward-difference velocity; error_integral = T_s sum q~.
    internal_units={"qdot_est": "rad_per_s", "error_integral": "rad_s"},
    settings=Pid,
)
