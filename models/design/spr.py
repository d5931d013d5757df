"""Strict positive realness of ``H(s) = C_zeta (sI - A_zeta)^-1 B_zeta`` via the
Kalman-Yakubovich-Popov conditions of Sec. 3.3.

For the paper's ``n``-state realisation with ``n`` inputs, ``Gamma B_zeta =
C_zeta^T`` fixes ``Gamma = C_zeta^T B_zeta^-1`` (``B_zeta`` must be invertible, else
``C_zeta B_zeta`` is singular and the relative degree is not 1). ``H`` is SPR with
relative degree 1 exactly when that ``Gamma`` is symmetric positive definite and
``A_zeta^T Gamma + Gamma A_zeta`` is negative definite; then
``A_zeta^T Gamma + Gamma A_zeta = -Q_zeta Q_zeta^T - 2 gamma Gamma`` holds for every
``gamma`` below ``gamma_max``, the smallest generalised eigenvalue of
``(-(A_zeta^T Gamma + Gamma A_zeta), 2 Gamma)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg


@dataclass(frozen=True, eq=False)
class SprCertificate:
    """The outcome of the check: ``reason`` is empty when ``H`` is SPR. ``gamma`` is
    half of ``gamma_max`` (strictly inside both KYP inequalities); 0 when not SPR."""

    is_spr: bool
    reason: str
    Gamma: np.ndarray | None
    gamma: float


def _refused(reason: str, Gamma: np.ndarray | None = None) -> SprCertificate:
    return SprCertificate(is_spr=False, reason=reason, Gamma=Gamma, gamma=0.0)


def spr_certificate(A: np.ndarray, B: np.ndarray, C: np.ndarray) -> SprCertificate:
    """KYP check of ``H(s) = C (sI - A)^-1 B`` (all ``n x n``)."""
    poles = np.linalg.eigvals(A)
    if np.max(poles.real) >= 0.0:
        return _refused(f"A_zeta has eigenvalues {np.round(poles, 6).tolist()} not in Re s < 0")
    if np.linalg.cond(B) > 1e12:
        return _refused(
            "B_zeta is singular, so C_zeta B_zeta is singular: relative degree is not 1"
        )
    Gamma = np.linalg.solve(B.T, C).T  # Gamma B = C^T
    scale = float(np.max(np.abs(Gamma)))
    if not np.allclose(Gamma, Gamma.T, rtol=0.0, atol=1e-10 * scale):
        return _refused(
            "Gamma = C_zeta^T B_zeta^-1 (the only solution of Gamma B_zeta = "
            f"C_zeta^T) = {Gamma.tolist()} is not symmetric",
            Gamma,
        )
    Gamma = 0.5 * (Gamma + Gamma.T)
    if np.linalg.eigvalsh(Gamma).min() <= 1e-12 * scale:
        return _refused(f"Gamma = {Gamma.tolist()} is not positive definite", Gamma)
    S = -(A.T @ Gamma + Gamma @ A)
    S = 0.5 * (S + S.T)
    if np.linalg.eigvalsh(S).min() <= 1e-12 * max(1.0, float(np.max(np.abs(S)))):
        return _refused("A_zeta^T Gamma + Gamma A_zeta is not negative definite", Gamma)
    gamma_max = float(scipy.linalg.eigh(S, 2.0 * Gamma, eigvals_only=True).min())
    return SprCertificate(is_spr=True, reason="", Gamma=Gamma, gamma=0.5 * gamma_max)
