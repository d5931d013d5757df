"""The common-Lyapunov margin program solved by an independent solver, cvxpy with Clarabel
(posfb's dev extra): the reference ``models.design.lyapunov_sdp`` is checked against in the
tests and timed against in ``bench/bench_lyapunov_sdp.py``."""

from __future__ import annotations

import numpy as np


def clarabel_margin(loops: list[np.ndarray]) -> float:
    """The optimum ``s`` of ``max s: tr P = 1, P >= s I, P - A_i^T P A_i >= s I`` (every
    ``A_i`` of ``loops``), by cvxpy with Clarabel at its defaults."""
    import cvxpy

    n = len(loops[0])
    P, s = cvxpy.Variable((n, n), symmetric=True), cvxpy.Variable()
    constraints = [P >> s * np.eye(n), cvxpy.trace(P) == 1]
    for A in loops:
        decrease = P - A.T @ P @ A
        constraints.append(0.5 * (decrease + decrease.T) >> s * np.eye(n))
    cvxpy.Problem(cvxpy.Maximize(s), constraints).solve(solver=cvxpy.CLARABEL)
    return float(s.value)
