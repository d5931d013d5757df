"""Linear closed loops of the nominal linear part (Eq. 2 with ``h = 0``):
``M0* q~'' + B* q~' = u`` (error coordinates, reference terms cancel) under a
position-only controller ``u = G (C x + D q~)`` of ``models.design.realisation``.

``output_gain`` ``G`` picks the torque from the filter's outputs: ``I`` for
``tau_LC`` (Eq. 13), ``[I, -alpha I]`` for ``tau_LC + tau_NC`` with the gain frozen at
``alpha`` (Eq. 19). The sampled-data loop holds ``u`` over each period (ZOH) and
applies the discretised filter's output at the sample instant (no extra delay),
as the controller LeafSystems do. ``sampled_data_loop`` adds the loop's inputs (a held
torque disturbance, the measurement error) and outputs (``q~``, ``u``), and
``stationary_deviations`` their stationary standard deviations: the predicted tracking
error and voltage that ``analysis.tuning`` minimises and bounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

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


@dataclass(frozen=True, eq=False)
class SampledLoop:
    """The sampled-data loop, state ``x_k = [q~_k, q~'_k, s_k]``, with two inputs:

    ``x_{k+1} = A x_k + B_w w_k + B_n n_k``, ``q~_k = C_q x_k``, ``u_k = C_u x_k + D_un n_k``,

    ``w`` a torque disturbance held over the period like ``u`` (the model error ``h``
    of Eq. 2, in volts) and ``n`` the error of the position measurement (the encoder's
    quantisation), which the filter reads with ``q~``."""

    A: np.ndarray
    B_w: np.ndarray
    B_n: np.ndarray
    C_q: np.ndarray
    C_u: np.ndarray
    D_un: np.ndarray


@dataclass(frozen=True, eq=False)
class HeldPlant:
    """The linear part held over one period: ``[q~, q~']_{k+1} = Phi [q~, q~']_k + Gamma
    u_k``. It does not depend on the controller, so a search over designs computes it
    once per plant."""

    Phi: np.ndarray
    Gamma: np.ndarray


def held_plant(M0: np.ndarray, B: np.ndarray, sample_time: float) -> HeldPlant:
    """``M0 q~'' + B q~' = u`` with ``u`` held over ``sample_time`` (``HeldPlant``)."""
    A_p, B_p, _ = _plant(M0, B)
    return HeldPlant(*zero_order_hold(A_p, B_p, sample_time))


def held_transition(
    plant: HeldPlant, controller: DiscreteFilter, output_gain: np.ndarray
) -> np.ndarray:
    """The one-period transition matrix of the held plant and the discrete filter, state
    ``[q~_k, q~'_k, s_k]``, assembled in place (a tuner asks for thousands)."""
    Phi, Gamma = plant.Phi, plant.Gamma
    size, n, states = len(Phi), Gamma.shape[1], len(controller.A)
    torque = Gamma @ output_gain
    A = np.zeros((size + states, size + states))
    A[:size, :size] = Phi
    A[:size, :n] += torque @ controller.D
    A[:size, size:] = torque @ controller.C
    A[size:, :n] = controller.B
    A[size:, size:] = controller.A
    return A


def held_loop(plant: HeldPlant, controller: DiscreteFilter, output_gain: np.ndarray) -> SampledLoop:
    """The held plant and the discrete filter over one period (``SampledLoop``)."""
    Gamma = plant.Gamma
    n = Gamma.shape[1]
    C_q = np.hstack([np.eye(n), np.zeros((n, n))])
    feedthrough = output_gain @ controller.D
    states = len(controller.A)
    return SampledLoop(
        A=held_transition(plant, controller, output_gain),
        B_w=np.vstack([Gamma, np.zeros((states, n))]),
        B_n=np.vstack([Gamma @ feedthrough, controller.B]),
        C_q=np.hstack([C_q, np.zeros((n, states))]),
        C_u=np.hstack([feedthrough @ C_q, output_gain @ controller.C]),
        D_un=feedthrough,
    )


def sampled_data_loop(
    M0: np.ndarray,
    B: np.ndarray,
    controller: DiscreteFilter,
    output_gain: np.ndarray,
    sample_time: float,
) -> SampledLoop:
    """The plant (ZOH input) and the discrete filter over one period (``SampledLoop``)."""
    return held_loop(held_plant(M0, B, sample_time), controller, output_gain)


def sampled_data_closed_loop(
    M0: np.ndarray,
    B: np.ndarray,
    controller: DiscreteFilter,
    output_gain: np.ndarray,
    sample_time: float,
) -> np.ndarray:
    """One-period transition matrix of the plant (ZOH input) and the discrete filter,
    state ``[q~_k, q~'_k, s_k]``."""
    return sampled_data_loop(M0, B, controller, output_gain, sample_time).A


def stationary_deviations(
    loop: SampledLoop,
    disturbance_std: np.ndarray,
    noise_std: np.ndarray,
    disturbance_pole: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint standard deviations of ``q~`` and ``u`` in the loop's stationary state.

    ``n`` is white with per-joint standard deviations ``noise_std``; ``w`` is a
    first-order Gauss-Markov sequence ``w_{k+1} = p w_k + sqrt(1 - p^2) e_k`` with
    ``p = disturbance_pole`` (0: white) and per-joint standard deviations
    ``disturbance_std``. The loop augmented with ``w`` solves
    ``X = A X A^T + B N B^T`` (the discrete Lyapunov equation: the squared H2 norms
    weighted by the inputs' intensities). Requires a stable loop (spectral radius < 1)."""
    states, joints = len(loop.A), len(disturbance_std)
    A = np.block(
        [[loop.A, loop.B_w], [np.zeros((joints, states)), disturbance_pole * np.eye(joints)]]
    )
    drive = np.vstack(
        [np.zeros((states, joints)), math.sqrt(1.0 - disturbance_pole**2) * np.eye(joints)]
    )
    W = np.diag(np.square(disturbance_std))
    N = np.diag(np.square(noise_std))
    B_n = np.vstack([loop.B_n, np.zeros((joints, loop.B_n.shape[1]))])
    X = scipy.linalg.solve_discrete_lyapunov(A, drive @ W @ drive.T + B_n @ N @ B_n.T)
    C_q = np.hstack([loop.C_q, np.zeros((len(loop.C_q), joints))])
    C_u = np.hstack([loop.C_u, np.zeros((len(loop.C_u), joints))])
    q = np.diag(C_q @ X @ C_q.T)
    u = np.diag(C_u @ X @ C_u.T + loop.D_un @ N @ loop.D_un.T)
    return np.sqrt(np.maximum(q, 0.0)), np.sqrt(np.maximum(u, 0.0))


def spectral_radius(matrix: np.ndarray) -> float:
    """Largest eigenvalue modulus (``< 1``: the discrete loop is asymptotically stable)."""
    return float(np.max(np.abs(np.linalg.eigvals(matrix))))
