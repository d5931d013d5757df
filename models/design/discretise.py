"""Discretisation at the sample time by matrix exponentials.

The controllers' filters (Eq. 13, 20, 25) take the sampled error ``q~(t_k)``; they
are discretised with a first-order hold (FOH, "triangle hold"): the input is taken
as the straight line between consecutive samples. FOH keeps the exact pole map
``z = exp(s T_s)``, is exact for ramps and second-order accurate for smooth inputs
(a zero-order hold of the *input* would lag it by half a sample: first order),
and its causal form below has a direct feedthrough, so the output at ``t_k`` uses
``q~(t_k)`` with no extra sample of delay. The plant's input, the voltage, really
is held (ZOH) between samples.

Zero-order hold of the filters' input and Tustin's bilinear map are equally valid
choices (``DISCRETISATIONS``); at the paper's ``alpha* = 4`` the sampled-data loop
sits near its stability margin (spectral radius 1.04-1.06 for all three), so they
give visibly different joint-2 errors and the design report names the one used.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

#: The discretisations a controller's filters may use (``ControllerConfig.discretisation``):
#: first-order hold (the default), zero-order hold, Tustin (bilinear).
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
