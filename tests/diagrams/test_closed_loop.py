"""``diagrams.wiring`` and ``diagrams.runner``: wiring, timing, saturation, divergence, reuse."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from helpers.loop_checks import assert_position_only
from posfb.analysis.common.metrics import run_metrics
from posfb.analysis.paper.experiment import case_parameters, payload_mass
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.diagrams.runner import ClosedLoopRunner
from posfb.diagrams.sections import Actuator, Sensor, Timing
from posfb.models.controllers import kinds
from posfb.models.trajectory import desired

#: Short runs keep the module fast; 3 s covers the transient and a joint-2 period.
DURATION = 3.0


@pytest.fixture(scope="module")
def runners():
    return {
        kind: ClosedLoopRunner(ClosedLoopConfig(controller=kind, timing=Timing(duration=DURATION)))
        for kind in kinds()  # every registered controller, the plug-in baselines included
    }


@pytest.fixture(scope="module")
def payload_runs(runners):
    return {
        kind: runner.run(case_parameters(runner.arm, "payload"))
        for kind, runner in runners.items()
        if kind in ("lin_lc", "proposed")
    }


@pytest.mark.parametrize("kind", kinds())
def test_the_only_path_from_plant_to_controller_is_the_quantised_position(runners, kind):
    assert_position_only(runners[kind].loop)


def test_voltage_computed_at_t_k_uses_the_measurement_at_t_k(runners):
    result = runners["pid"].run()
    assert result.status == "ok"
    T_s = result.times[1] - result.times[0]
    np.testing.assert_allclose(result.times, np.arange(len(result.times)) * T_s, atol=1e-12)
    assert len(result.times) == round(DURATION / T_s) + 1
    # PID's backward difference at row k is (q_m(t_k) - q_m(t_{k-1})) / T_s: no extra delay
    estimate = result.internals[:, result.internals_names.index("qdot_est_2")]
    np.testing.assert_allclose(
        estimate[1:], np.diff(result.q_measured[:, 1]) / T_s, rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(result.q_true[0], desired(0.0)[0])


def test_measured_position_is_the_true_one_quantised(runners):
    runner = runners["lin_lc"]
    for counts in (2000, 0):
        result = runner.run(
            sensor=dataclasses.replace(runner.config.sensor_state, encoder_counts=(counts, counts))
        )
        error = np.abs(result.q_measured - result.q_true)
        if counts:
            step = 2 * math.pi / counts
            assert error.max() <= step / 2 + 1e-12
            np.testing.assert_allclose(
                result.q_measured / step, np.round(result.q_measured / step), atol=1e-9
            )
        else:
            assert error.max() == 0.0


def test_applied_voltage_never_exceeds_the_limit(runners):
    for kind, runner in runners.items():
        result = runner.run()
        assert np.max(np.abs(result.u_applied)) <= 24.0, kind


def test_saturation_clips_the_commanded_voltage():
    runner = ClosedLoopRunner(ClosedLoopConfig(
        controller="pid", timing=Timing(duration=1.0), actuator=Actuator(voltage_limit=[3.0])
    ))
    result = runner.run()
    assert run_metrics(result).saturated_fraction > 0.1
    assert np.max(np.abs(result.u_applied)) <= 3.0
    np.testing.assert_allclose(result.u_applied, np.clip(result.u_commanded, -3.0, 3.0))


def test_runner_reuses_its_diagram_with_fresh_contexts(runners):
    runner = runners["proposed"]
    first, second = runner.run(), runner.run()
    np.testing.assert_array_equal(first.q_true, second.q_true)
    heavy = runner.run(runner.arm.default_parameters.with_payload(payload_mass("payload")))
    assert not np.allclose(heavy.q_true, first.q_true)
    np.testing.assert_array_equal(runner.run().u_commanded, first.u_commanded)


def test_a_diverging_run_is_reported_not_raised(runners):
    runner = runners["lin_lc"]
    weak = dataclasses.replace(runner.arm.default_parameters, motor_constant=(0.01, 0.01))
    result = runner.run(weak)
    assert result.status == "diverged"
    assert "divergence_bound" in result.message
    assert result.times[-1] < DURATION


def test_an_integrator_failure_is_reported_not_raised(runners):
    runner = runners["lin_lc"]
    p = runner.arm.default_parameters
    # link 2 without any inertia about its joint: Drake refuses the mass matrix
    singular = dataclasses.replace(
        p,
        link_com=(p.link_com[0], 0.0),
        link_inertia=(p.link_inertia[0], 0.0),
        rotor_inertia=(p.rotor_inertia[0], 0.0),
    )
    result = runner.run(singular)
    assert result.status == "diverged"
    assert result.message.startswith("integrator failed")
    assert math.isnan(run_metrics(result).rms_q[0])


def test_payload_proposed_beats_lin_lc_on_joint_2(payload_runs):
    """Sec. 4.3: Lin+LC cannot resist the payload's M1, C, G changes; tau_NC does."""
    proposed, lin_lc = payload_runs["proposed"], payload_runs["lin_lc"]
    assert proposed.status == lin_lc.status == "ok"
    assert run_metrics(proposed).rms_q[1] < run_metrics(lin_lc).rms_q[1]


@pytest.mark.parametrize(
    ("change", "name"),
    [
        ({"controller": "lqr"}, "controller.kind = 'lqr'"),
        ({"timing": Timing(duration=1.005)}, "timing.duration = 1.005"),
        ({"sensor": Sensor(encoder_counts=[-5])}, "sensor.encoder_counts"),
        ({"actuator": Actuator(voltage_limit=[-24.0])}, "actuator.voltage_limit[0] = -24.0"),
        ({"timing": Timing(divergence_bound=math.nan)}, "timing.divergence_bound = nan"),
        ({"timing": Timing(lost_bound=0.0)}, "timing.lost_bound = 0.0 is not positive"),
        ({"timing": Timing(lost_fraction=0.0)}, "timing.lost_fraction = 0.0 is not positive"),
        ({"timing": Timing(lost_fraction=1.5)}, "timing.lost_fraction = 1.5; a fraction in"),
        ({"timing": Timing(saturated_share=1.5)}, "timing.saturated_share = 1.5; a share in"),
        ({"timing": Timing(saturated_share=math.inf)}, "timing.saturated_share = inf"),
        ({"sensor": Sensor(noise_std=[-1.0])}, "sensor.noise_std[0] = -1.0"),
        ({"sensor": Sensor(delay_samples=1.5)}, "sensor.delay_samples = 1.5"),
    ],
)
def test_config_errors_name_the_scenario_key(change, name):
    # The config is the scenario resolved: its messages use the scenario's key, the one
    # name each setting has, so no caller re-labels them.
    with pytest.raises(ValueError) as error:
        ClosedLoopConfig(**change)
    assert str(error.value).startswith(name)


def test_the_sample_time_has_one_home(tmp_path):
    # Issue 44: a scenario's timing.sample_time is resolved into one LoopContext, which
    # the design, the controller's Drake system and the loop read; no other section holds
    # a copy that could disagree (the loop's Timing has no sample time at all).
    assert "sample_time" not in {f.name for f in dataclasses.fields(Timing)}
    path = tmp_path / "fast.yaml"
    path.write_text("controller: !LinLc {}\ntiming: {sample_time: 0.005, duration: 0.1}\n")
    config = resolve(load_scenario(path)).config
    assert config.design.context is config.context
    assert config.sample_time == config.design.sample_time == 0.005
    runner = ClosedLoopRunner(config)
    assert runner.loop.controller.sample_time == 0.005  # the period Drake's event holds


def test_a_config_keeps_its_own_sections():
    # The config holds the scenario's sections as copies: changing the scenario's lists
    # afterwards changes nothing the runner reads.
    sensor = Sensor(encoder_counts=[4096])
    config = ClosedLoopConfig(controller="lin_lc", sensor=sensor)
    sensor.encoder_counts[0] = 7
    assert config.sensor.encoder_counts == [4096]
    assert config.sensor_state.encoder_counts == (4096, 4096)
