"""The desired trajectory of Sec. 4.2 with analytic derivatives, and a Drake
system that outputs it.

    q1d(t) = -pi/2 + pi/4 (1 - e^{-2t^3}) + pi/9 (1 - e^{-2t^3}) sin(4t)
    q2d(t) =         pi/3 (1 - e^{-2t^3}) + pi/6 (1 - e^{-2t^3}) sin(3t)

Each joint is ``offset + s(t) f(t)`` with ``s(t) = 1 - exp(-2 t^3)`` and
``f(t) = amplitude + wave_amplitude sin(frequency t)``; the derivatives follow
from the product rule. The system depends on time only, so it is evaluated at
control samples and log instants, never inside the integrator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

#: Size of the stacked desired vector ``[q_d, qdot_d, qddot_d]``.
DESIRED_SIZE = 6


@dataclass(frozen=True)
class JointWave:
    """One joint's ``offset + s(t) (amplitude + wave_amplitude sin(frequency t))``."""

    offset: float
    amplitude: float
    wave_amplitude: float
    frequency: float


#: Sec. 4.2, joint 1 then joint 2.
PAPER_TRAJECTORY = (
    JointWave(offset=-np.pi / 2, amplitude=np.pi / 4, wave_amplitude=np.pi / 9, frequency=4.0),
    JointWave(offset=0.0, amplitude=np.pi / 3, wave_amplitude=np.pi / 6, frequency=3.0),
)


def desired(
    t: float, waves: tuple[JointWave, ...] = PAPER_TRAJECTORY
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``q_d(t)``, ``qdot_d(t)``, ``qddot_d(t)`` of Sec. 4.2 (analytic)."""
    e = np.exp(-2.0 * t**3)
    s, ds, dds = 1.0 - e, 6.0 * t**2 * e, (12.0 * t - 36.0 * t**4) * e
    offset = np.array([w.offset for w in waves])
    amplitude = np.array([w.amplitude for w in waves])
    wave = np.array([w.wave_amplitude for w in waves])
    omega = np.array([w.frequency for w in waves])
    sine, cosine = np.sin(omega * t), np.cos(omega * t)
    f, df, ddf = amplitude + wave * sine, wave * omega * cosine, -wave * omega**2 * sine
    return offset + s * f, ds * f + s * df, dds * f + 2.0 * ds * df + s * ddf


class DesiredTrajectory(LeafSystem):
    """Outputs ``[q_d, qdot_d, qddot_d]`` (size 6) on port ``desired`` (Sec. 4.2)."""

    def __init__(self, waves: tuple[JointWave, ...] = PAPER_TRAJECTORY) -> None:
        super().__init__()
        if len(waves) != 2:
            raise ValueError(f"waves has {len(waves)} entries; exactly 2 (one per joint) required")
        self._waves = waves
        self.set_name("desired_trajectory")
        self.DeclareVectorOutputPort("desired", DESIRED_SIZE, self._calc_desired)

    def _calc_desired(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(np.concatenate(desired(context.get_time(), self._waves)))
