"""The margins of the sampled loop (``models.design.margins``, ``posfb.design``): closed
forms on loops small enough to solve by hand, python-control's disk margins on the
paper's loops, the delay margin against the sampled loop's radius and a simulation, and
the exported python-control and Drake objects against posfb's own radius."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import posfb
from helpers.paths import REPO
from posfb.diagrams.resolve import resolve
from posfb.models.design import compute_design
from posfb.models.design.closed_loop import NO_EFFECTS
from posfb.models.design.margins import (
    DELAY_RESOLUTION,
    SampledFeedback,
    channel_margins,
    delayed,
    frequency_grid,
)
from posfb.models.design.realisation import DiscreteFilter

CLI = [sys.executable, "-m", "posfb.analysis.cli"]

#: A unit mass under a PD with a backward-difference derivative, at 100 Hz.
MASS, SAMPLE_TIME, KP, KD = 1.0, 0.01, 100.0, 15.0


def _largest_root(coefficients: np.ndarray) -> float:
    return float(np.max(np.abs(np.roots(coefficients))))


def _pd_characteristic(rotation: complex = 1.0, delay: int = 0) -> np.ndarray:
    """``2 m z^(d+1) (z - 1)^2 + rotation T^2 (z + 1) ((K_p + K_d/T) z - K_d/T)``: the
    closed loop of the double integrator ``P(z) = T^2 (z + 1) / (2 m (z - 1)^2)`` (the
    zero-order-hold equivalent of ``1 / (m s^2)``) under ``u_k = -K_p q_k - K_d (q_k -
    q_(k-1)) / T`` with a loop gain ``rotation`` and ``d`` whole periods of delay."""
    T = SAMPLE_TIME
    plant = np.polymul([2.0 * MASS, 0.0], np.polymul([1.0, -1.0], [1.0, -1.0]))
    plant = np.polymul(plant, [1.0] + [0.0] * delay)
    law = rotation * T**2 * np.polymul([1.0, 1.0], [KP + KD / T, -KD / T])
    return np.polyadd(plant, law)


def _bisect(unstable, low: float, high: float) -> float:
    """The boundary between ``low`` (stable) and ``high`` (unstable) of ``unstable``."""
    for _ in range(200):
        middle = 0.5 * (low + high)
        low, high = (low, middle) if unstable(middle) else (middle, high)
    return 0.5 * (low + high)


@pytest.fixture(scope="module")
def double_integrator():
    """The PD loop above as a ``SampledFeedback`` and its margins."""
    T = SAMPLE_TIME
    pd = DiscreteFilter(  # state q_(k-1)
        A=np.zeros((1, 1)), B=np.ones((1, 1)), C=np.array([[KD / T]]),
        D=np.array([[-KP - KD / T]]), initial=np.ones((1, 1)),
    )  # fmt: skip
    loop = SampledFeedback(np.array([[MASS]]), np.zeros((1, 1)), T, NO_EFFECTS, pd)
    return loop, loop.margins()


def test_double_integrator_margins_match_its_characteristic_polynomial(double_integrator):
    """Gain and phase margins: the loop gain, and the phase rotation ``exp(-j phi)``, at
    which a root of the closed loop's polynomial (written by hand) reaches the unit
    circle; the loop-wide delay margin lies between the whole-period delays on either
    side of ``PM / omega_c``."""
    loop, margins = double_integrator
    assert _largest_root(_pd_characteristic()) < 1.0
    assert margins.radius == pytest.approx(_largest_root(_pd_characteristic()), rel=1e-9)
    channel = margins.at_input.channels[0]
    gain = _bisect(lambda k: _largest_root(_pd_characteristic(k)) >= 1.0, 1.0, 100.0)
    assert channel.gain_margin == pytest.approx(gain, rel=1e-6)
    phase = _bisect(
        lambda p: _largest_root(_pd_characteristic(np.exp(-1j * math.radians(p)))) >= 1.0,
        0.0, 180.0,
    )  # fmt: skip
    assert channel.phase_margin_deg == pytest.approx(phase, abs=1e-6)
    assert channel.delay_margin_s == pytest.approx(
        math.radians(channel.phase_margin_deg) / channel.crossover_rad_per_s
    )
    periods = channel.delay_margin_s / SAMPLE_TIME
    below, above = math.floor(periods), math.ceil(periods)
    assert _largest_root(_pd_characteristic(delay=below)) < 1.0
    assert _largest_root(_pd_characteristic(delay=above)) >= 1.0
    assert below * SAMPLE_TIME <= margins.delay_margin_s <= above * SAMPLE_TIME
    # One channel: both breaks and the disk margin agree with the SISO forms.
    output = margins.at_output.channels[0]
    assert output.gain_margin == pytest.approx(channel.gain_margin, rel=1e-9)
    assert output.phase_margin_deg == pytest.approx(channel.phase_margin_deg, abs=1e-9)
    omega = frequency_grid(SAMPLE_TIME, 20000)
    L = -loop.controller.response(omega)[:, 0, 0] * loop.plant.response(omega)[:, 0, 0]
    balanced = np.abs(1.0 / (1.0 + L) - 0.5)
    assert margins.disk_margin == pytest.approx(1.0 / balanced.max(), rel=1e-5)


def test_integrator_loop_margins_in_closed_form():
    """``L(z) = k / (z - 1)``: ``|L| = k / (2 sin(w T / 2))`` and ``arg L = -90 deg - w T
    / 2``, so the crossover is ``w_c = (2 / T) asin(k / 2)``, the phase margin ``90 deg -
    w_c T / 2``, the phase crossover the Nyquist frequency with gain margin ``2 / k``."""
    T, k = 0.01, 0.4
    margins = channel_margins(
        lambda w: k / (np.exp(1j * np.asarray(w) * T) - 1.0), frequency_grid(T)
    )
    crossover = 2.0 / T * math.asin(k / 2.0)
    phase = 90.0 - math.degrees(crossover * T / 2.0)
    assert margins.crossover_rad_per_s == pytest.approx(crossover, rel=1e-9)
    assert margins.phase_margin_deg == pytest.approx(phase, abs=1e-7)
    assert margins.gain_margin == pytest.approx(2.0 / k, rel=1e-9)
    assert margins.phase_crossover_rad_per_s == pytest.approx(math.pi / T, rel=1e-12)
    assert margins.delay_margin_s == pytest.approx(math.radians(phase) / crossover, rel=1e-9)


@pytest.mark.parametrize("kind", ["lin_lc", "pid"])
def test_disk_margin_equals_python_controls(kind):
    """python-control's ``disk_margins`` (slycot's mu upper bound, on the same grid) at both
    breaks of the paper's loops; its stability_margins for one channel with the other
    open is not what loop-at-a-time means, so only the disk margin is compared."""
    control = pytest.importorskip("control")
    pytest.importorskip("slycot")
    loop = posfb.design(None, kind)
    margins = loop.margins()
    P, K = loop.plant_ss(), loop.controller_ss()
    omega = frequency_grid(loop.sample_time)
    for where, L in (("input", -K * P), ("output", -P * K)):
        theirs, gain, phase = control.disk_margins(L, omega, skew=0.0)  # gain in dB
        ours = margins.at_input if where == "input" else margins.at_output
        # Ours is refined between grid points, so it may only be the smaller (worse).
        assert ours.disk_margin == pytest.approx(theirs, rel=1e-4), where
        assert ours.disk_margin <= theirs * (1.0 + 1e-9), where
        assert ours.disk_gain_margin == pytest.approx(10.0 ** (gain / 20.0), rel=1e-3), where
        assert ours.disk_phase_margin_deg == pytest.approx(phase, rel=1e-3), where


@pytest.fixture(scope="module")
def paper_loops():
    """The paper's Lin+LC and its controller at the labelled alpha* = 3.25."""
    return {
        "lin_lc": posfb.design(None, "lin_lc"),
        "proposed": posfb.design(
            posfb.load_scenario(set={"controller.alpha_star": 3.25}), "proposed"
        ),
    }


@pytest.mark.parametrize("kind", ["lin_lc", "proposed"])
def test_delay_margin_is_where_the_sampled_loop_turns_unstable(paper_loops, kind):
    loop = paper_loops[kind]
    margin = loop.margins().delay_margin_s
    T = loop.sample_time
    assert 0.0 < margin < math.inf
    assert loop.loop.radius(margin - DELAY_RESOLUTION * T) < 1.0
    assert loop.loop.radius(margin) >= 1.0
    # The first crossing: no delay a resolution step or more below it is unstable.
    below = np.linspace(0.0, margin - DELAY_RESOLUTION * T, 60)
    assert max(loop.loop.radius(d) for d in below) < 1.0


def _error_envelope(run: posfb.Run, start: float, stop: float) -> float:
    frame = run.frame()
    window = frame[(frame.time_s >= start) & (frame.time_s < stop)]
    joints = [c[: -len("_desired_rad")] for c in frame.columns if c.endswith("_desired_rad")]
    return max(float(np.abs(window[f"{j}_rad"] - window[f"{j}_desired_rad"]).max())
               for j in joints)  # fmt: skip


@pytest.mark.slow
def test_delay_margin_predicts_the_simulation(paper_loops):
    """Lin+LC for 10 s with the delay 20 % below its margin keeps its error envelope; 20 %
    above, the envelope of the last 2 s is over 1.5 times that of seconds 1-3 (the loop
    grows until the voltage limit holds it). The delay goes in as ``sensor.delay_samples``
    whole periods and ``actuator.compute_delay`` for the rest."""
    margin = paper_loops["lin_lc"].margins().delay_margin_s
    growth = {}
    for factor in (0.8, 1.2):
        effects = delayed(NO_EFFECTS, factor * margin, SAMPLE_TIME)
        scenario = posfb.load_scenario(set={
            "timing.duration": 10.0, "sensor.delay_samples": effects.delay_samples,
            "actuator.compute_delay": effects.compute_delay,
        })  # fmt: skip
        run = posfb.simulate(scenario, "lin_lc")
        assert run.status == "ok"
        growth[factor] = _error_envelope(run, 8.0, 10.0) / _error_envelope(run, 1.0, 3.0)
    assert growth[0.8] < 1.1
    assert growth[1.2] > 1.5


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["pd_gravity", "adrc"])
def test_baselines_delay_margins_predict_the_simulation(kind):
    """The two baselines' linearised feedbacks (``ControllerSpec.linear``) against their own
    nonlinear step: 10 s with the delay 20 % below the margin never reaches the voltage
    limit; 20 % above, the loop's high-frequency oscillation grows until it does, more
    than 10 % of the time (measured: 12 % and 20 %)."""
    margin = posfb.design(None, kind).margins().delay_margin_s
    shares = {}
    for factor in (0.8, 1.2):
        effects = delayed(NO_EFFECTS, factor * margin, SAMPLE_TIME)
        scenario = posfb.load_scenario(set={
            "timing.duration": 10.0, "sensor.delay_samples": effects.delay_samples,
            "actuator.compute_delay": effects.compute_delay,
        })  # fmt: skip
        shares[factor] = posfb.simulate(scenario, kind).metrics.saturated_fraction
    assert shares[0.8] == 0.0
    assert shares[1.2] > 0.1


@pytest.mark.parametrize("kind", ["lin_lc", "proposed", "pid", "pd_gravity", "adrc"])
def test_exported_objects_close_the_loop_posfb_analyses(kind):
    """``control.feedback(plant, controller, sign=+1)`` of the exported objects has the
    sampled loop's eigenvalues; for the Sec. 3 designs its radius is ``posfb design``'s."""
    control = pytest.importorskip("control")
    scenario = posfb.load_scenario(set={"controller.alpha_star": 3.25})
    loop = posfb.design(scenario, kind)
    closed = control.feedback(loop.plant_ss(), loop.controller_ss(), sign=1)
    assert closed.dt == loop.sample_time
    ours = np.sort_complex(loop.closed_loop_eigenvalues())
    theirs = np.sort_complex(np.linalg.eigvals(closed.A))
    assert np.max(np.abs(ours - theirs)) < 1e-9
    if kind in ("lin_lc", "proposed"):
        design = compute_design(resolve(scenario).config.design)
        stated = (design.sampled_data_spectral_radius_lin_lc if kind == "lin_lc"
                  else design.sampled_data_spectral_radius)  # fmt: skip
        assert float(np.max(np.abs(theirs))) == pytest.approx(stated, abs=1e-9)


def test_drake_linear_systems_close_the_same_loop():
    """The Drake ``LinearSystem`` halves wired in a Diagram (``u = K y``): the diagram's
    periodic discrete update, applied to each unit state, is a transition matrix with
    the sampled loop's eigenvalues."""
    from pydrake.systems.framework import DiagramBuilder

    loop = posfb.design(None, "lin_lc")
    builder = DiagramBuilder()
    plant = builder.AddSystem(loop.plant_system())
    controller = builder.AddSystem(loop.controller_system())
    builder.Connect(plant.get_output_port(), controller.get_input_port())
    builder.Connect(controller.get_output_port(), plant.get_input_port())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    assert diagram.GetUniquePeriodicDiscreteUpdateAttribute().period_sec() == loop.sample_time
    groups = context.get_discrete_state()
    sizes = [groups.get_vector(g).size() for g in range(groups.num_groups())]
    columns = []
    for unit in np.eye(sum(sizes)):
        for g, part in enumerate(np.split(unit, np.cumsum(sizes)[:-1])):
            context.SetDiscreteState(g, part)
        update = diagram.EvalUniquePeriodicDiscreteUpdate(context)
        columns.append(np.concatenate([update.get_vector(g).value() for g in range(len(sizes))]))
    transition = np.column_stack(columns)
    ours = np.sort_complex(loop.closed_loop_eigenvalues())
    assert np.max(np.abs(np.sort_complex(np.linalg.eigvals(transition)) - ours)) < 1e-9


# The margins' tests pass --no-sim: the exact arm's run (20 s of the paper's arm) is not
# what they check; tests/analysis/cli/test_cli_design.py checks it.
def test_margins_json_and_text():
    result = subprocess.run(
        [*CLI, "design", "--margins", "--controller", "lin_lc", "--json", "--no-sim"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    margins = json.loads(result.stdout)["margins"]
    assert margins["stable"] is True
    for key in ("delay_margin_s", "disk_margin", "disk_gain_margin", "disk_phase_margin_deg",
                "peak_sensitivity", "peak_complementary_sensitivity"):  # fmt: skip
        assert margins[key] > 0.0, key
    assert margins["peak_sensitivity"] >= 1.0
    assert len(margins["channels"]) == 2
    for channel in margins["channels"]:
        assert set(channel) >= {"gain_margin", "phase_margin_deg", "crossover_rad_per_s",
                                "delay_margin_s"}  # fmt: skip
    # The disk margin bounds every loop-at-a-time margin (one channel is a special case).
    disk_gain = margins["disk_gain_margin"]
    assert all(c["gain_margin"] >= disk_gain * (1 - 1e-6) for c in margins["channels"])
    text = subprocess.run(
        [*CLI, "design", "--margins", "--set", "controller.kind=pid", "--no-sim"],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    assert "delay margin" in text and "disk margin" in text and "joint 2:" in text


def test_unstable_loop_has_no_margins():
    result = subprocess.run(
        [*CLI, "design", "--margins", "--json", "--no-sim"], capture_output=True, text=True,
        check=True,
    )  # the paper's alpha* = 4 loop: radius 1.04 (docs/results/report.md)
    margins = json.loads(result.stdout)["margins"]
    assert margins["stable"] is False and margins["spectral_radius"] >= 1.0
    assert margins["disk_margin"] is None and margins["delay_margin_s"] is None


@pytest.mark.slow
def test_the_guides_margins_table_is_the_codes():
    """``docs/margins/table.md`` (included in the guide) is what ``margins_table`` writes."""
    from posfb.analysis.design.margins_table import read_rows, table

    docs = REPO / "docs/margins"
    assert (docs / "table.md").read_text() == table(read_rows(docs / "rows.yaml"))


def test_bode_marks_each_channels_margins():
    """The Bode figure's marks are the margins: the red segment spans the gain margin in
    dB below 0 dB at the phase crossover, the green one the phase margin above -180 deg
    at the gain crossover."""
    from posfb.analysis.design.margins_figures import margins_bode

    loop = posfb.design(None, "lin_lc")
    margins = loop.margins()
    figure = margins_bode(loop, margins)
    axes = figure.get_axes()
    assert len(axes) == 2 * loop.joints
    for j, channel in enumerate(margins.at_input.channels):
        magnitude, phase = axes[2 * j], axes[2 * j + 1]
        gain_mark = [line for line in magnitude.lines if len(line.get_xdata()) == 2
                     and line.get_color() == "tab:red"]  # fmt: skip
        assert len(gain_mark) == 1
        assert gain_mark[0].get_xdata()[0] == pytest.approx(channel.phase_crossover_rad_per_s)
        low, high = gain_mark[0].get_ydata()
        assert high - low == pytest.approx(20.0 * math.log10(channel.gain_margin))
        phase_mark = [line for line in phase.lines if len(line.get_xdata()) == 2
                      and line.get_color() == "tab:green"]  # fmt: skip
        start, end = phase_mark[0].get_ydata()
        assert start - end == pytest.approx(channel.phase_margin_deg)
        assert end % 360.0 == pytest.approx(180.0, abs=0.5)


@pytest.mark.slow  # over 10 s on 2 cores (issue 45, item 4)
def test_margins_out_writes_the_json_and_figures(tmp_path):
    out = tmp_path / "margins"
    subprocess.run(
        [*CLI, "design", "--margins", "--controller", "pid", "--out", str(out), "--no-sim"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(["margins.json"] + [f"{stem}.{suffix}" for stem in
                           ("margins_bode", "margins_nyquist", "margins_sensitivity")
                           for suffix in ("png", "svg")])  # fmt: skip
    assert json.loads((out / "margins.json").read_text())["controller"] == "pid"
