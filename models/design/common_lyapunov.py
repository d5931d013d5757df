"""A common quadratic Lyapunov function for a set of discrete-time loops (issue 40).

For transition matrices ``A_1 .. A_m`` (e.g. the sampled loop with ``M*(q)`` frozen at
several configurations), a symmetric ``P`` with

    ``P > 0``  and  ``A_i^T P A_i - P < 0``  for every ``i``

makes ``V(x) = x^T P x`` decrease along ``x_(k+1) = A(k) x_k`` for *every* sequence of
matrices ``A(k)`` in the convex hull of the ``A_i``, switching arbitrarily fast: the
quadratic stability of the polytopic linear differential inclusion (Boyd, El Ghaoui,
Feron and Balakrishnan, "Linear Matrix Inequalities in System and Control Theory",
SIAM 1994, Sec. 5.1; the discrete-time form is convex in ``A`` through the Schur
complement ``[[P, A^T P], [P A, P]] > 0`` of Sec. 2.1, hence the hull). It is
sufficient, not necessary: a switched system can be stable without one.

The LMIs are homogeneous in ``P``, so they have a solution exactly when the semidefinite
program

    maximise ``s``  subject to  ``tr P = 1``,  ``P >= s I``,  ``P - A_i^T P A_i >= s I``

(all ``i``) has a positive optimum ``s`` (the decrease margin).
``models.design.lyapunov_sdp`` solves it with an interior-point method written for it
(its normal equations in closed form: a 42-state arm's four loops in 0.5-0.6 s, where
cvxpy with Clarabel took 12 s), in
*balanced* coordinates ``z = D^-1 x``, ``A_i`` becoming ``D^-1 A_i D``, with ``D`` the
diagonal, power-of-two scaling of ``sum |A_i|`` (``scipy.linalg.matrix_balance``): it evens
out states of very different units (entries of ``1e3`` and ``1e-3``) and is exact in
floating point. Neither outcome is taken from the solver:

* a ``P`` is *checked* in numpy, in those coordinates (``P = D^-1 Q D^-1`` is congruent to
  ``Q``, so ``A^T P A - P`` has the inertia of ``B^T Q B - Q`` with ``B = D^-1 A D``): the
  certificate is ``feasible`` only when ``P`` is positive definite and every
  ``A_i^T P A_i - P`` is negative definite by more than its rounding error;
* "infeasible" needs the dual's proof: positive semidefinite ``Z_i`` whose
  ``sum_i (A_i Z_i A_i^T - Z_i)`` is positive definite, its smallest eigenvalue computed in
  numpy with its rounding error (``lyapunov_sdp.dual_bound`` below 0). A search that ends
  with neither says so, with the dual bound on the margin any ``P`` could have.

Before any SDP, each of the worst loops' own Lyapunov equation ``B^T Q B - Q = -I`` is
solved and its ``Q`` checked on every loop: loops that differ little share it, and then
no SDP is needed.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from posfb.models.design.closed_loop import spectral_radius
from posfb.models.design.lyapunov_sdp import maximise_margin
from posfb.models.disk_cache import cached_floats

#: How many rounding errors (``n * eps * (||A||^2 + 1) * ||P||``) below zero the largest
#: eigenvalue of ``A^T P A - P`` must lie to count as negative definite.
ROUNDING_MARGIN = 100.0

#: How many loops the first SDP takes (those of largest spectral radius), and the most
#: each later one adds (those the last ``P`` fails on, worst first).
BATCH = 4


@dataclass(frozen=True, eq=False)
class LyapunovCertificate:
    """What ``common_lyapunov`` found.

    ``feasible``: a common ``P`` was found by the solver *and* verified in numpy;
    ``P``: that ``P``, scaled to smallest eigenvalue 1 (``None`` when infeasible);
    ``decay``: ``max_i sqrt(lambda_max(P^-1 A_i^T P A_i))``, a common contraction rate of
    ``||x||_P = sqrt(x^T P x)`` per step (``< 1`` when feasible, ``nan`` otherwise);
    ``condition``: ``cond(P)`` (``nan`` when infeasible); ``loops``: how many transition
    matrices; ``message``: one line, what was found or why not."""

    feasible: bool
    P: np.ndarray | None
    decay: float
    condition: float
    loops: int
    message: str


def _checked(transitions: Sequence[np.ndarray]) -> list[np.ndarray]:
    """The transition matrices as float arrays; ValueError unless they are a non-empty
    sequence of finite square matrices of one size."""
    if isinstance(transitions, np.ndarray) and transitions.ndim == 2:
        raise ValueError(
            f"transitions is one {transitions.shape} matrix; a sequence of square matrices "
            "is required (wrap a single matrix in a list)"
        )
    matrices = []
    for index, A in enumerate(transitions):
        name = f"transitions[{index}]"
        try:
            A = np.asarray(A, dtype=float)
        except (TypeError, ValueError) as error:
            raise ValueError(f"{name} is not a numeric array ({error}); a square matrix is "
                             "required") from None  # fmt: skip
        if A.ndim != 2 or A.shape[0] != A.shape[1] or A.shape[0] == 0:
            raise ValueError(
                f"{name} has shape {A.shape}; a square 2-D matrix (n, n) with n >= 1 is required"
            )
        if matrices and A.shape != matrices[0].shape:
            raise ValueError(
                f"{name} has shape {A.shape}; every matrix must have the shape of "
                f"transitions[0], {matrices[0].shape}"
            )
        if not np.all(np.isfinite(A)):
            bad = tuple(int(i) for i in np.argwhere(~np.isfinite(A))[0])
            raise ValueError(
                f"{name} has the non-finite entry {A[bad]} at {bad}; finite entries are required"
            )
        matrices.append(A)
    if not matrices:
        raise ValueError("transitions is empty; at least one transition matrix is required")
    return matrices


def verify(P: np.ndarray, transitions: Sequence[np.ndarray]) -> float:
    """The squared common decay of ``P`` on ``transitions``:
    ``max_i lambda_max(P^-1/2 A_i^T P A_i P^-1/2)``, below 1 exactly when every
    ``A_i^T P A_i - P`` is negative definite. Use it to check a found ``P`` on other
    matrices (e.g. a fine grid of the hull).

    With ``P = L L^T`` (Cholesky), ``P^-1/2 A^T P A P^-1/2`` is similar to ``B^T B`` with
    ``B = L^T A L^-T``, so the value is ``max_i ||L^T A_i L^-T||_2^2``. ValueError when
    ``P`` is not a symmetric positive definite matrix of the transitions' size."""
    matrices = _checked(transitions)
    P = np.asarray(P, dtype=float)
    n = matrices[0].shape[0]
    if P.shape != (n, n) or not np.all(np.isfinite(P)):
        raise ValueError(f"P has shape {P.shape}; a finite ({n}, {n}) matrix is required")
    if not np.allclose(P, P.T, rtol=1e-10, atol=0.0):
        raise ValueError("P is not symmetric; a symmetric positive definite matrix is required")
    try:
        L = np.linalg.cholesky(0.5 * (P + P.T))
    except np.linalg.LinAlgError:
        raise ValueError("P is not positive definite; a symmetric positive definite matrix "
                         "is required") from None  # fmt: skip
    L_inverse_T = scipy.linalg.solve_triangular(L, np.eye(n), lower=True).T
    return max(float(np.linalg.norm(L.T @ A @ L_inverse_T, 2)) ** 2 for A in matrices)


def decay_rate(P: np.ndarray, transitions: Sequence[np.ndarray]) -> float:
    """``sqrt(verify(P, transitions))``: how much ``||x||_P`` can grow in one step of any of
    ``transitions`` (``< 1``: ``P`` certifies every one of them)."""
    return math.sqrt(verify(P, transitions))


def _balancing(matrices: list[np.ndarray]) -> np.ndarray:
    """``d``: the SDP is solved for ``D^-1 A_i D`` with ``D = diag(d)``, powers of two
    (module docstring)."""
    _, (scale, _) = scipy.linalg.matrix_balance(
        sum(np.abs(A) for A in matrices), permute=False, separate=True
    )
    return scale


def _solve(matrices: list[np.ndarray]) -> tuple[np.ndarray | None, str, float]:
    """The SDP of the module docstring on ``matrices``: ``(P, status, bound)``, ``P`` scaled
    to smallest eigenvalue 1 when its margin is positive (else ``None``), ``status`` one of
    ``SOLVER_STATUSES``, ``bound`` the dual bound on the margin (checked in numpy)."""
    answer = maximise_margin(matrices)
    if answer.margin > 0.0:
        P = 0.5 * (answer.P + answer.P.T)
        smallest = float(np.linalg.eigvalsh(P)[0])
        if smallest > 0.0:
            converged = answer.ended == "converged"
            return P / smallest, "optimal" if converged else "not converged", answer.bound
    if answer.bound < 0.0:
        return None, "infeasible", answer.bound
    return None, "not found", answer.bound


def _negative_margin(Q: np.ndarray, B: np.ndarray) -> tuple[float, float]:
    """``(lambda_max(B^T Q B - Q), rounding)``: negative definite in numpy when the first is
    below ``-rounding``, ``ROUNDING_MARGIN`` times the error of forming the matrix."""
    largest = float(np.linalg.eigvalsh(B.T @ Q @ B - Q)[-1])
    size = float(np.linalg.norm(Q, 2)) * (float(np.linalg.norm(B, 2)) ** 2 + 1.0)
    return largest, ROUNDING_MARGIN * len(Q) * np.finfo(float).eps * size


#: The search's method, part of a cache entry's key (an answer of an older method is not
#: read).
SOLVER = "lyapunov_sdp 1"

#: The ``models.disk_cache`` kind of a search's answer (its ``Q``, stored as floats; a cache
#: hit is checked in numpy as a fresh answer is, so an entry cannot make a certificate).
CACHE_KIND = "common_lyapunov"

#: The statuses an answer is stored as (their index): a ``P`` of positive margin at the
#: optimum, or where the iterations ended; the dual's proof of infeasibility; neither.
SOLVER_STATUSES = (
    "optimal",
    "not converged",
    "infeasible",
    "not found",
    "the Lyapunov equation of one loop",
)


def _equation_candidate(balanced: list[np.ndarray], radii: list[float]) -> np.ndarray | None:
    """A ``Q`` found without the SDP: the solution of ``B^T Q B - Q = -I`` of one of the
    ``BATCH`` loops of largest radius (``scipy.linalg.solve_discrete_lyapunov``), the first
    that passes the numeric check on every loop; ``None`` when none does. Loops that differ
    little (an arm whose inertia barely moves) often share the worst one's."""
    for i in np.argsort(radii)[::-1][:BATCH]:
        B = balanced[int(i)]
        Q = scipy.linalg.solve_discrete_lyapunov(B.T, np.eye(len(B)))
        Q = 0.5 * (Q + Q.T)
        if np.all(np.isfinite(Q)) and np.linalg.eigvalsh(Q)[0] > 0.0 and _holds(Q, balanced):
            return Q / float(np.linalg.eigvalsh(Q)[0])
    return None


def _searched(balanced: list[np.ndarray], radii: list[float]) -> dict[str, float]:
    """The cutting-plane search (``common_lyapunov``'s docstring) on the ``balanced`` loops:
    ``feasible`` (1/0), ``status`` (index into ``SOLVER_STATUSES``), ``taken`` (the loops
    the last LMI held), ``bound`` (its dual bound on the margin; not when a loop's own
    Lyapunov equation holds, no SDP having run) and, when feasible, ``Q``'s entries
    ``q0 ..`` (the cache keeps finite numbers only). A loop's own
    Lyapunov equation is tried first (``_equation_candidate``): no SDP where it holds."""
    candidate = _equation_candidate(balanced, radii)
    if candidate is not None:
        code = SOLVER_STATUSES.index("the Lyapunov equation of one loop")
        entries = {f"q{i}": float(v) for i, v in enumerate(candidate.ravel())}
        return {"feasible": 1.0, "status": float(code), "taken": 1.0, **entries}
    taken = [int(i) for i in np.argsort(radii)[::-1][:BATCH]]
    while True:
        Q, status, bound = _solve([balanced[i] for i in taken])
        code = float(SOLVER_STATUSES.index(status))
        if Q is None:
            return {"feasible": 0.0, "status": code, "taken": float(len(taken)), "bound": bound}
        margins = [_negative_margin(Q, B) for B in balanced]
        failing = [i for i, (largest, rounding) in enumerate(margins) if not largest < -rounding]
        new = sorted((i for i in failing if i not in taken), key=lambda i: -margins[i][0])
        if not new:
            break
        taken += new[:BATCH]
    entries = {f"q{i}": float(v) for i, v in enumerate(Q.ravel())}
    return {"feasible": 1.0, "status": code, "taken": float(len(taken)), "bound": bound,
            **entries}  # fmt: skip


def _stored_q(stored: dict[str, float], n: int) -> np.ndarray:
    """``Q`` from a ``_searched`` answer's entries (symmetrised)."""
    Q = np.array([stored[f"q{i}"] for i in range(n * n)]).reshape(n, n)
    return 0.5 * (Q + Q.T)


def _holds(Q: np.ndarray, balanced: list[np.ndarray]) -> bool:
    """Whether ``Q`` passes the numeric check on every loop."""
    return all(largest < -rounding for largest, rounding in (
        _negative_margin(Q, B) for B in balanced))  # fmt: skip


def _refusal(stored: dict[str, float], loops: int) -> str:
    """The message of a search that found no ``P``: proved infeasible, or not decided."""
    taken, bound = int(stored["taken"]), stored["bound"]
    if SOLVER_STATUSES[int(stored["status"])] == "infeasible":
        return (f"no common quadratic Lyapunov function for the {loops} loops: the LMI on "
                f"{taken} of them is infeasible (its dual proves it: the margin of any P is at "
                f"most {bound:.3g} < 0, checked in numpy)")  # fmt: skip
    return (f"no common quadratic Lyapunov function found for the {loops} loops: on {taken} of "
            f"them no P (tr P = 1) has a decrease margin above {bound:.3g} (the dual bound, "
            "checked in numpy; the search proved neither a P nor infeasibility)")


def _infeasible(loops: int, message: str) -> LyapunovCertificate:
    return LyapunovCertificate(False, None, math.nan, math.nan, loops, message)


def common_lyapunov(transitions: Sequence[np.ndarray]) -> LyapunovCertificate:
    """Search for one quadratic Lyapunov function ``x^T P x`` common to the discrete-time
    loops ``x_(k+1) = A_i x_k`` (the SDP of the module docstring).

    A loop with spectral radius ``>= 1`` has no Lyapunov function at all: infeasible at
    once, without a solve. Otherwise ``feasible`` only when the solver reports
    ``optimal``/``optimal_inaccurate`` and numpy confirms ``P > 0`` and every
    ``A_i^T P A_i - P < 0`` (by more than ``ROUNDING_MARGIN`` rounding errors).

    Many similar loops (frozen configurations of one arm) are solved as cutting planes:
    the SDP on the ``BATCH`` loops of largest spectral radius, its ``P`` checked on all
    loops, the (up to ``BATCH``) worst loops it fails added, until it holds on every loop
    or the SDP on the loops taken is infeasible (then so is the whole set's). ValueError
    when ``transitions`` is empty or holds a non-finite, non-square matrix or matrices of
    different sizes."""
    matrices = _checked(transitions)
    loops = len(matrices)
    radii = [spectral_radius(A) for A in matrices]
    worst = int(np.argmax(radii))
    if radii[worst] >= 1.0:
        return _infeasible(loops, f"transitions[{worst}] has spectral radius {radii[worst]:.6g}"
                           " >= 1: no Lyapunov function exists for it alone")  # fmt: skip
    d = _balancing(matrices)
    balanced = [A / d[:, None] * d[None, :] for A in matrices]  # D^-1 A D, exact
    # The check is made in the balanced coordinates: P = D^-1 Q D^-1 is congruent to Q,
    # so A^T P A - P = D^-1 (B^T Q B - Q) D^-1 with B = D^-1 A D has the same inertia.
    key = {"loops": hashlib.sha256(np.stack(balanced).tobytes()).hexdigest(), "batch": BATCH,
           "solver": SOLVER}  # fmt: skip
    stored = cached_floats(CACHE_KIND, key, lambda: _searched(balanced, radii))
    if stored["feasible"] == 1.0 and not _holds(_stored_q(stored, len(d)), balanced):
        stored = _searched(balanced, radii)  # an entry that does not hold: searched afresh
    if stored["feasible"] == 0.0:
        return _infeasible(loops, _refusal(stored, loops))
    Q = _stored_q(stored, len(d))
    status, taken = SOLVER_STATUSES[int(stored["status"])], range(int(stored["taken"]))
    # the stored Q is checked here whatever its source: a cache entry cannot certify
    margins = [_negative_margin(Q, B) for B in balanced]
    failing = sorted((i for i, (largest, rounding) in enumerate(margins)
                      if not largest < -rounding), key=lambda i: -margins[i][0])  # fmt: skip
    if failing:
        largest, rounding = margins[failing[0]]
        return _infeasible(loops, f"the solver's P ({status}) fails the numeric check on "
                           f"transitions[{failing[0]}]: lambda_max(A^T P A - P) = {largest:.3g} "
                           f"is not below -{rounding:.3g} (balanced coordinates)")  # fmt: skip
    decay = decay_rate(Q, balanced)  # lambda(P^-1 A^T P A) is invariant under D
    if not decay < 1.0:
        return _infeasible(loops, f"the solver's P ({status}) passes the eigenvalue check but "
                           f"its decay {decay:.9g} is not below 1")  # fmt: skip
    # P = D^-1 Q D^-1 may be graded (cond 1e12 for states 1e3 apart), where eigvalsh(P) gets
    # its smallest eigenvalue wrong: take it as 1 / lambda_max(P^-1), P^-1 = D Q^-1 D.
    scale = np.outer(d, d)
    P = Q / scale
    largest = float(np.linalg.eigvalsh(P)[-1])
    smallest = 1.0 / float(np.linalg.eigvalsh(np.linalg.inv(Q) * scale)[-1])
    P, condition = P / smallest, largest / smallest
    how = ("the Lyapunov equation of one loop" if status == SOLVER_STATUSES[-1]
           else f"LMI on {len(taken)} of them, solver {status}")  # fmt: skip
    return LyapunovCertificate(
        True, P, decay, condition, loops,
        f"common quadratic Lyapunov function for the {loops} loops: ||x||_P contracts by "
        f"{decay:.6g} per step at worst (cond P = {condition:.3g}; {how}, checked on all "
        "in numpy)",
    )  # fmt: skip
