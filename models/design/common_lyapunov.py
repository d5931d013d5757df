"""A common quadratic Lyapunov function for a set of sampled loops: the certificate that a
loop stays stable while ``M*(q)`` varies among the frozen configurations, however fast
(issue 40).

For transition matrices ``A_1 .. A_m`` (the sampled loop with ``M*(q)`` frozen at each
configuration of ``models.design.configurations``), a symmetric ``P`` with

    ``P > 0`` and ``A_i^T P A_i - P < 0`` for every ``i``

makes ``V(x) = x^T P x`` decrease along ``x_(k+1) = A(k) x_k`` for *any* sequence of
matrices ``A(k)`` in the convex hull of the ``A_i`` (the polytopic linear differential
inclusion's quadratic stability: Boyd, El Ghaoui, Feron and Balakrishnan, "Linear Matrix
Inequalities in System and Control Theory", SIAM 1994, Sec. 5.1; its discrete-time form
by the Schur complement of Sec. 2.1). By homogeneity the strict inequalities are
equivalent to ``I <= P <= t I`` and ``A_i^T P A_i - P <= -I``, solved here as a
semidefinite program (cvxpy with the Clarabel interior-point solver), ``t`` minimised so
that the ``P`` found is the best conditioned. The solver's answer is then *checked* in
numpy: a certificate is ``feasible`` only when every ``A_i^T P A_i - P`` is negative
definite at the returned ``P`` (the solver's own tolerance is not trusted).

What it covers: the loops' linear part with ``M*`` anywhere in the hull of the sampled
loops, switching arbitrarily. What it leaves out: the Coriolis terms, friction and
saturation (``M*(q)`` moving between the sampled loops' matrices is covered only as far as
the loop at an intermediate ``M*`` lies in their hull; ``verify`` checks a ``P`` on other
loops, e.g. a fine grid between configurations).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: The solver's statuses a solution is read from (then checked in numpy).
SOLVED = ("optimal", "optimal_inaccurate")

#: Loops the first solve takes (those of largest spectral radius), and the most each
#: later solve adds (those the last ``P`` fails on, worst first).
FIRST_LOOPS = 4


@dataclass(frozen=True, eq=False)
class LyapunovCertificate:
    """The search's answer: ``feasible`` (a common ``P`` found *and* verified), ``P``
    (scaled to smallest eigenvalue 1; ``None`` when infeasible), ``decay`` (the largest
    over the loops of ``sqrt(lambda_max(P^-1 A_i^T P A_i))``: the common contraction rate
    of ``||x||_P`` per sample, below 1 when feasible; ``nan`` otherwise), ``condition``
    (of ``P``), ``loops`` and ``message`` (one line: what was found, or why not)."""

    feasible: bool
    P: np.ndarray | None
    decay: float
    condition: float
    loops: int
    message: str


def _require_transitions(transitions: Sequence[np.ndarray]) -> list[np.ndarray]:
    matrices = [np.asarray(A, dtype=float) for A in transitions]
    if not matrices:
        raise ValueError("transitions is empty; at least one transition matrix is required")
    size = matrices[0].shape
    for index, A in enumerate(matrices):
        if A.ndim != 2 or A.shape[0] != A.shape[1] or A.shape[0] == 0:
            raise ValueError(
                f"transitions[{index}] has shape {A.shape}; a non-empty square matrix is required"
            )
        if A.shape != size:
            raise ValueError(
                f"transitions[{index}] has shape {A.shape}; every matrix must have "
                f"transitions[0]'s shape {size}"
            )
        if not np.all(np.isfinite(A)):
            raise ValueError(
                f"transitions[{index}] has a non-finite entry; finite entries are required"
            )
    return matrices


def decay_rate(P: np.ndarray, transitions: Sequence[np.ndarray]) -> float:
    """The largest over ``transitions`` of ``sqrt(lambda_max(P^-1 A^T P A))``: how much
    ``||x||_P`` can grow in one sample (``< 1``: ``P`` certifies every one of them)."""
    matrices = _require_transitions(transitions)
    P = np.asarray(P, dtype=float)
    P = 0.5 * (P + P.T)
    root = np.linalg.cholesky(P)  # P = L L^T; LinAlgError when P is not positive definite
    inverse = np.linalg.inv(root)
    worst = 0.0
    for A in matrices:
        # lambda_max(P^-1 A^T P A) = lambda_max(L^-1 A^T L L^T A L^-T) = sigma_max(L^T A L^-T)^2
        worst = max(worst, float(np.linalg.norm(root.T @ A @ inverse.T, 2)))
    return worst


def _solve(matrices: list[np.ndarray]) -> tuple[np.ndarray | None, str]:
    """The SDP of the module docstring on ``matrices``: ``P`` (scaled to smallest
    eigenvalue 1), or ``None`` and why."""
    import cvxpy  # on use: start-up

    n = matrices[0].shape[0]
    P = cvxpy.Variable((n, n), symmetric=True)
    bound = cvxpy.Variable()
    eye = np.eye(n)
    constraints = [P >> eye, P << bound * eye]
    for A in matrices:
        decrease = A.T @ P @ A - P
        constraints.append(0.5 * (decrease + decrease.T) << -eye)
    problem = cvxpy.Problem(cvxpy.Minimize(bound), constraints)
    try:
        problem.solve(solver=cvxpy.CLARABEL)
    except cvxpy.error.SolverError as error:
        return None, f"the solver failed: {error}"
    if problem.status not in SOLVED or P.value is None:
        return None, f"the LMI is {problem.status}"
    found = 0.5 * (P.value + P.value.T)
    smallest = float(np.linalg.eigvalsh(found)[0])
    if smallest <= 0.0:
        return None, "the solver's P is not positive definite"
    return found / smallest, ""


def _balance(matrices: list[np.ndarray]) -> np.ndarray:
    """``L`` with ``L L^T = P0``, the Lyapunov matrix of the loop with the smallest
    spectral radius (``A^T P0 A - P0 = -I``): in the coordinates ``L^T x`` that loop
    contracts in the plain norm, so the LMI's ``I`` bounds are on the loops' own scale
    (position errors in rad, filter states in volts: many decades apart)."""
    import scipy.linalg

    reference = min(matrices, key=lambda A: float(np.max(np.abs(np.linalg.eigvals(A)))))
    P0 = scipy.linalg.solve_discrete_lyapunov(reference.T, np.eye(len(reference)))
    return np.linalg.cholesky(0.5 * (P0 + P0.T))


def common_lyapunov(
    transitions: Sequence[np.ndarray], first: int = FIRST_LOOPS
) -> LyapunovCertificate:
    """Search for one quadratic Lyapunov function common to ``transitions`` (module
    docstring). A loop with spectral radius ``>= 1`` has none: refused without a solve.

    The LMI is solved on the ``first`` loops of largest spectral radius, the ``P`` found
    checked on all of them, and the loops it fails added until it holds on every one or
    one solve is infeasible (a cutting-plane: few of many similar loops bind)."""
    matrices = _require_transitions(transitions)
    loops = len(matrices)
    radii = [float(np.max(np.abs(np.linalg.eigvals(A)))) for A in matrices]
    worst = int(np.argmax(radii))
    if radii[worst] >= 1.0:
        return LyapunovCertificate(
            False, None, math.nan, math.nan, loops,
            f"loop {worst} has spectral radius {radii[worst]:.4f} >= 1: no Lyapunov function "
            "exists for it alone",
        )  # fmt: skip
    L = _balance(matrices)
    L_inverse = np.linalg.inv(L)
    balanced = [L.T @ A @ L_inverse.T for A in matrices]
    active = [int(i) for i in np.argsort(radii)[::-1][:first]]
    while True:
        found, why = _solve([balanced[i] for i in active])
        if found is None:
            return LyapunovCertificate(
                False, None, math.nan, math.nan, loops,
                f"no common quadratic Lyapunov function for the {loops} loops ({why} on "
                f"{len(active)} of them)",
            )  # fmt: skip
        rates = [decay_rate(found, [A]) for A in balanced]
        failing = [i for i in np.argsort(rates)[::-1] if rates[i] >= 1.0 and i not in active]
        if not failing:
            break
        active += [int(i) for i in failing[:first]]
    P = L @ found @ L.T
    P = P / float(np.linalg.eigvalsh(0.5 * (P + P.T))[0])
    decay = decay_rate(P, matrices)
    if decay >= 1.0:
        return LyapunovCertificate(
            False, None, math.nan, math.nan, loops,
            f"the solver's P does not decrease on every loop (rate {decay:.6f} >= 1 in numpy)",
        )  # fmt: skip
    condition = float(np.linalg.cond(P))
    return LyapunovCertificate(
        True, P, decay, condition, loops,
        f"common quadratic Lyapunov function for the {loops} loops: ||x||_P contracts by at "
        f"least {decay:.4f} per sample (cond P = {condition:.3g}; LMI on {len(active)} of "
        "them, checked on all)",
    )  # fmt: skip
