"""``tau_Lin + tau_LC``: the paper's ablation without the nonlinear torque (Sec. 4.2).

``tau_LC = tau_d + eta~`` (Eq. 13) with ``eta~`` from the position-only, ZOH-
discretised filter of ``models.design.realisation`` (state ``w = eta~ + K2 q~``),
initialised at rest (``eta~(0) = 0``) from the first measurement.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from posfb.models.controllers.base import SampledController, joint_names
from posfb.models.controllers.registry import ControllerSpec
from posfb.models.design import Design, cached_design, designed_feedback
from posfb.models.design.settings import LinLc

if TYPE_CHECKING:
    from posfb.models.laws.law import Law


def lin_lc_internals(joints: int) -> tuple[str, ...]:
    """Columns of the ``internals`` output for ``joints`` joints."""
    return joint_names("tau_lin", joints) + joint_names("tau_lc", joints)


def lin_lc_law(design: Design) -> Law:
    """The controller's update as a ``models.laws`` law (the one description the
    simulation evaluates and ``posfb codegen`` prints): memory ``w`` of the filter,
    ``eta~ = C w + D q~``, ``w' = A w + B q~``, ``u = tau_Lin + tau_d + eta~`` (Eq. 4,
    7, 13) on the nominal model's ``models.laws.nominal`` form."""
    import casadi as ca

    from posfb.models.laws.law import law
    from posfb.models.laws.nominal import desired_torque, symbolic_model

    design.require_linear_torque()
    f = design.lin_lc_filter
    n = design.config.joints
    model = symbolic_model(design.config.nominal)

    def step(w: ca.SX, q: ca.SX, q_d: ca.SX, qd_dot: ca.SX,
             qd_ddot: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:  # fmt: skip
        error = q - q_d
        tau_lin = model.linearization(q, qd_dot, qd_ddot)
        eta = ca.mtimes(ca.DM(f.C), w) + ca.mtimes(ca.DM(f.D), error)
        tau_lc = desired_torque(model.M0, model.B, qd_dot, qd_ddot) + eta
        return (tau_lin + tau_lc, ca.vertcat(tau_lin, tau_lc),
                ca.mtimes(ca.DM(f.A), w) + ca.mtimes(ca.DM(f.B), error))  # fmt: skip

    return law("lin_lc", n, len(f.A), lambda q, q_d: ca.mtimes(ca.DM(f.initial), q - q_d), step)


class LinLcController(SampledController):
    """``u = tau_Lin + tau_LC`` (Eq. 3 without ``tau_NC``); refuses a failed LQR design.
    Its step evaluates ``lin_lc_law``."""

    #: The torques of the lumped model are armature voltages.
    INTERNAL_UNITS = {"tau_lin": "V", "tau_lc": "V"}

    def __init__(self, design: Design) -> None:
        from posfb.models.laws.law import Stepper

        self.law = lin_lc_law(design)
        n = design.config.joints
        super().__init__(design.config.sample_time, n, lin_lc_internals(n), self.law.memory)
        self.set_name("lin_lc_controller")
        self._stepper = Stepper(self.law)

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        return self._stepper.start(q, desired)

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        return self._stepper.step(q, desired, memory)


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
    law=lambda build: lin_lc_law(cached_design(build.design)),
)
