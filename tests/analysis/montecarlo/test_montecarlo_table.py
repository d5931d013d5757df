"""The tidy export of a study and the per-sample sampled-data spectral radius."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import posfb
from helpers.montecarlo_helpers import TINY_STUDY, run_into_store
from posfb.analysis.cli import main
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.montecarlo.table import (
    RATIO_COLUMNS,
    THETA_COLUMNS,
    plant_columns,
    study_table,
)
from posfb.analysis.uncertainty.study import study_from_text
from posfb.models.controllers import cached_design
from posfb.models.design import ControllerConfig, plant_spectral_radii
from posfb.models.lumped import LumpedParameters

#: The tiny study, shorter, with one scenario key drawn as well.
STUDY = (
    TINY_STUDY.replace("duration: 1.0", "duration: 0.3")
    + "draws:\n  sensor.noise_std[1]: !Uniform {min: 0.0, max: 1e-5}\n"
)

ISSUE_COLUMNS = [
    "sample", "controller", "status", "rms_q1_rad", "rms_q2_rad", "rms_u1_V", "rms_u2_V",
    "max_abs_q_err_rad", "saturated_fraction",
]  # fmt: skip


@pytest.fixture(scope="module")
def db(tmp_path_factory) -> Path:
    return run_into_store(tmp_path_factory.mktemp("table") / "study.sqlite", STUDY)


def test_the_table_has_a_row_per_sample_and_controller_with_every_column(db):
    table = study_table(db)
    assert len(table) == 4 * 2
    assert list(table.columns[: len(ISSUE_COLUMNS)]) == ISSUE_COLUMNS
    for column in (*plant_columns(2), "sensor.noise_std[1]", *THETA_COLUMNS, *RATIO_COLUMNS):
        assert column in table.columns, column
    assert {"inside_bounds", "sampled_data_spectral_radius"} <= set(table.columns)
    assert "link_mass_1_kg" in table.columns and "payload_mass_kg" in table.columns
    assert set(zip(table["sample"], table["controller"], strict=True)) == {
        (i, c) for i in range(4) for c in ("proposed", "pid")
    }
    assert table["inside_bounds"].dtype == bool


def test_the_table_equals_what_the_store_holds(db):
    table = study_table(db).set_index(["sample", "controller"])
    with ResultStore.open_existing(db) as store:
        samples = {row["sample"]: row for row in store.sample_rows()}
        runs = store.run_rows()
    for run in runs:
        row = table.loc[(run["sample"], run["controller"])]
        sample = samples[run["sample"]]
        assert row["status"] == run["status"]
        assert row["rms_q2_rad"] == run["rms_q2"] and row["rms_u1_V"] == run["rms_u1"]
        assert row["link_com_2_m"] == sample["parameters"]["link_com"][1]
        assert row["payload_mass_kg"] == sample["parameters"]["payload_mass"]
        assert row["sensor.noise_std[1]"] == sample["parameters"]["sensor.noise_std[1]"]
        assert row["theta7"] == sample["theta"]["theta7"]
        assert row["delta_M0_ratio"] == sample["bound_ratios"]["delta_M0"]
        assert row["encoder_counts"] == sample["encoder_counts"]


def test_export_writes_parquet_and_csv_that_read_back_equal(db, tmp_path, capsys):
    table = study_table(db)
    for name, read in (("t.parquet", pd.read_parquet), ("t.csv", pd.read_csv)):
        out = tmp_path / name
        assert main(["montecarlo", "export", "--db", str(db), "--out", str(out)]) == 0
        assert "8 rows (4 samples)" in capsys.readouterr().out
        back = read(out)
        # An empty message is an empty CSV field, which pandas reads as missing.
        back["message"] = back["message"].astype(object).where(back["message"].notna(), "")
        pd.testing.assert_frame_equal(back, table, check_dtype=False)


def test_export_refuses_bad_input_in_one_line(db, tmp_path, capsys):
    missing = str(tmp_path / "missing.sqlite")
    for db_arg, out, needle in (
        (str(db), "t.xlsx", "--out 't.xlsx'; a file ending in one of .parquet, .csv"),
        (missing, str(tmp_path / "t.csv"), "results do not exist"),
    ):
        assert main(["montecarlo", "export", "--db", db_arg, "--out", out]) != 0
        err = capsys.readouterr().err.strip()
        assert needle in err and len(err.splitlines()) == 1


def _angles(scenario: object) -> tuple[tuple[float, ...], ...]:
    """The configurations of a scenario's path (``analysis.common.configurations``)."""
    from posfb.analysis.common.configurations import scenario_configurations
    from posfb.diagrams.resolve import LoadedScenario, resolve

    if not isinstance(scenario, LoadedScenario):
        scenario = LoadedScenario(scenario, Path.cwd())
    configurations = scenario_configurations(resolve(scenario).config)
    return tuple(c.q for c in configurations.configurations)


def test_the_radius_on_the_nominal_plant_is_the_design_reports(capsys):
    for alpha_star in (4.0, 2.75):
        config = ControllerConfig().with_alpha_star(alpha_star)
        assert main(["design", "--json", "--alpha-star", str(alpha_star)]) == 0
        report = json.loads(capsys.readouterr().out)
        radii = plant_spectral_radii(cached_design(config), config.nominal)
        assert radii["sampled_data"] == report["sampled_data_spectral_radius_at_M0"]
        assert radii["sampled_data_lin_lc"] == report["sampled_data_spectral_radius_lin_lc_at_M0"]
        # over the path's configurations (the study worker's radius): the report's worst
        angles = _angles(posfb.load_scenario())
        frozen = plant_spectral_radii(cached_design(config), config.nominal, configurations=angles)
        for loop, key in (("sampled_data", "sampled_data_spectral_radius"),
                          ("sampled_data_lin_lc", "sampled_data_spectral_radius_lin_lc")):
            assert frozen[loop] == pytest.approx(report[key], rel=1e-12)


def test_each_sample_stores_the_radius_of_its_own_plant(db):
    table = study_table(db)
    study = study_from_text(STUDY)
    design = cached_design(study.controller_config())
    angles = _angles(study.base_scenario())
    for _, row in table.iterrows():
        if row["controller"] == "pid":
            assert np.isnan(row["sampled_data_spectral_radius"])
            continue
        theta = LumpedParameters(
            **{f"theta{i}": row[f"theta{i}"] for i in range(1, 12)}, l1=row["l1_m"]
        )
        # the worker's radius: the worst over the plant's M0* and its M*(q) frozen at the
        # configurations of the study's path (its base scenario, 0.3 s)
        expected = plant_spectral_radii(design, theta, configurations=angles)["sampled_data"]
        assert row["sampled_data_spectral_radius"] == expected
    radii = table.loc[table["controller"] == "proposed", "sampled_data_spectral_radius"]
    assert radii.nunique() == 4  # four plants, four loops
