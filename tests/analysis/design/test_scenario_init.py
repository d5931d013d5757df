"""``posfb scenario init`` (``analysis.design.scenario_init``) and its rules
(``models.design.initial``): a generated 4-link arm gets a complete scenario that loads,
passes ``scenario check`` without warnings, stays within its voltage and joint limits
(recomputed here), and runs all three controllers; the rules have the properties they
claim (checked by independent computations, not by their own numbers)."""

from __future__ import annotations

import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

import posfb
from helpers.planar_arm import planar_arm_urdf
from helpers.slow import heavy
from posfb.models.design import initial
from posfb.models.design.config import LqrWeights
from posfb.models.lumped import TABLE1, LumpedModel
from posfb.models.nominal import UrdfNominal, nominal_model
from posfb.models.trajectory import JointWave, WaveTrajectory

CLI = [sys.executable, "-m", "posfb.analysis.cli"]
SAMPLE_TIME = 0.002
DURATION = 2.0
LIMITS = [None, (-1.2, 1.6), (-1.0, 1.0), None]


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
@heavy
def written(tmp_path_factory) -> tuple[Path, Path, subprocess.CompletedProcess]:
    """The 4-link arm, its scenario (written by the CLI at 2 ms) and ``scenario check``."""
    folder = tmp_path_factory.mktemp("init")
    urdf = planar_arm_urdf(4, folder, limits=LIMITS)
    out = folder / "four.yaml"
    result = _cli(
        "scenario", "init", "--urdf", urdf.name, "--out", out.name, "--sample-time",
        str(SAMPLE_TIME), "--duration", str(DURATION), cwd=folder,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    check = _cli("scenario", "check", str(out), cwd=folder)
    return urdf, out, check


def test_check_passes_without_warnings(written):
    _, _, check = written
    assert check.returncode == 0, check.stdout + check.stderr
    assert "warning" not in check.stdout.lower()
    assert "verdict: every check of the proposed controller passed" in check.stdout


def test_every_per_joint_list_has_one_entry_per_joint(written):
    _, out, _ = written
    scenario = posfb.load_scenario(out).scenario
    n = 4
    assert len(scenario.trajectory.joints) == n
    for values in (
        scenario.sensor.encoder_counts, scenario.sensor.zero_offset, scenario.sensor.noise_std,
        scenario.actuator.voltage_limit, scenario.controller.lambdas, scenario.controller.H.gamma,
        *(getattr(scenario.controllers["pid"], k) for k in ("Kp", "Kv", "KI")),
        scenario.controllers["lin_lc"].lambdas,
    ):  # fmt: skip
        assert len(values) == n
    for entry in (scenario.controller, scenario.controllers["lin_lc"]):
        assert np.shape(entry.Q1) == (2 * n, 2 * n)
        assert np.shape(entry.Q2) == np.shape(entry.R) == (n, n)
    assert scenario.plant.urdf == scenario.nominal_model.urdf == "planar_arm_4.urdf"
    text = out.read_text()
    assert text.count("# ") > 30  # every choice commented


def _urdf_limits(urdf: Path) -> list[tuple[float, float]]:
    """Joint limits read from the URDF text (continuous: unbounded)."""
    limits = []
    for joint in ET.parse(urdf).getroot().findall("joint"):
        if joint.get("type") == "fixed":
            continue
        element = joint.find("limit")
        if element is None:
            limits.append((-math.inf, math.inf))
        else:
            limits.append((float(element.get("lower")), float(element.get("upper"))))
    return limits


def test_trajectory_within_voltage_and_joint_limits(written):
    urdf, out, _ = written
    scenario = posfb.load_scenario(out).scenario
    waves = tuple(JointWave(w.offset, w.amplitude, w.wave_amplitude, w.frequency)
                  for w in scenario.trajectory.joints)  # fmt: skip
    trajectory = WaveTrajectory(waves)
    model = nominal_model(UrdfNominal(str(urdf)))
    times = np.arange(round(DURATION / SAMPLE_TIME) + 1) * SAMPLE_TIME
    samples = [trajectory.evaluate(float(t)) for t in times]
    voltages = np.array([model.inverse_dynamics(*s) for s in samples])
    limit = scenario.actuator.voltage_limit[0]
    assert np.abs(voltages).max() <= initial.VOLTAGE_HEADROOM * limit + 1e-9
    assert np.abs(voltages).max() > 0.1 * limit  # it does move the arm
    positions = np.array([q for q, _, _ in samples])
    for j, (low, high) in enumerate(_urdf_limits(urdf)):
        assert low < positions[:, j].min() and positions[:, j].max() < high
        if math.isfinite(low):
            room = 0.05 * (high - low)
            assert low + room < positions[:, j].min() and positions[:, j].max() < high - room


def test_filter_pole_satisfies_its_condition(written):
    _, out, _ = written
    scenario = posfb.load_scenario(out).scenario
    assert scenario.controller.filter_a > math.log(2) / SAMPLE_TIME
    for ts in (0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05):
        assert initial.filter_pole(ts) * ts / math.log(2) >= 1.44


@pytest.mark.parametrize("controller", ["proposed", "lin_lc", "pid"])
def test_written_scenario_runs_with_bounded_error(written, controller):
    _, out, _ = written
    run = posfb.simulate(posfb.load_scenario(out), controller=controller)
    assert run.status == "ok"
    assert run.metrics.max_abs_q_err < 0.02
    assert run.metrics.saturated_fraction < 0.05


@pytest.mark.slow
def test_existing_file_needs_force(written, tmp_path):
    urdf, _, _ = written
    out = tmp_path / "taken.yaml"
    out.write_text("# mine\n")
    refused = _cli("scenario", "init", "--urdf", str(urdf), "--out", str(out), cwd=tmp_path)
    assert refused.returncode == 2 and "--force" in refused.stderr
    assert out.read_text() == "# mine\n"


# --- the rules -------------------------------------------------------------------------


def _siso_lqr(m: float, b: float, lam: float, Qp: float, Qv: float, Qe: float, R: float):
    """One joint's augmented system (Eq. 11) and its LQR (Eq. 14-15), solved here."""
    A = np.array([[0.0, 1.0, 0.0], [0.0, -b / m, 1.0 / m], [0.0, 0.0, -lam]])
    B = np.array([[0.0], [0.0], [1.0]])
    P = scipy.linalg.solve_continuous_are(A, B, np.diag([Qp, Qv, Qe]), np.array([[R]]))
    K = B.T @ P / R
    return np.linalg.eigvals(A - B @ K), P


def _geometric_radius(poles: np.ndarray) -> float:
    return float(np.prod(np.abs(poles)) ** (1.0 / len(poles)))


def _paper_joint1():
    weights = LqrWeights()
    m = LumpedModel(TABLE1).M0()[0, 0]
    b = LumpedModel(TABLE1).B()[0, 0]
    Q1, Q2, R = (np.asarray(x) for x in (weights.Q1, weights.Q2, weights.R))
    return m, b, weights.lambdas[0], Q1[0, 0], Q1[2, 2], Q2[0, 0], R[0, 0]


def test_bandwidth_is_the_geometric_mean_of_the_lqr_poles_whatever_the_damping():
    for m, b, lam in ((0.3, 0.0, 10.0), (0.02, 1.5, 40.0), (2.0, 30.0, 3.0)):
        poles, _ = _siso_lqr(m, b, lam, 5000.0, 3.0, 0.01, 2e-4)
        assert _geometric_radius(poles) == pytest.approx(
            initial.joint_bandwidth(5000.0, 2e-4, m), rel=1e-9
        )


def test_rule_reproduces_the_papers_joint1_loop_on_table1_at_its_sample_time():
    m, b, lam, Qp, Qv, Qe, R = _paper_joint1()
    paper_poles, _ = _siso_lqr(m, b, lam, Qp, Qv, Qe, R)
    rule = initial.lqr_weights(LumpedModel(TABLE1).M0(), 0.01)
    rule_poles, _ = _siso_lqr(m, b, rule.lambdas[0], rule.Qp[0], rule.Qv[0], rule.Qe[0],
                              rule.R[0])  # fmt: skip
    np.testing.assert_allclose(np.sort_complex(rule_poles), np.sort_complex(paper_poles),
                               rtol=1e-5)  # fmt: skip
    assert _geometric_radius(rule_poles) * 0.01 == pytest.approx(
        _geometric_radius(paper_poles) * 0.01, rel=1e-5
    )


@pytest.mark.parametrize("sample_time", [0.002, 0.005, 0.02])
def test_rule_keeps_the_papers_bandwidth_per_sample_on_any_joint(sample_time):
    m, b, lam, Qp, Qv, Qe, R = _paper_joint1()
    paper = _geometric_radius(_siso_lqr(m, b, lam, Qp, Qv, Qe, R)[0]) * 0.01
    M0 = np.diag([0.9, 0.12, 0.015])
    rule = initial.lqr_weights(M0, sample_time)
    for j, mj in enumerate(np.diag(M0)):
        poles, _ = _siso_lqr(mj, 2.0, rule.lambdas[j], rule.Qp[j], rule.Qv[j], rule.Qe[j],
                             rule.R[j])  # fmt: skip
        assert _geometric_radius(poles) * sample_time == pytest.approx(paper, rel=1e-5)


def test_undamped_joint_gets_the_reference_loop_scaled_in_time_and_torque():
    """b = 0: poles scale by omega / omega_ref and E (Eq. 20) by rho (torque) x the state
    scales, so tau_NC's input is the reference's in the joint's own units."""
    m, _, lam, Qp, Qv, Qe, R = _paper_joint1()
    ref_poles, ref_P = _siso_lqr(m, 0.0, lam, Qp, Qv, Qe, R)
    mj, ts = 0.05, 0.004
    rule = initial.lqr_weights(np.array([[mj]]), ts)
    poles, P = _siso_lqr(mj, 0.0, rule.lambdas[0], rule.Qp[0], rule.Qv[0], rule.Qe[0],
                         rule.R[0])  # fmt: skip
    k = 0.01 / ts
    np.testing.assert_allclose(np.sort_complex(poles), np.sort_complex(ref_poles * k),
                               rtol=1e-4)  # fmt: skip
    rho = rule.rho[0]
    omega, omega_ref = rule.bandwidth, initial.paper_reference().bandwidth
    scale_ref = np.diag([1.0, omega_ref, m * omega_ref**2])
    scale = np.diag([1.0, omega, mj * omega**2])
    E_ref = (ref_P[:, 1] / m) @ scale_ref  # E x~ per dimensionless state
    E = (P[:, 1] / mj) @ scale
    np.testing.assert_allclose(E, rho * E_ref, rtol=1e-4)


def test_pid_rule_places_its_poles_and_respects_the_encoder():
    M0 = LumpedModel(TABLE1).M0()
    pid = initial.pid_gains(0.01, M0, 20000, 24.0)
    omega = 2 * math.pi / (20 * 0.01)
    assert pid.bandwidth == (pytest.approx(omega), pytest.approx(omega))  # the sampling rule
    expected = np.poly([-omega, -omega, -0.1 * omega])  # (s + w)^2 (s + w / 10)
    np.testing.assert_allclose([1.0, pid.Kv[0], pid.Kp[0], pid.KI[0]], expected, rtol=1e-5)
    fast = initial.pid_gains(0.001, M0, 4096, 24.0)
    count = 2 * math.pi / 4096
    for j in range(2):
        jump = M0[j, j] * count * (fast.Kv[j] / 0.001 + fast.Kp[j])
        assert jump <= initial.QUANTISATION_FRACTION * 24.0 * (1 + 1e-5)


def test_alpha_star_is_the_largest_with_the_target_radius():
    choice = initial.largest_alpha_star(lambda a: 0.8 + 0.05 * a)  # 0.95 at alpha* = 3
    assert choice.met and choice.alpha_star == pytest.approx(3.0, abs=2e-3)
    assert choice.alpha_star <= 3.0
    assert initial.largest_alpha_star(lambda a: 0.5).alpha_star == 4.0
    assert not initial.largest_alpha_star(lambda a: 0.97 + 0.0 * a).met


def test_gamma_and_frequencies_follow_the_paper():
    assert initial.h_gamma(initial.wave_frequencies(2)) == initial.paper_h_gamma()
    assert initial.wave_frequencies(3)[:2] == (4.0, 3.0)


@pytest.mark.slow
def test_too_low_voltage_limit_names_the_option_and_the_voltage(written, tmp_path):
    urdf, _, _ = written
    result = _cli("scenario", "init", "--urdf", str(urdf), "--out", str(tmp_path / "x.yaml"),
                  "--voltage-limit", "1", cwd=tmp_path)  # fmt: skip
    assert result.returncode == 2
    line = result.stderr.strip().splitlines()
    assert len(line) == 1 and "--voltage-limit" in line[0] and "or more is needed" in line[0]
    assert not (tmp_path / "x.yaml").exists()


@pytest.mark.slow
def test_the_rules_work_at_5_khz(tmp_path: Path) -> None:
    """At ``T_s = 0.2 ms`` the LQR rule's weights span 14 decades, which scipy's Schur
    method failed on ("Q1, Q2, R: the Riccati equation has no stabilising solution", on
    keys the user never set); now the scenario is written and its design checks pass
    (issue 27). A 1 s duration keeps the voltage check's 5000 samples cheap."""
    arm = Path(posfb.__file__).resolve().parent.parent / "urdf" / "three_link_arm.urdf"
    out = tmp_path / "fast.yaml"
    result = _cli(
        "scenario", "init", "--urdf", str(arm), "--out", out.name, "--sample-time", "2e-4",
        "--duration", "1", cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    # the linear checks only: the exact arm's run of this design saturates (the rules'
    # bandwidth at 5 kHz; scenario check's simulation says so and exits 5: issue 40's
    # item 3, scenario init's rules over the exact arm, is not done yet)
    check = _cli("scenario", "check", out.name, "--no-sim", cwd=tmp_path)
    assert check.returncode == 0, check.stdout + check.stderr
    assert "verdict: every check of the proposed controller passed" in check.stdout


def test_a_shipped_arm_is_named_as_a_scenario_names_it(tmp_path):
    # argparse's type=Path folds package://posfb/ to package:/posfb/; both name the file
    from posfb.analysis.design.scenario_init import InitOptions, settings_of
    from posfb.models.plant import DEFAULT_URDF

    shipped = DEFAULT_URDF.parent / "three_link_arm.urdf"
    for urdf in ("package://posfb/three_link_arm.urdf", Path("package://posfb/three_link_arm.urdf")):
        settings = settings_of(InitOptions(urdf=urdf, out=tmp_path / "three.yaml"))
        assert settings.urdf == shipped


def test_the_written_rules_follow_the_rules_constants(monkeypatch):
    """``scenario init``'s comments are written by the rules of
    ``models.design.initial`` from their own constants: another integrator pole ratio or
    alpha* grid changes the text with the numbers, so the two cannot drift apart."""
    from posfb.models.design import initial

    monkeypatch.setattr(initial, "INTEGRATOR_POLE_RATIO", 0.2)
    kp, kv, ki = initial._pid_coefficients(1.0)
    pid = initial.pid_gains(0.01, np.eye(2), 4096, 24.0)
    text = " ".join(pid.rule())
    assert f"Kp = {kp:g} omega_j^2, Kv = {kv:g} omega_j, KI = 0.2 omega_j^3" in text
    assert pid.Kp[0] == pytest.approx(kp * pid.bandwidth[0] ** 2, rel=1e-5)  # the same rule
    monkeypatch.setattr(initial, "ALPHA_GRID_POINTS", 7)
    choice = initial.largest_alpha_star(lambda alpha: 2.0)  # no alpha* reaches the target
    assert not choice.met
    assert "7-point grid" in " ".join(choice.rule(2.0, 0.9))


def test_the_alpha_rule_judges_the_path_s_configurations(written):
    """The written alpha*'s loop meets the target radius at every configuration of the
    scenario's path (recomputed by ``posfb design``'s configuration set, another code path
    than the rule's)."""
    from posfb.analysis.design.design_report import nominal_design
    from posfb.diagrams.resolve import resolve

    _, out, _ = written
    design = nominal_design(resolve(posfb.load_scenario(out)))
    assert design.frozen_radii["sampled_data"].worst <= initial.TARGET_RADIUS + 1e-9


def test_a_rule_that_cannot_pass_says_why_in_one_line():
    from posfb.analysis.design.scenario_init import DesignedControllers

    failing = DesignedControllers(
        weights=initial.lqr_weights(np.eye(2), 0.01, initial.BANDWIDTH_SCALES[-1]),
        filter_a=100.0, gamma=10.0,
        alpha=initial.AlphaChoice(0.05, 1.07, met=False), pid=None,
        radius_lin_lc=1.02, radius_at_cap=1.3, eigenvalue_range=(0.3, 3.9),
    )  # fmt: skip
    reason = failing.reason()
    assert "varies 13x along the path" in reason and "Lin+LC's worst radius is 1.0200" in reason
    assert "at bandwidth scale 0.0625" in reason and "\n" not in reason
    assert "rotor inertia and gear, or a shorter T_s" in reason
    passing = DesignedControllers(
        weights=None, filter_a=100.0, gamma=10.0,
        alpha=initial.AlphaChoice(4.0, 0.9, met=True), pid=None,
        radius_lin_lc=0.88, radius_at_cap=0.9, eigenvalue_range=(0.3, 3.9),
    )  # fmt: skip
    assert passing.reason() == ""
