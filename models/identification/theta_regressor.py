"""The two-link model of Sec. 4.1 (Eq. 4) written linearly in theta_1..theta_11.

``models.lumped`` gives the voltage ``u = M*(q) q'' + C*(q, q') q' + G*(q) + B* q'
+ F*(q')``; every term is a theta times a function of the motion, so per sample::

    u = Y(q, q', q'') theta

Row 1 holds only theta_1..theta_6 and row 2 only theta_7..theta_11 (each row of
the lumped model is the joint's physical row divided by its own motor constant,
reading note 9), so each row is a regression of its own::

    u1 = q1'' th1 + (q1'' + q2'') th2
         + ((2 q1'' + q2'') c2 - (2 q1' + q2') q2' s2 + (g/l1) c12) th3
         + c1 th4 + q1' th5 + sgn(q1') th6
    u2 = (q1'' + q2'') th7 + (q1'' c2 + q1'^2 s2 + (g/l1) c12) th8 + q2'' th9
         + q2' th10 + sgn(q2') th11

with ``c2 = cos q2``, ``s2 = sin q2``, ``c12 = cos(q1 + q2)``, ``c1 = cos q1``.
``theta_regressor`` is checked against ``LumpedModel.inverse_dynamics`` (tests).
"""

from __future__ import annotations

import numpy as np

#: theta_j's index (0-based) in the stacked vector, per row of Eq. 4.
ROW_PARAMETERS = ((0, 1, 2, 3, 4, 5), (6, 7, 8, 9, 10))

#: The Coulomb terms (0-based theta indices) and the joint whose velocity they follow.
COULOMB_PARAMETERS = {5: 0, 10: 1}

THETA_NAMES = tuple(f"theta{i}" for i in range(1, 12))


def theta_regressor(
    q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray, l1: float, g: float
) -> np.ndarray:
    """``Y`` with ``u[k] = Y[k] @ theta`` for each sample ``k``: shape ``(N, 2, 11)``,
    from ``(N, 2)`` positions, velocities and accelerations (rad, rad/s, rad/s^2)."""
    q, qdot, qddot = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qdot, qddot))
    a1, a2 = qddot[:, 0], qddot[:, 1]
    v1, v2 = qdot[:, 0], qdot[:, 1]
    c1, c2, s2 = np.cos(q[:, 0]), np.cos(q[:, 1]), np.sin(q[:, 1])
    c12 = np.cos(q[:, 0] + q[:, 1])
    ratio = g / l1
    Y = np.zeros((q.shape[0], 2, 11))
    Y[:, 0, 0] = a1
    Y[:, 0, 1] = a1 + a2
    Y[:, 0, 2] = (2.0 * a1 + a2) * c2 - (2.0 * v1 + v2) * v2 * s2 + ratio * c12
    Y[:, 0, 3] = c1
    Y[:, 0, 4] = v1
    Y[:, 0, 5] = np.sign(v1)
    Y[:, 1, 6] = a1 + a2
    Y[:, 1, 7] = a1 * c2 + v1**2 * s2 + ratio * c12
    Y[:, 1, 8] = a2
    Y[:, 1, 9] = v2
    Y[:, 1, 10] = np.sign(v2)
    return Y
