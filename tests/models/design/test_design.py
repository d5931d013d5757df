"""The design maths of Sec. 3 against independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
import scipy.signal
from pydrake.systems.controllers import LinearQuadraticRegulator

from posfb.models.design import (
    ControllerConfig,
    LqrWeights,
    UncertaintyBounds,
    compute_design,
    diagonal,
)
from posfb.models.design.bounds import bound_filter_constants, coriolis_bound, resolve_bounds
from posfb.models.design.closed_loop import continuous_closed_loop, spectral_radius
from posfb.models.design.discretise import first_order_hold, zero_order_hold
from posfb.models.design.loop_context import LoopContext
from posfb.models.design.realisation import ContinuousFilter
from posfb.models.design.spr import spr_certificate
from posfb.models.lumped import TABLE1, LumpedModel


@pytest.fixture(scope="module")
def paper():
    return compute_design()


def test_K_and_P_match_drake_lqr(paper):
    K, S = LinearQuadraticRegulator(
        paper.A_a, paper.B_a1, LqrWeights().Q, np.asarray(LqrWeights().R)
    )
    np.testing.assert_allclose(paper.K, K, rtol=1e-8, atol=1e-8 * np.abs(K).max())
    np.testing.assert_allclose(paper.P, S, rtol=1e-8, atol=1e-8 * np.abs(S).max())
    np.testing.assert_allclose(paper.K, np.hstack([paper.K1, paper.K2, paper.K3]))


def test_closed_loop_is_hurwitz_and_riccati_residual_vanishes(paper):
    assert np.linalg.eigvals(paper.A_a - paper.B_a1 @ paper.K).real.max() < 0.0
    np.testing.assert_allclose(np.sort(paper.continuous_poles.real), np.sort(
        np.linalg.eigvals(paper.A_a - paper.B_a1 @ paper.K).real))  # fmt: skip
    R = np.asarray(LqrWeights().R)
    A, B1, P = paper.A_a, paper.B_a1, paper.P
    residual = A.T @ P + P @ A - P @ B1 @ np.linalg.solve(R, B1.T @ P) + LqrWeights().Q
    assert np.abs(residual).max() < 1e-8 * np.abs(LqrWeights().Q).max()
    assert np.linalg.eigvalsh(P).min() > 0.0


def test_augmented_system_is_eq_11(paper):
    """``x~' = A_a x~ + B_a1 v~``: ``q~'' = M0*^-1 (-B* q~' + eta~)``,
    ``eta~' = A_eta eta~ + v~``."""
    rng = np.random.default_rng(3)
    x, v = rng.normal(size=6), rng.normal(size=2)
    model = LumpedModel()
    M0, B = model.M0(), model.B()
    expected = np.concatenate(
        [x[2:4], np.linalg.solve(M0, -B @ x[2:4] + x[4:6]), -10.0 * x[4:6] + v]
    )
    np.testing.assert_allclose(paper.A_a @ x + paper.B_a1 @ v, expected, rtol=1e-12)
    np.testing.assert_allclose(paper.B_a2[2:4], np.linalg.inv(M0))


def test_E_is_the_lyapunov_cross_term(paper):
    """``2 x~^T P B_a2 w = 2 z^T w`` with ``z = E x~`` (Sec. 3.3), so ``E^T = P B_a2``."""
    np.testing.assert_allclose(paper.E.T, paper.P @ paper.B_a2, rtol=1e-10)
    np.testing.assert_allclose(paper.E, np.hstack([paper.E1, paper.E2, paper.E3]))
    assert paper.coupling_norm == pytest.approx(np.linalg.norm(paper.P @ paper.B_a2, 2))


def test_riccati_without_solution_is_refused():
    weights = LqrWeights(Q1=diagonal((1e12, 0.0, 0.0, 0.0)))
    with pytest.raises(ValueError, match="Q1, Q2, R: the Riccati equation"):
        compute_design(ControllerConfig(lqr=weights))


def test_non_stabilising_lqr_is_a_failed_check_and_refused_by_controllers():
    from posfb.models.controllers import make_controller

    config = ControllerConfig(lqr=LqrWeights(Q1=diagonal((0.0, 0.0, 0.0, 0.0))))
    design = compute_design(config)
    assert any("Riccati" in w or "LQR" in w for w in design.warnings)
    for kind in ("lin_lc", "proposed"):
        with pytest.raises(ValueError, match="Q1, Q2, R"):
            make_controller(kind, config)


def _min_hermitian_part(A, B, C, omegas):
    n = len(A)
    values = []
    for w in omegas:
        H = C @ np.linalg.solve(1j * w * np.eye(n) - A, B)
        values.append(np.linalg.eigvalsh(H + H.conj().T).min())
    return np.array(values)


def test_paper_filter_is_spr_with_gamma_point_one(paper):
    np.testing.assert_allclose(paper.Gamma, 0.1 * np.eye(2))
    assert paper.kyp_gamma == pytest.approx(5.0)
    omegas = np.logspace(-2, 4, 200)
    assert _min_hermitian_part(-10 * np.eye(2), 10 * np.eye(2), np.eye(2), omegas).min() > 0


@pytest.mark.parametrize(
    ("A", "B", "C", "reason"),
    [
        ([[1.0, 0.0], [0.0, -1.0]], [[1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 1.0]], "A_zeta"),
        ([[-1.0, 0.0], [0.0, -1.0]], [[1.0, 0.0], [0.0, 0.0]], [[1.0, 0.0], [0.0, 1.0]], "degree"),
        ([[-1.0, 0.0], [0.0, -1.0]], [[1.0, 0.0], [0.0, 1.0]], [[1.0, 1.0], [0.0, 1.0]], "symm"),
        ([[-1.0, 0.0], [0.0, -1.0]], [[-1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 1.0]], "defin"),
        ([[-1.0, 10.0], [0.0, -1.0]], [[1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 1.0]], "negat"),
    ],
)
def test_non_spr_filters_fail_the_kyp_check(A, B, C, reason):
    A, B, C = (np.asarray(m) for m in (A, B, C))
    certificate = spr_certificate(A, B, C)
    assert not certificate.is_spr
    assert reason in certificate.reason
    if reason == "negat":  # stable, Gamma = I, yet H(jw) + H(jw)^* is indefinite somewhere
        assert _min_hermitian_part(A, B, C, np.logspace(-2, 2, 400)).min() < 0.0


def test_bound_filter_constants_of_sec_3_4():
    at_100hz = bound_filter_constants(100.0, 0.01)
    assert at_100hz.abar == pytest.approx(math.exp(-1.0))
    assert at_100hz.c == pytest.approx(1.0 - 2.0 * math.exp(-1.0))
    assert at_100hz.valid
    at_200hz = bound_filter_constants(100.0, 0.005)
    assert at_200hz.min_a == pytest.approx(math.log(2.0) / 0.005)
    assert not at_200hz.valid


def test_k_C1_bounds_the_coriolis_matrix_tightly():
    k_C1 = coriolis_bound(TABLE1)
    model = LumpedModel()
    rng = np.random.default_rng(11)
    ratios = []
    for _ in range(4000):
        q, x, y = rng.uniform(-np.pi, np.pi, 2), rng.normal(size=2), rng.normal(size=2)
        ratios.append(np.linalg.norm(model.C(q, x) @ y) / (np.linalg.norm(x) * np.linalg.norm(y)))
    assert max(ratios) <= k_C1 * (1 + 1e-9)
    q, x = np.array([0.0, np.pi / 2]), np.array([1.0, 0.0])
    assert np.linalg.norm(model.C(q, x), 2) == pytest.approx(k_C1, rel=1e-6)


def test_resolved_bounds_default_to_half_the_nominal_norms():
    model = LumpedModel()
    bounds = resolve_bounds(UncertaintyBounds(), TABLE1)
    assert bounds.delta_M0 == pytest.approx(0.5 * np.linalg.norm(model.M0(), 2))
    assert bounds.delta_B == pytest.approx(0.5 * TABLE1.theta5)
    assert bounds.F_norm == pytest.approx(math.hypot(TABLE1.theta6, TABLE1.theta11))
    grid = np.linspace(-np.pi, np.pi, 73)
    largest_G = max(np.linalg.norm(model.G(np.array([a, b]))) for a in grid for b in grid)
    assert bounds.delta_G == pytest.approx(0.5 * largest_G, rel=1e-9)
    explicit = resolve_bounds(UncertaintyBounds(delta_G=0.25, k_C1=1.0), TABLE1)
    assert (explicit.delta_G, explicit.k_C1, explicit.delta_C) == (0.25, 1.0, 0.5)


def test_delta_bar_is_eq_18():
    b = resolve_bounds(UncertaintyBounds(relative=0.1), TABLE1)
    M1, U1, U2, v, a = 0.03, 0.2, 3.0, 1.5, 7.0
    expected = (
        M1 * U2 + (b.delta_M1 + b.delta_M0) * (U2 + a) + b.delta_B * (U1 + v)
        + (b.k_C1 + b.delta_C) * U1 * (U1 + 2 * v) + b.delta_C * v**2
        + b.delta_G + b.delta_F + 2 * b.F_norm
    )  # fmt: skip
    assert b.delta_bar(M1, U1, U2, v, a) == pytest.approx(expected)


def test_holds_match_scipy_and_foh_is_exact_on_ramps():
    rng = np.random.default_rng(5)
    A, B = rng.normal(size=(3, 3)) - 3 * np.eye(3), rng.normal(size=(3, 2))
    C, D = rng.normal(size=(2, 3)), rng.normal(size=(2, 2))
    T = 0.02
    Phi, Gamma = zero_order_hold(A, B, T)
    Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, C, D), T, method="zoh")
    np.testing.assert_allclose(np.hstack([Phi, Gamma]), np.hstack([Ad, Bd]), rtol=1e-12, atol=1e-14)
    discrete = ContinuousFilter(A, B, C, D, np.zeros((3, 2))).discretise(T, "foh")
    Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((A, B, C, D), T, method="foh")
    ours = (discrete.A, discrete.B, discrete.C, discrete.D)
    for mine, theirs in zip(ours, (Ad, Bd, Cd, Dd), strict=True):
        np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-14)
    # integrator x' = u driven by the ramp u = t: x(T) = T^2 / 2 exactly
    Phi, Gamma0, Gamma1 = first_order_hold(np.zeros((1, 1)), np.ones((1, 1)), T)
    assert (Phi @ [0.0] + Gamma0 @ [0.0] + Gamma1 @ [T])[0] == pytest.approx(T**2 / 2)


def test_continuous_loop_with_nc_matches_the_full_state_loop(paper):
    """Plant + position-only filters at alpha* against ``x~' = (A_a - B_a1 K) x~ -
    alpha* B_a2 C_zeta zeta``, ``zeta' = A_zeta zeta + B_zeta E x~`` (Sec. 3.3)."""
    alpha = ControllerConfig().nonlinear.alpha_star
    full = np.block(
        [
            [paper.A_a - paper.B_a1 @ paper.K, -alpha * paper.B_a2],
            [10.0 * paper.E, -10.0 * np.eye(2)],
        ]
    )
    expected = np.linalg.eigvals(full)
    np.testing.assert_allclose(
        np.sort_complex(paper.continuous_poles_with_nc), np.sort_complex(expected), rtol=1e-8
    )


def test_sampled_data_radius_against_scipy_holds(paper):
    """The loop rebuilt with scipy's ZOH for the filters (the default) and the plant."""
    from posfb.models.design.realisation import nonlinear_control_filter

    T, alpha = 0.01, ControllerConfig().nonlinear.alpha_star
    nc = nonlinear_control_filter(
        paper.K1, paper.K2, paper.K3, paper.A_eta, paper.E,
        -10 * np.eye(2), 10 * np.eye(2), np.eye(2),
    )  # fmt: skip
    gain = np.hstack([np.eye(2), -alpha * np.eye(2)])
    Ac, Bc, Cc, Dc, _ = scipy.signal.cont2discrete((nc.A, nc.B, gain @ nc.C, gain @ nc.D), T, "zoh")
    M0_inv = np.linalg.inv(paper.M0)
    Ap = np.block([[np.zeros((2, 2)), np.eye(2)], [np.zeros((2, 2)), -M0_inv @ paper.B]])
    Bp = np.vstack([np.zeros((2, 2)), M0_inv])
    Pd, Gd, *_ = scipy.signal.cont2discrete((Ap, Bp, np.eye(4), np.zeros((4, 2))), T, "zoh")
    Cq = np.hstack([np.eye(2), np.zeros((2, 2))])
    loop = np.block([[Pd + Gd @ Dc @ Cq, Gd @ Cc], [Bc @ Cq, Ac]])
    assert paper.sampled_data_spectral_radius == pytest.approx(spectral_radius(loop), rel=1e-10)
    # and sampling-free limit: the radius tends to exp(T max Re s) of the continuous loop
    fine = compute_design(ControllerConfig(LoopContext(sample_time=1e-4)))
    slowest = continuous_closed_loop(paper.M0, paper.B, nc, gain)
    limit = math.exp(1e-4 * np.linalg.eigvals(slowest).real.max())
    assert fine.sampled_data_spectral_radius == pytest.approx(limit, abs=1e-5)


def test_paper_settings_at_100_and_200_hz(paper):
    """Sec. 4.2 at 100 Hz: the linearised sampled-data loop is unstable at alpha* = 4
    (reported, not hidden); at 200 Hz it is stable but a = 100 <= ln 2 / T_s."""
    assert paper.sampled_data_spectral_radius > 1.0
    assert paper.sampled_data_spectral_radius_lin_lc < 1.0
    assert [c.name for c in paper.checks if not c.passed] == ["sampled_data"]
    assert "UNSTABLE" in paper.warnings[0]
    at_200hz = compute_design(ControllerConfig(LoopContext(sample_time=0.005)))
    assert at_200hz.sampled_data_spectral_radius < 1.0
    assert [c.name for c in at_200hz.checks if not c.passed] == ["bound_filter"]
    assert "filter_a = 100" in at_200hz.warnings[0]


def _care_residual(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, P: np.ndarray):
    """``||A'P + PA - P B R^-1 B' P + Q|| / ||Q||`` (Eq. 15) and the closed loop's slowest
    pole real part."""
    K = np.linalg.solve(R, B.T @ P)
    residual = A.T @ P + P @ A - P @ B @ K + Q
    return np.abs(residual).max() / np.abs(Q).max(), np.linalg.eigvals(A - B @ K).real.max()


def test_fast_weights_are_solved_in_scaled_units() -> None:
    """``scenario init``'s LQR rule at 5 kHz on the three-link arm (Q from 1e-3 to 1e11)
    defeated scipy 1.11's Schur method as written (issue 27); scipy 1.17 solves it with a
    relative residual of 3e-10 (measured). The scaled solve that ``solve_lqr`` falls back
    on reaches round-off (measured 4e-15) with a Hurwitz closed loop, and ``solve_lqr``
    returns a stabilising solution whichever scipy release it runs on."""
    from posfb.models.design.augmented import _scaled_care, augmented_system, solve_lqr
    from posfb.models.design.initial import lqr_weights
    from posfb.models.plant import DEFAULT_URDF
    from posfb.models.serial_model import SerialArmModel

    model = SerialArmModel(DEFAULT_URDF.with_name("three_link_arm.urdf"))
    weights = lqr_weights(model.M0(), 2e-4).lqr()
    system = augmented_system(model.M0(), model.B(), np.asarray(weights.lambdas))
    Q, R = weights.Q, np.asarray(weights.R)
    residual, slowest = _care_residual(
        system.A_a, system.B_a1, Q, R, _scaled_care(system.A_a, system.B_a1, Q, R)
    )
    assert residual < 1e-12
    assert slowest < 0.0
    solution = solve_lqr(system, Q, R)
    residual, slowest = _care_residual(system.A_a, system.B_a1, Q, R, solution.P)
    assert residual < 1e-8
    assert slowest < 0.0


def test_scaled_units_give_scipys_solution_where_both_solve() -> None:
    """On the paper's weights the scaled solve equals scipy's own to 1e-9."""
    from posfb.models.design.augmented import _scaled_care, augmented_system

    config = ControllerConfig()
    model = LumpedModel(TABLE1)
    system = augmented_system(model.M0(), model.B(), np.asarray(config.lqr.lambdas))
    Q, R = config.lqr.Q, np.asarray(config.lqr.R)
    direct = scipy.linalg.solve_continuous_are(system.A_a, system.B_a1, Q, R)
    np.testing.assert_allclose(_scaled_care(system.A_a, system.B_a1, Q, R), direct, rtol=1e-9)
