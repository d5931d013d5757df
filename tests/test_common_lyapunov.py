"""The common quadratic Lyapunov certificate (``models.design.common_lyapunov``): closed-form
answers (a scalar set, a nilpotent pair), the certificate's claim checked on a fine grid of
the hull, the numeric check of the solver's answer, and the design report's use of it."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from posfb.models.design.common_lyapunov import common_lyapunov, decay_rate


def test_scalars_share_one_iff_every_one_is_inside_the_unit_circle():
    # V = x^2 decreases for every a_i with |a_i| < 1; one |a| >= 1 has no V at all
    found = common_lyapunov([np.array([[0.5]]), np.array([[-0.9]])])
    assert found.feasible and found.decay == pytest.approx(0.9, abs=1e-6)
    refused = common_lyapunov([np.array([[0.5]]), np.array([[1.01]])])
    assert not refused.feasible and "loop 1" in refused.message and refused.P is None


@pytest.mark.parametrize(("c", "exists"), [(0.5, True), (0.9, True), (1.1, False), (2.0, False)])
def test_nilpotent_pair_shares_one_iff_c_below_one(c, exists):
    # A1 = [[0, c], [0, 0]], A2 = [[0, 0], [c, 0]]: both nilpotent (spectral radius 0, so
    # the radius test cannot decide). P = diag(p1, p2): A1^T P A1 = diag(0, c^2 p1) < P
    # needs c^2 p1 < p2, A2 needs c^2 p2 < p1, together c^4 < 1. For |c| >= 1, A1 A2 =
    # diag(c^2, 0) has eigenvalue c^2 >= 1: switching between them does not converge, so no
    # common quadratic Lyapunov function exists.
    A1, A2 = np.array([[0.0, c], [0.0, 0.0]]), np.array([[0.0, 0.0], [c, 0.0]])
    found = common_lyapunov([A1, A2])
    assert found.feasible is exists
    if exists:
        assert decay_rate(found.P, [A1, A2]) < 1.0


def _rotations(P_root: np.ndarray, angles: list[float], scale: float) -> list[np.ndarray]:
    """``scale * R^-1 O R`` with ``O`` plane rotations: each contracts ``||R x||``."""
    n = len(P_root)
    out = []
    for angle in angles:
        rotation = np.eye(n)
        rotation[:2, :2] = [[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]]
        out.append(scale * np.linalg.solve(P_root, rotation @ P_root))
    return out


def test_certified_means_every_frozen_loop_of_the_hull_is_stable():
    rng = np.random.default_rng(7)
    root = rng.normal(size=(4, 4)) + 4 * np.eye(4)
    loops = _rotations(root, [0.3, 1.4, 2.6], 0.9)
    found = common_lyapunov(loops)
    assert found.feasible
    # a simplex grid of the hull of the three: every convex combination is Schur and
    # contracts in the certificate's P
    for i in range(21):
        for j in range(21 - i):
            w = np.array([i, j, 20 - i - j]) / 20.0
            A = sum(weight * loop for weight, loop in zip(w, loops, strict=True))
            assert np.max(np.abs(np.linalg.eigvals(A))) < 1.0
            assert decay_rate(found.P, [A]) < 1.0


def _held_double_integrator(mass: float, T: float = 0.01) -> np.ndarray:
    """A mass under a fixed sampled PD law (gains designed for mass 1), held over T."""
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0 / mass]])
    block = scipy.linalg.expm(np.block([[A, B], [np.zeros((1, 3))]]) * T)
    Phi, Gamma = block[:2, :2], block[:2, 2:]
    K = np.array([[400.0, 30.0]])
    return Phi - Gamma @ K


def test_a_sampled_mass_that_varies_within_a_range_is_certified():
    loops = [_held_double_integrator(m) for m in (0.5, 1.0, 2.0)]
    assert all(np.max(np.abs(np.linalg.eigvals(A))) < 1.0 for A in loops)
    found = common_lyapunov(loops)
    assert found.feasible and found.decay < 1.0
    np.testing.assert_allclose(found.P, found.P.T)
    assert np.linalg.eigvalsh(found.P)[0] == pytest.approx(1.0)


def test_two_stable_loops_whose_switching_diverges_are_not_certified():
    # each is Schur (eigenvalues 0.5 +- 0.5 i sqrt(...)), their product is not
    A1 = np.array([[0.5, 3.0], [0.0, 0.5]])
    A2 = np.array([[0.5, 0.0], [3.0, 0.5]])
    assert np.max(np.abs(np.linalg.eigvals(A1 @ A2))) > 1.0
    assert not common_lyapunov([A1, A2]).feasible


@pytest.mark.parametrize(
    ("transitions", "needle"),
    [
        ([], "transitions is empty"),
        ([np.zeros((2, 3))], r"transitions\[0\] has shape \(2, 3\)"),
        ([np.eye(2), np.eye(3)], r"transitions\[1\] has shape \(3, 3\)"),
        ([np.array([[math.nan]])], r"transitions\[0\] has a non-finite entry"),
    ],
)
def test_bad_input_is_refused_by_name(transitions, needle):
    with pytest.raises(ValueError, match=needle):
        common_lyapunov(transitions)
