"""Sampling designs (random, Latin hypercube, Sobol', Saltelli): each a pure function of
(study, sample index), with the space-filling property its name promises."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from helpers.montecarlo_helpers import deterministic_rows
from posfb.analysis.montecarlo.scheduler import run_study
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.uncertainty.sampling import sample_plant
from posfb.analysis.uncertainty.study import (
    identity,
    saltelli_rows,
    study_from_text,
    varied_scalars,
)
from posfb.models.plant import build_arm_diagram

#: Two varied parameters: a uniform payload and a truncated normal joint-1 Coulomb level.
TWO_PARAMETERS = """
seed: 11
samples: 32
duration: 0.2
controllers: [lin_lc]
parameters:
  coulomb: [!Gaussian {mean: 0.0, stddev: 0.3, relative: true, min: -0.2, max: 0.5},
            !Deterministic {}]
  payload_mass: !Uniform {min: 0.0, max: 0.5}
"""


@pytest.fixture(scope="module")
def nominal():
    return build_arm_diagram()[1].default_parameters


def _study(sampling: str, samples: int = 32, text: str = TWO_PARAMETERS):
    return replace(study_from_text(f"{text}sampling: {sampling}\n"), samples=samples)


@pytest.mark.parametrize("sampling", ["random", "latin_hypercube", "sobol", "saltelli"])
def test_a_sample_is_the_same_plant_in_any_order(sampling, nominal):
    study = _study(sampling, samples=16 * saltelli_rows(2) if sampling == "saltelli" else 32)
    forward = [sample_plant(study, nominal, i) for i in range(study.samples)]
    backward = [sample_plant(study, nominal, i) for i in reversed(range(study.samples))]
    assert forward == backward[::-1]
    assert len({p.parameters for p in forward}) == study.samples


@pytest.mark.parametrize("sampling", ["random", "sobol", "saltelli"])
def test_sequences_keep_their_samples_when_the_study_grows(sampling, nominal):
    rows = saltelli_rows(2) if sampling == "saltelli" else 1
    small, large = _study(sampling, 8 * rows), _study(sampling, 32 * rows)
    assert identity(small) == identity(large)
    assert [sample_plant(small, nominal, i) for i in range(8 * rows)] == [
        sample_plant(large, nominal, i) for i in range(8 * rows)
    ]


def test_a_latin_hypercube_puts_one_sample_in_each_stratum_and_is_sized(nominal):
    study = _study("latin_hypercube")
    payload = np.array([sample_plant(study, nominal, i).parameters.payload_mass for i in range(32)])
    assert sorted(np.floor(payload / 0.5 * 32).astype(int)) == list(range(32))
    assert identity(study) != identity(replace(study, samples=64))


def test_sobol_points_are_balanced_and_map_through_the_inverse_cdf(nominal):
    study = _study("sobol")
    plants = [sample_plant(study, nominal, i).parameters for i in range(32)]
    payload = np.array([p.payload_mass for p in plants])
    assert sorted(np.floor(payload / 0.5 * 32).astype(int)) == list(range(32))
    # The truncated normal: every draw inside [min, max], and the 32 draws are the
    # truncated distribution's quantiles at one point per stratum (their CDF values
    # are balanced too).
    from scipy.stats import truncnorm

    c0 = nominal.coulomb[0]
    relative = np.array([p.coulomb[0] for p in plants]) / c0 - 1.0
    assert relative.min() >= -0.2 - 1e-12 and relative.max() <= 0.5 + 1e-12
    cdf = truncnorm.cdf(relative / 0.3, -0.2 / 0.3, 0.5 / 0.3)
    assert sorted(np.floor(cdf * 32).astype(int)) == list(range(32))
    assert all(p.coulomb[1] == nominal.coulomb[1] for p in plants)


def test_a_saltelli_block_changes_one_parameter_at_a_time(nominal):
    study = _study("saltelli", 4 * saltelli_rows(2))
    names = [scalar.column for scalar in varied_scalars(study)]
    assert names == ["coulomb_1_N_m", "payload_mass_kg"]
    a, ab1, ab2, b = (sample_plant(study, nominal, i).parameters for i in range(4))
    assert ab1.coulomb[0] == b.coulomb[0] and ab1.payload_mass == a.payload_mass
    assert ab2.coulomb[0] == a.coulomb[0] and ab2.payload_mass == b.payload_mass
    assert a.coulomb[0] != b.coulomb[0] and a.payload_mass != b.payload_mass


@pytest.mark.parametrize(
    ("sampling", "samples", "needle"),
    [
        ("lhs", 32, "sampling = 'lhs'; one of random, latin_hypercube, sobol, saltelli"),
        ("saltelli", 24, "N x 4 with N a power of 2"),
        ("saltelli", 30, "N x 4 with N a power of 2"),
    ],
)
def test_bad_designs_are_refused_naming_the_key(sampling, samples, needle):
    with pytest.raises(ValueError, match=needle.replace("(", r"\(")):
        study_from_text(
            f"{TWO_PARAMETERS}sampling: {sampling}\nsamples: {samples}\n".replace(
                "samples: 32\n", "", 1
            )
        )


@pytest.mark.slow
@pytest.mark.parametrize("sampling", ["random", "latin_hypercube", "sobol", "saltelli"])
def test_every_design_stores_the_same_rows_for_any_worker_count(sampling, tmp_path):
    study = _study(sampling, samples=saltelli_rows(2))  # one Saltelli block: 4 samples
    for workers in (1, 2):
        with ResultStore.create_or_resume(tmp_path / f"w{workers}.sqlite", study, "t") as store:
            run_study(study, store, "t", workers=workers, progress=False)
    assert deterministic_rows(tmp_path / "w1.sqlite") == deterministic_rows(tmp_path / "w2.sqlite")
