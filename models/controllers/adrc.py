"""Linear active disturbance rejection control (ADRC, Gao 2003): per joint, an extended
state observer (ESO) estimates position, velocity and the "total disturbance" from the
held position alone, and the control cancels the estimate. Written only against the
public plug-in contract (``posfb.Controller``).

Each joint is modelled as ``qddot = b0 u + f`` with ``b0 = 1 / m_j`` (``m_j = M0_jj``,
``NominalDynamics.mean_mass_matrix``, V s^2/rad) and ``f`` everything else (coupling,
gravity, friction, model error). The ESO, state ``z = [q^, qdot^, f^]``::

    z' = A z + B b0 u + L (q - z_1),   A = [[0,1,0],[0,0,1],[0,0,0]],  B = [0,1,0]^T,
    L = [3 w_o, 3 w_o^2, w_o^3]        (all observer poles at -w_o, continuous time)

is implemented as the current discrete ESO of Miklosovic, Radke and Gao (2006): the
chain is predicted exactly over a period with the held voltage, and corrected with the
measurement ``q_k`` of the same sample, the estimation error's poles at ``exp(-w_o T_s)``
(``eso_matrices``); a continuous ESO discretised with a held measurement lags a sample
and loses stability for ``w_o T_s`` near 1.5. The control at ``t_k`` uses the corrected
``z_k``::

    u_k = (K_p (q_d - z_1) + K_d (qdot_d - z_2) + qddot_d - z_3) / b0,

clipped to the voltage limit before it enters the observer (the voltage the motor gets).
``f^ / b0`` is exported as ``disturbance_j_V``: for a constant disturbance torque ``d``
on a joint of the nominal arm it converges to ``d`` in volts (``tests``).

**Tuning rule** (Gao 2003, "Scaling and bandwidth-parameterization based controller
tuning", ACC): the controller bandwidth ``w_c`` sets ``K_p = w_c^2``, ``K_d = 2 w_c``
(both closed-loop poles at ``-w_c``) and the observer runs ``observer_ratio`` (default 5,
Gao's 3-10) times faster, ``w_o = observer_ratio w_c``. With ``bandwidth`` 0, ``w_c = 2 pi /
(20 T_s)``, the sampling rule of ``models.controllers.tuning``; ``w_o`` must stay below the
Nyquist frequency.

Its linear feedback (derived from the law, ``models.controllers.linearise``): the same
ESO and law with the clip left out (the linear feedback is built without a voltage
limit: a linear loop does not saturate), a filter from the reading to the voltage.
"""

# No "from __future__ import annotations": Drake's YAML reads the settings field types.

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import expm

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
class Adrc:
    """Scenario settings of linear ADRC (``controller: !Adrc {...}``): the controller
    ``bandwidth`` ``w_c`` (rad/s; 0: ``2 pi / (20 T_s)``) and the observer's bandwidth as
    a multiple of it (``observer_ratio``)."""

    bandwidth: float = 0.0
    observer_ratio: float = 5.0


def eso_matrices(
    observer_bandwidth: float, sample_time: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Phi, Gamma, L)`` of one joint's current discrete ESO: the chain ``q, qdot, f``
    held over ``T_s`` (``Phi = exp(A T_s)``, ``Gamma = int exp(A s) ds B``, exact for a
    held ``b0 u``) and the correction gain ``L`` that puts the estimation error's three
    poles at ``beta = exp(-w_o T_s)`` (Ackermann's formula for the current estimator,
    Miklosovic, Radke and Gao 2006, "Discrete implementation and generalization of the
    extended state observer", ACC)::

        z_k = zbar_k + L (q_k - zbar_1,k),   zbar_{k+1} = Phi z_k + Gamma b0 u_k
    """
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    block = np.zeros((4, 4))
    block[:3, :3], block[1, 3] = A, 1.0
    exponential = expm(block * sample_time)
    Phi, Gamma = exponential[:3, :3], exponential[:3, 3]
    beta = math.exp(-observer_bandwidth * sample_time)
    H = np.array([1.0, 0.0, 0.0]) @ Phi  # the error is corrected after one prediction
    observability = np.vstack([H, H @ Phi, H @ Phi @ Phi])
    identity = np.eye(3)
    characteristic = (Phi - beta * identity) @ (Phi - beta * identity) @ (Phi - beta * identity)
    # The error evolves as e_k = (I - L C) Phi e_{k-1} = (Phi - L H) e_{k-1}.
    return Phi, Gamma, characteristic @ np.linalg.solve(observability, [0.0, 0.0, 1.0])


class AdrcController(Controller):
    """Linear ADRC per joint (module docstring); memory ``[z_1 (n), z_2 (n), z_3 (n)]``."""

    def __init__(
        self, setup: ControllerSetup, bandwidth: float = 0.0, observer_ratio: float = 5.0
    ) -> None:
        super().__init__(setup)
        n, T_s = setup.joints, setup.sample_time
        w_c = loop_bandwidth("Adrc", bandwidth, T_s)
        w_o = positive_setting("Adrc", "observer_ratio", observer_ratio) * w_c
        require_below_nyquist("Adrc", "observer_ratio x bandwidth", w_o, T_s)
        self.b0 = 1.0 / np.diag(setup.nominal.mean_mass_matrix())
        self.Kp, self.Kd = w_c**2, 2.0 * w_c
        self.Phi, self.Gamma, self.L = eso_matrices(w_o, T_s)
        self.limit = np.asarray(setup.voltage_limit, dtype=float)
        self.internals = tuple(f"disturbance_{j + 1}_V" for j in range(n)) + tuple(
            f"v_est_{j + 1}_rad_per_s" for j in range(n)
        )
        self.law = self._law()

    def _law(self) -> "Law":  # noqa: UP037 (no future annotations here: Drake's YAML)
        """The step as a ``models.laws`` law, the one description the simulation evaluates
        and ``posfb codegen`` prints; memory ``[zbar_1, zbar_2, zbar_3]`` (n each: the
        predicted position, velocity and total disturbance): ``z_r = zbar_r + L_r (q -
        zbar_1)``, ``u = (K_p (q_d - z_1) + K_d (qdot_d - z_2) + qddot_d - z_3) / b0``,
        ``zbar'_r = sum_c Phi_rc z_c + Gamma_r b0 clip(u)``."""
        import casadi as ca

        from posfb.models.laws.law import law

        n = self.setup.joints
        b0, limit = ca.DM(self.b0), ca.DM(self.limit)

        def step(memory: ca.SX, q: ca.SX, q_d: ca.SX, qdot_d: ca.SX,
                 qddot_d: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:  # fmt: skip
            rows = [memory[r * n : (r + 1) * n] for r in range(3)]
            z = [rows[r] + float(self.L[r]) * (q - rows[0]) for r in range(3)]
            u0 = self.Kp * (q_d - z[0]) + self.Kd * (qdot_d - z[1]) + qddot_d
            voltage = (u0 - z[2]) / b0
            applied = ca.fmin(ca.fmax(voltage, -limit), limit)
            predicted = [
                sum(float(self.Phi[r, c]) * z[c] for c in range(3)) + float(self.Gamma[r]) * (
                    b0 * applied) for r in range(3)
            ]  # fmt: skip
            return voltage, ca.vertcat(z[2] / b0, z[1]), ca.vertcat(*predicted)

        return law("adrc", n, 3 * n, lambda q, q_d: ca.vertcat(q, ca.DM.zeros(2 * n)), step)


#: Linear ADRC (Gao 2003): a registered plug-in baseline.
SPEC = ControllerSpec(
    kind="adrc",
    label="linear ADRC (ESO)",
    factory=plugin_factory(AdrcController),
    style={"linestyle": (0, (3, 1, 1, 1, 1, 1)), "color": "tab:purple"},
    settings=Adrc,
    law=lambda build: plugin_instance(AdrcController, build).law,
)
