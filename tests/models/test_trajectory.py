"""The desired trajectory of Sec. 4.2."""

from __future__ import annotations

import numpy as np
import pytest

from posfb.models.trajectory import SplineTrajectory, WaveTrajectory, desired, sampled_source


def test_starts_at_rest_hanging_down():
    q, qd, qdd = desired(0.0)
    np.testing.assert_allclose(q, [-np.pi / 2, 0.0], atol=1e-15)
    np.testing.assert_allclose(qd, 0.0, atol=1e-15)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-15)


def test_matches_the_printed_formula():
    t = 2.7
    s = 1 - np.exp(-2 * t**3)
    q1 = -np.pi / 2 + np.pi / 4 * s + np.pi / 9 * s * np.sin(4 * t)
    q2 = np.pi / 3 * s + np.pi / 6 * s * np.sin(3 * t)
    np.testing.assert_allclose(desired(t)[0], [q1, q2], rtol=1e-14)


@pytest.mark.parametrize("t", [0.3, 0.8, 1.5, 4.0, 11.3])
def test_derivatives_match_central_differences(t):
    h = 1e-5
    q_plus, qd_plus, _ = desired(t + h)
    q_minus, qd_minus, _ = desired(t - h)
    _, qd, qdd = desired(t)
    np.testing.assert_allclose(qd, (q_plus - q_minus) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(qdd, (qd_plus - qd_minus) / (2 * h), atol=1e-7)


def test_the_sampled_source_is_exact_at_every_sample_instant():
    T, samples = 0.01, 500
    for trajectory in (
        WaveTrajectory(),
        SplineTrajectory.from_waypoints([0.0, 2.0, 4.0], [[0, 0], [1, -1], [0.5, 0.2]]),
    ):
        source = sampled_source(trajectory, T, samples)
        context = source.CreateDefaultContext()
        for k in (0, 1, 7, 250, 399, samples - 1):
            context.SetTime(k * T)
            expected = np.concatenate(trajectory.evaluate(k * T))
            np.testing.assert_array_equal(source.get_output_port().Eval(context), expected)
