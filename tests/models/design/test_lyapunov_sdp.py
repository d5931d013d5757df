"""``models.design.lyapunov_sdp``: the margin program's optimum in closed form (a nilpotent
pair), against cvxpy with Clarabel (an independent solver of the same program), weak
duality of its bound, and its normal equations against the operator they stand for."""

from __future__ import annotations

import numpy as np
import pytest

from helpers.reference_sdp import clarabel_margin
from posfb.models.design.lyapunov_sdp import _Program, dual_bound, maximise_margin


def _nilpotent_pair(c):
    return [np.array([[0.0, c], [0.0, 0.0]]), np.array([[0.0, 0.0], [c, 0.0]])]


@pytest.mark.parametrize("c", [0.5, 0.9, 1.0, 1.1, 1.5])
def test_the_nilpotent_pair_s_best_margin_is_half_of_one_minus_c_squared(c):
    # The program is invariant under swapping x1, x2 (it swaps the pair) and under x2 -> -x2
    # (it negates both), so averaging an optimal P over both keeps it optimal: P = I / 2.
    # Then P - A1^T P A1 = diag(1, 1 - c^2) / 2, and s* = min(1, 1 - c^2) / 2 = (1 - c^2) / 2.
    answer = maximise_margin(_nilpotent_pair(c), decide=False)
    expected = (1.0 - c**2) / 2.0
    assert answer.margin == pytest.approx(expected, abs=1e-7)
    assert answer.margin <= answer.bound + 1e-12  # weak duality
    assert answer.bound == pytest.approx(expected, abs=1e-6)  # the gap RELATIVE_GAP stops at
    np.testing.assert_allclose(answer.P, np.eye(2) / 2.0, atol=1e-5)
    if c > 1.0:
        assert answer.bound < 0.0  # a proof of infeasibility
        decided = maximise_margin(_nilpotent_pair(c))  # stops at the proof
        assert decided.margin <= expected <= decided.bound < 0.0


def _random_loops(rng, count, n, radius):
    loops = []
    for _ in range(count):
        A = rng.normal(size=(n, n))
        loops.append(A * radius / max(abs(np.linalg.eigvals(A))))
    return loops


@pytest.mark.parametrize(("seed", "count", "n", "radius"),
                         [(0, 2, 3, 0.6), (1, 3, 4, 0.8), (2, 3, 4, 1.1), (3, 4, 5, 0.9),
                          (4, 2, 6, 0.95)])  # fmt: skip
def test_the_optimum_is_clarabel_s(seed, count, n, radius):
    loops = _random_loops(np.random.default_rng(seed), count, n, radius)
    answer = maximise_margin(loops, decide=False)
    assert answer.ended == "converged"
    optimum = clarabel_margin(loops)
    assert answer.margin == pytest.approx(optimum, abs=1e-6)
    assert answer.margin <= answer.bound + 1e-12
    assert np.trace(answer.P) == pytest.approx(1.0)
    # the margin is what P achieves, eigenvalues computed here
    achieved = min(np.linalg.eigvalsh(answer.P)[0],
                   *(np.linalg.eigvalsh(answer.P - A.T @ answer.P @ A)[0]
                     for A in loops))  # fmt: skip
    assert achieved == pytest.approx(answer.margin, abs=1e-12)
    decided = maximise_margin(loops)  # stops once the sign is proved
    assert decided.margin <= optimum + 1e-6 and optimum <= decided.bound + 1e-6
    assert (decided.margin > 0.0) == (optimum > 0.0) or decided.bound < 0.0


def test_the_dual_bound_holds_for_any_positive_semidefinite_z():
    # For any Z_j >= 0 and any P >= 0 with tr P = 1: margin(P) <= dual_bound(Z).
    rng = np.random.default_rng(9)
    loops = _random_loops(rng, 3, 4, 0.9)
    for _ in range(20):
        Z = [(lambda X: X @ X.T)(rng.normal(size=(4, 4))) for _ in range(4)]
        R = rng.normal(size=(4, 4))
        P = R @ R.T
        P /= np.trace(P)
        margin = min(np.linalg.eigvalsh(P)[0],
                     *(np.linalg.eigvalsh(P - A.T @ P @ A)[0] for A in loops))  # fmt: skip
        assert margin <= dual_bound(loops, Z)


def test_the_normal_matrix_is_the_operator_it_stands_for():
    # sum_j Ltilde_j^*(sym(Z_j Ltilde_j(X, t) S_j^-1)) applied to each basis element (svec P
    # and s), against the closed-form Kronecker assembly
    rng = np.random.default_rng(3)
    n, loops = 3, _random_loops(rng, 2, 3, 0.8)
    program = _Program(loops)
    spd = [(lambda X: X @ X.T + np.eye(n))(rng.normal(size=(n, n))) for _ in range(6)]
    Z, S_inverse = spd[:3], spd[3:]
    size = n * (n + 1) // 2
    columns = []
    for index in range(size + 1):
        unit = np.eye(size + 1)[index]
        X, t = program.svec.matrix(unit[:size]), unit[size]
        image, trace = np.zeros((n, n)), 0.0
        for j in program.blocks:
            product = Z[j] @ (program.block(j, X) - t * np.eye(n)) @ S_inverse[j]
            product = 0.5 * (product + product.T)
            image += program.adjoint(j, product)
            trace -= np.trace(product)
        columns.append(np.append(program.svec.vector(image), trace))
    np.testing.assert_allclose(program.normal_matrix(Z, S_inverse), np.array(columns).T,
                               rtol=1e-12, atol=1e-12)  # fmt: skip
