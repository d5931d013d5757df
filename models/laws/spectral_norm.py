"""The spectral norm ``||A||_2`` (the largest singular value) of a square ``SX`` matrix as
one fixed expression, which a law evaluates and C prints: Eq. 18's ``||M1*(q)||``.

A 2 x 2 matrix ``[[a, b], [c, d]]`` has a closed form free of cancellation (the sum of
its two singular values and their difference are the two square roots),

    ||A||_2 = (sqrt((a + d)^2 + (c - b)^2) + sqrt((a - d)^2 + (b + c)^2)) / 2;

a larger one gets the cyclic Jacobi method (Golub and Van Loan, Matrix Computations,
Sec. 8.5) on the symmetric ``A^T A``: ``JACOBI_SWEEPS`` sweeps of the rotations that zero
each off-diagonal pair in turn, a fixed count (no test on convergence, so the
expression is branch-free), after which the largest diagonal entry is the largest
eigenvalue. Jacobi's convergence is quadratic; the test compares with LAPACK's SVD on
random, graded and nearly degenerate matrices of every size used, to round-off.

``frobenius_norm`` is the cheap upper bound ``||A||_2 <= ||A||_F <= sqrt(n) ||A||_2``
that ``UncertaintyBounds.M1_norm = "frobenius"`` asks Eq. 18 for (``NORMS``).
"""

from __future__ import annotations

import casadi as ca

#: Sweeps of the cyclic Jacobi method (module docstring). Measured on the test's matrices
#: against LAPACK: 5 reach round-off up to 7 rows, 6 at 8 rows; one more for margin.
JACOBI_SWEEPS = 7


def spectral_norm(A: ca.SX) -> ca.SX:
    """``||A||_2`` of the square ``A`` (module docstring)."""
    n = A.size1()
    if A.size2() != n:
        raise ValueError(f"A is {n} x {A.size2()}; a square matrix is required")
    if n == 1:
        return ca.fabs(A[0, 0])
    if n == 2:
        a, b, c, d = A[0, 0], A[0, 1], A[1, 0], A[1, 1]
        return 0.5 * (_hypot(a + d, c - b) + _hypot(a - d, b + c))
    gram = ca.mtimes(A.T, A)
    a = [[gram[i, j] for j in range(n)] for i in range(n)]
    for _ in range(JACOBI_SWEEPS):
        for p in range(n - 1):
            for q in range(p + 1, n):
                _rotate(a, p, q)
    largest = a[0][0]
    for i in range(1, n):
        largest = ca.fmax(largest, a[i][i])
    return ca.sqrt(ca.fmax(largest, 0.0))


def frobenius_norm(A: ca.SX) -> ca.SX:
    """``||A||_F = sqrt(sum a_ij^2)``, an upper bound of ``||A||_2`` (module docstring)."""
    return ca.sqrt(ca.sumsqr(A))


#: Eq. 18's ``||M1*(q)||`` by the name ``UncertaintyBounds.M1_norm`` gives it
#: (``models.design.config.M1_NORMS``).
NORMS = {"spectral": spectral_norm, "frobenius": frobenius_norm}


def _hypot(x: ca.SX, y: ca.SX) -> ca.SX:
    """``sqrt(x^2 + y^2)``."""
    return ca.sqrt(x * x + y * y)


def _rotate(a: list[list[ca.SX]], p: int, q: int) -> None:
    """The Jacobi rotation that zeroes ``a[p][q]`` of the symmetric ``a``, in place (Golub
    and Van Loan's ``sym.schur2``: ``tau = (a_qq - a_pp) / 2 a_pq``, ``t = sgn(tau) /
    (|tau| + sqrt(1 + tau^2))``, no rotation where ``a_pq = 0``)."""
    apq = a[p][q]
    zero = apq == 0
    tau = (a[q][q] - a[p][p]) / (2.0 * ca.if_else(zero, 1.0, apq))
    t = ca.if_else(zero, 0.0, ca.copysign(1.0, tau) / (ca.fabs(tau) + ca.sqrt(1.0 + tau * tau)))
    c = 1.0 / ca.sqrt(1.0 + t * t)
    s = t * c
    for k in range(len(a)):
        if k in (p, q):
            continue
        akp, akq = a[k][p], a[k][q]
        a[k][p] = a[p][k] = c * akp - s * akq
        a[k][q] = a[q][k] = s * akp + c * akq
    a[p][p] = a[p][p] - t * apq
    a[q][q] = a[q][q] + t * apq
    a[p][q] = a[q][p] = ca.SX(0.0)
