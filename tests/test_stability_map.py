"""``posfb design --map`` (``analysis.stability_map``): the map's numbers against
independent computations (the design report's radius, a brentq root, the bound filter's
closed-form refusal, plant radii rebuilt from the ``ControllerConfig``), the largest
robust sample time against the map, and the files. Coarse grids and few plants."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from posfb.analysis import stability_map as sm
from posfb.analysis.cases import CASE_FILES
from posfb.analysis.cli import main
from posfb.analysis.commands.design import relevant_checks
from posfb.analysis.errors import UsageError
from posfb.analysis.tuning.plants import linear_plants, plant_family
from posfb.analysis.tuning.settings import DEFAULT_MARGIN
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.models.design import compute_design, design_loop
from posfb.models.design.closed_loop import spectral_radius

PLANTS = 6
SEED = 3
T_S, ALPHA = sm.SAMPLE_TIME, "controller.alpha_star"


def _setup(settings: tuple[str, ...] = (), plants: int = PLANTS) -> sm.MapSetup:
    loaded = load_scenario(CASE_FILES["nominal"], settings)
    relevant = relevant_checks(resolve(loaded).config)
    return sm.map_setup(loaded, relevant, None, plants, SEED, DEFAULT_MARGIN)


@pytest.fixture(scope="module")
def setup() -> sm.MapSetup:
    return _setup()


@pytest.fixture(scope="module")
def paper_map(setup) -> sm.StabilityMap:
    """T_s 5 .. 35 ms (5 ms steps: 5 ms is refused), alpha* 0.5 .. 4 (0.5 steps)."""
    x = sm.MapAxis(T_S, np.linspace(0.005, 0.035, 7), 0.01)
    y = sm.MapAxis(ALPHA, np.linspace(0.5, 4.0, 8), 4.0)
    return sm.compute_map(setup, x, y)


def _config(sample_time: float, alpha_star: float):
    """The paper's design inputs at ``(T_s, alpha*)``, built without the map's path
    (no scenario setting, no ``controller_inputs``)."""
    config = resolve(load_scenario(CASE_FILES["nominal"])).config.design
    return dataclasses.replace(config.with_alpha_star(alpha_star), sample_time=sample_time)


def test_rho_at_the_scenario_point_is_the_design_report(paper_map):
    i, j = 1, len(paper_map.y.values) - 1
    assert paper_map.x.values[i] == pytest.approx(0.01) and paper_map.y.values[j] == 4.0
    report = compute_design(resolve(load_scenario(CASE_FILES["nominal"])).config.design)
    assert paper_map.rho[j, i] == pytest.approx(report.sampled_data_spectral_radius, abs=1e-12)
    assert paper_map.rho[j, i] > 1.0
    exact = compute_design(_config(paper_map.x.values[i], paper_map.y.values[j]))
    assert paper_map.rho[j, i] == pytest.approx(exact.sampled_data_spectral_radius, abs=1e-12)


def test_the_rho_one_crossing_in_alpha_star_at_10_ms(setup):
    x = sm.MapAxis(T_S, np.array([0.01]), 0.01)
    y = sm.MapAxis(ALPHA, np.linspace(3.0, 3.5, 11), 4.0)
    column = sm.compute_map(setup, x, y).rho[:, 0]
    above = column >= 1.0
    assert not above[0] and above[-1]
    crossing = int(np.argmax(above))  # the first grid alpha* with rho >= 1
    assert not above[:crossing].any() and above[crossing:].all()

    def excess(alpha: float) -> float:
        return compute_design(_config(0.01, alpha)).sampled_data_spectral_radius - 1.0

    root = brentq(excess, 3.0, 3.5, xtol=1e-6)
    assert 3.0 < root < 3.5
    assert y.values[crossing - 1] <= root <= y.values[crossing]


def test_refused_exactly_where_the_bound_filter_fails(paper_map):
    a = 100.0  # the paper's filter_a
    expected = np.broadcast_to(a <= math.log(2.0) / paper_map.x.values, paper_map.rho.shape)
    assert np.array_equal(paper_map.refused, expected)
    assert paper_map.refused.any() and not paper_map.refused.all()
    assert np.isnan(paper_map.rho[paper_map.refused]).all()
    assert np.isnan(paper_map.share[paper_map.refused]).all()
    assert not paper_map.robust[paper_map.refused].any()


def test_shares_and_robustness_agree_with_the_plant_radii(paper_map):
    valid = ~paper_map.refused
    share, worst, limit = paper_map.share[valid], paper_map.worst[valid], 1.0 - DEFAULT_MARGIN
    assert ((share >= 0.0) & (share <= 1.0)).all()
    assert np.allclose(share * PLANTS, np.round(share * PLANTS))  # whole plants
    # every plant robustly stable exactly when the worst plant is
    assert np.array_equal(share == 1.0, worst <= limit)
    robust = (paper_map.rho[valid] <= limit) & (share == 1.0)
    assert np.array_equal(paper_map.robust[valid], robust)
    assert paper_map.robust.any() and (valid & ~paper_map.robust).any()
    # the map holds both kinds of points: every plant unstable, and some stable
    assert (share == 0.0).any() and (share > 0.0).any()


def test_one_point_rebuilt_from_the_controller_config(setup, paper_map):
    """The share at one grid point from the design built without the scenario path and
    the plants drawn again."""
    loaded = load_scenario(CASE_FILES["nominal"])
    resolved = resolve(loaded)
    plants = linear_plants(plant_family(None, loaded), resolved, SEED, PLANTS)
    limit = 1.0 - DEFAULT_MARGIN
    for i, j in ((2, 3), (3, 1), (1, 7)):
        design = compute_design(_config(paper_map.x.values[i], paper_map.y.values[j]))
        radii = [spectral_radius(design_loop(design, "proposed", p.M0, p.B).A) for p in plants]
        assert paper_map.share[j, i] == pytest.approx(np.mean(np.array(radii) <= limit))
        assert paper_map.worst[j, i] == pytest.approx(max(radii), abs=1e-12)


def test_largest_robust_sample_time_is_consistent_with_the_map(setup, paper_map):
    found = sm.largest_robust_sample_time(setup, paper_map)
    times = paper_map.x.values
    row = int(np.flatnonzero(np.isclose(times, found.grid))[0])
    assert paper_map.robust[:, row].any()
    assert not paper_map.robust[:, row + 1 :].any()
    assert row + 1 < len(times) and not found.at_edge
    assert found.grid <= found.refined < times[row + 1]
    robust_values = paper_map.y.values[paper_map.robust[:, row]]
    assert np.allclose(found.other_values, robust_values)
    # at the refined T_s the reported alpha* is robust, rebuilt independently
    design = compute_design(_config(found.refined, found.other_at_refined))
    limit = 1.0 - DEFAULT_MARGIN
    assert design.sampled_data_spectral_radius <= limit
    radii = [spectral_radius(design_loop(design, "proposed", p.M0, p.B).A) for p in setup.plants]
    assert max(radii) <= limit
    text = sm.robust_text(paper_map, found, limit)
    assert "within the map's grid of controller.alpha_star" in text
    assert "the scenario's other settings fixed" in text


def test_lin_lc_entry_maps_its_own_loop():
    setup = _setup(("controller.kind=lin_lc",), plants=2)
    assert setup.controller == "lin_lc"
    point = sm.evaluate_point(setup, {T_S: 0.01})
    design = compute_design(resolve(load_scenario(CASE_FILES["nominal"])).config.design)
    assert point.rho == pytest.approx(design.sampled_data_spectral_radius_lin_lc, abs=1e-12)


@pytest.mark.parametrize(
    ("key", "needle"),
    [
        ("controller.alpha_sta", "unknown key"),
        ("controller.discretisation", "is not a number"),
        ("sensor.encoder_counts", "not a design key"),
    ],
)
def test_map_keys_are_checked(key, needle):
    loaded = load_scenario(CASE_FILES["nominal"])
    with pytest.raises(UsageError, match=needle):
        sm.key_value(loaded, key)


def test_a_per_joint_list_of_one_value_is_a_key():
    assert sm.key_value(load_scenario(CASE_FILES["nominal"]), "controller.lambdas") == 10.0


def test_out_writes_the_figure_and_the_json(tmp_path, capsys):
    mark = tmp_path / "tuned.yaml"
    mark.write_text("controller: !Proposed {alpha_star: 2.5}\ntiming: {sample_time: 0.008}\n")
    out = tmp_path / "map"
    code = main(
        ["design", "--map", "--map-points", "4", "--plants", "2", "--map-range", "0.005",
         "0.02", "1", "4", "--mark", str(mark), "--out", str(out), "--json"]
    )  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    for name in ("stability_map.png", "stability_map.svg", "stability_map.json"):
        assert (out / name).stat().st_size > 0
    printed = json.loads(captured.out)
    written = json.loads((out / "stability_map.json").read_text())
    assert {k: v for k, v in printed.items() if k != "files"} == written
    assert printed["x"]["key"] == T_S and printed["y"]["key"] == ALPHA
    assert len(written["rho_nominal"]) == 4 and len(written["share_stable"][0]) == 4
    assert written["points"]["marked"]["values"] == {T_S: 0.008, ALPHA: 2.5}
    assert written["points"]["scenario"]["rho_nominal"] == pytest.approx(1.0426, abs=1e-4)
    assert written["plants"] == 2 and written["margin"] == DEFAULT_MARGIN


def test_map_options_need_map(capsys):
    assert main(["design", "--plants", "3"]) == 2
    assert "--plants applies to the stability map; add --map" in capsys.readouterr().err


def test_help_states_the_defaults(capsys):
    with pytest.raises(SystemExit):
        main(["design", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    low, high = sm.POINTS_RANGE
    assert f"(default {sm.DEFAULT_POINTS}, {low} .. {high})" in text
    assert f"(default: {' '.join(sm.DEFAULT_AXES)})" in text
    fractions = (sm.SAMPLE_TIME_RANGE, sm.OTHER_RANGE)
    assert fractions == ((0.25, 4.0), (1.0 / 16.0, 2.0))  # as the help says:
    assert "T_s/4 .. 4 T_s for the sample time, value/16 .. 2 value" in text
