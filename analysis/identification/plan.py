"""``posfb identify plan``: an exciting trajectory for a scenario's arm
(``models.identification.excitation``, Swevers et al. 1997), written as a CSV that
``trajectory: !CsvFile`` runs and a drive can play.

The limits come from the scenario: at rest at its trajectory's start ``q_d(0)``; each
joint within ``excursion`` rad of it and inside the plant URDF's position limits where
it has finite ones; ``|q'|`` under ``velocity_limit`` (default: the URDF's velocity
limit where finite, else ``DEFAULT_VELOCITY_LIMIT``); ``|u|`` of the nominal model's
inverse dynamics under ``actuator.voltage_limit``; sampled at ``timing.sample_time``. The
regressor is the one ``identify`` fits: theta's for the paper's arm; for a URDF arm its
base-parameter regressor with the motor-constant ratio columns of the nominal voltage
(``SerialModel.fit_columns``), so the condition number the plan reports is the one
``identify`` reports on a log of it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from posfb.analysis.identification.identify import serial_model
from posfb.diagrams.resolve import LoadedScenario, resolve
from posfb.models.identification.estimate import (
    FilterSettings,
    Motion,
    Reference,
    planned_condition,
)
from posfb.models.identification.excitation import (
    STARTS,
    ExcitationPlan,
    per_sample,
    plan_excitation,
    write_trajectory_csv,
)
from posfb.models.identification.theta_regressor import COULOMB_PARAMETERS, theta_regressor
from posfb.models.lumped import LumpedModel, LumpedParameters

if TYPE_CHECKING:
    from posfb.models.plant import PlantConfig

#: Velocity limit (rad/s) where the URDF gives none.
DEFAULT_VELOCITY_LIMIT = 2.0

#: The fewest encoder counts a plan must move every joint by (peak to peak): a motion of
#: a few counts is the encoder's quantisation, not an excitation.
MIN_COUNTS = 20

#: Default largest excursion from the rest position (rad).
DEFAULT_EXCURSION = np.pi / 2

#: Defaults of the plan's length, harmonics and period (s): six 10 s periods.
DEFAULT_DURATION = 60.0
DEFAULT_HARMONICS = 5
DEFAULT_PERIOD = 10.0


def _urdf_limits(plant: PlantConfig, joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The plant URDF's position limits and velocity limits (``inf`` where none), as the
    scenario's description (welds) leaves its arm joints."""
    from posfb.models.plant import PlantConfig, build_arm_diagram

    _, arm, _ = build_arm_diagram(PlantConfig(urdf=plant.urdf, description=plant.description))
    plant = arm.plant
    lower, upper, velocity = (np.full(joints, np.inf) * s for s in (-1.0, 1.0, 1.0))
    for j, name in enumerate(arm.layout.joints):
        joint = plant.GetJointByName(name)
        lower[j] = joint.position_lower_limits()[0]
        upper[j] = joint.position_upper_limits()[0]
        velocity[j] = joint.velocity_upper_limits()[0]
    return lower, upper, velocity


@dataclass(frozen=True)
class PlannedExcitation:
    """A plan for a scenario's arm: the optimiser's ``plan``, the scenario's name and the
    condition number ``identify`` reports on an exact log of the plan (its default
    filter and row selection: ``estimate.planned_condition``)."""

    plan: ExcitationPlan
    source: str
    fit_condition: float

    def save(self, path: str | Path) -> Path:
        """Write the plan as a ``!CsvFile`` trajectory (``time_s, q1_rad, ..``), whole or
        not at all (``analysis.common.outputs.atomic_file``)."""
        from posfb.analysis.common.outputs import atomic_file

        with atomic_file(path) as temporary:
            write_trajectory_csv(self.plan, temporary)
        return Path(path)

    def as_dict(self) -> dict[str, object]:
        """What ``posfb identify plan --json`` prints."""
        plan = self.plan
        return {
            "condition_number_start": plan.condition_start,
            "condition_number": plan.condition,
            "fit_condition_number": self.fit_condition,
            "limits_met": plan.limits_met,
            "duration_s": plan.duration,
            "period_s": plan.trajectory.period,
            "harmonics": plan.trajectory.harmonics,
            "rest_rad": list(plan.rest),
            "position_margin_rad": list(plan.position_margin),
            "peak_velocity_rad_per_s": list(plan.peak_velocity),
            "peak_voltage_V": list(plan.peak_voltage),
        }

    def report(self) -> str:
        """The plan in a few lines: condition number before and after, peaks."""
        plan = self.plan
        joints = range(len(plan.rest))
        lines = [
            f"excitation for {self.source}: {plan.duration:g} s, {plan.trajectory.harmonics} "
            f"harmonics of a {plan.trajectory.period:g} s period (Swevers et al. 1997)",
            f"condition number of the scaled regressor: {plan.condition_start:.3g} at the "
            f"random start -> {plan.condition:.3g} (on one period); identify's on a log of "
            f"it (filtered, without the rows near rest): {self.fit_condition:.3g}",
            "limits " + ("met" if plan.limits_met else "NOT met") + " at every sample:",
        ]
        for j in joints:
            lines.append(
                f"  joint {j + 1}: max |q'| {plan.peak_velocity[j]:.3g} rad/s, max |u| "
                f"{plan.peak_voltage[j]:.3g} V, closest to a joint limit "
                f"{plan.position_margin[j]:.3g} rad"
            )
        return "\n".join(lines)


def _require_counts(moved: np.ndarray, excursion: float, can: str = "") -> None:
    """``ValueError`` naming the joints a plan moves (``can``: "can move at most") by
    fewer than ``MIN_COUNTS`` encoder counts (``moved``: counts peak to peak per joint)."""
    short = np.flatnonzero(moved < MIN_COUNTS)
    if short.size:
        listed = ", ".join(f"joint {j + 1} {moved[j]:.3g}" for j in short)
        raise ValueError(
            f"the plan {can or 'moves'} {listed} encoder counts (peak to peak) at excursion = "
            f"{excursion:g} rad; at least {MIN_COUNTS} counts per joint are required to "
            "excite anything: a larger excursion (or joint limits that allow one)"
        )


def plan_for_scenario(
    loaded: LoadedScenario,
    *,
    duration: float = DEFAULT_DURATION,
    harmonics: int = DEFAULT_HARMONICS,
    period: float | None = DEFAULT_PERIOD,
    seed: int = 0,
    excursion: float | None = None,
    velocity_limit: float | None = None,
    progress: Callable[[str], None] | None = None,
) -> PlannedExcitation:
    """The exciting trajectory for the scenario's arm (module docstring); ``progress``
    gets a line at each start and iteration of the search."""
    config = resolve(loaded).config
    nominal = config.design.nominal
    if isinstance(nominal, LumpedParameters):
        model = LumpedModel(nominal)
        regressor = lambda q, v, a: theta_regressor(q, v, a, nominal.l1, nominal.g)  # noqa: E731
        voltage, coulomb = per_sample(model.inverse_dynamics), COULOMB_PARAMETERS
    else:
        serial = serial_model(config)
        regressor, voltage, coulomb = serial.fit_columns, serial.voltage, serial.coulomb()
    excursion = DEFAULT_EXCURSION if excursion is None else excursion
    if not (np.isfinite(excursion) and excursion > 0.0):
        raise ValueError(f"excursion = {excursion!r} rad; a finite value > 0 is required")
    joints = config.joints
    rest = np.asarray(config.trajectory.evaluate(0.0)[0], dtype=float)
    lower, upper, urdf_velocity = _urdf_limits(config.plant, joints)
    lower = np.maximum(lower, rest - excursion)
    upper = np.minimum(upper, rest + excursion)
    counts = np.asarray(config.sensor.encoder_counts, dtype=float)
    step = 2.0 * np.pi / counts if np.all(counts > 0) else None
    if step is not None:  # before the search: the limits leave too little room
        _require_counts((upper - lower) / np.broadcast_to(step, (joints,)), excursion,
                        "can move at most")  # fmt: skip
    if velocity_limit is None:
        velocity = np.where(np.isfinite(urdf_velocity), urdf_velocity, DEFAULT_VELOCITY_LIMIT)
    else:
        velocity = np.full(joints, velocity_limit, dtype=float)
    plan = plan_excitation(
        regressor,
        voltage,
        joints=joints,
        rest=rest,
        duration=duration,
        harmonics=harmonics,
        base_period=period,
        sample_time=config.sample_time,
        joint_limits=(lower, upper),
        velocity_limit=velocity,
        voltage_limit=np.asarray(config.voltage_limit, dtype=float),
        seed=seed,
        progress=None if progress is None else (
            lambda start, done: progress(f"start {start + 1} of {STARTS}, SLSQP iteration {done}")
        ),
    )  # fmt: skip
    time = plan.sample_times()
    q, qdot, qddot = plan.trajectory.sample(time)
    if step is not None:
        _require_counts(np.ptp(q, axis=0) / np.broadcast_to(step, (joints,)), excursion)
    settings = FilterSettings().with_rule(time, q, Reference(q, qdot, qddot), step)
    motion = Motion(time, q, qdot, qddot, voltage(q, qdot, qddot),
                    settings.cutoff(float(time[1] - time[0])))  # fmt: skip
    fit = planned_condition(motion, regressor, coulomb, settings)
    return PlannedExcitation(plan, loaded.source, fit)
