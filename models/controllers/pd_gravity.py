"""PD with a dirty-derivative velocity estimate plus gravity compensation: the classic
industrial law, written only against the public plug-in contract (``posfb.Controller``).

Per joint ``j``, at each sample ``t_k`` from the held position ``q_k``::

    v_k = (tau_f v_{k-1} + q_k - q_{k-1}) / (tau_f + T_s)      (dirty derivative)
    u_k = K_p (q_d - q_k) + K_d (qdot_d - v_k) + G(q_k)        (V)

``v`` is the backward-Euler discretisation of ``tau_f v' + v = qdot``, i.e. the
derivative ``s / (tau_f s + 1)`` of the measured position; ``G`` is the nominal model's
gravity. Kelly (1993, "A simple set-point robot controller by using only position
measurements", IFAC World Congress) proved global asymptotic stability of PD + gravity
with such a filtered velocity for set points; here it tracks with the desired velocity
in the derivative term and no model feedforward.

**Tuning rule** (stated, not fitted to posfb's other controllers): each joint is a
critically damped second-order loop of bandwidth ``omega`` on its nominal inertia
``m_j = M0_jj`` (``NominalDynamics.mean_mass_matrix``)::

    K_p,j = m_j omega^2,   K_d,j = 2 zeta m_j omega,   tau_f = 1 / (filter_ratio omega)

with ``zeta = damping_ratio`` (default 1), ``filter_ratio`` 5 (the derivative filter a
factor 5 above the loop) and, when ``bandwidth`` is 0, ``omega = 2 pi / (20 T_s)`` (5 Hz
at 100 Hz; ``models.controllers.tuning``). The derivative filter's pole must stay below
the Nyquist frequency ``pi / T_s``.

Its linear feedback (derived from the law, ``models.controllers.linearise``): on the
nominal linear part (``G`` belongs to ``h`` of Eq. 2) ``u_k = -K_p q~_k - K_d v_k`` with
``v`` the dirty derivative of ``q~``.
"""

# No "from __future__ import annotations": Drake's YAML reads the settings field types.

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from posfb.models.controllers.plugin import (
    Controller,
    ControllerSetup,
    plugin_factory,
    plugin_instance,
)
from posfb.models.controllers.registry import ControllerSpec
from posfb.models.controllers.tuning import (
    loop_bandwidth,
    positive_setting,
    require_below_nyquist,
)

if TYPE_CHECKING:
    from posfb.models.laws.law import Law


@dataclass
class PdGravity:
    """Scenario settings of PD + gravity (``controller: !PdGravity {...}``): the loop
    ``bandwidth`` (rad/s; 0: ``2 pi / (20 T_s)``), its ``damping_ratio`` and the
    dirty-derivative pole as a multiple of the bandwidth (``filter_ratio``)."""

    bandwidth: float = 0.0
    damping_ratio: float = 1.0
    filter_ratio: float = 5.0


class PdGravityController(Controller):
    """``u = K_p q~ + K_d (qdot_d - v) + G(q)`` with a dirty-derivative ``v`` (module
    docstring); memory ``[q_{k-1}, v_{k-1}]``."""

    def __init__(
        self,
        setup: ControllerSetup,
        bandwidth: float = 0.0,
        damping_ratio: float = 1.0,
        filter_ratio: float = 5.0,
    ) -> None:
        super().__init__(setup)
        n, T_s = setup.joints, setup.sample_time
        omega = loop_bandwidth("PdGravity", bandwidth, T_s)
        zeta = positive_setting("PdGravity", "damping_ratio", damping_ratio)
        ratio = positive_setting("PdGravity", "filter_ratio", filter_ratio)
        require_below_nyquist("PdGravity", "filter_ratio x bandwidth", ratio * omega, T_s)
        inertia = np.diag(setup.nominal.mean_mass_matrix())
        self.Kp = inertia * omega**2
        self.Kd = 2.0 * zeta * inertia * omega
        self.tau_f = 1.0 / (ratio * omega)
        self.internals = tuple(f"v_est_{j + 1}_rad_per_s" for j in range(n)) + tuple(
            f"gravity_{j + 1}_V" for j in range(n)
        )
        self.law = self._law()

    def _law(self) -> "Law":  # noqa: UP037 (no future annotations here: Drake's YAML)
        """The step (class docstring) as a ``models.laws`` law, the one description the
        simulation evaluates and ``posfb codegen`` prints: ``v = (tau_f v_(k-1) + q -
        q_(k-1)) / (tau_f + T_s)``, ``u = K_p q~ + K_d (qdot_d - v) + G(q)``."""
        import casadi as ca

        from posfb.models.laws.law import law

        n, T_s = self.setup.joints, self.setup.sample_time
        model = self.setup.nominal.symbolic()
        Kp, Kd = ca.DM(self.Kp), ca.DM(self.Kd)

        def step(memory: ca.SX, q: ca.SX, q_d: ca.SX, qdot_d: ca.SX,
                 qddot_d: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:  # fmt: skip
            velocity = (self.tau_f * memory[n:] + q - memory[:n]) / (self.tau_f + T_s)
            gravity = model.gravity(q)
            voltage = Kp * (q_d - q) + Kd * (qdot_d - velocity) + gravity
            return voltage, ca.vertcat(velocity, gravity), ca.vertcat(q, velocity)

        return law("pd_gravity", n, 2 * n, lambda q, q_d: ca.vertcat(q, ca.DM.zeros(n)), step)


#: PD + gravity with a dirty derivative (Kelly 1993): a registered plug-in baseline.
SPEC = ControllerSpec(
    kind="pd_gravity",
    label="PD + gravity (dirty derivative)",
    factory=plugin_factory(PdGravityController),
    style={"linestyle": (0, (5, 1, 1, 1)), "color": "tab:red"},
    settings=PdGravity,
    law=lambda build: plugin_instance(PdGravityController, build).law,
)
