"""Discretisation at the sample time by matrix exponentials.

The controllers' filters (Eq. 13, 20, 25) take the sampled error ``q~(t_k)``: the
encoder reading, held by the zero-order-hold quantiser over each period. A
zero-order hold (ZOH) of the filter's input is therefore the exact discretisation of
a filter driven by what the controller really sees, and it is the default of
MATLAB's ``c2d`` and python-control's ``sample_system``; it keeps the exact pole
map ``z = exp(s T_s)``, and the output at ``t_k`` uses ``q~(t_k)`` through the
direct feedthrough, with no extra sample of delay. ZOH is the default (issue 20;
earlier versions used FOH).

A first-order hold (FOH, "triangle hold": the input taken as the straight line
between consecutive samples, exact for ramps) and Tustin's bilinear map stay
selectable (``DISCRETISATIONS``). At the paper's ``alpha* = 4`` the sampled-data
loop sits near its stability margin (spectral radius 1.04-1.06 for all three), so
they give visibly different joint-2 errors and the design report names the one used.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

#: The discretisations a controller's filters may use (``ControllerConfig.discretisation``):
#: first-order hold, zero-order hold (the default), Tustin (bilinear).
DISCRETISATIONS = ("foh", "zoh", "tustin")

#: How reports name each discretisation.
DISCRETISATION_NAMES = {
    "foh": "first-order hold (FOH)",
    "zoh": "zero-order hold (ZOH)",
    "tustin": "Tustin (bilinear)",
}


def zero_order_hold(A: np.ndarray, B: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Phi, Gamma0)``: ``x_{k+1} = Phi x_k + Gamma0 u_k`` for ``u`` held on each step."""
    n, m = B.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = A * T, B * T
    exponential = scipy.linalg.expm(block)
    return exponential[:n, :n], exponential[:n, n:]


def first_order_hold(
    A: np.ndarray, B: np.ndarray, T: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Phi, Gamma0, Gamma1)`` of ``x_{k+1} = Phi x_k + Gamma0 u_k + Gamma1 (u_{k+1} - u_k)``
    for ``u`` linear between samples: ``Gamma0 = int_0^T e^{As} ds B`` and
    ``Gamma1 = (1/T) int_0^T e^{A(T - tau)} B tau dtau``."""
    n, m = B.shape
    block = np.zeros((n + 2 * m, n + 2 * m))
    block[:n, :n], block[:n, n : n + m] = A * T, B * T
    block[n : n + m, n + m :] = np.eye(m)
    exponential = scipy.linalg.expm(block)
    return exponential[:n, :n], exponential[:n, n : n + m], exponential[:n, n + m :]
