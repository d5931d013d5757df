"""Warnings about a scenario's desired trajectory, before it is run: a path that the
nominal model says needs more than the voltage limit, or that leaves the URDF's
joint limits, is still simulated (saturation and limits are part of what a user
may want to see), but the user is told."""

from __future__ import annotations

import numpy as np

from posfb.diagrams.resolve import ResolvedScenario
from posfb.models.nominal import nominal_model
from posfb.models.plant import build_arm_diagram


def trajectory_warnings(resolved: ResolvedScenario) -> list[str]:
    """One line per problem of the scenario's trajectory at its sample instants."""
    config = resolved.config
    times = np.arange(config.samples + 1) * config.sample_time
    samples = [config.trajectory.evaluate(float(t)) for t in times]
    positions = np.array([q for q, _, _ in samples])
    model = nominal_model(config.design.nominal)
    voltages = np.array([model.inverse_dynamics(*sample) for sample in samples])
    warnings = []
    for j, limit in enumerate(config.voltage_limit):
        peak = float(np.max(np.abs(voltages[:, j])))
        if peak > limit:
            when = float(times[int(np.argmax(np.abs(voltages[:, j])))])
            warnings.append(
                f"the trajectory needs up to {peak:.3g} V on joint {j + 1} (nominal model, "
                f"t = {when:g} s), more than its voltage limit {limit:g} V: the run saturates"
            )
    _, arm, _ = build_arm_diagram(config.plant)
    lower = arm.plant.GetPositionLowerLimits()
    upper = arm.plant.GetPositionUpperLimits()
    for j in range(positions.shape[1]):
        low, high = float(positions[:, j].min()), float(positions[:, j].max())
        if low < lower[j] or high > upper[j]:
            warnings.append(
                f"the trajectory moves joint {j + 1} over [{low:.4g}, {high:.4g}] rad, outside "
                f"the URDF's joint limits [{lower[j]:.4g}, {upper[j]:.4g}] rad (a continuous "
                "plant does not enforce them)"
            )
    return warnings
