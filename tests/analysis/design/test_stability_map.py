"""``posfb design --map`` (``analysis.design.stability_map``): the map's numbers against
independent computations (the design report's radius, a brentq root, the bound filter's
closed-form refusal, plant radii rebuilt from the ``ControllerConfig``), the largest
robust sample time against the map, and the files. Coarse grids and few plants."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from matplotlib.collections import QuadMesh
from scipy.optimize import brentq

from posfb.analysis.cli import main
from posfb.analysis.common.cases import CASE_FILES, SCENARIO_DIR
from posfb.analysis.common.configurations import scenario_configurations
from posfb.analysis.common.errors import UsageError
from posfb.analysis.design import stability_map as sm
from posfb.analysis.design.design_report import nominal_design, relevant_checks
from posfb.analysis.design.settings import DEFAULT_MARGIN, TuneSettings
from posfb.analysis.uncertainty.plants import draw_plants, plant_family
from posfb.analysis.uncertainty.study import load_study
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.models.design import compute_design, design_loop
from posfb.models.design.closed_loop import spectral_radius
from posfb.models.nominal import nominal_model

PLANTS = 6
SEED = 3
T_S, ALPHA = sm.SAMPLE_TIME, "controller.alpha_star"
TUNED = SCENARIO_DIR / "paper_tuned.yaml"
PAPER_STUDY = SCENARIO_DIR.parent / "studies" / "paper_uncertainty.yaml"


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


def _config(sample_time: float, alpha_star: float, scenario=CASE_FILES["nominal"]):
    """The design inputs of ``scenario`` (the paper's) at ``(T_s, alpha*)``, built without
    the map's path (no scenario setting, no ``controller_inputs``)."""
    config = resolve(load_scenario(scenario)).config.design
    return dataclasses.replace(
        config.with_alpha_star(alpha_star),
        context=dataclasses.replace(config.context, sample_time=sample_time),
    )


def _plant_radii(design, plants) -> np.ndarray:
    """Each plant's sampled-data radius of the proposed loop, the worst over its ``M0*`` and
    its ``M*(q)`` at the path's lightest and heaviest configurations, from the full
    closed loop (``design_loop``), not the map's transition-only ``held_design_radius``."""
    return np.array([max(spectral_radius(design_loop(design, "sampled_data", M, p.B).A)
                         for M in (p.M0, *p.M_at)) for p in plants])  # fmt: skip


def _plants(study, loaded, seed: int, count: int) -> list:
    """The map's plants drawn again: ``count`` draws with their ``M*(q)`` at the path's
    lightest and heaviest configurations."""
    resolved = resolve(loaded)
    extremes = tuple(c.q for c in scenario_configurations(resolved.config).configurations
                     if c.role in ("lightest", "heaviest"))  # fmt: skip
    return list(draw_plants(plant_family(study, loaded), resolved, seed, count,
                            configurations=extremes))  # fmt: skip


def _nominal_radius(design, loop: str = "sampled_data", scenario=CASE_FILES["nominal"]):
    """The nominal model's radius, the worst over ``M0*`` and every configuration of the
    scenario's path, from the full closed loop."""
    config = resolve(load_scenario(scenario)).config
    model = nominal_model(config.design.nominal)
    masses = (model.M0(), *scenario_configurations(config).masses)
    return max(spectral_radius(design_loop(design, loop, M, model.B()).A) for M in masses)


def test_rho_at_the_scenario_point_is_the_design_report(paper_map):
    i, j = 1, len(paper_map.y.values) - 1
    assert paper_map.x.values[i] == pytest.approx(0.01) and paper_map.y.values[j] == 4.0
    report = nominal_design(resolve(load_scenario(CASE_FILES["nominal"])))
    assert paper_map.rho[j, i] == pytest.approx(report.sampled_data_spectral_radius, abs=1e-12)
    assert paper_map.rho[j, i] > 1.0
    exact = compute_design(_config(paper_map.x.values[i], paper_map.y.values[j]))
    assert paper_map.rho[j, i] == pytest.approx(_nominal_radius(exact), abs=1e-12)


def test_the_rho_one_crossing_in_alpha_star_at_10_ms(setup):
    x = sm.MapAxis(T_S, np.array([0.01]), 0.01)
    y = sm.MapAxis(ALPHA, np.linspace(3.0, 3.5, 11), 4.0)
    column = sm.compute_map(setup, x, y).rho[:, 0]
    above = column >= 1.0
    assert not above[0] and above[-1]
    crossing = int(np.argmax(above))  # the first grid alpha* with rho >= 1
    assert not above[:crossing].any() and above[crossing:].all()

    def excess(alpha: float) -> float:
        return _nominal_radius(compute_design(_config(0.01, alpha))) - 1.0

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
    plants = _plants(None, loaded, SEED, PLANTS)
    limit = 1.0 - DEFAULT_MARGIN
    for i, j in ((2, 3), (3, 1), (1, 7)):
        design = compute_design(_config(paper_map.x.values[i], paper_map.y.values[j]))
        radii = _plant_radii(design, plants)
        assert paper_map.share[j, i] == pytest.approx(np.mean(radii <= limit))
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
    assert _nominal_radius(design) <= limit
    assert max(_plant_radii(design, setup.plants)) <= limit
    text = sm.robust_text(paper_map, found, limit)
    assert "within the map's grid of controller.alpha_star" in text
    assert "the scenario's other settings fixed" in text


def test_lin_lc_entry_maps_its_own_loop():
    setup = _setup(("controller.kind=lin_lc",), plants=2)
    assert setup.controller == "lin_lc"
    point = sm.evaluate_point(setup, {T_S: 0.01})
    design = compute_design(resolve(load_scenario(CASE_FILES["nominal"])).config.design)
    assert point.rho == pytest.approx(_nominal_radius(design, "sampled_data_lin_lc"), abs=1e-12)


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


@pytest.mark.slow
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
    # 4 points per axis, and the mark's value added to each grid
    assert 0.008 in written["x"]["values"] and 2.5 in written["y"]["values"]
    assert len(written["rho_nominal"]) == 5 and len(written["share_stable"][0]) == 5
    assert written["points"]["marked"]["values"] == {T_S: 0.008, ALPHA: 2.5}
    # the design report's worst radius over M0* and the path's configurations (1.0426 at
    # M0*, the paper's own figure; 1.0436 at the worst configuration)
    report = nominal_design(resolve(load_scenario(CASE_FILES["nominal"])))
    rho = written["points"]["scenario"]["rho_nominal"]
    assert rho == pytest.approx(report.sampled_data_spectral_radius, abs=1e-12)
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


@pytest.mark.parametrize("points", [3, 4, 25, 26])
def test_each_axis_is_log_spaced_through_the_scenario_value(points):
    for key, value in ((T_S, 0.01), (ALPHA, 4.0)):
        low, high = sm.default_range(key, value)
        axis = sm.make_axis(key, low, high, points, value)
        assert len(axis.values) == points and axis.values[0] == low and axis.values[-1] == high
        k = axis.index(value)
        assert k is not None and 0 < k < points - 1  # the value itself, inside
        steps = np.diff(np.log(axis.values))
        assert (steps > 0).all()
        assert np.allclose(steps[:k], steps[0]) and np.allclose(steps[k:], steps[-1])
        # each grid value inside its own cell, the edges its neighbours' geometric means
        edges = axis.edges
        assert (edges[:-1] < axis.values).all() and (axis.values < edges[1:]).all()
        assert np.allclose(edges[1:-1] ** 2, axis.values[:-1] * axis.values[1:])
    # T_s / 4 .. 4 T_s is symmetric about T_s in log: an odd count centres it, one ratio
    times = sm.make_axis(T_S, 0.0025, 0.04, points, 0.01)
    if points % 2:
        assert times.index(0.01) == points // 2
        assert np.allclose(np.diff(np.log(times.values)), math.log(16.0) / (points - 1))


def test_a_value_at_the_end_of_its_range_is_the_end_point():
    axis = sm.make_axis(ALPHA, 1.0, 4.0, 5, 4.0)
    assert axis.index(4.0) == 4
    assert np.allclose(np.diff(np.log(axis.values)), math.log(4.0) / 4)


@pytest.mark.parametrize(
    ("low", "high", "needle"),
    [
        (0.02, 0.04, "LOW <= 0.01 <= HIGH is required"),
        (0.0, 0.04, "log-spaced; 0 < LOW < HIGH is required"),
    ],
)
def test_a_range_must_be_positive_and_hold_the_scenario_value(low, high, needle):
    with pytest.raises(UsageError, match=needle):
        sm.make_axis(T_S, low, high, 5, 0.01)


def test_a_mark_inside_the_map_becomes_a_grid_point():
    x = sm.make_axis(T_S, 0.0025, 0.04, 5, 0.01)
    y = sm.make_axis(ALPHA, 0.25, 8.0, 5, 4.0)
    inside, outside = {T_S: 0.008, ALPHA: 2.5}, {T_S: 0.05, ALPHA: 1.0}
    wide_x, wide_y = sm.with_marks(x, y, [inside, outside])
    assert wide_x.index(0.008) is not None and wide_y.index(2.5) is not None
    assert wide_y.index(1.0) is None and len(wide_x.values) == len(wide_y.values) == 6
    assert (np.diff(wide_x.values) > 0).all() and wide_x.index(0.01) is not None


def _map_figure(monkeypatch) -> list:
    """Keep each figure ``posfb design --map --out`` writes (``sm.write_map``'s input)."""
    figures, write = [], sm.write_map

    def keep(out, figure, data):
        figures.append(figure)
        return write(out, figure, data)

    monkeypatch.setattr(sm, "write_map", keep)
    return figures


def _drawn_cell(axis, name: str) -> tuple[tuple[float, float], float]:
    """The marker labelled ``name`` (its data coordinates) and the value of the colour
    mesh's cell it lies in, read back from the figure."""
    (line,) = [line for line in axis.lines if line.get_label() == name]
    x, y = float(line.get_xdata()[0]), float(line.get_ydata()[0])
    mesh = next(c for c in axis.collections if isinstance(c, QuadMesh))
    corners, values = mesh.get_coordinates(), mesh.get_array()
    x_edges, y_edges = corners[0, :, 0], corners[:, 0, 1]
    i, j = np.searchsorted(x_edges, x) - 1, np.searchsorted(y_edges, y) - 1
    assert x_edges[i] < x < x_edges[i + 1] and y_edges[j] < y < y_edges[j + 1]
    return (x, y), float(values[j, i])


@pytest.mark.slow
def test_the_drawn_cells_are_the_printed_verdicts(tmp_path, monkeypatch, capsys):
    """The tuned scenario (star) and a marked design (diamond) on a 5-point map: the cell
    the figure draws under each marker, the JSON and the printed line all give the share
    and the verdict computed here from the full closed loops on freshly drawn plants."""
    figures = _map_figure(monkeypatch)
    mark = tmp_path / "mark.yaml"
    mark.write_text("controller: !Proposed {alpha_star: 0.3}\ntiming: {sample_time: 0.025}\n")
    out = tmp_path / "map"
    code = main(["design", "--map", "--scenario", str(TUNED), "--study", str(PAPER_STUDY),
                 "--plants", str(PLANTS), "--map-points", "5", "--mark", str(mark),
                 "--out", str(out)])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    data = json.loads((out / "stability_map.json").read_text())
    (figure,) = figures
    axis = figure.axes[0]
    assert axis.get_xscale() == axis.get_yscale() == "log"
    loaded = load_scenario(TUNED)
    own_alpha = resolve(loaded).config.design.nonlinear.alpha_star
    plants = _plants(load_study(PAPER_STUDY), loaded, TuneSettings().seed, PLANTS)
    limit = 1.0 - DEFAULT_MARGIN
    for name, values in (("scenario", (0.01, own_alpha)), ("marked", (0.025, 0.3))):
        drawn_at, cell = _drawn_cell(axis, name)
        assert drawn_at == values  # drawn where it is
        design = compute_design(_config(*values, scenario=TUNED))
        radii = _plant_radii(design, plants)
        share = float(np.mean(radii <= limit))
        robust = _nominal_radius(design, scenario=TUNED) <= limit and radii.max() <= limit
        assert cell == pytest.approx(share)
        point = data["points"][name]
        assert point["share_stable"] == pytest.approx(share) and point["robust"] == robust
        j, i = point["grid_index"]
        assert (data["x"]["values"][i], data["y"]["values"][j]) == values
        (line,) = [line for line in printed.splitlines() if line.startswith(f"  {name} (")]
        verdict = "robust" if robust else "not robust"
        assert line.endswith(f"on {round(share * PLANTS)} of {PLANTS} plants; {verdict}")
    # the two verdicts differ, so a cell read from the wrong point would show
    assert data["points"]["scenario"]["robust"] != data["points"]["marked"]["robust"]


@pytest.mark.slow
def test_a_robust_scenario_gives_a_robust_sample_time(capsys):
    """The issue's map (4 points, T_s x lambdas) of the tuned design: the scenario's own
    cell is robust exactly when its loop is on every plant (computed here), so the largest
    robust sample time is at least the scenario's."""
    lambdas = "controller.lambdas"
    code = main(["design", "--map", "--scenario", str(TUNED), "--study", str(PAPER_STUDY),
                 "--plants", str(PLANTS), "--map-points", "4", "--map-axes", T_S, lambdas,
                 "--json"])  # fmt: skip
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    loaded = load_scenario(TUNED)
    own = sm.key_value(loaded, lambdas)
    i, j = data["x"]["values"].index(0.01), data["y"]["values"].index(own)
    design = compute_design(resolve(loaded).config.design)
    plants = _plants(load_study(PAPER_STUDY), loaded, TuneSettings().seed, PLANTS)
    limit = 1.0 - DEFAULT_MARGIN
    worst = _plant_radii(design, plants).max()
    robust = _nominal_radius(design, scenario=TUNED) <= limit and worst <= limit
    assert robust  # the tuned design: robust on the study's plants
    assert data["robust"][j][i] is True and data["points"]["scenario"]["grid_index"] == [j, i]
    assert data["largest_robust_sample_time"]["grid"] >= 0.01


def test_a_map_too_large_is_refused_before_any_plant_is_drawn(monkeypatch, capsys):
    # grid points x plants against MAX_MAP_LOOPS: the largest grid (with a mark's value)
    # at the default plants fits, one plant more does not
    side = sm.POINTS_RANGE[1] + 1
    largest = sm.MapAxis(T_S, np.geomspace(0.0025, 0.04, side), 0.01)
    other = sm.MapAxis(ALPHA, np.geomspace(0.25, 8.0, side), 4.0)
    sm.check_size(largest, other, TuneSettings().plants)
    with pytest.raises(UsageError, match="2,081,004 loops to judge; at most 2,040,200"):
        sm.check_size(largest, other, TuneSettings().plants + 1)

    def drawn(*args: object, **kwargs: object) -> None:
        raise AssertionError("the plants were drawn")

    monkeypatch.setattr(sm, "map_setup", drawn)
    assert main(["design", "--map", "--map-points", "201", "--plants", "60"]) == 2
    assert "--map-points 201 x 201 grid points with --plants 60: 2,424,060 loops" in (
        capsys.readouterr().err
    )
    # the map's plants under the plants' own ceiling (one round: not doubled), so that
    # 6000 plants on a 3 x 3 grid pass both checks and reach the drawing
    assert main(["design", "--map", "--plants", "10001"]) == 2
    assert "--plants = 10001; at most 10,000 plants are allowed" in capsys.readouterr().err
    main(["design", "--map", "--map-points", "3", "--plants", "6000"])
    assert "the plants were drawn" in capsys.readouterr().err
