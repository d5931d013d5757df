"""``tau_Lin + tau_LC``: the paper's ablation without the nonlinear torque (Sec. 4.2).

``tau_LC = tau_d + eta~`` (Eq. 13) with ``eta~`` from the position-only, ZOH-
discretised filter of ``models.design.realisation`` (state ``w = eta~ + K2 q~``),
initialised at rest (``eta~(0) = 0``) from the first measurement.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from posfb.models.controllers.base import joint_names
from posfb.models.controllers.registry import ControllerSpec
from posfb.models.controllers.tunable import Tuning, lqr_knobs, with_lqr_knobs
from posfb.models.design import Design, cached_design
from posfb.models.design.settings import LinLc

if TYPE_CHECKING:
    from posfb.models.laws.law import Law
    from posfb.models.laws.nominal import SymbolicModel


def lin_lc_internals(joints: int) -> tuple[str, ...]:
    """Columns of the ``internals`` output for ``joints`` joints."""
    return joint_names("tau_lin", joints) + joint_names("tau_lc", joints)


def lin_lc_law(design: Design, model: SymbolicModel) -> Law:
    """The controller's update as a ``models.laws`` law on ``model`` (the one description
    the simulation evaluates and ``posfb codegen`` prints): memory ``w`` of the filter,
    ``eta~ = C w + D q~``, ``w' = A w + B q~``, ``u = tau_Lin + tau_d + eta~`` (Eq. 4,
    7, 13) on the nominal model's ``models.laws.nominal`` form."""
    import casadi as ca

    from posfb.models.laws.law import law
    from posfb.models.laws.nominal import desired_torque

    design.require_linear_torque()
    f = design.lin_lc_filter
    n = design.config.joints

    def step(w: ca.SX, q: ca.SX, q_d: ca.SX, qd_dot: ca.SX,
             qd_ddot: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:  # fmt: skip
        error = q - q_d
        tau_lin = model.linearization(q, qd_dot, qd_ddot)
        eta = ca.mtimes(ca.DM(f.C), w) + ca.mtimes(ca.DM(f.D), error)
        tau_lc = desired_torque(model.M0, model.B, qd_dot, qd_ddot) + eta
        return (tau_lin + tau_lc, ca.vertcat(tau_lin, tau_lc),
                ca.mtimes(ca.DM(f.A), w) + ca.mtimes(ca.DM(f.B), error))  # fmt: skip

    return law("lin_lc", n, len(f.A), lambda q, q_d: ca.mtimes(ca.DM(f.initial), q - q_d), step)


#: Lin + LC (Eq. 4 + 13): the paper's ablation without the nonlinear torque; refuses a
#: failed LQR design.
SPEC = ControllerSpec(
    kind="lin_lc",
    label="Lin + LC",
    law=lambda build: lin_lc_law(cached_design(build.design), build.symbolic_model()),
    style={"linestyle": "--", "color": "tab:orange"},
    checks=("riccati", "lc_filter", "sampled_data_lin_lc"),
    require=lambda design: cached_design(design).require_linear_torque(),
    internals=lin_lc_internals,
    # The torques of the lumped model are armature voltages.
    internal_units={"tau_lin": "V", "tau_lc": "V"},
    settings=LinLc,
    design_loop="sampled_data_lin_lc",
    tuning=Tuning(
        knobs=lambda entry: lqr_knobs(),
        apply=lambda entry, values, sample_time: with_lqr_knobs(entry, values),
        shown=("Q1", "R", "lambdas"),
    ),
)
