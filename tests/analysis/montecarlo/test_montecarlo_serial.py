"""Monte-Carlo studies of an n-joint arm (issue 13): a three-link study runs, stores
and exports one column per joint, replays bit for bit, and its per-sample checks
agree with independent computations on known plants."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from helpers.montecarlo_helpers import run_into_store
from helpers.paths import REPO
from helpers.slow import heavy
from posfb.analysis.cli import main
from posfb.analysis.montecarlo.table import study_table
from posfb.analysis.uncertainty.coverage import BOUND_NAMES, serial_coverage
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.models.controllers import cached_design
from posfb.models.design import plant_spectral_radii
from posfb.models.nominal import nominal_model
from posfb.models.plant import PlantConfig, apply_parameters, arm_model, build_arm_diagram

SCENARIO = REPO / "analysis/scenarios/three_link_nominal.yaml"

STUDY = f"""\
seed: 11
scenario: {SCENARIO}
samples: 2
duration: 0.5
controllers: [proposed, lin_lc, pid]
parameters:
  link_mass: [!Uniform {{min: -0.2, max: 0.2, relative: true}}]
  damping:
    - !Uniform {{min: -0.2, max: 0.2, relative: true}}
    - !Deterministic {{}}
    - !Deterministic {{}}
  payload_mass: !Uniform {{min: 0.0, max: 0.3}}
"""


@pytest.fixture(scope="module")
@heavy
def db(tmp_path_factory) -> Path:
    return run_into_store(tmp_path_factory.mktemp("serial") / "study.sqlite", STUDY)


def test_a_three_link_study_stores_one_column_per_joint(db):
    table = study_table(db)
    assert len(table) == 6 and set(table["status"]) == {"ok"}
    for j in (1, 2, 3):
        assert f"rms_q{j}_rad" in table and f"link_mass_{j}_kg" in table
    assert "theta1" not in table  # a URDF nominal model identifies no theta
    drawn = table.drop_duplicates("sample")
    assert np.all(drawn["damping_2_N_m_s_per_rad"] == 4.0)  # joints 2, 3 deterministic
    assert np.all(np.isfinite(table[[f"{name}_ratio" for name in BOUND_NAMES]]))
    radius = table.loc[table["controller"] == "pid", "sampled_data_spectral_radius"]
    assert radius.isna().all()


@pytest.mark.slow
def test_a_three_link_sample_replays_bit_for_bit(db, tmp_path, capsys):
    code = main(["montecarlo", "replay", "--db", str(db), "--sample", "1", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0, out
    for controller in ("proposed", "lin_lc", "pid"):
        assert f"{controller}: matches the stored row" in out


def _sampled(scale: float):
    """The three-link plant with every link mass scaled by ``scale``, as a model."""
    urdf = str(SCENARIO.parent.parent.parent / "urdf" / "three_link_arm.urdf")
    _, arm, context = build_arm_diagram(PlantConfig(urdf=urdf))
    defaults = arm.default_parameters
    apply_parameters(
        arm, context, replace(defaults, link_mass=tuple(scale * m for m in defaults.link_mass))
    )
    return arm_model(arm, context)


def test_per_sample_checks_on_known_plants():
    """On the nominal plant every Assumption-1 ratio is 0 and the spectral radii are the
    design's own; with every link mass 10 % heavier M1*, C* and G* grow by exactly
    10 % (rotor inertia and damping are unchanged), so at relative = 0.5 their ratios
    are 0.2, which the per-sample search reaches from below."""
    resolved = resolve(load_scenario(SCENARIO))
    design = cached_design(resolved.config.design)
    nominal = nominal_model(resolved.config.design.nominal)
    same = _sampled(1.0)
    ratios = serial_coverage(same, nominal, design.bounds).ratios
    assert max(ratios.values()) < 1e-9, ratios
    radii = plant_spectral_radii(design, same)
    assert radii["sampled_data"] == pytest.approx(design.sampled_data_spectral_radius, rel=1e-9)
    assert radii["sampled_data_lin_lc"] == pytest.approx(
        design.sampled_data_spectral_radius_lin_lc, rel=1e-9
    )
    heavier = serial_coverage(_sampled(1.1), nominal, design.bounds).ratios
    for name in ("delta_M1", "delta_C", "delta_G"):
        assert 0.19 < heavier[name] <= 0.2 + 1e-9, (name, heavier[name])
    assert heavier["delta_B"] == 0.0 and heavier["delta_F"] == 0.0
