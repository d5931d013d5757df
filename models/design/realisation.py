"""Position-only realisations of the controllers' linear filters, driven by the
sampled position error ``q~`` alone (no numerical differentiation).

Each filter is ``x' = A x + B q~``, ``y = C x + D q~``; the derivative ``q~'`` that
Eq. 12, 20 and 25 contain is removed by a change of state:

* Eq. 13: ``eta~' = (A_eta - K3) eta~ - K1 q~ - K2 q~'``; with ``w = eta~ + K2 q~``:
  ``w' = A_w w - (A_w K2 + K1) q~``, ``eta~ = w - K2 q~``, ``A_w = A_eta - K3``.
* Eq. 20: ``zeta' = A_zeta zeta + B_zeta (E1 q~ + E2 q~' + E3 eta~)``; with
  ``xi = zeta - B_zeta E2 q~``: ``xi' = A_zeta xi + B_zeta E3 w + (A_zeta B_zeta E2 +
  B_zeta E1 - B_zeta E3 K2) q~``, ``phi = C_zeta xi + C_zeta B_zeta E2 q~``.
* Eq. 23-25 (reading note 3): ``r1 = G q~``, ``p = sG q~ = a (q~ - r1)``;
  ``r2 = G p``, ``pbar = sG p = a (p - r2)``.

``rest`` maps the first error sample to the state of a filter at rest: ``eta~(0) = 0``
(``tau_LC(0) = tau_d(0)``), ``zeta(0) = 0`` and ``p(0) = pbar(0) = 0`` as Sec. 3.4
assumes. ``ContinuousFilter.discretise`` applies a hold of ``models.design.discretise``
(``ControllerConfig.discretisation``: zero-order by default).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from posfb.models.design.discretise import DISCRETISATIONS, first_order_hold, zero_order_hold


@dataclass(frozen=True, eq=False)
class DiscreteFilter:
    """``s_{k+1} = A s_k + B q~_k``, ``y_k = C s_k + D q~_k``, ``s_0 = initial q~_0``."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    initial: np.ndarray


@dataclass(frozen=True, eq=False)
class ContinuousFilter:
    """``x' = A x + B q~``, ``y = C x + D q~``; at rest ``x = rest q~``."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    rest: np.ndarray

    def discretise(self, sample_time: float, method: str) -> DiscreteFilter:
        """The filter sampled at ``sample_time`` by ``method`` (``DISCRETISATIONS``).

        ``foh``: first-order hold in its causal form, state ``s_k = x_k - Gamma1 q~_k``;
        ``zoh``: the input held over each period (``s_k = x_k``); ``tustin``: the
        bilinear map ``s = (2/T)(z - 1)/(z + 1)`` (scipy's state coordinates). All three
        have a direct feedthrough (the output at ``t_k`` uses ``q~_k``) and start at rest."""
        if method == "zoh":
            Phi, Gamma0 = zero_order_hold(self.A, self.B, sample_time)
            return DiscreteFilter(A=Phi, B=Gamma0, C=self.C, D=self.D, initial=self.rest)
        if method == "tustin":
            import scipy.signal  # on use: the CLI's start-up does not pay for it

            A, B, C, D, _ = scipy.signal.cont2discrete(
                (self.A, self.B, self.C, self.D), sample_time, method="bilinear"
            )
            # At rest x = A x + B q~ holds for the continuous rest state as well.
            return DiscreteFilter(A=A, B=B, C=C, D=D, initial=self.rest)
        if method != "foh":
            raise ValueError(
                f"discretisation = {method!r}; one of {', '.join(DISCRETISATIONS)} is required"
            )
        Phi, Gamma0, Gamma1 = first_order_hold(self.A, self.B, sample_time)
        return DiscreteFilter(
            A=Phi,
            B=Gamma0 + (Phi - np.eye(Phi.shape[0])) @ Gamma1,
            C=self.C,
            D=self.D + self.C @ Gamma1,
            initial=self.rest - Gamma1,
        )


def stack(*filters: ContinuousFilter) -> ContinuousFilter:
    """Filters side by side on the same input: states and outputs concatenated."""
    return ContinuousFilter(
        A=scipy.linalg.block_diag(*(f.A for f in filters)),
        B=np.vstack([f.B for f in filters]),
        C=scipy.linalg.block_diag(*(f.C for f in filters)),
        D=np.vstack([f.D for f in filters]),
        rest=np.vstack([f.rest for f in filters]),
    )


def linear_control_filter(
    K1: np.ndarray, K2: np.ndarray, K3: np.ndarray, A_eta: np.ndarray
) -> ContinuousFilter:
    """Eq. 13: ``eta~ = -[Lambda^-1(s) + K3]^-1 [K1 + s K2] q~``; state ``w``, output ``eta~``."""
    A_w = A_eta - K3
    return ContinuousFilter(A=A_w, B=-(A_w @ K2 + K1), C=np.eye(len(A_w)), D=-K2, rest=K2.copy())


def nonlinear_control_filter(
    K1: np.ndarray,
    K2: np.ndarray,
    K3: np.ndarray,
    A_eta: np.ndarray,
    E: np.ndarray,
    A_zeta: np.ndarray,
    B_zeta: np.ndarray,
    C_zeta: np.ndarray,
) -> ContinuousFilter:
    """Eq. 13 and Eq. 20 together: state ``[w, xi]``, output ``[eta~, phi]``."""
    n = len(A_eta)
    E1, E2, E3 = E[:, :n], E[:, n : 2 * n], E[:, 2 * n :]
    lc = linear_control_filter(K1, K2, K3, A_eta)
    zero = np.zeros((n, n))
    return ContinuousFilter(
        A=np.block([[lc.A, zero], [B_zeta @ E3, A_zeta]]),
        B=np.vstack([lc.B, A_zeta @ B_zeta @ E2 + B_zeta @ E1 - B_zeta @ E3 @ K2]),
        C=np.block([[lc.C, zero], [zero, C_zeta]]),
        D=np.vstack([lc.D, C_zeta @ B_zeta @ E2]),
        rest=np.vstack([lc.rest, -B_zeta @ E2]),
    )


def velocity_bound_filter(a: float, n: int) -> ContinuousFilter:
    """Eq. 23-25: state ``[r1, r2]``, output ``[p, pbar] = [sG q~, s^2 G^2 q~]``."""
    eye, zero = np.eye(n), np.zeros((n, n))
    C = np.block([[-a * eye, zero], [-a * a * eye, -a * eye]])
    D = np.vstack([a * eye, a * a * eye])
    return ContinuousFilter(A=C.copy(), B=D.copy(), C=C, D=D, rest=np.vstack([eye, zero]))
