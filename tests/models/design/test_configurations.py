"""The configurations the arm visits (``models.design.configurations``) in the linear
verdicts: the set's construction, and a two-link arm with a light gear whose ``M*(q)``
varies several-fold, where the ``M0*`` verdict says stable, a configuration on the path is
unstable, and the exact arm's simulation grows (issue 40)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import posfb
from helpers.planar_arm import planar_arm_urdf
from posfb.analysis.design.design_report import nominal_design
from posfb.diagrams.resolve import resolve
from posfb.models.design.configurations import (
    EXTREME_SCAN_STEPS,
    Configuration,
    FrozenFigures,
    distinct,
    mass_ratio_eigenvalues,
    path_configurations,
)
from posfb.models.lumped import TABLE1, LumpedModel
from posfb.models.nominal import UrdfNominal, nominal_model
from posfb.models.trajectory import WaveTrajectory

#: Lin+LC's LQR weights on the light-gear arm: its sampled loop at ``M0*`` has spectral
#: radius 0.91, while with the folded arm's ``M*(q)`` (``q2`` near 2.7 rad, the lightest
#: along the path below) it is above 1 (found by scanning ``R`` with the loop of
#: ``models.design.synthesis``; the test checks both, it does not trust the numbers).
LIGHT_GEAR_WEIGHTS = {
    "Q1": [[1373.01, 0, 0, 0], [0, 139.384, 0, 0], [0, 0, 0.429064, 0], [0, 0, 0, 0.0435574]],
    "Q2": [[0.001, 0], [0, 0.001]],
    "R": [[3e-7, 0], [0, 3e-7]],
    "lambdas": [10.0, 10.0],
}


def test_mass_ratio_eigenvalues_are_the_physical_problem_s():
    # M0*, M* have rows divided by kappa_j (not symmetric); M0*^-1 M* = M0^-1 M
    rng = np.random.default_rng(3)
    root = rng.normal(size=(3, 3))
    M0 = root @ root.T + 3 * np.eye(3)
    other = rng.normal(size=(3, 3))
    M = other @ other.T + np.eye(3)
    kappa = np.diag([0.2, 1.5, 7.0])
    found = mass_ratio_eigenvalues(np.linalg.solve(kappa, M0), np.linalg.solve(kappa, M))
    expected = np.sort(np.linalg.eigvals(np.linalg.solve(M0, M)).real)
    np.testing.assert_allclose(found, expected, rtol=1e-10)
    assert np.all(found > 0)


def test_the_path_set_holds_the_samples_and_the_extremes():
    model = LumpedModel(TABLE1)
    trajectory = WaveTrajectory()
    duration, spacing = 6.0, 0.5
    found = path_configurations(model, trajectory, duration, spacing)
    path = [c for c in found.configurations if c.role == "path"]
    assert [c.time for c in path] == pytest.approx(list(np.arange(13) * spacing))
    for c in path:
        np.testing.assert_allclose(c.q, trajectory.evaluate(c.time)[0])
    roles = {c.role: c for c in found.configurations if c.role != "path"}
    assert set(roles) == {"lightest", "heaviest"}
    # the extremes hold the path's smallest and largest eigenvalue on a scan finer than
    # the set's own (an independent grid, 4x finer than the scan that found them)
    fine = np.linspace(0.0, duration, 4 * EXTREME_SCAN_STEPS * int(duration / spacing) + 1)
    values = [mass_ratio_eigenvalues(model.M0(), model.M(trajectory.evaluate(t)[0]))
              for t in fine]  # fmt: skip
    lightest = mass_ratio_eigenvalues(model.M0(), model.M(np.array(roles["lightest"].q)))[0]
    heaviest = mass_ratio_eigenvalues(model.M0(), model.M(np.array(roles["heaviest"].q)))[-1]
    assert lightest <= min(v[0] for v in values) + 1e-6
    assert heaviest >= max(v[-1] for v in values) - 1e-6
    low, high = found.eigenvalue_range()
    assert low == pytest.approx(lightest) and high == pytest.approx(heaviest)
    for mass, c in zip(found.masses, found.configurations, strict=True):
        np.testing.assert_array_equal(mass, model.M(np.array(c.q)))


@pytest.mark.parametrize("spacing", [0.0, -1.0, math.nan, math.inf])
def test_a_bad_spacing_is_refused_by_name(spacing):
    with pytest.raises(ValueError, match="timing.configuration_spacing"):
        path_configurations(LumpedModel(TABLE1), WaveTrajectory(), 1.0, spacing)


def test_a_spacing_that_asks_for_too_many_configurations_is_refused():
    with pytest.raises(ValueError, match="at most"):
        path_configurations(LumpedModel(TABLE1), WaveTrajectory(), 20.0, 1e-4)


def test_the_scenario_key_is_validated():
    with pytest.raises(ValueError, match="timing.configuration_spacing = 0"):
        posfb.load_scenario(set={"timing.configuration_spacing": 0})


def test_distinct_keeps_the_first_of_each_configuration():
    # the path's worst, lightest and heaviest configurations may be one q
    worst = Configuration((0.0, 1.0), 0.0, "path")
    lightest = Configuration((0.0, 1.0), 0.0, "lightest")
    heaviest = Configuration((0.5, 1.0), 2.0, "heaviest")
    assert distinct([worst, lightest, heaviest]) == (worst, heaviest)


def test_frozen_figures_pick_the_worst_end():
    radii = FrozenFigures((0.5, 1.2, 0.9), at_M0=0.7)
    assert radii.worst_index == 1 and radii.worst == 1.2
    margins = FrozenFigures((0.5, 0.2, math.nan), at_M0=0.7, worse="min")
    assert margins.worst_index == 2  # a figure that could not be computed counts as worst
    with pytest.raises(ValueError, match="worse"):
        FrozenFigures((1.0,), 1.0, worse="mean")


@pytest.fixture(scope="module")
def light_gear(tmp_path_factory) -> posfb.analysis.api.LoadedScenario:
    """A two-link arm with a gear 20x lighter than the generated arm's (``M*(q)`` varying
    several-fold) on a path through the folded arm, under Lin+LC's ``LIGHT_GEAR_WEIGHTS``,
    the voltage limit lifted so that saturation does not mask the loop."""
    folder = tmp_path_factory.mktemp("light_gear")
    urdf = planar_arm_urdf(2, folder, name="light_gear", gear_scale=0.05, limits=(-3.0, 3.0))
    weights = "\n".join(f"  {key}: {value}" for key, value in LIGHT_GEAR_WEIGHTS.items())
    path = folder / "light_gear.yaml"
    path.write_text(
        f"plant: {{urdf: {urdf}}}\n"
        f"nominal_model: !UrdfModel {{urdf: {urdf}}}\n"
        "trajectory: !Wave\n  joints:\n"
        "  - {offset: 0.0, amplitude: 0.3, wave_amplitude: 0.2, frequency: 1.0}\n"
        "  - {offset: 2.0, amplitude: 0.5, wave_amplitude: 0.2, frequency: 1.0}\n"
        "timing: {duration: 10.0}\n"
        "sensor: {encoder_counts: [20000, 20000]}\n"
        "actuator: {voltage_limit: [1000.0, 1000.0]}\n"
        f"controller: !LinLc\n{weights}\n"
    )
    return posfb.load_scenario(path)


def test_light_gear_mass_matrix_varies_several_fold(light_gear):
    config = resolve(light_gear).config
    assert isinstance(config.design.nominal, UrdfNominal)
    low, high = nominal_design(resolve(light_gear)).configurations.eigenvalue_range()
    assert high / low > 3.0


def test_light_gear_unstable_configuration_is_found_and_the_arm_grows(light_gear):
    resolved = resolve(light_gear)
    design = nominal_design(resolved)
    frozen = design.frozen_radii["sampled_data_lin_lc"]
    # the M0* verdict alone says stable ...
    assert frozen.at_M0 < 1.0
    # ... the configuration set finds a configuration of the path where the frozen loop
    # is unstable, and the check fails, naming it
    assert frozen.worst > 1.0
    check = next(c for c in design.checks if c.name == "sampled_data_lin_lc")
    assert not check.passed
    where = design.configurations.configurations[frozen.worst_index]
    assert f"t = {where.time:.3g} s" in check.detail
    # the loop at that configuration, rebuilt from the nominal model's own M*(q)
    model = nominal_model(resolved.config.design.nominal)
    loop = posfb.design(light_gear).loop.with_plant(
        model.M(np.array(where.q)), model.B(), posfb.models.design.NO_EFFECTS
    )
    assert loop.radius() == pytest.approx(frozen.worst, rel=1e-9)
    # the exact arm's simulation grows: the error leaves the encoder's scale and the run
    # diverges before its end
    run = posfb.simulate(light_gear)
    assert run.status == "diverged", run.message
    assert run.result.times[-1] < resolved.config.timing.duration


def test_paper_arm_verdicts_barely_move():
    # the paper's arm: M*(q) moves little with q, and so do its radii (at M0*: 1.0426 and
    # 0.8521, the design report's; the frozen configurations move them by about 1e-3)
    design = nominal_design(resolve(posfb.load_scenario()))
    for name in ("sampled_data", "sampled_data_lin_lc"):
        figures = design.frozen_radii[name]
        assert abs(figures.worst - figures.at_M0) < 0.005
    passed = {c.name: c.passed for c in design.checks}
    assert passed["sampled_data"] is False and passed["sampled_data_lin_lc"] is True


def test_scenario_check_confirms_on_the_exact_arm(light_gear, capsys):
    from posfb.analysis.cli import main

    path = str(light_gear.base_dir / "light_gear.yaml")
    code = main(["scenario", "check", path])
    out = capsys.readouterr().out
    # the linear check fails and the exact arm agrees: one line says both
    assert "verdict: the lin_lc controller fails sampled_data_lin_lc" in out
    line = next(x for x in out.splitlines() if x.startswith("exact arm:"))
    assert "diverged" in line and "as the linear checks say" in line
    assert code != 0
    main(["scenario", "check", path, "--no-sim"])
    assert "exact arm:" not in capsys.readouterr().out


def test_the_agreement_line_names_a_disagreement():
    from posfb.analysis.common.metrics import Verdict
    from posfb.analysis.design.exact_arm import ExactArmRun, agreement

    saturated = ExactArmRun(Verdict("saturated", "saturated: 47 % of the samples"), 20.0, 20.0)
    line = agreement(True, saturated)
    assert line.startswith("exact arm: the linear checks pass;") and "47 %" in line
    ok = ExactArmRun(Verdict("ok", ""), 20.0, 20.0)
    assert "as the linear checks say" in agreement(True, ok)
    assert "though the linear checks fail" in agreement(False, ok)


def test_the_certificate_is_reported_for_the_scenario_controller(light_gear):
    design = nominal_design(resolve(light_gear))
    (name, certificate), = design.certificates.items()
    assert name == "sampled_data_lin_lc"
    # a frozen loop on the path is unstable: no common Lyapunov function can exist
    assert not certificate.feasible and ">= 1" in certificate.message
