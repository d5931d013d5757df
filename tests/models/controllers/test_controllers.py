"""The three controller LeafSystems: ports, timing, initialisation, the laws they
compute at a sample, and the adaptive gain alpha(t) of Eq. 21."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from helpers.lumped_plant import exact_model_config, simulate
from posfb.models.controllers import PAPER_CONTROLLERS, internals_names, make_controller
from posfb.models.design import ControllerConfig, NonlinearTorqueConfig
from posfb.models.lumped import LumpedModel
from posfb.models.trajectory import desired

T = ControllerConfig().sample_time
Q_D, QD_DOT, QD_DDOT = desired(1.0)
DESIRED = np.concatenate([Q_D, QD_DOT, QD_DDOT])


def _samples(controller, positions) -> tuple[np.ndarray, np.ndarray]:
    """Voltage and internals at samples 0, 1, ... with the (held) ``q_measured`` equal to
    ``positions[k]`` from sample ``k`` on and ``desired`` fixed: the update at ``t_k``
    steps with sample ``k - 1``'s input, then the input takes sample ``k``, as a
    ``ZeroOrderHold`` in front does (``models.controllers.base``)."""
    simulator = Simulator(controller)
    context = simulator.get_mutable_context()
    controller.GetInputPort("desired").FixValue(context, DESIRED)
    q_port = controller.GetInputPort("q_measured")
    q_port.FixValue(context, np.asarray(positions[0], dtype=float))
    voltages, internals = [], []
    for k, q in enumerate(positions):
        # past t_k (a simulator handles the updates at t_k when it steps beyond t_k)
        simulator.AdvanceTo((k + 0.5) * controller.sample_time)
        q_port.FixValue(context, np.asarray(q, dtype=float))
        voltages.append(controller.GetOutputPort("voltage").Eval(context))
        internals.append(controller.GetOutputPort("internals").Eval(context))
    return np.array(voltages), np.array(internals)


@pytest.mark.parametrize("kind", PAPER_CONTROLLERS)
def test_ports_take_positions_and_no_velocity(kind):
    controller = make_controller(kind)
    inputs = [controller.get_input_port(i) for i in range(controller.num_input_ports())]
    assert [(p.get_name(), p.size()) for p in inputs] == [
        ("q_measured", 2),
        ("desired", 6),
    ]
    outputs = [controller.get_output_port(i) for i in range(controller.num_output_ports())]
    assert [(p.get_name(), p.size()) for p in outputs] == [
        ("voltage", 2),
        ("internals", len(internals_names(kind, 2))),
    ]


@pytest.mark.parametrize("kind", PAPER_CONTROLLERS)
def test_outputs_feed_through_the_held_input_and_the_state_updates_every_period(kind):
    controller = make_controller(kind)
    assert controller.num_continuous_states() == 0
    q_port = controller.GetInputPort("q_measured")
    voltage_port = controller.GetOutputPort("voltage")
    assert controller.HasDirectFeedthrough(q_port.get_index(), voltage_port.get_index())
    periodic = controller.GetUniquePeriodicDiscreteUpdateAttribute()
    assert (periodic.period_sec(), periodic.offset_sec()) == (T, 0.0)


@pytest.mark.parametrize("kind", ["lin_lc", "proposed"])
def test_first_sample_on_the_trajectory_is_the_inverse_dynamics(kind):
    """At ``q = q_d`` with filters at rest: ``tau_Lin + tau_d = M* qdd_d + C* qd_d + G* +
    B* qd_d + F*(qd_d)``."""
    voltage, _ = _samples(make_controller(kind), [Q_D])
    expected = LumpedModel().inverse_dynamics(Q_D, QD_DOT, QD_DDOT, friction=True)
    np.testing.assert_allclose(voltage[0], expected, rtol=1e-12)


@pytest.mark.parametrize("kind", ["lin_lc", "proposed"])
def test_filters_start_at_rest_from_the_first_measurement(kind):
    """An initial error gives ``eta~(0) = 0`` and ``phi(0) = 0``: no kick at ``t = 0``."""
    q0 = Q_D + np.array([0.05, -0.03])
    voltage, internals = _samples(make_controller(kind), [q0])
    model = LumpedModel()
    tau_d = model.M0() @ QD_DDOT + model.B() @ QD_DOT
    names = internals_names(kind, 2)
    tau_lc = internals[0, [names.index("tau_lc_1"), names.index("tau_lc_2")]]
    np.testing.assert_allclose(tau_lc, tau_d, rtol=1e-9)
    if kind == "proposed":
        phi = internals[0, [names.index("phi_1"), names.index("phi_2")]]
        np.testing.assert_allclose(phi, 0.0, atol=1e-9)


def test_pid_is_eq_26_with_the_backward_difference():
    gains = ControllerConfig().pid
    Kp, Kv, KI = (np.asarray(g) for g in (gains.Kp, gains.Kv, gains.KI))
    q0, q1 = Q_D + np.array([0.01, -0.02]), Q_D + np.array([0.012, -0.017])
    voltage, internals = _samples(make_controller("pid"), [q0, q1])
    model = LumpedModel()
    # sample 0: zero velocity estimate, zero integral
    e0 = q0 - Q_D
    expected0 = model.inverse_dynamics(q0, np.zeros(2), QD_DDOT + Kv * QD_DOT - Kp * e0)
    np.testing.assert_allclose(voltage[0], expected0, rtol=1e-12)
    # sample 1: qdot = (q1 - q0) / T, integral T e0
    qdot, e1 = (q1 - q0) / T, q1 - Q_D
    command = QD_DDOT - Kv * (qdot - QD_DOT) - Kp * e1 - KI * T * e0
    np.testing.assert_allclose(voltage[1], model.inverse_dynamics(q1, qdot, command), rtol=1e-12)
    np.testing.assert_allclose(internals[1], np.concatenate([qdot, T * e0]), rtol=1e-12)


def test_alpha_rises_in_closed_form_without_error():
    """With ``q = q_d`` held, ``U_x = 0`` and Eq. 21 is ``y' = -y / K_alpha``:
    ``alpha_k = alpha* - (alpha* - alpha0) exp(-k T / (2 K_alpha))``."""
    nonlinear = NonlinearTorqueConfig(alpha0=1.0)
    controller = make_controller("proposed", ControllerConfig(nonlinear=nonlinear))
    _, internals = _samples(controller, [Q_D] * 30)
    alpha = internals[:, PROPOSED_ALPHA]
    k = np.arange(30)
    expected = 4.0 - 3.0 * np.exp(-k * T / (2 * nonlinear.K_alpha))
    np.testing.assert_allclose(alpha, expected, rtol=1e-12)


PROPOSED_ALPHA = internals_names("proposed", 2).index("alpha")


@pytest.fixture(scope="module")
def closed_loop_run():
    """Exact-model closed loop at 2 ms from an initial error, alpha(0) = 1."""
    base = exact_model_config(0.002)
    config = ControllerConfig(
        context=base.context,
        nonlinear=NonlinearTorqueConfig(filter_a=base.nonlinear.filter_a, alpha0=1.0),
    )
    return simulate("proposed", config, 2.0, initial_error=(0.05, -0.05))


def test_alpha_is_monotone_bounded_and_does_not_chatter(closed_loop_run):
    alpha = closed_loop_run.internals[PROPOSED_ALPHA, 1:]  # log 0 precedes the first update
    assert alpha[0] == 1.0
    assert np.all(alpha >= 1.0) and np.all(alpha <= 4.0)
    assert np.all(np.diff(alpha) >= 0.0)
    reached = int(np.argmax(alpha == 4.0))
    assert alpha[reached] == 4.0 and np.all(alpha[reached:] == 4.0)


def test_torques_add_up_to_the_voltage(closed_loop_run):
    names = internals_names("proposed", 2)
    parts = closed_loop_run.internals
    for joint in (1, 2):
        total = sum(parts[names.index(f"tau_{t}_{joint}")] for t in ("lin", "lc", "nc"))
        np.testing.assert_allclose(
            total, closed_loop_run.voltage[joint - 1], rtol=1e-12, atol=1e-12
        )
    tau_nc, phi = parts[names.index("tau_nc_1")], parts[names.index("phi_1")]
    np.testing.assert_allclose(tau_nc, -parts[PROPOSED_ALPHA] * phi, rtol=1e-12, atol=1e-15)
    assert np.all(parts[names.index("U1"), 1:] >= 0.0)
    assert np.all(np.diff(parts[names.index("U2"), 1:]) >= 0.0)  # running maximum
    assert math.isfinite(parts[names.index("delta_bar")].max())


def test_scalar_feedforward_equals_the_lumped_model_matrices():
    """The theta model's law form (``models.laws.nominal``: Eq. 4, 7, ||M1*||) against
    ``LumpedModel``'s matrices."""
    from posfb.models.controllers.feedforward import nominal_torques
    from posfb.models.lumped import TABLE1, LumpedModel

    model = LumpedModel(TABLE1)
    torques = nominal_torques(TABLE1)
    rng = np.random.default_rng(4)
    for _ in range(50):
        q, v, a = rng.uniform(-3, 3, 2), rng.uniform(-2, 2, 2), rng.uniform(-5, 5, 2)
        expected = model.M1(q) @ a + model.C(q, v) @ v + model.G(q) + model.F(v)
        np.testing.assert_allclose(torques.linearization(q, v, a), expected, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(torques.desired(v, a), model.M0() @ a + model.B() @ v)
        assert torques.M1_norm(q) == pytest.approx(np.linalg.norm(model.M1(q), 2), rel=1e-12)
