"""The sampled loop of ``models.design.closed_loop`` cut into its two discrete systems,
the plant ``P`` (held voltage ``u_k`` to the reading ``y_k`` the controller takes) and
the controller ``K`` (``y_k`` to ``u_k``), and their frequency responses on the unit
circle ``z = exp(j omega T_s)``.

The loop closes with ``u = K y`` (``held_transition``: the filter's output is applied as
it is), so in the negative-feedback convention of a control toolbox the loop transfer
broken at the plant input is ``L_i = -K P`` and at the measured output ``L_o = -P K``;
``S = (I + L)^-1`` and ``T = I - S`` at each break.

``plant_system`` keeps ``HeldPlant``'s state order ``[xi, u_(k-1), y_(k-1) .. y_(k-d)]``
(``held_transition``'s without the filter), so ``closed_loop_matrix(plant, controller)``
is ``held_transition``'s matrix, to rounding (a test checks it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from posfb.models.design.closed_loop import HeldPlant
from posfb.models.design.realisation import DiscreteFilter


@dataclass(frozen=True, eq=False)
class DiscreteSystem:
    """``x_(k+1) = A x_k + B v_k``, ``w_k = C x_k + D v_k``, period ``sample_time`` (s)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    sample_time: float

    @property
    def inputs(self) -> int:
        return self.B.shape[1]

    @property
    def outputs(self) -> int:
        return self.C.shape[0]

    def response(self, omega: np.ndarray) -> np.ndarray:
        """``C (z I - A)^-1 B + D`` at ``z = exp(j omega T_s)`` for each ``omega`` (rad/s):
        shape ``(len(omega), outputs, inputs)``."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        z = np.exp(1j * omega * self.sample_time)
        size = len(self.A)
        if size == 0:
            return np.broadcast_to(self.D, (len(omega), *self.D.shape)).astype(complex)
        shifted = z[:, None, None] * np.eye(size) - self.A
        solved = np.linalg.solve(shifted, np.broadcast_to(self.B, (len(z), *self.B.shape)))
        return self.C @ solved + self.D


def feedback_system(feedback: DiscreteFilter, sample_time: float) -> DiscreteSystem:
    """A controller's discrete filter from ``q~`` (the reading) to ``u`` (V) as a system."""
    return DiscreteSystem(feedback.A, feedback.B, feedback.C, feedback.D, sample_time)


def plant_system(plant: HeldPlant, sample_time: float) -> DiscreteSystem:
    """The held plant from ``u_k`` to the reading ``y_k`` (the measurement of ``t_(k-d)``),
    state ``[xi_k, u_(k-1), y_(k-1) .. y_(k-d)]`` (the middle blocks only with a compute
    delay, a sensor delay)."""
    size, n = len(plant.Phi), plant.Gamma.shape[1]
    previous = 0 if plant.previous is None else n
    delayed = plant.delay_samples * n
    total = size + previous + delayed
    A = np.zeros((total, total))
    B = np.zeros((total, n))
    A[:size, :size] = plant.Phi
    B[:size] = plant.Gamma
    if previous:
        A[:size, size : size + n] = plant.previous
        B[size : size + n] = np.eye(n)
    C = np.zeros((n, total))
    if delayed:
        start = size + previous
        A[start : start + n, :size] = plant.C_y
        A[start + n : total, start : total - n] = np.eye(delayed - n)
        C[:, total - n :] = np.eye(n)
    else:
        C[:, :size] = plant.C_y
    return DiscreteSystem(A, B, C, np.zeros((n, n)), sample_time)


def closed_loop_matrix(plant: DiscreteSystem, controller: DiscreteSystem) -> np.ndarray:
    """The transition matrix of ``u = K y`` closed around a strictly proper ``plant``
    (``D = 0``), state ``[plant, controller]``."""
    if np.any(plant.D):
        raise ValueError("closed_loop_matrix needs a strictly proper plant (D = 0)")
    return np.block(
        [
            [plant.A + plant.B @ controller.D @ plant.C, plant.B @ controller.C],
            [controller.B @ plant.C, controller.A],
        ]
    )
