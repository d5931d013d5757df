"""Computed torque + PID, the paper's baseline (Eq. 26, reading note 2)::

    u = M*(q) [qdd_d - K_v (qdot - qd_d) - K_p q~ - K_I int q~] + C*(q, qdot) qdot
        + G*(q) + B* qdot + F*(qdot)

with ``qdot = (q_k - q_{k-1}) / T_s`` the backward difference of the measured
position everywhere (``F*`` uses its sign: no Coulomb term while the encoder
count does not change). At the first sample ``q_{-1} = q_0`` (zero velocity
estimate) and the integral is 0; the integral is the left-rectangle sum
``I_k = T_s (q~_0 + ... + q~_{k-1})``.

Its linear feedback (``pid_feedback``, for the margins): on the nominal linear part
(``M* = M0*``; ``C* q'``, ``G*`` and ``F*`` belong to ``h`` of Eq. 2 and the reference
terms cancel) ``u_k = M0* (-K_p q~_k - K_v d_k - K_I I_k) + B* d_k`` with ``d_k = (q~_k -
q~_(k-1)) / T_s``.
"""

from __future__ import annotations

import numpy as np

from posfb.models.controllers.base import SampledController, joint_names
from posfb.models.controllers.registry import ControllerBuild, ControllerSpec
from posfb.models.design.config import PidGains
from posfb.models.design.realisation import DiscreteFilter
from posfb.models.design.settings import Pid
from posfb.models.nominal import NominalModel, joint_count, nominal_model


def pid_internals(joints: int) -> tuple[str, ...]:
    """Columns of the ``internals`` output for ``joints`` joints."""
    return joint_names("qdot_est", joints) + joint_names("error_integral", joints)


class PidController(SampledController):
    """``u = tau_PID`` of Eq. 26 from measured positions only."""

    #: ``qdot_est``: the backward-difference velocity; ``error_integral = T_s sum q~``.
    INTERNAL_UNITS = {"qdot_est": "rad_per_s", "error_integral": "rad_s"}

    def __init__(self, nominal: NominalModel, gains: PidGains, sample_time: float) -> None:
        n = joint_count(nominal)
        # memory: [q_{k-1}, I_k]
        super().__init__(sample_time, n, pid_internals(n), 2 * n)
        self.set_name("pid_controller")
        self._model = nominal_model(nominal)
        self._Kp, self._Kv, self._KI = (
            np.asarray(g, dtype=float) for g in (gains.Kp, gains.Kv, gains.KI)
        )

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        return np.concatenate([q, np.zeros(self.joints)])

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        q_d, qd_dot, qd_ddot = self.split_desired(desired)
        error, n = q - q_d, self.joints
        qdot = (q - memory[:n]) / self.sample_time
        integral = memory[n:].copy()
        command = qd_ddot - self._Kv * (qdot - qd_dot) - self._Kp * error - self._KI * integral
        voltage = self._model.inverse_dynamics(q, qdot, command, friction=True)
        memory[:n] = q
        memory[n:] = integral + self.sample_time * error
        return voltage, np.concatenate([qdot, integral])


def pid_feedback(build: ControllerBuild) -> DiscreteFilter:
    """Eq. 26 linearised on the nominal linear part (module docstring), state ``[q~_(k-1),
    I_k]``, started at ``[q~_0, 0]`` as the controller is."""
    design = build.design
    model = nominal_model(design.nominal)
    M0, B, T = model.M0(), model.B(), design.sample_time
    Kp, Kv, KI = (np.diag(np.asarray(g, dtype=float)) for g in (design.pid.Kp, design.pid.Kv,
                                                                 design.pid.KI))  # fmt: skip
    n, zero, eye = len(M0), np.zeros_like(M0), np.eye(len(M0))
    rate = (M0 @ Kv - B) / T  # the gain of q~_(k-1) through d_k
    return DiscreteFilter(
        A=np.block([[zero, zero], [zero, eye]]),
        B=np.vstack([eye, T * eye]),
        C=np.hstack([rate, -M0 @ KI]),
        D=-M0 @ Kp - rate,
        initial=np.vstack([eye, np.zeros((n, n))]),
    )


def _build(build: ControllerBuild) -> PidController:
    design = build.design
    return PidController(design.nominal, design.pid, design.sample_time)


#: Computed torque + PID (Eq. 26): the paper's baseline; no Sec. 3 design.
SPEC = ControllerSpec(
    kind="pid",
    label="computed torque + PID",
    factory=_build,
    style={"linestyle": "-", "color": "tab:blue"},
    internals=pid_internals,
    settings=Pid,
    linear=pid_feedback,
)
