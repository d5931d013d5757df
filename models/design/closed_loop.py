"""Linear closed loops of the nominal linear part (Eq. 2 with ``h = 0``):
``M0* q~'' + B* q~' = u`` (error coordinates, reference terms cancel) under a
position-only controller ``u = G (C x + D q~)`` of ``models.design.realisation``.

``output_gain`` ``G`` picks the torque from the filter's outputs: ``I`` for
``tau_LC`` (Eq. 13), ``[I, -alpha I]`` for ``tau_LC + tau_NC`` with the gain frozen at
``alpha`` (Eq. 19). The sampled-data loop holds ``u`` over each period (ZOH) and
applies the discretised filter's output at the sample instant (no extra delay),
as the controller LeafSystems do.
"""

from __future__ import annotations

import numpy as np

from posfb.models.design.discretise import zero_order_hold
from posfb.models.design.realisation import ContinuousFilter, DiscreteFilter


def _plant(M0: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """State ``[q~, q~']``: ``(A_p, B_p, C_q)`` of the nominal linear part."""
    n = len(M0)
    M0_inv = np.linalg.inv(M0)
    zero, eye = np.zeros((n, n)), np.eye(n)
    return (
        np.block([[zero, eye], [zero, -M0_inv @ B]]),
        np.vstack([zero, M0_inv]),
        np.hstack([eye, zero]),
    )


def continuous_closed_loop(
    M0: np.ndarray, B: np.ndarray, controller: ContinuousFilter, output_gain: np.ndarray
) -> np.ndarray:
    """State matrix of plant and continuous filter, state ``[q~, q~', x]``."""
    A_p, B_p, C_q = _plant(M0, B)
    return np.block(
        [
            [A_p + B_p @ output_gain @ controller.D @ C_q, B_p @ output_gain @ controller.C],
            [controller.B @ C_q, controller.A],
        ]
    )


def sampled_data_closed_loop(
    M0: np.ndarray,
    B: np.ndarray,
    controller: DiscreteFilter,
    output_gain: np.ndarray,
    sample_time: float,
) -> np.ndarray:
    """One-period transition matrix of the plant (ZOH input) and the discrete filter,
    state ``[q~_k, q~'_k, s_k]``."""
    A_p, B_p, C_q = _plant(M0, B)
    Phi, Gamma = zero_order_hold(A_p, B_p, sample_time)
    return np.block(
        [
            [Phi + Gamma @ output_gain @ controller.D @ C_q, Gamma @ output_gain @ controller.C],
            [controller.B @ C_q, controller.A],
        ]
    )


def spectral_radius(matrix: np.ndarray) -> float:
    """Largest eigenvalue modulus (``< 1``: the discrete loop is asymptotically stable)."""
    return float(np.max(np.abs(np.linalg.eigvals(matrix))))
