"""Computed torque + PID, the paper's baseline (Eq. 26, reading note 2)::

    u = M*(q) [qdd_d - K_v (qdot - qd_d) - K_p q~ - K_I int q~] + C*(q, qdot) qdot
        + G*(q) + B* qdot + F*(qdot)

with ``qdot = (q_k - q_{k-1}) / T_s`` the backward difference of the measured
position everywhere (``F*`` uses its sign: no Coulomb term while the encoder
count does not change). At the first sample ``q_{-1} = q_0`` (zero velocity
estimate) and the integral is 0; the integral is the left-rectangle sum
``I_k = T_s (q~_0 + ... + q~_{k-1})``.
"""

from __future__ import annotations

import numpy as np

from posfb.models.controllers.base import SampledController
from posfb.models.design.config import JOINTS, PidGains
from posfb.models.lumped import LumpedModel, LumpedParameters

#: Columns of the ``internals`` output.
PID_INTERNALS = ("qdot_est_1", "qdot_est_2", "error_integral_1", "error_integral_2")

_N = JOINTS


class PidController(SampledController):
    """``u = tau_PID`` of Eq. 26 from measured positions only."""

    def __init__(self, nominal: LumpedParameters, gains: PidGains, sample_time: float) -> None:
        # memory: [q_{k-1}, I_k]
        super().__init__(sample_time, PID_INTERNALS, 2 * _N)
        self.set_name("pid_controller")
        self._model = LumpedModel(nominal)
        self._Kp, self._Kv, self._KI = (
            np.asarray(g, dtype=float) for g in (gains.Kp, gains.Kv, gains.KI)
        )

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        return np.concatenate([q, np.zeros(_N)])

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        error, qd_dot, qd_ddot = q - desired[0:2], desired[2:4], desired[4:6]
        qdot = (q - memory[:_N]) / self.sample_time
        integral = memory[_N:].copy()
        command = qd_ddot - self._Kv * (qdot - qd_dot) - self._Kp * error - self._KI * integral
        voltage = self._model.inverse_dynamics(q, qdot, command, friction=True)
        memory[:_N] = q
        memory[_N:] = integral + self.sample_time * error
        return voltage, np.concatenate([qdot, integral])
