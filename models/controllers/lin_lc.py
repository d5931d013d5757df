"""``tau_Lin + tau_LC``: the paper's ablation without the nonlinear torque (Sec. 4.2).

``tau_LC = tau_d + eta~`` (Eq. 13) with ``eta~`` from the position-only, ZOH-
discretised filter of ``models.design.realisation`` (state ``w = eta~ + K2 q~``),
initialised at rest (``eta~(0) = 0``) from the first measurement.
"""

from __future__ import annotations

import numpy as np

from posfb.models.controllers.base import SampledController, joint_names
from posfb.models.controllers.feedforward import nominal_torques
from posfb.models.controllers.registry import ControllerSpec
from posfb.models.design import Design, cached_design, designed_feedback
from posfb.models.design.settings import LinLc


def lin_lc_internals(joints: int) -> tuple[str, ...]:
    """Columns of the ``internals`` output for ``joints`` joints."""
    return joint_names("tau_lin", joints) + joint_names("tau_lc", joints)


class LinLcController(SampledController):
    """``u = tau_Lin + tau_LC`` (Eq. 3 without ``tau_NC``); refuses a failed LQR design."""

    #: The torques of the lumped model are armature voltages.
    INTERNAL_UNITS = {"tau_lin": "V", "tau_lc": "V"}

    def __init__(self, design: Design) -> None:
        design.require_linear_torque()
        self._filter = design.lin_lc_filter
        n = design.config.joints
        super().__init__(design.config.sample_time, n, lin_lc_internals(n), len(self._filter.A))
        self.set_name("lin_lc_controller")
        self._torques = nominal_torques(design.config.nominal)

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        return self._filter.initial @ (q - desired[: self.joints])

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        q_d, qd_dot, qd_ddot = self.split_desired(desired)
        error = q - q_d
        f = self._filter
        eta = f.C @ memory + f.D @ error
        memory[:] = f.A @ memory + f.B @ error
        tau_lin = self._torques.linearization(q, qd_dot, qd_ddot)
        tau_lc = self._torques.desired(qd_dot, qd_ddot) + eta
        return tau_lin + tau_lc, np.concatenate([tau_lin, tau_lc])


#: Lin + LC (Eq. 4 + 13): the paper's ablation without the nonlinear torque.
SPEC = ControllerSpec(
    kind="lin_lc",
    label="Lin + LC",
    factory=lambda build: LinLcController(cached_design(build.design)),
    style={"linestyle": "--", "color": "tab:orange"},
    checks=("riccati", "lc_filter", "sampled_data_lin_lc"),
    require=lambda design: cached_design(design).require_linear_torque(),
    internals=lin_lc_internals,
    settings=LinLc,
    linear=lambda build: designed_feedback(cached_design(build.design), "lin_lc"),
)
