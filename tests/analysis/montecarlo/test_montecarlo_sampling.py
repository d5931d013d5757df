"""Sampled plants: reproducible from (seed, index), inside the configured ranges."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from helpers.montecarlo_helpers import TINY_STUDY
from posfb.analysis.uncertainty.sampling import sample_plant
from posfb.analysis.uncertainty.study import study_from_text
from posfb.models.plant import build_arm_diagram


@pytest.fixture(scope="module")
def nominal():
    return build_arm_diagram()[1].default_parameters


@pytest.fixture(scope="module")
def study():
    return study_from_text(TINY_STUDY)


def test_same_seed_and_index_give_the_same_plant_in_any_order(study, nominal):
    forward = [sample_plant(study, nominal, i) for i in range(20)]
    backward = [sample_plant(study, nominal, i) for i in reversed(range(20))][::-1]
    assert forward == backward
    longer = replace(study, samples=1000)
    assert sample_plant(longer, nominal, 13) == forward[13]


def test_different_seeds_and_indices_give_different_plants(study, nominal):
    a = sample_plant(study, nominal, 3)
    assert sample_plant(replace(study, seed=8), nominal, 3) != a
    assert sample_plant(study, nominal, 4) != a
    other_seed = sample_plant(replace(study, seed=8), nominal, 3)
    assert a.parameters.link_mass != other_seed.parameters.link_mass


def test_draws_follow_the_configured_ranges(study, nominal):
    plants = [sample_plant(study, nominal, i) for i in range(400)]
    mass = np.array([p.parameters.link_mass for p in plants])
    com = np.array([p.parameters.link_com for p in plants])
    coulomb = np.array([p.parameters.coulomb for p in plants])
    kappa = np.array([p.parameters.motor_constant for p in plants])
    payload = np.array([p.parameters.payload_mass for p in plants])
    m0, c0 = np.array(nominal.link_mass), np.array(nominal.link_com)
    assert np.all(mass >= 0.8 * m0) and np.all(mass <= 1.2 * m0)
    assert np.all(com >= 0.9 * c0) and np.all(com <= 1.1 * c0)
    # Uniform: the draws fill the range (each tenth of it gets some).
    counts, _ = np.histogram(mass[:, 0] / m0[0], bins=10, range=(0.8, 1.2))
    assert counts.min() > 15
    assert np.all((payload >= 0.0) & (payload <= 0.5))
    assert payload.mean() == pytest.approx(0.25, abs=0.03)
    # Coulomb: joint 1 drawn, joint 2 fixed at the URDF value.
    assert np.ptp(coulomb[:, 0]) > 0.3 * nominal.coulomb[0]
    assert np.all(coulomb[:, 1] == nominal.coulomb[1])
    # Truncated normal: inside +-15 %, standard deviation about 5 %.
    relative = kappa / np.array(nominal.motor_constant) - 1.0
    assert np.all(np.abs(relative) <= 0.15)
    assert relative.std() == pytest.approx(0.05, rel=0.15)
    assert abs(relative.mean()) < 0.01
    # Parameters left out of the study keep the URDF value.
    assert all(p.parameters.link_inertia == nominal.link_inertia for p in plants)
    assert {p.encoder_counts for p in plants} == {20000, 4000}
    # Joints draw independently.
    assert abs(np.corrcoef(mass[:, 0], mass[:, 1])[0, 1]) < 0.15


def test_changing_one_distribution_leaves_the_other_draws_alone(nominal):
    base = study_from_text(TINY_STUDY)
    changed = study_from_text(
        TINY_STUDY.replace("!Uniform {min: 0.0, max: 0.5}", "!Deterministic {value: 1.0}")
    )
    for i in range(5):
        a, b = sample_plant(base, nominal, i), sample_plant(changed, nominal, i)
        assert b.parameters.payload_mass == 1.0
        assert replace(a.parameters, payload_mass=1.0) == b.parameters


def test_overrides_pin_one_sample(nominal):
    pins = "{motor_constant: [0.5, 0.25], encoder_counts: [0]}"
    text = TINY_STUDY + f"overrides: [{{sample: 2, values: {pins}}}]\n"
    study, base = study_from_text(text), study_from_text(TINY_STUDY)
    pinned = sample_plant(study, nominal, 2)
    assert pinned.parameters.motor_constant == (0.5, 0.25) and pinned.encoder_counts == 0
    assert pinned.parameters.link_mass == sample_plant(base, nominal, 2).parameters.link_mass
    assert sample_plant(study, nominal, 1) == sample_plant(base, nominal, 1)


POSTERIOR_STUDY = """\
seed: 3
samples: 4000
duration: 1.0
controllers: [pid]
posterior:
  keys: ['link_mass[0]', 'damping[1]', 'motor_constant[1]']
  mean: [0.1, -0.05, 0.0]
  covariance:
  - [0.04, 0.012, 0.0]
  - [0.012, 0.01, -0.003]
  - [0.0, -0.003, 0.0025]
"""


def test_a_posterior_draws_correlated_log_normal_plants(nominal):
    """``posterior``: ``log(p / p_base)`` of 4000 samples has the stated mean and
    covariance (within 5 standard errors of the sample estimates; standard error of a
    covariance entry ``sqrt((s_ii s_jj + s_ij^2) / N)``), every other entry stays."""
    study = study_from_text(POSTERIOR_STUDY)
    plants = [sample_plant(study, nominal, i).parameters for i in range(study.samples)]
    logs = np.array(
        [
            [
                np.log(p.link_mass[0] / nominal.link_mass[0]),
                np.log(p.damping[1] / nominal.damping[1]),
                np.log(p.motor_constant[1] / nominal.motor_constant[1]),
            ]
            for p in plants
        ]
    )
    mean = np.array(study.posterior.mean)
    covariance = np.array(study.posterior.covariance)
    n = logs.shape[0]
    assert np.all(np.abs(logs.mean(axis=0) - mean) < 5 * np.sqrt(np.diag(covariance) / n))
    error = np.sqrt((np.outer(np.diag(covariance), np.diag(covariance)) + covariance**2) / n)
    assert np.all(np.abs(np.cov(logs.T) - covariance) < 5 * error)
    assert all(p.link_mass[1] == nominal.link_mass[1] for p in plants)
    assert all(p.coulomb == nominal.coulomb for p in plants)


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        ("keys: ['link_mass[0]', 'damping[1]', 'motor_constant[1]']",
         "keys: ['link_mass[0]', 'damping[7]', 'motor_constant[1]']"),
        ("mean: [0.1, -0.05, 0.0]", "mean: [0.1, -0.05]"),
        ("  - [0.0, -0.003, 0.0025]", "  - [0.0, -0.003, -1.0]"),
    ],
)  # fmt: skip
def test_a_bad_posterior_is_refused_naming_its_key(change, needle):
    text = POSTERIOR_STUDY.replace(change, needle)
    with pytest.raises(ValueError, match="posterior"):
        study_from_text(text)
    with pytest.raises(ValueError, match="sampling: random"):
        study_from_text(POSTERIOR_STUDY + "sampling: sobol\n")
