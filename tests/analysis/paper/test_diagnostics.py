"""``analysis.paper.diagnostics`` against independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from posfb.analysis.paper.diagnostics import (
    LoopEigen,
    ScanRow,
    band_rms,
    choose_alpha_star,
    model_voltage_rms,
    peak_frequency,
    pid_mismatch_prediction,
    sampled_data_scan,
)
from posfb.models.controllers import cached_design
from posfb.models.design import ControllerConfig
from posfb.models.lumped import TABLE1
from posfb.models.trajectory import WaveTrajectory


def test_scan_at_the_paper_alpha_star_matches_the_design_check():
    (row,) = sampled_data_scan((4.0,))
    assert row.design.radius == pytest.approx(
        cached_design(ControllerConfig()).sampled_data_spectral_radius, rel=1e-9
    )
    assert 5.0 < row.design.frequency < 50.0
    assert set(row.true_arm) == {"nominal", "payload"}


def test_choose_alpha_star_takes_the_largest_stable_value():
    def row(alpha, radii):
        return ScanRow(
            alpha,
            LoopEigen(radii[0], 1.0),
            {"nominal": LoopEigen(radii[0], 1.0), "payload": LoopEigen(radii[1], 1.0)},
        )

    rows = [row(4.0, (1.1, 1.0)), row(3.0, (0.9, 1.01)), row(2.0, (0.8, 0.95))]
    assert choose_alpha_star(rows) == 2.0
    assert choose_alpha_star(rows[:2]) is None


def test_band_rms_and_peak_frequency_on_a_two_tone_signal():
    T_s = 0.01
    t = np.arange(2000) * T_s
    signal = 0.3 * np.sin(2 * np.pi * 0.5 * t) + 0.01 * np.sin(2 * np.pi * 17 * t)
    assert band_rms(signal, T_s, 5.0) == pytest.approx(0.01 / math.sqrt(2), rel=1e-6)
    assert peak_frequency(signal, T_s) == pytest.approx(0.5)
    assert peak_frequency(signal, T_s, above=5.0) == pytest.approx(17.0)


def test_pid_mismatch_prediction_grows_with_the_payload():
    nominal = pid_mismatch_prediction("nominal", WaveTrajectory(), 2.0, 0.01)
    payload = pid_mismatch_prediction("payload", WaveTrajectory(), 2.0, 0.01)
    assert nominal[1] < 0.005 < payload[1]


def test_model_voltage_is_the_inverse_dynamics_rms():
    u = model_voltage_rms(TABLE1, WaveTrajectory(), 20.0, 0.01)
    assert 4.0 < u[0] < 5.0 and 2.5 < u[1] < 3.5
