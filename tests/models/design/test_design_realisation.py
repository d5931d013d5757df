"""The position-only filters (Eq. 13, 20, 25) against the laws they realise,
evaluated with the known derivative of a smooth error signal."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from posfb.models.design import compute_design
from posfb.models.design.realisation import (
    ContinuousFilter,
    linear_control_filter,
    nonlinear_control_filter,
    velocity_bound_filter,
)

SAMPLE_TIMES = (0.01, 0.005, 0.0025)
DURATION = 1.0
A_ZETA, B_ZETA, C_ZETA = -10.0 * np.eye(2), 10.0 * np.eye(2), np.eye(2)


def error(t: float) -> np.ndarray:
    """A smooth test error ``q~(t)``, not at rest at ``t = 0``."""
    return np.array([0.02 * np.sin(5 * t) + 0.01 * t, 0.03 * (np.cos(3 * t) - 1) + 0.02 * t**2])


def error_rate(t: float) -> np.ndarray:
    return np.array([0.1 * np.cos(5 * t) + 0.01, -0.09 * np.sin(3 * t) + 0.04 * t])


@pytest.fixture(scope="module")
def design():
    return compute_design()


def _reference(rhs, size: int, times: np.ndarray) -> np.ndarray:
    """Solution from a zero state (filters at rest), sampled at ``times`` (size x N)."""
    solution = solve_ivp(rhs, (0.0, times[-1]), np.zeros(size), t_eval=times, rtol=1e-11,
                         atol=1e-13, method="DOP853")  # fmt: skip
    return solution.y


def _sampled(filt: ContinuousFilter, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Run the FOH-discretised filter on the samples of ``error``: (times, outputs)."""
    discrete = filt.discretise(T, "foh")
    times = np.arange(0.0, DURATION + T / 2, T)
    state = discrete.initial @ error(0.0)
    outputs = []
    for t in times:
        e = error(t)
        outputs.append(discrete.C @ state + discrete.D @ e)
        state = discrete.A @ state + discrete.B @ e
    return times, np.array(outputs).T


def _errors(filt: ContinuousFilter, reference) -> list[float]:
    """Largest deviation from the reference, relative to its peak, per sample time."""
    result = []
    for T in SAMPLE_TIMES:
        times, outputs = _sampled(filt, T)
        expected = reference(times)
        result.append(float(np.abs(outputs - expected).max() / np.abs(expected).max()))
    return result


def _assert_converges(errors: list[float]) -> None:
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] < 1e-3, errors
    assert np.all(orders > 1.7), orders  # FOH: second order on smooth signals


def _eq12(design, t, eta):
    """Eq. 9 with the state feedback of Eq. 12: ``eta~' = A_eta eta~ - K x~``."""
    v = -design.K1 @ error(t) - design.K2 @ error_rate(t) - design.K3 @ eta
    return design.A_eta @ eta + v


def test_position_only_eq13_equals_state_feedback_eq12(design):
    filt = linear_control_filter(design.K1, design.K2, design.K3, design.A_eta)
    errors = _errors(filt, lambda times: _reference(lambda t, x: _eq12(design, t, x), 2, times))
    _assert_converges(errors)


def test_position_only_phi_equals_eq20(design):
    """``phi = H(s) (E1 q~ + E2 q~' + E3 eta~)`` with ``eta~`` of Eq. 12."""

    def rhs(t, x):
        eta, zeta = x[:2], x[2:]
        z = design.E1 @ error(t) + design.E2 @ error_rate(t) + design.E3 @ eta
        return np.concatenate([_eq12(design, t, eta), A_ZETA @ zeta + B_ZETA @ z])

    def reference(times):
        states = _reference(rhs, 4, times)
        return np.vstack([states[:2], C_ZETA @ states[2:]])

    filt = nonlinear_control_filter(
        design.K1, design.K2, design.K3, design.A_eta, design.E, A_ZETA, B_ZETA, C_ZETA
    )
    _assert_converges(_errors(filt, reference))


def test_velocity_bound_filter_is_sG_and_s2G2(design):
    """``p = G(s) q~'`` and ``pbar = G(s) p'`` (reading note 3), from ``p(0) = pbar(0) = 0``."""
    a = 100.0

    def rhs(t, x):
        p, pbar = x[:2], x[2:]
        p_rate = a * (error_rate(t) - p)
        return np.concatenate([p_rate, a * (p_rate - pbar)])

    _assert_converges(_errors(velocity_bound_filter(a, 2), lambda times: _reference(rhs, 4, times)))


def test_filters_start_at_rest(design):
    """The first output has ``eta~ = 0``, ``phi = 0``, ``p = pbar = 0`` whatever ``q~(0)``."""
    discrete = design.proposed_filter
    e0 = np.array([0.3, -0.2])
    np.testing.assert_allclose(discrete.C @ (discrete.initial @ e0) + discrete.D @ e0, 0.0,
                               atol=1e-9)  # fmt: skip
