"""``models.identification.excitation``: the Fourier excitation of Swevers et al. (1997),
its rest at both ends, the optimised condition number and limits on the two-link paper
arm, one-line errors for impossible limits, and the CSV played back through ``!CsvFile``."""

from __future__ import annotations

import numpy as np
import pytest

from posfb.diagrams.resolve import load_scenario, resolve
from posfb.diagrams.sections import Actuator
from posfb.models.identification.excitation import (
    GRID_POINTS,
    FourierTrajectory,
    per_sample,
    plan_excitation,
    write_trajectory_csv,
)
from posfb.models.identification.theta_regressor import theta_regressor
from posfb.models.lumped import TABLE1, LumpedModel
from posfb.models.trajectory import PAPER_TRAJECTORY, desired

#: The paper's start (hanging down, Sec. 4.2): where a scenario's run begins.
REST = desired(0.0, PAPER_TRAJECTORY)[0]

#: The shipped scenarios' voltage limit (``actuator.voltage_limit``), V.
VOLTAGE_LIMIT = Actuator().voltage_limits(2)

DURATION, SAMPLE_TIME, HARMONICS = 10.0, 0.01, 5


def regressor(q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray) -> np.ndarray:
    return theta_regressor(q, qdot, qddot, TABLE1.l1, TABLE1.g)


voltage = per_sample(LumpedModel(TABLE1).inverse_dynamics)


def settings(**changes: object) -> dict[str, object]:
    """The two-link arm's plan settings: +-pi/2 about the rest, 2 rad/s, the scenarios'
    voltage limit; ``changes`` replace entries."""
    base = {
        "joints": 2,
        "rest": REST,
        "duration": DURATION,
        "harmonics": HARMONICS,
        "sample_time": SAMPLE_TIME,
        "joint_limits": (REST - np.pi / 2, REST + np.pi / 2),
        "velocity_limit": [2.0, 2.0],
        "voltage_limit": VOLTAGE_LIMIT,
        "seed": 3,
        "starts": 1,
    }
    return {**base, **changes}


@pytest.fixture(scope="module")
def plan():
    return plan_excitation(regressor, voltage, **settings())


def scaled_condition(Y: np.ndarray) -> float:
    stacked = Y.reshape(-1, Y.shape[-1])
    return float(np.linalg.cond(stacked / np.linalg.norm(stacked, axis=0)))


def test_the_derivatives_are_those_of_the_series():
    rng = np.random.default_rng(0)
    trajectory = FourierTrajectory.from_arrays(
        rng.normal(size=3), rng.normal(size=(3, 4)), rng.normal(size=(3, 4)), period=7.0
    )
    t, h = np.linspace(0.3, 13.0, 17), 1e-5
    (q_plus, qd_plus, _), (q_minus, qd_minus, _) = (
        trajectory.sample(t + h),
        trajectory.sample(t - h),
    )
    q, qd, qdd = trajectory.sample(t)
    assert q.shape == qd.shape == qdd.shape == (17, 3)
    np.testing.assert_allclose(qd, (q_plus - q_minus) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(qdd, (qd_plus - qd_minus) / (2 * h), atol=1e-8)
    # The printed formula, joint 2 at one time; periodic; one time as the Trajectory protocol.
    w, k = 2 * np.pi / 7.0, np.arange(1, 5)
    a, b = np.array(trajectory.a[1]), np.array(trajectory.b[1])
    t0 = 2.3
    printed = trajectory.q0[1] + np.sum(
        a / (w * k) * np.sin(w * k * t0) - b / (w * k) * np.cos(w * k * t0)
    )
    np.testing.assert_allclose(trajectory.sample(t0)[0][0, 1], printed, rtol=1e-14)
    for now, later in zip(trajectory.sample(t0), trajectory.sample(t0 + 7.0), strict=True):
        np.testing.assert_allclose(now, later, atol=1e-12)
    for one, row in zip(trajectory.evaluate(t0), trajectory.sample(t0), strict=True):
        np.testing.assert_array_equal(one, row[0])


def test_the_plan_is_at_rest_at_both_ends(plan):
    q, qd, qdd = plan.trajectory.sample([0.0, DURATION])
    np.testing.assert_allclose(q, [REST, REST], atol=1e-9)
    np.testing.assert_allclose(qd, 0.0, atol=1e-9)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-9)
    assert plan.trajectory.period == DURATION and plan.rest == tuple(REST)


def test_the_optimised_condition_number_is_lower_and_the_limits_hold_at_every_sample(plan):
    assert plan.condition < 0.6 * plan.condition_start, (plan.condition_start, plan.condition)
    # The objective as documented: the midpoint grid, columns divided by their norms.
    t = (np.arange(GRID_POINTS) + 0.5) / GRID_POINTS * DURATION
    grid = scaled_condition(regressor(*plan.trajectory.sample(t)))
    np.testing.assert_allclose(plan.condition, grid, rtol=1e-9)
    # The limits themselves (no margin) at every sample time, computed here afresh.
    times = np.linspace(0.0, DURATION, round(DURATION / SAMPLE_TIME) + 1)
    q, qd, qdd = plan.trajectory.sample(times)
    u = voltage(q, qd, qdd)
    lower, upper = settings()["joint_limits"]
    assert plan.limits_met
    assert np.all(q > lower) and np.all(q < upper)
    assert np.all(np.abs(qd) <= 2.0) and np.all(np.abs(u) <= np.array(VOLTAGE_LIMIT))
    np.testing.assert_allclose(plan.position_margin, np.minimum(q - lower, upper - q).min(0))
    np.testing.assert_allclose(plan.peak_velocity, np.abs(qd).max(0))
    np.testing.assert_allclose(plan.peak_voltage, np.abs(u).max(0))
    # Between samples too: the fine check is not fooled by the sample time.
    dense = plan.trajectory.sample(np.linspace(0.0, DURATION, 50001))[1]
    assert np.max(np.abs(dense)) <= 2.0
    # It excites: a fair share of the velocity limit on each joint.
    assert min(plan.peak_velocity) > 0.5


def test_progress_counts_each_start_and_iteration_and_changes_nothing(plan):
    # Issue 45, item 3: identify plan's progress line; SLSQP's callback only watches.
    calls: list[tuple[int, int]] = []
    shown = plan_excitation(regressor, voltage, **settings(starts=2),
                            progress=lambda start, done: calls.append((start, done)))  # fmt: skip
    assert plan_excitation(regressor, voltage, **settings(starts=2)) == shown
    for start in (0, 1):
        done = [d for s, d in calls if s == start]
        assert done == list(range(len(done))) and len(done) > 1  # 0, 1, 2, ... in order
    assert [s for s, _ in calls] == sorted(s for s, _ in calls)


def test_the_same_seed_gives_the_same_plan_and_another_seed_another(plan):
    assert plan_excitation(regressor, voltage, **settings()) == plan
    other = plan_excitation(regressor, voltage, **settings(seed=4, max_iterations=2))
    assert other.trajectory != plan.trajectory


@pytest.mark.parametrize(
    ("changes", "needle"),
    [
        # A voltage limit below what holds the arm at rest (horizontal: gravity pulls).
        ({"rest": [0.0, 0.0], "joint_limits": ([-1, -1], [1, 1]), "voltage_limit": [2.0, 24]},
         "voltage_limit[0] = 2 V is not above the 2.357 V that holds joint 1 at rest"),
        # Above the hold voltage but below the Coulomb level: no motion fits.
        ({"voltage_limit": [1.0, 1.0]}, "voltage_limit = [1.0, 1.0] V leaves the arm no motion"),
        ({"joint_limits": (REST + 0.1, REST + 1.0)}, "joint_limits[0] = [-1.4708, -0.570796] rad: "
         "rest[0] = -1.5708 rad is not inside [-1.4258, -0.615796]"),
        ({"joint_limits": (REST + 1.0, REST - 1.0)}, "joint_limits = "),
        ({"velocity_limit": [2.0, 0.0]}, "velocity_limit = [2.0, 0.0]; values > 0 are required"),
        ({"velocity_limit": [2.0]}, "velocity_limit has shape (1,)"),
        ({"voltage_limit": [24.0, np.nan]}, "voltage_limit = [24.0, nan] has non-finite"),
        ({"rest": [0.0, 0.0, 0.0]}, "rest has shape (3,)"),
        ({"duration": 0.0}, "duration = 0.0 is not positive"),
        ({"harmonics": 1}, "harmonics = 1; an integer 2 to 20 is required"),
        ({"harmonics": 2.5}, "harmonics = 2.5 is not an integer"),
        ({"base_period": 3.0}, "duration = 10.0 s is not a whole number (>= 1) of base_period"),
        ({"sample_time": 0.3}, "sample_time = 0.3 s; at most base_period / (10 harmonics) = 0.2"),
        ({"sample_time": 0.003}, "duration = 10.0 s is not a whole number (>= 1) of sample_time"),
        ({"sample_time": -0.01}, "sample_time = -0.01 is not positive"),
        ({"seed": -1}, "seed = -1; an integer at least 0 is required"),
        ({"max_iterations": 0}, "max_iterations = 0; an integer at least 1 is required"),
        ({"margin": 0.5}, "margin = 0.5; a share in [0, 0.5) is required"),
        ({"joints": 0}, "joints = 0; an integer at least 1 is required"),
    ],
)  # fmt: skip
def test_impossible_or_bad_settings_are_refused_naming_the_parameter(changes, needle):
    with pytest.raises(ValueError) as error:
        plan_excitation(regressor, voltage, **settings(**changes))
    assert needle in str(error.value) and "\n" not in str(error.value), error.value


def test_a_regressor_with_dependent_columns_or_the_wrong_shape_is_refused():
    def doubled(q, qd, qdd):
        Y = regressor(q, qd, qdd)
        return np.concatenate([Y, 2.0 * Y[:, :, :1]], axis=2)

    with pytest.raises(ValueError, match="regressor has condition number .* dependent"):
        plan_excitation(doubled, voltage, **settings())
    with pytest.raises(ValueError, match=r"regressor returned shape \[200, 22\]"):
        plan_excitation(lambda *m: regressor(*m).reshape(len(m[0]), -1), voltage, **settings())


def test_any_number_of_joints_one_pendulum():
    """Nothing is two-link specific: a pendulum, u = J q'' + b q' + f sgn q' + m g l cos q."""
    theta = np.array([0.4, 1.2, 0.6, 3.0])

    def pendulum(q, qd, qdd):
        return np.stack([qdd, qd, np.sign(qd), np.cos(q)], axis=-1)

    rest = np.array([-np.pi / 2])
    plan = plan_excitation(
        pendulum,
        lambda q, qd, qdd: pendulum(q, qd, qdd) @ theta,
        joints=1,
        rest=rest,
        duration=8.0,
        harmonics=4,
        sample_time=0.01,
        joint_limits=(rest - 1.0, rest + 1.0),
        velocity_limit=[3.0],
        voltage_limit=[10.0],
        seed=0,
    )
    assert plan.limits_met and plan.condition < plan.condition_start
    assert plan.trajectory.joints == 1 and plan.trajectory.harmonics == 4


def test_the_csv_plays_back_through_a_csv_file_scenario(plan, tmp_path):
    path = write_trajectory_csv(plan, tmp_path / "excitation.csv")
    lines = path.read_text().splitlines()
    assert lines[0] == "time_s,q1_rad,q2_rad"
    assert len(lines) == 1 + round(DURATION / SAMPLE_TIME) + 1
    first, last = (np.array([float(v) for v in lines[k].split(",")]) for k in (1, -1))
    np.testing.assert_allclose(first, [0.0, *REST], atol=1e-15, rtol=0)
    assert last[0] == DURATION
    np.testing.assert_allclose(last[1:], REST, atol=1e-12, rtol=0)
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(
        f"trajectory: !CsvFile {{path: excitation.csv}}\ntiming: {{duration: {DURATION}}}\n"
    )
    trajectory = resolve(load_scenario(scenario)).config.trajectory
    times = plan.sample_times()
    played = np.array([trajectory.evaluate(float(t))[0] for t in times])
    np.testing.assert_allclose(played, plan.trajectory.sample(times)[0], atol=1e-9, rtol=0)
    # The run starts at the rest position, and the spline's velocity follows the plan's.
    np.testing.assert_allclose(trajectory.evaluate(0.0)[0], REST, atol=1e-12)
    for t in (1.234, 5.0, 8.71):
        np.testing.assert_allclose(
            trajectory.evaluate(t)[1], plan.trajectory.evaluate(t)[1], atol=1e-4
        )
