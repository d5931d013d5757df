"""The augmented system and its LQR state feedback (Sec. 3.2, Eq. 5-6, 11, 14-15)
and the input direction of the nonlinear torque (Eq. 20).

The state is ``x~ = [q~, q~', eta~]`` with ``eta~ = tau_LC - tau_d`` (Eq. 9-10).
Everything is sized by the number of joints ``n = len(M0)``: the augmented system
has ``3 n`` states (the paper's arm: 6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg


@dataclass(frozen=True, eq=False)
class AugmentedSystem:
    """``x~' = A_a x~ + B_a1 v~ + B_a2 (tau_NC + tau_Lin - h + Delta tau_d)`` (Eq. 11),
    with ``Lambda(s)`` realised as ``eta' = A_eta eta + v`` (Eq. 6)."""

    A_eta: np.ndarray
    A_a: np.ndarray
    B_a1: np.ndarray
    B_a2: np.ndarray


def augmented_system(M0: np.ndarray, B: np.ndarray, lambdas: np.ndarray) -> AugmentedSystem:
    """Eq. 11 for the nominal linear part ``M0* q'' + B* q' = tau_LC`` (Eq. 2) cascaded
    with ``Lambda(s) = diag(1/(s + lambda_i))`` (Eq. 5)."""
    M0_inv = np.linalg.inv(M0)
    n = len(M0)
    zero, eye = np.zeros((n, n)), np.eye(n)
    A_eta = -np.diag(lambdas)
    A_a = np.block([[zero, eye, zero], [zero, -M0_inv @ B, M0_inv], [zero, zero, A_eta]])
    return AugmentedSystem(
        A_eta=A_eta,
        A_a=A_a,
        B_a1=np.vstack([zero, zero, eye]),
        B_a2=np.vstack([zero, M0_inv, zero]),
    )


def column_block(matrix: np.ndarray, index: int) -> np.ndarray:
    """The ``index``-th ``n``-column block of a ``[X1 X2 X3]`` matrix with ``3 n``
    columns (``K`` of Eq. 14, ``E`` of Eq. 20)."""
    n = matrix.shape[1] // 3
    return matrix[:, index * n : (index + 1) * n]


class GainBlocks:
    """``K1, K2, K3`` of ``K = [K1 K2 K3]`` (Eq. 12) for a class that holds ``K``."""

    K: np.ndarray

    @property
    def K1(self) -> np.ndarray:
        return column_block(self.K, 0)

    @property
    def K2(self) -> np.ndarray:
        return column_block(self.K, 1)

    @property
    def K3(self) -> np.ndarray:
        return column_block(self.K, 2)


@dataclass(frozen=True, eq=False)
class LqrSolution(GainBlocks):
    """``P`` of the Riccati equation (15) and ``K = R^-1 B_a1^T P = [K1 K2 K3]`` (Eq. 14)."""

    P: np.ndarray
    K: np.ndarray


def _scaled_care(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Eq. 15 solved in coordinates where ``Q`` and ``R`` have unit diagonals: with
    ``x = S z`` (``S = diag(1/sqrt(Q_ii))``) and ``v = T w`` (``T = diag(1/sqrt(R_ii))``)
    the equation for ``(S^-1 A S, S^-1 B T, S Q S, T R T)`` has the solution
    ``S P S``, the same equation in other units. Weights of a fast loop (``scenario init``
    at 5 kHz: ``Q`` from 1e-3 to 1e11, ``R`` 2e-7) make the unscaled Hamiltonian too
    ill-conditioned for the Schur method; the scaled one is not."""
    q, r = np.diag(Q).copy(), np.diag(R)
    q[q <= 0.0] = 1.0
    s, t = 1.0 / np.sqrt(q), 1.0 / np.sqrt(r)
    Pz = scipy.linalg.solve_continuous_are(
        A * (s[None, :] / s[:, None]), B * (t[None, :] / s[:, None]),
        Q * np.outer(s, s), R * np.outer(t, t),
    )  # fmt: skip
    return Pz / np.outer(s, s)


def is_hurwitz(poles: np.ndarray) -> bool:
    """Every pole's real part below ``-1e-9`` times the largest ``|pole|`` (or 1): a pole
    on the imaginary axis up to round-off is not stable."""
    return bool(poles.real.max() < -1e-9 * max(1.0, float(np.abs(poles).max())))


def solve_lqr(system: AugmentedSystem, Q: np.ndarray, R: np.ndarray) -> LqrSolution:
    """Solve Eq. 15 with scipy and form ``K`` (Eq. 14). Where scipy's Schur method fails
    on the weights as written it solves the same equation in scaled units
    (``_scaled_care``) and keeps that solution if it is stabilising.

    Raises ``ValueError`` naming ``Q1, Q2, R`` when no stabilising solution exists.
    """
    A, B = system.A_a, system.B_a1
    try:
        P = scipy.linalg.solve_continuous_are(A, B, Q, R)
    except (np.linalg.LinAlgError, ValueError) as error:
        try:
            P = _scaled_care(A, B, Q, R)
        except (np.linalg.LinAlgError, ValueError):
            P = None
        stable = (
            P is not None
            and np.all(np.isfinite(P))
            and is_hurwitz(np.linalg.eigvals(A - B @ np.linalg.solve(R, B.T @ P)))
        )
        if not stable:
            raise ValueError(
                f"Q1, Q2, R: the Riccati equation (Eq. 15) has no stabilising solution ({error})"
            ) from None
    P = 0.5 * (P + P.T)
    return LqrSolution(P=P, K=np.linalg.solve(R, B.T @ P))


def nonlinear_input_matrix(P: np.ndarray, M0: np.ndarray) -> np.ndarray:
    """``E = (M0*)^-T P2^T = [E1 E2 E3]`` with ``P = [P1 P2 P3]`` (Eq. 20), so that the
    SPR filter's input is ``z = E x~``."""
    return np.linalg.solve(M0.T, column_block(P, 1).T)
