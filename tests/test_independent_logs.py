"""The independent log generator (``helpers.independent_logs``): its dynamics are posfb's
model of the arm, its closed loop tracks with a quantised encoder, posfb reads its logs and
its perturbed arms."""

from __future__ import annotations

import numpy as np
import pytest

from helpers.independent_logs import (
    FRICTION_VELOCITY,
    PinocchioArm,
    fourier_reference,
    perturbed_urdf,
    simulate_log,
)
from helpers.spatial_arm import spatial_arm_urdf
from posfb.analysis.identification.log import read_log
from posfb.models.plant import PlantConfig, build_arm_diagram
from posfb.models.serial_model import SerialArmModel


def test_inverse_dynamics_is_posfb_model(tmp_path):
    """At 20 random states the generator's voltage (Pinocchio RNEA, armature, damping and
    tanh-smoothed Coulomb, over kappa) is posfb's Eq. 2 with its Coulomb term smoothed the
    plant's way; where ``|q'| >= 0.5`` rad/s the tanh is 1 and it is Eq. 2 itself."""
    urdf = spatial_arm_urdf(4, tmp_path, seed=3)
    arm, model = PinocchioArm(urdf), SerialArmModel(str(urdf))
    assert arm.joints == model.joints
    rng = np.random.default_rng(0)
    for _ in range(20):
        q, a = rng.uniform(-np.pi, np.pi, 4), rng.uniform(-5.0, 5.0, 4)
        slow = rng.uniform(-0.05, 0.05, 4)
        fast = rng.choice([-1.0, 1.0], 4) * rng.uniform(0.5, 2.0, 4)
        smoothed = model.coulomb_levels() * np.tanh(slow / FRICTION_VELOCITY)
        expected = model.inverse_dynamics(q, slow, a, friction=False) + smoothed
        np.testing.assert_allclose(
            arm.voltage(q, slow, a), expected, rtol=1e-8, atol=1e-8 * np.abs(expected).max()
        )
        expected = model.inverse_dynamics(q, fast, a)
        np.testing.assert_allclose(
            arm.voltage(q, fast, a), expected, rtol=1e-8, atol=1e-8 * np.abs(expected).max()
        )


def test_fourier_reference_is_bounded_and_consistent():
    reference = fourier_reference(3, duration=10.0, sample_time=1e-3, seed=4, amplitude=0.4)
    assert reference.q.shape == (10001, 3) and reference.sample_time == pytest.approx(1e-3)
    assert np.abs(reference.q).max() <= 1.5 * 0.4
    interior = slice(1, -1)
    for value, rate in ((reference.q, reference.qd), (reference.qd, reference.qdd)):
        derivative = np.gradient(value, reference.time, axis=0)
        np.testing.assert_allclose(derivative[interior], rate[interior], atol=1e-5)


def test_closed_loop_tracks_and_posfb_reads_the_log(tmp_path):
    nominal = spatial_arm_urdf(4, tmp_path, seed=3)
    true = perturbed_urdf(nominal, tmp_path / "true.urdf", seed=1)
    reference = fourier_reference(4, duration=2.0, sample_time=1e-3, seed=0)
    counts = 4096
    log = simulate_log(true, nominal, reference, counts=counts, voltage_limit=50.0)
    assert np.sqrt(np.mean((log.q_true - reference.q) ** 2)) < 0.05
    step = 2.0 * np.pi / counts
    assert np.abs(log.q_measured - log.q_true).max() <= step / 2 + 1e-12
    np.testing.assert_allclose(np.round(log.q_measured / step), log.q_measured / step, atol=1e-9)
    assert np.abs(log.u_applied).max() <= 50.0
    read = read_log(log.write_csv(tmp_path / "log.csv"), joints=4)
    np.testing.assert_allclose(read.time, log.time, atol=1e-12)
    np.testing.assert_array_equal(read.q, log.q_measured)
    np.testing.assert_array_equal(read.u, log.u_applied)
    np.testing.assert_array_equal(read.reference.qddot, reference.qdd)


def test_perturbed_urdf_loads_in_posfb_with_other_parameters(tmp_path):
    nominal = spatial_arm_urdf(4, tmp_path, seed=3)
    true = perturbed_urdf(nominal, tmp_path / "true.urdf", seed=2, spread=0.15)
    assert 'xmlns:posfb="urn:posfb:urdf"' in true.read_text()
    _, nominal_arm, _ = build_arm_diagram(PlantConfig(urdf=str(nominal)))
    _, true_arm, _ = build_arm_diagram(PlantConfig(urdf=str(true)))
    before, after = nominal_arm.default_parameters, true_arm.default_parameters
    for name in ("link_mass", "rotor_inertia", "damping", "coulomb", "motor_constant"):
        ratio = np.array(getattr(after, name)) / np.array(getattr(before, name))
        assert np.all(ratio != 1.0) and np.all(np.abs(ratio - 1.0) <= 0.15), name
    arm = PinocchioArm(true)
    np.testing.assert_allclose(arm.motor_constant, after.motor_constant, rtol=1e-12)
    np.testing.assert_allclose(arm.model.armature, after.rotor_inertia, rtol=1e-12)
