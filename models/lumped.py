"""The lumped two-link model of Sec. 4.1, in volts.

Each row of the paper's experimental model is a joint's physical equation of
motion divided by that joint's motor constant (volts to joint torque), so the
model maps joint motion to armature voltage ``u``::

    M*(q) q'' + C*(q, q') q' + G*(q) + B* q' + F*(q') = u

with (reading note 1: the printed ``sin q'`` is ``sgn q'``)::

    M*(q) = [[th1 + th2 + 2 th3 cos q2,  th2 + th3 cos q2],
             [th7 + th8 cos q2,          th7 + th9      ]]
    C*(q, q') = [[-th3 q2' sin q2, -th3 (q1' + q2') sin q2],
                 [ th8 q1' sin q2,  0                    ]]
    G*(q) = [th4 cos q1 + (g/l1) th3 cos(q1 + q2),  (g/l1) th8 cos(q1 + q2)]
    B* = diag(th5, th10),   F*(q') = [th6 sgn q1', th11 sgn q2']

The split ``M*(q) = M0* + M1*(q)`` of Sec. 2 (reading note 5) takes ``M0*`` as
the q-independent part and ``M1*(q)`` as the ``cos q2`` part. This model is
what the controllers use; the URDF plant is the truth.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from posfb.models.validation import require_finite, require_positive, require_vector

#: Gravity used throughout (Drake's default, m/s^2).
GRAVITY = 9.81


@dataclass(frozen=True)
class LumpedParameters:
    """theta_1..theta_11 of Table 1 (SI units per volt) and the link length ``l1`` (m).

    ``l1`` is not printed in the paper (reading note 6); it enters through the
    ``g/l1`` factor of the gravity terms and is taken from the URDF.
    """

    theta1: float = 0.3339
    theta2: float = 0.0048
    theta3: float = 0.0054
    theta4: float = 2.1450
    theta5: float = 2.8219
    theta6: float = 1.5177
    theta7: float = 0.0240
    theta8: float = 0.0280
    theta9: float = 0.00002
    theta10: float = 1.2211
    theta11: float = 1.6282
    l1: float = 0.25
    g: float = GRAVITY

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            if field.name in ("theta1", "theta7", "l1", "g"):
                require_positive(field.name, value)
            elif field.name in ("theta3", "theta8"):
                require_finite(field.name, value)
            else:
                # Inertias, damping and Coulomb levels cannot be negative.
                if require_finite(field.name, value) < 0.0:
                    raise ValueError(
                        f"{field.name} = {value!r} is negative; a finite value >= 0 is required"
                    )

    @property
    def theta(self) -> np.ndarray:
        """theta_1..theta_11 as an array (index 0 holds theta_1)."""
        return np.array([getattr(self, f"theta{i}") for i in range(1, 12)])

    @classmethod
    def from_theta(cls, theta: np.ndarray, l1: float, g: float = GRAVITY) -> LumpedParameters:
        """Build from an array theta_1..theta_11."""
        values = require_vector("theta", theta, 11)
        return cls(**{f"theta{i + 1}": float(v) for i, v in enumerate(values)}, l1=l1, g=g)

    def as_dict(self) -> dict[str, float]:
        """``{"theta1": .., ..., "theta11": .., "l1": ..}`` (the identify --json keys)."""
        result = {f"theta{i}": float(getattr(self, f"theta{i}")) for i in range(1, 12)}
        result["l1"] = float(self.l1)
        return result


#: Table 1 of the paper, with the URDF's l1.
TABLE1 = LumpedParameters()


class LumpedModel:
    """The nominal model M*, C*, G*, B*, F* of Sec. 4.1 evaluated at given states."""

    def __init__(self, parameters: LumpedParameters = TABLE1) -> None:
        self.parameters = parameters
        p = parameters
        self._gravity_ratio = p.g / p.l1

    def M0(self) -> np.ndarray:
        """The constant part ``M0*`` of ``M*(q)`` (reading note 5)."""
        p = self.parameters
        return np.array([[p.theta1 + p.theta2, p.theta2], [p.theta7, p.theta7 + p.theta9]])

    def M1(self, q: np.ndarray) -> np.ndarray:
        """The configuration-dependent part ``M1*(q) = M*(q) - M0*``."""
        p = self.parameters
        c2 = np.cos(q[1])
        return np.array([[2.0 * p.theta3 * c2, p.theta3 * c2], [p.theta8 * c2, 0.0]])

    def M(self, q: np.ndarray) -> np.ndarray:
        """The lumped inertia matrix ``M*(q)``."""
        return self.M0() + self.M1(q)

    def C(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """The Coriolis/centrifugal matrix ``C*(q, q')``."""
        p = self.parameters
        s2 = np.sin(q[1])
        return np.array(
            [
                [-p.theta3 * qdot[1] * s2, -p.theta3 * (qdot[0] + qdot[1]) * s2],
                [p.theta8 * qdot[0] * s2, 0.0],
            ]
        )

    def coriolis(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """The Coriolis/centrifugal voltage ``C*(q, q') q'`` (as ``SerialArmModel``'s)."""
        return self.C(q, qdot) @ qdot

    def G(self, q: np.ndarray) -> np.ndarray:
        """The gravity vector ``G*(q)``."""
        p = self.parameters
        c12 = np.cos(q[0] + q[1])
        return np.array(
            [
                p.theta4 * np.cos(q[0]) + self._gravity_ratio * p.theta3 * c12,
                self._gravity_ratio * p.theta8 * c12,
            ]
        )

    def B(self) -> np.ndarray:
        """The viscous-friction matrix ``B* = diag(theta5, theta10)``."""
        p = self.parameters
        return np.diag([p.theta5, p.theta10])

    def coulomb_levels(self) -> np.ndarray:
        """The Coulomb levels ``[theta6, theta11]`` (volts)."""
        p = self.parameters
        return np.array([p.theta6, p.theta11])

    def F(self, qdot: np.ndarray) -> np.ndarray:
        """Coulomb friction ``F*(q') = [theta6 sgn q1', theta11 sgn q2']`` (reading note 1)."""
        return self.coulomb_levels() * np.sign(qdot)

    def inverse_dynamics(
        self, q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray, friction: bool = True
    ) -> np.ndarray:
        """Voltage ``u`` that produces ``qddot`` at ``(q, qdot)`` (Sec. 4.1)."""
        u = self.M(q) @ qddot + self.C(q, qdot) @ qdot + self.G(q) + self.B() @ qdot
        return u + self.F(qdot) if friction else u

    def forward_dynamics(
        self, q: np.ndarray, qdot: np.ndarray, u: np.ndarray, friction: bool = True
    ) -> np.ndarray:
        """Acceleration ``q''`` produced by voltage ``u`` at ``(q, qdot)`` (Sec. 4.1)."""
        rhs = u - self.C(q, qdot) @ qdot - self.G(q) - self.B() @ qdot
        if friction:
            rhs = rhs - self.F(qdot)
        return np.linalg.solve(self.M(q), rhs)
