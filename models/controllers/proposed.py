"""The paper's controller ``tau_Lin + tau_LC + tau_NC`` (Eq. 3, 4, 13, 19-25).

Per sample ``t_k`` (one filter, ``models.design.realisation``, ZOH-discretised by default):

* ``[eta~, phi, p, pbar] = C s_k + D q~_k``, then ``s_{k+1} = A s_k + B q~_k``;
* ``U1 = ||max_{m<=k} |p_m| || / c``, ``U2 = ||max_{m<=k} |pbar_m| || / c^2``
  (Eq. 24-25, per-joint running maxima), ``delta_bar`` (Eq. 18),
  ``U_x = sqrt(|q~|^2 + U1^2 + |eta~|^2)``;
* ``alpha_k = alpha* - sqrt(y_k)`` with ``y = |alpha~1|``, ``tau_NC = -alpha phi``.

Eq. 21 for ``alpha~1 < 0`` reads ``y' = -y / K_alpha - 2 U_x ||P2 (M0*)^-1||
(delta_bar + ||C_zeta zeta|| sqrt(y)) / K_alpha``: every term drives ``y`` down, so
``y`` reaches 0 in finite time, where ``sgn`` is undefined (reading note 4). Each
step integrates the linear part exactly with the forcing frozen at ``t_k`` and
clips at 0; once at 0 it stays there (the Filippov solution). Hence ``alpha`` is
non-decreasing, starts at ``alpha(0)``, never exceeds ``alpha*`` and cannot
chatter. ``alpha(0) = alpha0`` (default 0: ``alpha~1(0) = -alpha*^2``).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from posfb.models.controllers.base import joint_names
from posfb.models.controllers.registry import ControllerSpec
from posfb.models.controllers.tunable import Knob, Tuning, lqr_knobs, with_lqr_knobs
from posfb.models.design import ControllerConfig, Design, cached_design
from posfb.models.design.bounds import bound_filter_constants
from posfb.models.design.initial import filter_pole
from posfb.models.design.settings import Proposed

if TYPE_CHECKING:
    from posfb.models.laws.law import Law
    from posfb.models.laws.nominal import SymbolicModel


def proposed_internals(joints: int) -> tuple[str, ...]:
    """Columns of the ``internals`` output for ``joints`` joints."""
    torques = ("tau_lin", "tau_lc", "tau_nc")
    per_joint = tuple(name for prefix in torques for name in joint_names(prefix, joints))
    return (*per_joint, "alpha", *joint_names("phi", joints), "U1", "U2", "delta_bar")


def proposed_law(design: Design, model: SymbolicModel) -> Law:
    """The controller's update (module docstring) as a ``models.laws`` law on ``model``,
    the one description the simulation evaluates and ``posfb codegen`` prints; memory
    ``[s, max |p|, max |pbar|, y]`` (the filter's state, the running maxima of Eq. 24-25,
    ``y = |alpha~1|``). The linear feedback holds the maxima at 0 and ``y`` at 0, i.e.
    ``alpha = alpha*``, as the design's sampled-data check closes the loop."""
    import casadi as ca

    from posfb.models.laws.law import law
    from posfb.models.laws.nominal import desired_torque

    design.require_nonlinear_torque()
    f, n = design.proposed_filter, design.config.joints
    states = len(f.A)
    nonlinear = design.config.nonlinear
    c = design.bound_filter.c
    decay = math.exp(-design.config.sample_time / nonlinear.K_alpha)
    rate = 2.0 * design.coupling_norm * (1.0 - decay)

    def step(memory: ca.SX, q: ca.SX, q_d: ca.SX, qd_dot: ca.SX,
             qd_ddot: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:  # fmt: skip
        error, state = q - q_d, memory[:states]
        outputs = ca.mtimes(ca.DM(f.C), state) + ca.mtimes(ca.DM(f.D), error)
        eta, phi = outputs[0:n], outputs[n : 2 * n]
        p_max = ca.fmax(memory[states : states + n], ca.fabs(outputs[2 * n : 3 * n]))
        pbar_max = ca.fmax(memory[states + n : states + 2 * n], ca.fabs(outputs[3 * n :]))
        U1 = ca.sqrt(ca.sumsqr(p_max)) / c
        U2 = ca.sqrt(ca.sumsqr(pbar_max)) / c**2
        delta_bar = design.bounds.delta_bar(
            model.M1_norm(q, design.config.bounds.M1_norm), U1, U2, ca.sqrt(ca.sumsqr(qd_dot)),
            ca.sqrt(ca.sumsqr(qd_ddot)),
        )
        U_x = ca.sqrt(ca.sumsqr(error) + U1 * U1 + ca.sumsqr(eta))
        y = memory[-1]
        alpha = nonlinear.alpha_star - ca.sqrt(y)
        forcing = rate * U_x * (delta_bar + ca.sqrt(ca.sumsqr(phi)) * ca.sqrt(y))
        tau_lin = model.linearization(q, qd_dot, qd_ddot)
        tau_lc = desired_torque(model.M0, model.B, qd_dot, qd_ddot) + eta
        tau_nc = -alpha * phi
        return (
            tau_lin + tau_lc + tau_nc,
            ca.vertcat(tau_lin, tau_lc, tau_nc, alpha, phi, U1, U2, delta_bar),
            ca.vertcat(ca.mtimes(ca.DM(f.A), state) + ca.mtimes(ca.DM(f.B), error), p_max,
                       pbar_max, ca.fmax(0.0, decay * y - forcing)),
        )  # fmt: skip

    def start(q: ca.SX, q_d: ca.SX) -> ca.SX:
        return ca.vertcat(ca.mtimes(ca.DM(f.initial), q - q_d), ca.DM.zeros(2 * n),
                          (nonlinear.alpha_star - nonlinear.alpha0) ** 2)  # fmt: skip

    memory = states + 2 * n + 1
    return law("proposed", n, memory, start, step, dict.fromkeys(range(states, memory), 0.0))


def _knobs(entry: Proposed) -> tuple[Knob, ...]:
    """``alpha_star`` (the steady-state gain of ``tau_NC``, Eq. 19-21) in ``0.05 .. max(10,
    2 alpha*)``, then the Sec. 3.2 weights (``tunable.lqr_knobs``). ``K_alpha``, ``H`` and
    ``Q2`` do not enter the linear loop at ``alpha = alpha*`` and are kept."""
    top = max(10.0, 2.0 * entry.alpha_star)
    return (Knob("alpha_star", 0.05, top, entry.alpha_star), *lqr_knobs())


def _tuned(entry: Proposed, values: np.ndarray, sample_time: float) -> Proposed:
    """``entry`` with ``alpha_star`` and the weights of ``values`` (``_knobs`` order);
    ``filter_a`` (Sec. 3.4) kept when above ``ln 2 / T_s``, else replaced by ``posfb
    scenario init``'s rule (``models.design.initial.filter_pole``), so that a tuned entry
    never holds an invalid pair."""
    values = list(values)
    alpha_star = float(values.pop(0))
    valid = bound_filter_constants(entry.filter_a, sample_time).valid
    filter_a = float(entry.filter_a) if valid else filter_pole(sample_time)
    return replace(with_lqr_knobs(entry, values), alpha_star=alpha_star, filter_a=filter_a)


#: The label of the paper's controller with the paper's Sec. 4.2 settings.
PAPER_LABEL = "Lin + LC + NC (paper)"

#: Its label with any other settings (a tuned design, a scenario's own values).
OWN_SETTINGS_LABEL = "Lin + LC + NC (own settings)"


def has_paper_settings(design: ControllerConfig) -> bool:
    """Whether ``design``'s controller settings are the paper's Sec. 4.2 ones (the
    defaults of ``ControllerConfig``): the LQR weights and ``lambdas``, the nonlinear
    torque, the Assumption-1 bounds and the discretisation. The arm (nominal model) and
    ``T_s`` are the scenario's, not the controller's, and are not compared."""
    paper = ControllerConfig()
    return (design.lqr, design.nonlinear, design.bounds, design.discretisation) == (
        paper.lqr, paper.nonlinear, paper.bounds, paper.discretisation
    )  # fmt: skip


def proposed_label(design: ControllerConfig) -> str:
    """``PAPER_LABEL`` for the paper's settings (``has_paper_settings``), else
    ``OWN_SETTINGS_LABEL``."""
    return PAPER_LABEL if has_paper_settings(design) else OWN_SETTINGS_LABEL


#: The paper's controller (Eq. 3): Lin + LC + NC; refuses a failed LQR design, a non-SPR
#: ``H`` or ``a <= ln 2 / T_s``.
SPEC = ControllerSpec(
    kind="proposed",
    label=PAPER_LABEL,
    design_label=proposed_label,
    law=lambda build: proposed_law(cached_design(build.design), build.symbolic_model()),
    style={"linestyle": ":", "color": "tab:green", "linewidth": 1.6},
    checks=("riccati", "lc_filter", "spr", "bound_filter", "continuous_with_nc", "sampled_data"),
    require=lambda design: cached_design(design).require_nonlinear_torque(),
    internals=proposed_internals,
    # Torques, phi and delta_bar are armature voltages (tau_NC = -alpha phi with a
    # dimensionless alpha); U1, U2 bound ||q~'||, ||q~''||.
    internal_units={
        "tau_lin": "V", "tau_lc": "V", "tau_nc": "V", "alpha": "dimensionless", "phi": "V",
        "U1": "rad_per_s", "U2": "rad_per_s2", "delta_bar": "V",
    },  # fmt: skip
    settings=Proposed,
    design_loop="sampled_data",
    tuning=Tuning(
        knobs=_knobs, apply=_tuned,
        shown=("alpha_star", "K_alpha", "filter_a", "Q1", "R", "lambdas"),
    ),  # fmt: skip
)
