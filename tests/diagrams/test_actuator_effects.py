"""The actuator section's electronics (``diagrams.actuator``): electrical lag, DAC and
compute delay, each checked against a closed form or an independent computation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Multiplexer, VectorLogSink

from posfb.analysis.common.metrics import run_metrics
from posfb.analysis.montecarlo.worker import ClosedLoopEvaluator
from posfb.analysis.uncertainty.sampling import sample_scenario
from posfb.analysis.uncertainty.study import study_from_text
from posfb.diagrams.actuator import (
    EFFECT_BLOCKS,
    ActuatorState,
    add_electrical_lag,
    dac_step,
    set_time_constants,
)
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.diagrams.runner import ClosedLoopRunner
from posfb.diagrams.structure import structure_key
from posfb.diagrams.wiring import LoopSystems

SHORT = "timing.duration=0.5"


def config(*settings: str, controller: str = "pid"):
    loaded = load_scenario(None, [SHORT, f"controller.kind={controller}", *settings])
    return resolve(loaded).config


def block_names(runner: ClosedLoopRunner) -> set[str]:
    return {system.get_name() for system in runner.diagram.GetSystems()}


def test_the_default_diagram_has_no_actuator_effect_block():
    names = block_names(ClosedLoopRunner(config()))
    assert not any(name.startswith(EFFECT_BLOCKS) for name in names), names
    assert "voltage_saturation" in names
    on = config(
        "actuator.electrical_time_constant=0.001",
        "actuator.dac_bits=12",
        "actuator.compute_delay=0.002",
    )
    assert set(EFFECT_BLOCKS) <= block_names(ClosedLoopRunner(on))


def test_the_electrical_lag_step_response_has_time_constant_L_over_R():
    taus, step = [0.002, 0.0, 0.0005], np.array([2.0, -3.0, 1.5])
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource(step))
    lagged, lag = add_electrical_lag(builder, source.get_output_port(), taus)
    assert lag is not None
    logger = builder.AddSystem(VectorLogSink(3, 1e-4))
    builder.Connect(lagged, logger.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    set_time_constants(lag, lag.GetMyMutableContextFromRoot(simulator.get_mutable_context()), taus)
    simulator.get_mutable_integrator().set_target_accuracy(1e-10)
    simulator.AdvanceTo(0.01)
    log = logger.FindLog(simulator.get_context())
    t, v = log.sample_times(), log.data()
    for j, tau in enumerate(taus):
        expected = step[j] * (1.0 - np.exp(-t / tau)) if tau > 0 else np.full_like(t, step[j])
        np.testing.assert_allclose(v[j], expected, atol=1e-7 * abs(step[j]))
    # The time constant itself: 1 - 1/e of the step is reached at t = tau.
    at_tau = np.interp(0.002, t, v[0]) / step[0]
    assert abs(at_tau - (1.0 - math.exp(-1.0))) < 1e-6


def test_the_lag_and_the_dac_are_per_context_values():
    """One diagram built with a lag and a DAC runs other time constants and resolutions
    set in its Context exactly as a diagram built with them; off in the Context (every
    tau = 0, 0 bits) it is today's run to the bit (the pass-through is exact, the idle lag
    states add nothing to the integrator's error norm)."""
    names = ("q_true", "q_measured", "u_commanded", "u_applied")
    built = ClosedLoopRunner(
        config("actuator.electrical_time_constant=0.001", "actuator.dac_bits=12")
    )
    other = ("actuator.electrical_time_constant=[0.0004, 0]", "actuator.dac_bits=9")
    expected = ClosedLoopRunner(config(*other)).run()
    found = built.run(actuator=ActuatorState((0.0004, 0.0), 9))
    for name in names:
        np.testing.assert_array_equal(getattr(found, name), getattr(expected, name))
    today = ClosedLoopRunner(config()).run()
    off = built.run(actuator=ActuatorState((0.0, 0.0), 0))
    for name in names:
        np.testing.assert_array_equal(getattr(off, name), getattr(today, name))
    bare = ClosedLoopRunner(config())  # no lag, no DAC: an effect it lacks is refused
    with pytest.raises(ValueError, match=r"actuator.dac_bits = 8 needs a diagram built"):
        bare.run(actuator=ActuatorState((0.0, 0.0), 8))
    with pytest.raises(ValueError, match=r"electrical_time_constant\[1\] = -1.0"):
        built.run(actuator=ActuatorState((0.001, -1.0), 12))


def test_a_vanishing_electrical_lag_recovers_the_static_motor():
    static = run_metrics(ClosedLoopRunner(config()).run())
    errors = []
    for tau in (2e-3, 5e-4, 1.25e-4):
        lagged = run_metrics(
            ClosedLoopRunner(config(f"actuator.electrical_time_constant={tau}")).run()
        )
        errors.append(max(abs(a - b) / b for a, b in zip(lagged.rms_q, static.rms_q, strict=True)))
    # The difference shrinks with tau (about in proportion) and is small at the end.
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[2] < 0.5 * errors[0] and errors[2] < 0.05, errors


def quantised_independently(u: np.ndarray, limit: float, bits: int) -> np.ndarray:
    """The two's-complement DAC written with numpy: levels c Delta, c in
    [-2^(b-1), 2^(b-1) - 1], Delta = 2 V / 2^b, nearest level (half to even)."""
    delta = 2.0 * limit / 2**bits
    return np.clip(np.round(u / delta), -(2 ** (bits - 1)), 2 ** (bits - 1) - 1) * delta


def test_every_applied_voltage_lies_on_the_dac_grid():
    bits = 6
    runner = ClosedLoopRunner(config(f"actuator.dac_bits={bits}"))
    result = runner.run()
    limit = runner.config.voltage_limit[0]
    delta = dac_step(limit, bits)
    assert delta == pytest.approx(0.75)
    codes = result.u_applied / delta
    np.testing.assert_array_equal(codes, np.round(codes))  # on the grid, to the bit
    assert codes.min() >= -(2 ** (bits - 1)) and codes.max() <= 2 ** (bits - 1) - 1
    commanded = result.u_commanded
    np.testing.assert_array_equal(result.u_applied, quantised_independently(commanded, limit, bits))
    inside = (commanded >= -limit) & (commanded <= limit - delta / 2)
    error = np.abs(result.u_applied - commanded)[inside]
    assert error.max() <= delta / 2 * (1 + 1e-12)
    assert error.max() > 0.4 * delta  # a run this long does reach nearly half a step
    # Python out of the inner loop: the DAC is computed about once per period, although
    # the integrator evaluates the loop many times per period.
    dac = runner.loop.actuator.dac
    assert dac.evaluations <= 2 * (runner.config.samples + 2), dac.evaluations
    assert result.integrator_steps > runner.config.samples


def test_a_zero_compute_delay_is_todays_run_to_the_bit():
    today = ClosedLoopRunner(config()).run()
    runner = ClosedLoopRunner(config("actuator.compute_delay=0.0"))
    assert runner.loop.actuator.compute_delay is None
    zero = runner.run()
    for name in ("q_true", "q_measured", "u_commanded", "u_applied"):
        np.testing.assert_array_equal(getattr(zero, name), getattr(today, name))


def fine_log(delay: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """A run with ``compute_delay = delay`` and a logger at T_s / 10 of the controller's
    voltage and the applied one: times, commanded, applied, T_s and the limit."""
    cfg = config(f"actuator.compute_delay={delay!r}")
    loggers: list[VectorLogSink] = []

    def extend(builder: DiagramBuilder, systems: LoopSystems) -> None:
        n = systems.controller.GetOutputPort("voltage").size()
        both = builder.AddSystem(Multiplexer([n, n]))
        builder.Connect(systems.controller.GetOutputPort("voltage"), both.get_input_port(0))
        builder.Connect(systems.actuator.applied, both.get_input_port(1))
        logger = builder.AddSystem(VectorLogSink(2 * n, cfg.sample_time / 10))
        builder.Connect(both.get_output_port(0), logger.get_input_port())
        loggers.append(logger)

    runner = ClosedLoopRunner(cfg, extend=extend)
    simulator = runner.new_simulator()
    runner.advance(simulator)
    log = loggers[0].FindLog(simulator.get_context())
    n = cfg.joints
    data = log.data().T
    return log.sample_times(), data[:, :n], data[:, n:], cfg.sample_time, cfg.voltage_limit[0]


@pytest.mark.parametrize("fraction", [0.45, 1.0])
def test_the_voltage_of_t_k_applies_from_t_k_plus_the_delay(fraction):
    """Inside period k (fine samples j = 1..9 of t_k + j T_s/10; j = 0 falls on the
    sample instant itself): the applied voltage is the command of t_(k-1) before
    t_k + d and the command of t_k from there on."""
    T_s = 0.01
    times, commanded, applied, T_s, limit = fine_log(fraction * T_s)
    fine = np.rint(times / (T_s / 10)).astype(int)
    k, j = fine // 10, fine % 10
    command = {}  # the controller's output over [t_k, t_{k+1}), read at t_k + T_s/10
    for row in np.flatnonzero(j == 1):
        command[k[row]] = commanded[row]
    checked = 0
    for row in np.flatnonzero(j > 0):
        np.testing.assert_array_equal(commanded[row], command[k[row]])  # held all period
        source = k[row] - 1 if j[row] < fraction * 10 else k[row]
        if source < 0:  # before the first computed voltage: the controller's initial one
            np.testing.assert_array_equal(applied[row], np.clip(commanded[0], -limit, limit))
            continue
        np.testing.assert_array_equal(applied[row], np.clip(command[source], -limit, limit))
        checked += 1
    assert checked > 400


STUDY = """
seed: 5
samples: 2
duration: 0.5
controllers: [pid]
draws:
  actuator.electrical_time_constant: !Uniform {min: 0.0005, max: 0.002}
"""


def test_a_study_draws_the_electrical_time_constant():
    study = study_from_text(STUDY)
    evaluator = ClosedLoopEvaluator(study)
    taus = []
    for index in range(study.samples):
        sample = evaluator(index)
        tau = sample.parameters["actuator.electrical_time_constant"]
        taus.append(tau)
        assert 0.0005 <= tau <= 0.002
        (run,) = sample.runs
        direct = run_metrics(
            ClosedLoopRunner(config(f"actuator.electrical_time_constant={tau!r}")).run(
                evaluator.nominal_plant
            )
        )
        assert run.status == "ok"
        assert run.metrics["rms_q2"] == direct.rms_q[1]
    assert taus[0] != taus[1]
    # one diagram serves every sample: the drawn tau is a Context value
    keys = {structure_key(sample_scenario(study, i)[0], "pid") for i in range(study.samples)}
    assert len(keys) == 1


def test_switching_an_effect_on_changes_the_monte_carlo_structure_key():
    off = load_scenario(None, [SHORT]).scenario
    for setting in (
        "actuator.dac_bits=8",
        "actuator.compute_delay=0.005",
        "actuator.electrical_time_constant=0.001",
    ):
        on = load_scenario(None, [SHORT, setting]).scenario
        assert structure_key(on, "pid") != structure_key(off, "pid"), setting


def test_lag_and_dac_values_share_a_structure_and_delays_do_not():
    def key(*settings: str) -> str:
        return structure_key(load_scenario(None, [SHORT, *settings]).scenario, "pid")

    assert key("actuator.dac_bits=12") == key("actuator.dac_bits=14")
    lag = "actuator.electrical_time_constant"
    assert key(f"{lag}=0.001") == key(f"{lag}=[0.0002, 0]")
    # an event time is the diagram's (diagrams.actuator)
    assert key("actuator.compute_delay=0.002") != key("actuator.compute_delay=0.003")
