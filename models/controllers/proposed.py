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

import numpy as np

from posfb.models.controllers.base import SampledController, joint_names
from posfb.models.controllers.feedforward import nominal_torques
from posfb.models.controllers.registry import ControllerSpec
from posfb.models.design import ControllerConfig, Design, cached_design, designed_feedback
from posfb.models.design.settings import Proposed


def proposed_internals(joints: int) -> tuple[str, ...]:
    """Columns of the ``internals`` output for ``joints`` joints."""
    torques = ("tau_lin", "tau_lc", "tau_nc")
    per_joint = tuple(name for prefix in torques for name in joint_names(prefix, joints))
    return (*per_joint, "alpha", *joint_names("phi", joints), "U1", "U2", "delta_bar")


class ProposedController(SampledController):
    """``u = tau_Lin + tau_LC + tau_NC``; refuses a failed LQR design, a non-SPR ``H`` or
    ``a <= ln 2 / T_s``."""

    #: Torques, ``phi`` and ``delta_bar`` are armature voltages (``tau_NC = -alpha phi``
    #: with a dimensionless ``alpha``); ``U1``, ``U2`` bound ``||q~'||``, ``||q~''||``.
    INTERNAL_UNITS = {
        "tau_lin": "V", "tau_lc": "V", "tau_nc": "V", "alpha": "dimensionless", "phi": "V",
        "U1": "rad_per_s", "U2": "rad_per_s2", "delta_bar": "V",
    }  # fmt: skip

    def __init__(self, design: Design) -> None:
        design.require_nonlinear_torque()
        self._filter = design.proposed_filter
        self._states = len(self._filter.A)
        n = design.config.joints
        # memory: [filter state, running max |p|, running max |pbar|, y = |alpha~1|]
        super().__init__(
            design.config.sample_time, n, proposed_internals(n), self._states + 2 * n + 1
        )
        self.set_name("proposed_controller")
        self._torques = nominal_torques(design.config.nominal)
        self._bounds = design.bounds
        self._c = design.bound_filter.c
        nonlinear = design.config.nonlinear
        self._alpha_star = nonlinear.alpha_star
        self._y0 = (nonlinear.alpha_star - nonlinear.alpha0) ** 2
        self._decay = math.exp(-design.config.sample_time / nonlinear.K_alpha)
        self._rate = 2.0 * design.coupling_norm * (1.0 - self._decay)

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        memory = np.zeros(self._states + 2 * self.joints + 1)
        memory[: self._states] = self._filter.initial @ (q - desired[: self.joints])
        memory[-1] = self._y0
        return memory

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        q_d, qd_dot, qd_ddot = self.split_desired(desired)
        error, j = q - q_d, self.joints
        f, n = self._filter, self._states
        state = memory[:n]
        outputs = f.C @ state + f.D @ error
        memory[:n] = f.A @ state + f.B @ error
        eta, phi = outputs[0:j], outputs[j : 2 * j]
        p_max, pbar_max = memory[n : n + j], memory[n + j : n + 2 * j]
        np.maximum(p_max, np.abs(outputs[2 * j : 3 * j]), out=p_max)
        np.maximum(pbar_max, np.abs(outputs[3 * j :]), out=pbar_max)
        U1 = math.sqrt(p_max @ p_max) / self._c
        U2 = math.sqrt(pbar_max @ pbar_max) / self._c**2
        delta_bar = self._bounds.delta_bar(
            self._torques.M1_norm(q), U1, U2,
            math.sqrt(qd_dot @ qd_dot), math.sqrt(qd_ddot @ qd_ddot),
        )  # fmt: skip
        U_x = math.sqrt(error @ error + U1 * U1 + eta @ eta)
        y = memory[-1]
        alpha = self._alpha_star - math.sqrt(y)
        forcing = self._rate * U_x * (delta_bar + math.sqrt(phi @ phi) * math.sqrt(y))
        memory[-1] = max(0.0, self._decay * y - forcing)
        tau_lin = self._torques.linearization(q, qd_dot, qd_ddot)
        tau_lc = self._torques.desired(qd_dot, qd_ddot) + eta
        tau_nc = -alpha * phi
        internals = np.concatenate([tau_lin, tau_lc, tau_nc, [alpha], phi, [U1, U2, delta_bar]])
        return tau_lin + tau_lc + tau_nc, internals


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


#: The paper's controller (Eq. 3): Lin + LC + NC.
SPEC = ControllerSpec(
    kind="proposed",
    label=PAPER_LABEL,
    design_label=proposed_label,
    factory=lambda build: ProposedController(cached_design(build.design)),
    style={"linestyle": ":", "color": "tab:green", "linewidth": 1.6},
    checks=("riccati", "lc_filter", "spr", "bound_filter", "continuous_with_nc", "sampled_data"),
    require=lambda design: cached_design(design).require_nonlinear_torque(),
    internals=proposed_internals,
    settings=Proposed,
    linear=lambda build: designed_feedback(cached_design(build.design), "proposed"),
)
