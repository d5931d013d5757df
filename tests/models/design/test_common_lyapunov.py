"""``models.design.common_lyapunov``: closed-form answers (scalar loops, a nilpotent pair
whose switching is stable exactly when ``|c| < 1``), loops built around a known common
``P``, a sampled-data pair, badly scaled loops, and the numeric check that a solver's
answer must pass."""

from __future__ import annotations

import importlib

import numpy as np
import pytest
import scipy.linalg
from scipy.stats import ortho_group

from posfb.models.design.common_lyapunov import (
    common_lyapunov,
    decay_rate,
    spectral_radius,
    verify,
)
from posfb.models.design.discretise import zero_order_hold
from posfb.models.disk_cache import CACHE_ENV

#: The module (for monkeypatching its solver), by name: a package that re-exports the
#: function ``common_lyapunov`` would shadow the attribute of the same name.
module = importlib.import_module("posfb.models.design.common_lyapunov")


def _hull_pair(A1, A2, points=50):
    return [(1 - s) * A1 + s * A2 for s in np.linspace(0.0, 1.0, points)]


def _hull_triple(A1, A2, A3, divisions=30):
    """A simplex grid of the triangle: ``(i A1 + j A2 + k A3) / divisions``, ``i+j+k = d``."""
    return [
        (i * A1 + j * A2 + (divisions - i - j) * A3) / divisions
        for i in range(divisions + 1)
        for j in range(divisions + 1 - i)
    ]


def _around(P, rate, orthogonals):
    """``A_i = rate P^-1/2 O_i P^1/2``: ``A_i^T P A_i = rate^2 P`` for orthogonal ``O_i``,
    so ``P`` is a common Lyapunov matrix with decay exactly ``rate``."""
    root = scipy.linalg.sqrtm(P).real
    return [rate * np.linalg.solve(root, O @ root) for O in orthogonals]


def _random_spd(rng, n, condition=20.0):
    Q = ortho_group.rvs(n, random_state=rng)
    return Q @ np.diag(np.geomspace(1.0, condition, n)) @ Q.T


# ---- closed forms -------------------------------------------------------------------------


def test_scalar_loops_share_p_1_when_every_one_is_stable():
    # For scalars a_i, p (a_i^2 - 1) < 0 for one p > 0 exactly when every |a_i| < 1, and the
    # decay is max |a_i| whatever p is.
    certificate = common_lyapunov([np.array([[0.5]]), np.array([[-0.9]])])
    assert certificate.feasible, certificate.message
    np.testing.assert_allclose(certificate.P, [[1.0]])
    assert certificate.decay == pytest.approx(0.9, rel=1e-9)
    assert certificate.condition == pytest.approx(1.0)
    assert certificate.loops == 2


def test_a_loop_of_spectral_radius_one_or_more_is_refused_without_a_solve(monkeypatch):
    def no_solve(matrices):
        raise AssertionError("the short-cut must decide without the solver")

    monkeypatch.setattr(module, "_solve", no_solve)
    certificate = common_lyapunov([np.array([[0.5]]), np.array([[1.01]])])
    assert not certificate.feasible
    assert certificate.P is None
    assert np.isnan(certificate.decay) and np.isnan(certificate.condition)
    assert certificate.loops == 2
    assert "transitions[1]" in certificate.message and "1.01" in certificate.message


# A1 = [[0, c], [0, 0]] and A2 = [[0, 0], [c, 0]] are nilpotent (spectral radius 0), so
# the radius short-cut never decides them: the LMI does. With P = diag(p1, p2) (a common P
# may be taken diagonal: the pair is invariant under x2 -> -x2, so averaging P with its
# reflection keeps it a solution), A1^T P A1 = diag(0, c^2 p1) < P needs c^2 p1 < p2 and
# A2^T P A2 = diag(c^2 p2, 0) < P needs c^2 p2 < p1, so c^4 < 1: |c| < 1 (P = I then works,
# with decay |c|). For |c| >= 1, A1 A2 = diag(c^2, 0) has the eigenvalue c^2 >= 1, so
# switching A2, A1, A2, A1, ... does not converge, and no common quadratic Lyapunov
# function exists. And any common P has decay >= |c|: ||A1 A2||_P <= decay^2 and the
# spectral radius c^2 of A1 A2 is at most its P-norm.
def _nilpotent_pair(c):
    return [np.array([[0.0, c], [0.0, 0.0]]), np.array([[0.0, 0.0], [c, 0.0]])]


def test_the_nilpotent_pair_has_a_common_function_for_c_below_one():
    certificate = common_lyapunov(_nilpotent_pair(0.9))
    assert certificate.feasible, certificate.message
    assert 0.9 - 1e-9 <= certificate.decay < 1.0
    assert verify(certificate.P, _nilpotent_pair(0.9)) == pytest.approx(certificate.decay**2)


def test_the_nilpotent_pair_has_none_for_c_above_one():
    pair = _nilpotent_pair(1.1)
    assert max(map(spectral_radius, pair)) == 0.0
    assert spectral_radius(pair[0] @ pair[1]) == pytest.approx(1.21)
    certificate = common_lyapunov(pair)
    assert not certificate.feasible
    assert certificate.P is None and np.isnan(certificate.decay)
    assert "infeasible" in certificate.message


def test_verify_is_the_squared_decay_of_a_known_p():
    rng = np.random.default_rng(7)
    P = _random_spd(rng, 4)
    loops = _around(P, 0.8, [ortho_group.rvs(4, random_state=rng) for _ in range(3)])
    assert verify(P, loops) == pytest.approx(0.64, rel=1e-9)
    assert decay_rate(P, loops) == pytest.approx(0.8, rel=1e-9)
    assert verify(np.eye(4), [np.eye(4) * 0.5]) == pytest.approx(0.25)


# ---- a certificate covers the hull -------------------------------------------------------


@pytest.mark.parametrize(("seed", "count", "n"), [(0, 2, 3), (1, 2, 5), (2, 3, 4), (3, 3, 3)])
def test_a_certificate_makes_every_loop_of_the_hull_stable(seed, count, n):
    rng = np.random.default_rng(seed)
    loops = _around(_random_spd(rng, n), 0.9,
                    [ortho_group.rvs(n, random_state=rng) for _ in range(count)])  # fmt: skip
    certificate = common_lyapunov(loops)
    assert certificate.feasible, certificate.message
    assert certificate.loops == count
    assert certificate.decay < 1.0
    assert np.linalg.eigvalsh(certificate.P)[0] == pytest.approx(1.0)
    assert certificate.condition == pytest.approx(np.linalg.cond(certificate.P))
    hull = _hull_pair(*loops) if count == 2 else _hull_triple(*loops)
    assert max(map(spectral_radius, hull)) < 1.0
    # the Lyapunov inequality on the whole grid with the returned P, at the common rate
    assert verify(certificate.P, hull) <= certificate.decay**2 * (1 + 1e-9)
    for A in hull[:: len(hull) // 7]:
        assert np.linalg.eigvalsh(A.T @ certificate.P @ A - certificate.P)[-1] < 0.0


def test_many_loops_are_taken_in_batches_and_checked_on_all():
    rng = np.random.default_rng(4)
    loops = _around(_random_spd(rng, 3), 0.9,
                    [ortho_group.rvs(3, random_state=rng) for _ in range(10)])  # fmt: skip
    certificate = common_lyapunov(loops)
    assert certificate.feasible, certificate.message
    assert certificate.loops == 10
    assert verify(certificate.P, loops) < 1.0


def test_a_loop_outside_the_first_batch_can_make_the_set_infeasible():
    # Four benign loops of spectral radius 0.5 make the first batch (largest radii); the
    # nilpotent pair at c = 1.1 (radius 0) fails their P and is added: then infeasible.
    benign = [0.5 * np.eye(2), -0.5 * np.eye(2), np.diag([0.5, 0.2]), np.diag([0.2, -0.5])]
    certificate = common_lyapunov([*_nilpotent_pair(1.1), *benign])
    assert not certificate.feasible
    assert "LMI on 6 of them is infeasible" in certificate.message


# ---- sampled-data loops ---------------------------------------------------------------------


def _held_double_integrator(mass, T=0.05, damping=0.5, gains=(20.0, 6.0)):
    """``m x'' = -b x' + u`` with ``u_k = -K x_k`` held over ``T``: ``Phi - Gamma K``."""
    A = np.array([[0.0, 1.0], [0.0, -damping / mass]])
    B = np.array([[0.0], [1.0 / mass]])
    Phi, Gamma = zero_order_hold(A, B, T)
    return Phi - Gamma @ np.array([gains])


def test_a_held_state_feedback_at_two_masses_is_certified():
    loops = [_held_double_integrator(1.0), _held_double_integrator(2.0)]
    assert max(map(spectral_radius, loops)) < 1.0
    certificate = common_lyapunov(loops)
    assert certificate.feasible, certificate.message
    assert certificate.decay < 1.0
    assert verify(certificate.P, _hull_pair(*loops)) < 1.0


def test_two_stable_loops_whose_switching_diverges_have_no_common_function():
    # Each has spectral radius 0.8, but A1 A2 = 0.64 [[10, 3], [3, 1]] has spectral radius
    # 0.64 (5.5 + sqrt(29.25)) = 6.98 > 1; a common P would make ||A1 A2||_P < 1.
    A1 = 0.8 * np.array([[1.0, 3.0], [0.0, 1.0]])
    loops = [A1, A1.T]
    assert max(map(spectral_radius, loops)) == pytest.approx(0.8)
    assert spectral_radius(A1 @ A1.T) > 1.0
    certificate = common_lyapunov(loops)
    assert not certificate.feasible
    assert "infeasible" in certificate.message


# ---- scaling -------------------------------------------------------------------------------


def test_loops_with_entries_of_1e3_and_states_decades_apart():
    rng = np.random.default_rng(11)
    loops = _around(_random_spd(rng, 3), 0.9, [ortho_group.rvs(3, random_state=rng) for _ in
                                               range(2)])  # fmt: skip
    D = np.diag([1.0, 3e3, 1e-3])  # e.g. rad, V, rad s: a common P becomes D^-1 P D^-1
    scaled = [D @ A @ np.linalg.inv(D) for A in loops]
    assert np.max(np.abs(scaled)) > 1e3
    certificate = common_lyapunov(scaled)
    assert certificate.feasible, certificate.message
    np.linalg.cholesky(certificate.P)  # positive definite, though cond P ~ 1e13
    assert certificate.condition > 1e10
    assert verify(certificate.P, scaled) < 1.0


def test_spectral_radius_0_999():
    rng = np.random.default_rng(5)
    loops = _around(_random_spd(rng, 3), 0.999,
                    [ortho_group.rvs(3, random_state=rng) for _ in range(2)])  # fmt: skip
    jordan = [np.array([[0.999, 1.0], [0.0, 0.5]])]  # far from normal
    for case in (loops, jordan):
        certificate = common_lyapunov(case)
        assert certificate.feasible, certificate.message
        assert max(map(spectral_radius, case)) <= certificate.decay < 1.0


# ---- the numeric check ---------------------------------------------------------------------


def test_a_solver_answer_that_fails_in_numpy_is_not_a_certificate(monkeypatch):
    # I is not a Lyapunov matrix of a loop with ||A||_2 > 1, however stable: a solver that
    # claims it is optimal is overruled, and the message names the loop.
    monkeypatch.setattr(module, "_equation_candidate", lambda balanced, radii: None)
    monkeypatch.setattr(module, "_solve", lambda matrices: (np.eye(2), "optimal", 0.1))
    loops = [0.5 * np.eye(2), np.array([[0.5, 2.0], [0.0, 0.5]])]
    certificate = common_lyapunov(loops)
    assert not certificate.feasible
    assert certificate.P is None
    assert "transitions[1]" in certificate.message and "numeric check" in certificate.message


def test_close_loops_share_one_loop_s_lyapunov_equation(monkeypatch):
    # loops 1 % apart: the worst one's own Lyapunov equation holds for all, no SDP is run,
    # and the P found passes the independent check on every loop
    def no_sdp(matrices):
        raise AssertionError("the SDP ran")

    monkeypatch.setattr(module, "_solve", no_sdp)
    base = np.array([[0.9, 0.2], [-0.1, 0.7]])
    loops = [base * (1.0 + 0.01 * k) for k in range(-2, 3)]
    certificate = common_lyapunov(loops)
    assert certificate.feasible and "Lyapunov equation of one loop" in certificate.message
    assert verify(certificate.P, loops) < 1.0


def test_the_nilpotent_pair_at_c_one_is_neither_certified_nor_called_infeasible():
    # At c = 1 the best margin is exactly 0 ((1 - c^2) / 2, test_lyapunov_sdp.py): no strict
    # common P exists, and no dual Z proves it with room, so the search says it decided
    # neither, with a dual bound on the margin at rounding level.
    certificate = common_lyapunov(_nilpotent_pair(1.0))
    assert not certificate.feasible
    assert "proved neither a P nor infeasibility" in certificate.message
    bound = float(certificate.message.split("decrease margin above ")[1].split(" ")[0])
    assert 0.0 <= bound < 1e-8


def test_a_search_that_ends_without_an_answer_gives_its_dual_bound(monkeypatch):
    monkeypatch.setattr(module, "_equation_candidate", lambda balanced, radii: None)
    monkeypatch.setattr(module, "_solve", lambda matrices: (None, "not found", 0.25))
    certificate = common_lyapunov([0.5 * np.eye(2), np.array([[0.5, 0.3], [0.0, 0.4]])])
    assert not certificate.feasible
    assert "no P (tr P = 1) has a decrease margin above 0.25" in certificate.message


@pytest.mark.parametrize("case", ["equation", "sdp", "infeasible"])
def test_each_answer_is_read_from_the_cache_the_second_time(monkeypatch, tmp_path, case):
    # the cache keeps finite numbers only: every kind of answer must be one it can keep
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    base = np.array([[0.9, 0.2], [-0.1, 0.7]])
    loops = {
        "equation": [base * (1.0 + 0.01 * k) for k in range(-2, 3)],
        "sdp": [_held_double_integrator(1.0), _held_double_integrator(2.0)],
        "infeasible": _nilpotent_pair(1.1),
    }[case]
    first = common_lyapunov(loops)

    def searched_again(balanced, radii):
        raise AssertionError("the search ran again")

    monkeypatch.setattr(module, "_searched", searched_again)
    second = common_lyapunov(loops)
    assert second.message == first.message and second.feasible == first.feasible


# ---- input -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("transitions", "match"),
    [
        ([], r"transitions is empty"),
        ([np.zeros((2, 3))], r"transitions\[0\] has shape \(2, 3\).*square"),
        ([np.zeros(3)], r"transitions\[0\] has shape \(3,\)"),
        ([np.eye(2), np.eye(2), np.eye(3)], r"transitions\[2\] has shape \(3, 3\).*\(2, 2\)"),
        ([np.eye(2), np.array([[0.5, np.nan], [0.0, 0.5]])], r"transitions\[1\].*nan.*\(0, 1\)"),
        ([[["a"]]], r"transitions\[0\] is not a numeric array"),
        (np.eye(2), r"transitions is one \(2, 2\) matrix"),
    ],
)
def test_bad_transitions_are_refused_naming_the_parameter(transitions, match):
    with pytest.raises(ValueError, match=match):
        common_lyapunov(transitions)


def test_verify_refuses_a_p_that_is_not_positive_definite():
    with pytest.raises(ValueError, match="P is not positive definite"):
        verify(np.diag([1.0, -1.0]), [np.eye(2)])
    with pytest.raises(ValueError, match=r"P has shape \(3, 3\)"):
        verify(np.eye(3), [np.eye(2)])
