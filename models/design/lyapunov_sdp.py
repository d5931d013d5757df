"""The semidefinite program behind the common-Lyapunov search
(``models.design.common_lyapunov``), solved by an interior-point method written for it.

For transition matrices ``A_1 .. A_k`` of size ``n``, the program (normalised so that its
optimum is positive exactly when the strict LMIs ``P > 0``, ``A_i^T P A_i - P < 0`` have
a solution) is

    maximise ``s``  over symmetric ``P`` and ``s``:  ``tr P = 1``,  ``P - s I >= 0``,
    ``P - A_i^T P A_i - s I >= 0``  (every ``i``),

``s`` being the decrease margin of ``P``; it always has strictly feasible points
(``P = I / n`` with ``s`` low enough). Its dual is

    minimise ``mu``  over ``Z_0, Z_i >= 0``:  ``Z_0 + sum_i (Z_i - A_i Z_i A_i^T) = mu I``,
    ``tr Z_0 + sum_i tr Z_i = 1``.

**The dual bound.** For *any* positive semidefinite ``Z_0 .. Z_k`` (of total trace 1) and
every feasible ``(P, s)`` with ``P >= 0``: ``0 <= sum_j <Z_j, S_j> = <M, P> - s``, where
``S_j`` are the blocks above and ``M = Z_0 + sum_i (Z_i - A_i Z_i A_i^T)``, so
``s <= lambda_max(M)``. ``bound`` is that eigenvalue, computed in numpy from the dual iterates
(the least over them) plus its rounding error: whatever the iterations did, no ``P >= 0`` with
``tr P = 1`` has a margin above it, and ``bound < 0`` proves that no common quadratic
Lyapunov function exists (then ``sum_i (A_i Z_i A_i^T - Z_i)`` is positive definite, the
theorem of alternatives of Boyd et al. 1994, Sec. 2.2).

**Why not a generic solver.** cvxpy with Clarabel factorises a sparse KKT system with
``k + 1`` dense blocks of ``n (n + 1) / 2`` rows: for the 42 states and four loops of a
seven-joint arm about 0.9 s an iteration on two cores, 12 s a solve. Here the normal
equations in ``svec P`` (the Schur complement) are a sum of Kronecker products in closed
form: for a loop's block ``L(P) = P - A^T P A`` and the HKM scaling ``X -> Z X S^-1``,
``L^* (Z L(X) S^-1) = Z X S^-1 - Z A^T X A S^-1 - A Z X S^-1 A^T + A Z A^T X A S^-1 A^T``,
one matrix product of ``n^2 x (4k + 1)`` by ``(4k + 1) x n^2`` and a gather to ``svec``
(0.03-0.05 s an iteration, 0.5-0.6 s the same solve; ``bench/bench_lyapunov_sdp.py``).
``tests/models/design/test_lyapunov_sdp.py`` checks the optimum against cvxpy with
Clarabel.

**The method**: primal-dual path following with the HKM direction (Helmberg, Rendl,
Vanderbei and Wolkowicz 1996; Kojima, Shindoh and Hara 1997; Monteiro 1997) and
Mehrotra's predictor-corrector, as in SDPT3 (Toh, Todd and Tütüncü 1999), from a strictly
feasible primal and dual start (``P = I / n``; ``Z_i = I``, ``Z_0 = I + sum_i A_i A_i^T``,
``mu = k + 1``, scaled to total trace 1). Neither answer is trusted: the caller checks a
``P`` in numpy, and ``bound`` is computed from the ``Z``'s in numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from threadpoolctl import threadpool_limits

#: The relative duality gap ``(mu - s) / s`` at which a positive margin counts as optimal.
RELATIVE_GAP = 1e-6

#: The duality gap (margins are of order ``1 / n`` at most, ``tr P = 1``) below which the
#: optimum is taken as settled however close to 0 it lies: past it, the iterates are
#: rounding noise.
ABSOLUTE_GAP = 1e-11

#: The iterations' limit (an iteration takes 0.03-0.05 s at 42 states and four loops; a
#: solve takes 10 to 20).
MAX_ITERATIONS = 60

#: How many rounding errors (``n * eps`` times the size of the terms) ``dual_bound`` adds
#: to the largest eigenvalue it computes (``common_lyapunov.ROUNDING_MARGIN``'s rule).
ROUNDING_MARGIN = 100.0

#: The fraction of the step to the boundary of the cone that an iterate takes.
STEP_FRACTION = 0.95


@dataclass(frozen=True)
class SdpAnswer:
    """The solve's last iterate and what it proves.

    ``P``: the last primal ``P`` (symmetric, ``tr P = 1``); ``margin``: what it achieves,
    the smallest eigenvalue over ``P`` and every ``P - A_i^T P A_i`` (computed in numpy,
    without the caller's rounding allowance); ``bound``: the dual bound of the module
    docstring, rounding included, the least over the iterates (``< 0`` proves
    infeasibility); ``iterations``; ``ended``: ``"converged"``, ``"stalled"`` (a step could
    not be computed) or ``"iteration limit"``."""

    P: np.ndarray
    margin: float
    bound: float
    iterations: int
    ended: str


class _Svec:
    """Symmetric ``n x n`` matrices as vectors of ``n (n + 1) / 2`` entries in an
    orthonormal basis (``<X, Y> = svec(X) . svec(Y)``): ``X_ii`` and ``sqrt(2) X_ij``."""

    def __init__(self, n: int):
        self.n = n
        self.rows, self.cols = np.triu_indices(n)
        off = self.rows != self.cols
        self.scale = np.where(off, np.sqrt(2.0), 1.0)
        self.weight = np.where(off, np.sqrt(0.5), 1.0)  # E_ab's entries
        self.twice = off.astype(float)
        self._gathers: list[np.ndarray] | None = None  # kronecker_sum's, made on first use
        self._gathered = np.empty(0)

    def vector(self, X: np.ndarray) -> np.ndarray:
        return X[self.rows, self.cols] * self.scale

    def matrix(self, v: np.ndarray) -> np.ndarray:
        X = np.zeros((self.n, self.n))
        X[self.rows, self.cols] = v * self.weight
        return X + np.triu(X, 1).T

    def kronecker_sum(self, product: np.ndarray) -> np.ndarray:
        """The ``svec`` matrix of the map ``V -> sum_t Y_t V X_t^T`` on symmetric matrices,
        from ``product = sum_t vec(Y_t) vec(X_t)^T`` laid out as ``[(a, c), (b, d)]``
        (``product[a n + c, b n + d] = sum_t Y_t[a, c] X_t[b, d]``, the map's entry from
        ``V_cd`` to its image's ``(a, b)``): each ``svec`` entry gathers the (up to) four
        entries of ``E_ab`` and ``E_cd``, read where they lie in ``product``. The matrix
        returned is this object's workspace: the next call overwrites it."""
        if self._gathers is None:
            n, rows, cols = self.n, self.rows, self.cols

            def at(a, b, c, d):  # product's flat index of [a n + c, b n + d]
                return np.add.outer(a * n**3 + b * n, c * n**2 + d).ravel()

            self._gathers = [at(rows, cols, rows, cols), at(rows, cols, cols, rows),
                             at(cols, rows, rows, cols), at(cols, rows, cols, rows)]  # fmt: skip
            size = len(self.rows)
            self._gathered = np.empty((4, size, size))  # reused: no fresh pages per call
        flat, (same, swapped_in, swapped_out, both) = product.ravel(), self._gathered
        for index, out in zip(self._gathers, self._gathered, strict=True):
            flat.take(index, out=out.reshape(-1))
        twice = self.twice  # in place, in the order same + in + out + both
        same += np.multiply(swapped_in, twice[None, :], out=swapped_in)
        same += np.multiply(swapped_out, twice[:, None], out=swapped_out)
        same += np.multiply(both, np.outer(twice, twice), out=both)
        return np.multiply(same, np.outer(self.weight, self.weight), out=same)


def _symmetric(X: np.ndarray) -> np.ndarray:
    return 0.5 * (X + X.T)


def _step_to_boundary(X: np.ndarray, dX: np.ndarray) -> float:
    """The largest ``a <= 1`` with ``X + a dX`` positive semidefinite (``X`` positive
    definite): ``1 / -lambda_min(R^-1 dX R^-T)``, ``X = R R^T``."""
    R = np.linalg.cholesky(X)
    inverse = scipy.linalg.solve_triangular(R, np.eye(len(X)), lower=True)
    smallest = float(np.linalg.eigvalsh(inverse @ dX @ inverse.T)[0])
    return 1.0 if smallest >= 0.0 else min(1.0, -1.0 / smallest)


def dual_bound(matrices: list[np.ndarray], Z: list[np.ndarray]) -> float:
    """``lambda_max(M) + rounding`` for ``M = (Z_0 + sum_i (Z_i - A_i Z_i A_i^T)) /
    sum_j tr Z_j`` (module docstring), the ``Z``'s first made exactly positive
    semidefinite (negative eigenvalues dropped): no ``P >= 0`` with ``tr P = 1`` has a
    margin above it."""
    projected, largest = [], []
    for X in Z:
        values, vectors = np.linalg.eigh(_symmetric(X))
        values = np.maximum(values, 0.0)
        projected.append((vectors * values) @ vectors.T)
        largest.append(float(values[-1]))
    total = sum(float(np.trace(X)) for X in projected)
    M = projected[0] + sum(X - A @ X @ A.T for A, X in zip(matrices, projected[1:], strict=True))
    # the terms' size, ||A||_2 bounded by the Frobenius norm
    size = largest[0] + sum(value * (float(np.sum(A * A)) + 1.0)
                            for A, value in zip(matrices, largest[1:], strict=True))  # fmt: skip
    rounding = ROUNDING_MARGIN * len(M) * np.finfo(float).eps * size
    return float((np.linalg.eigvalsh(_symmetric(M))[-1] + rounding) / total)


class _Program:
    """The program of the module docstring for ``matrices``: its blocks and a step."""

    def __init__(self, matrices: list[np.ndarray]):
        self.matrices = matrices
        self.transposed = [A.T for A in matrices]
        self.n = len(matrices[0])
        self.blocks = range(len(matrices) + 1)
        self.svec = _Svec(self.n)
        self.eye = np.eye(self.n)
        self.e = self.svec.vector(self.eye)
        # the normal matrix's workspace, reused by every step (a fresh 25 MB array at 42
        # states costs its page faults each time)
        self._product = np.empty((self.n**2, self.n**2))

    def block(self, j: int, X: np.ndarray) -> np.ndarray:
        """``L_j(X)``: ``X`` (``j = 0``), else ``X - A_j^T X A_j``."""
        return X if j == 0 else X - self.transposed[j - 1] @ X @ self.matrices[j - 1]

    def adjoint(self, j: int, X: np.ndarray) -> np.ndarray:
        """``L_j^*(X)``: ``X`` (``j = 0``), else ``X - A_j X A_j^T``."""
        return X if j == 0 else X - self.matrices[j - 1] @ X @ self.transposed[j - 1]

    def normal_matrix(self, Z: list[np.ndarray], S_inverse: list[np.ndarray]) -> np.ndarray:
        """The normal equations' matrix in ``(svec dP, ds)``: ``sum_j`` of
        ``Ltilde_j^* (X -> Z_j X S_j^-1) Ltilde_j``, ``Ltilde_j(P, s) = L_j(P) - s I``, the
        ``P`` part as a sum of Kronecker products (module docstring)."""
        n, left, right = self.n, [], []
        for j in self.blocks:
            left.append(Z[j])
            right.append(S_inverse[j])
            if j:
                A = self.matrices[j - 1]
                ZAt, AS = Z[j] @ A.T, A @ S_inverse[j]
                left += [-ZAt, -ZAt.T, A @ ZAt]
                right += [AS.T, AS, AS @ A.T]
        count = len(left)
        product = np.matmul(np.stack(left).reshape(count, n * n).T,
                            np.stack(right).reshape(count, -1), out=self._product)  # fmt: skip
        ZS = [_symmetric(Z[j] @ S_inverse[j]) for j in self.blocks]
        g = self.svec.vector(sum(self.adjoint(j, ZS[j]) for j in self.blocks))
        size = len(self.e)
        K = np.empty((size + 1, size + 1))
        K[:size, :size] = self.svec.kronecker_sum(product)
        K[:size, size] = K[size, :size] = -g
        K[size, size] = sum(float(np.trace(X)) for X in ZS)
        return K

    def step(self, P: np.ndarray, s: float, Z: list[np.ndarray], mu: float):
        """One predictor-corrector step (HKM direction) from ``(P, s, Z, mu)``;
        LinAlgError when the normal equations or an iterate stop being positive
        definite."""
        blocks, eye, e, size = self.blocks, self.eye, self.e, len(self.e)
        S = [self.block(j, P) - s * eye for j in blocks]
        S_inverse = [_symmetric(np.linalg.inv(X)) for X in S]
        factor = scipy.linalg.cho_factor(self.normal_matrix(Z, S_inverse))
        border = scipy.linalg.cho_solve(factor, np.append(e, 0.0))
        trace_residual = 1.0 - float(np.trace(P))
        pairs = len(Z) * self.n
        nu = sum(float(np.sum(Z[j] * S[j])) for j in blocks) / pairs

        def direction(sigma: float, correction: list[np.ndarray]):
            centre = [sigma * nu * S_inverse[j] - correction[j] for j in blocks]
            rhs_P = sum(self.adjoint(j, centre[j]) for j in blocks) - mu * eye
            rhs_s = 1.0 - sum(float(np.trace(X)) for X in centre)
            solved = scipy.linalg.cho_solve(factor, np.append(self.svec.vector(rhs_P), rhs_s))
            d_mu = (e @ solved[:size] - trace_residual) / (e @ border[:size])
            d = solved - d_mu * border
            dP, ds = self.svec.matrix(d[:size]), float(d[size])
            dS = [self.block(j, dP) - ds * eye for j in blocks]
            dZ = [_symmetric(centre[j] - Z[j] - Z[j] @ dS[j] @ S_inverse[j]) for j in blocks]
            primal = min(_step_to_boundary(S[j], dS[j]) for j in blocks)
            dual = min(_step_to_boundary(Z[j], dZ[j]) for j in blocks)
            return dP, ds, d_mu, dS, dZ, primal, dual

        _, _, _, dS, dZ, primal, dual = direction(0.0, [np.zeros_like(eye)] * len(Z))
        predicted = sum(float(np.sum((Z[j] + dual * dZ[j]) * (S[j] + primal * dS[j])))
                        for j in blocks) / pairs  # fmt: skip
        sigma = min(1.0, (predicted / nu) ** 3)
        correction = [_symmetric(dZ[j] @ dS[j] @ S_inverse[j]) for j in blocks]
        dP, ds, d_mu, _, dZ, primal, dual = direction(sigma, correction)
        primal, dual = STEP_FRACTION * primal, STEP_FRACTION * dual
        return (P + primal * dP, s + primal * ds, [Z[j] + dual * dZ[j] for j in blocks],
                mu + dual * d_mu)  # fmt: skip


def maximise_margin(matrices: list[np.ndarray], decide: bool = True) -> SdpAnswer:
    """Solve the program of the module docstring for the square matrices ``matrices``
    (finite, one size; ``common_lyapunov`` checks them). ``decide``: stop as soon as the
    dual bound proves infeasibility (the question ``common_lyapunov`` asks), else go on to
    the optimum. One BLAS thread: its matrices are small (``n x n`` blocks, a normal matrix
    of ``n^2 / 2``), where more threads cost more than they give (a 42-state arm's four
    loops: 0.8 s against 1.8 s with two), and the answer does not depend on the machine's
    thread count."""
    with threadpool_limits(1):
        return _maximise_margin(matrices, decide)


def _maximise_margin(matrices: list[np.ndarray], decide: bool) -> SdpAnswer:
    program = _Program(matrices)
    eye, n, k = program.eye, program.n, len(matrices)
    P = eye / n
    s = min(float(np.linalg.eigvalsh(program.block(j, P))[0]) for j in program.blocks) - 1.0
    Z = [eye + sum(A @ A.T for A in matrices)] + [eye.copy() for _ in range(k)]
    total = sum(float(np.trace(X)) for X in Z)
    Z, mu = [X / total for X in Z], (k + 1.0) / total
    iterations, ended, bound = 0, "iteration limit", math.inf
    while True:
        bound = min(bound, dual_bound(matrices, Z))  # every iterate's bound holds: the best
        gap = mu - s
        if (decide and bound < 0.0) or gap <= ABSOLUTE_GAP or abs(gap) <= RELATIVE_GAP * abs(s):
            ended = "converged"
            break
        if iterations == MAX_ITERATIONS:
            break
        try:
            P, s, Z, mu = program.step(P, s, Z, mu)
        except np.linalg.LinAlgError:
            ended = "stalled"
            break
        iterations += 1
    margin = min(float(np.linalg.eigvalsh(program.block(j, P))[0]) for j in program.blocks)
    return SdpAnswer(P, margin, bound, iterations, ended)
