"""``diagrams.encoder``: quantisation to the nearest count, per-Context resolution."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from posfb.diagrams.encoder import DEFAULT_ENCODER_COUNTS, Encoder, quantise


def test_quantise_rounds_to_the_nearest_count():
    step = 2 * math.pi / 1000
    q = np.array([0.4 * step, 0.6 * step, -0.4 * step, -0.6 * step, 10.49 * step])
    np.testing.assert_allclose(quantise(q, 1000), [0.0, step, 0.0, -step, 10 * step])


def test_quantisation_error_is_at_most_half_a_count_and_zero_mean():
    q = np.random.default_rng(0).uniform(-3, 3, 20000)
    error = quantise(q, DEFAULT_ENCODER_COUNTS) - q
    half = math.pi / DEFAULT_ENCODER_COUNTS
    assert np.max(np.abs(error)) <= half * (1 + 1e-9)
    assert abs(np.mean(error)) < 0.02 * half


def test_zero_counts_is_an_ideal_sensor():
    q = np.array([0.123456789, -1.0])
    np.testing.assert_array_equal(quantise(q, 0), q)


def test_encoder_system_resolution_changes_per_context():
    encoder = Encoder(2, 1000)
    context = encoder.CreateDefaultContext()
    q = np.array([0.0031, -0.0094])
    encoder.get_input_port(0).FixValue(context, q)
    np.testing.assert_allclose(encoder.get_output_port(0).Eval(context), quantise(q, 1000))
    encoder.set_counts(context, 0)
    np.testing.assert_array_equal(encoder.get_output_port(0).Eval(context), q)
    assert encoder.counts(encoder.CreateDefaultContext()) == (1000, 1000)


@pytest.mark.parametrize("counts", [-1, 2.5, True])
def test_bad_counts_are_refused_by_name(counts):
    with pytest.raises(ValueError, match="encoder_counts"):
        Encoder(2, counts)


def test_counts_offset_and_noise_are_per_joint():
    encoder = Encoder(2, [1000, 0], noisy=True)
    context = encoder.CreateDefaultContext()
    q = np.array([0.0031, -0.0094])
    encoder.GetInputPort("q").FixValue(context, q)
    encoder.GetInputPort("unit_noise").FixValue(context, [1.0, -2.0])
    encoder.set_zero_offset(context, [0.01, 0.02])
    encoder.set_noise_std(context, [1e-3, 1e-4])
    step = 2 * math.pi / 1000
    expected = [step * round((q[0] + 0.01) / step) + 1e-3, q[1] + 0.02 - 2e-4]
    np.testing.assert_allclose(encoder.get_output_port(0).Eval(context), expected, rtol=1e-15)


@settings(max_examples=300, deadline=None)
@given(
    q=st.lists(st.floats(-50.0, 50.0), min_size=2, max_size=2),
    counts=st.lists(st.sampled_from([0, 1, 7, 1000, 4096, 20000, 2**20]), min_size=2, max_size=2),
    offset=st.lists(st.floats(-0.1, 0.1), min_size=2, max_size=2),
)
@pytest.mark.slow
def test_the_encoder_system_equals_the_vectorised_quantiser_bit_for_bit(q, counts, offset):
    """The system quantises joint by joint with Python floats (its per-sample fast path);
    it must give exactly the bits of the vectorised ``quantise`` (half to even in both)."""
    encoder = Encoder(2, 1000)
    context = encoder.CreateDefaultContext()
    encoder.set_counts(context, counts)
    encoder.set_zero_offset(context, offset)
    encoder.get_input_port(0).FixValue(context, q)
    expected = quantise(np.array(q) + np.array(offset), np.array(counts))
    np.testing.assert_array_equal(encoder.get_output_port(0).Eval(context), expected)


def test_exact_half_counts_round_to_even_like_numpy():
    step = 2 * math.pi / 4
    encoder = Encoder(2, 4)
    context = encoder.CreateDefaultContext()
    q = np.array([0.5, 1.5]) * step
    encoder.get_input_port(0).FixValue(context, q)
    np.testing.assert_array_equal(encoder.get_output_port(0).Eval(context), quantise(q, 4))
