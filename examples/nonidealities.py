"""What each non-ideality does to one run
=======================================

The paper's arm and trajectory under a controller, each effect switched on alone (user
guide, "Non-idealities"), the joint-2 tracking error of each run against the ideal one,
and a table of RMS errors.

Each effect is one scenario setting (``EFFECTS``), run with ``posfb.simulate``. Run it:
``.venv/bin/python examples/nonidealities.py [--controller lin_lc] [--duration 5]
[--out effects.png]`` (the gear rows are the slow ones: a stiff gear's mode sets the
integrator's steps).
"""

from __future__ import annotations

import argparse

import pandas as pd
from matplotlib.figure import Figure

import posfb

#: Group -> effect label -> scenario settings. Values from the sources cited in the
#: user guide's "Non-idealities" page: a 1 ms armature L/R, a 12-bit DAC, half a period
#: of computation; Stribeck and LuGre at their entries' defaults; a 5000 N m/rad gear,
#: with 0.5 mrad of backlash and the encoder on the motor shaft.
EFFECTS = {
    "electronics": {
        "L/R = 1 ms": {"actuator.electrical_time_constant": 0.001},
        "DAC 12 bit": {"actuator.dac_bits": 12},
        "compute delay T_s/2": {"actuator.compute_delay": 0.005},
    },
    "friction": {
        "Stribeck": {"plant.friction": "!Stribeck {}"},
        "LuGre (accuracy 1e-6)": {"plant.friction": "!LuGre {}",
                                  "timing.simulator.accuracy": 1e-6},
    },
    "drive train": {
        "gear k = 5000": {"plant.gear_stiffness": 5000.0},
        "gear + backlash, motor encoder": {"plant.gear_stiffness": 5000.0,
                                           "plant.backlash": 0.0005,
                                           "sensor.location": "motor"},
    },
}  # fmt: skip


def run_effects(controller: str = "lin_lc", duration: float = 5.0) -> dict[str, posfb.Run]:
    """The ideal run (``"off"``) and one run per effect, by label."""
    base = {"timing.duration": duration}
    runs = {"off": posfb.simulate(posfb.load_scenario(set=base), controller)}
    for effects in EFFECTS.values():
        for label, settings in effects.items():
            runs[label] = posfb.simulate(posfb.load_scenario(set={**base, **settings}), controller)
    return runs


def table(runs: dict[str, posfb.Run]) -> pd.DataFrame:
    """One row per run: status and RMS(q~) per joint."""
    return pd.DataFrame(
        [{"effect": label, "status": run.status, "rms_q1_rad": run.rms_q[0],
          "rms_q2_rad": run.rms_q[1]} for label, run in runs.items()]  # fmt: skip
    )


def figure(runs: dict[str, posfb.Run], controller: str) -> Figure:
    """Joint-2 error over time, one panel per group, the ideal run in grey in each."""
    fig = Figure(figsize=(10, 8), constrained_layout=True)
    axes = fig.subplots(len(EFFECTS), 1, sharex=True)
    ideal = runs["off"].result
    for axis, (group, effects) in zip(axes, EFFECTS.items(), strict=True):
        axis.plot(ideal.times, ideal.q_error[:, 1], color="0.6", linewidth=1.0, label="ideal")
        for label in effects:
            result = runs[label].result
            axis.plot(result.times, result.q_error[:, 1], linewidth=0.9, label=label)
        axis.set_title(group)
        axis.set_ylabel("q~2 (rad)")
        axis.legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(f"Joint-2 tracking error of {controller}, one non-ideality at a time")
    return fig


def main(controller: str = "lin_lc", duration: float = 5.0, out: str | None = None) -> pd.DataFrame:
    runs = run_effects(controller, duration)
    rows = table(runs)
    print(rows.to_string(index=False))
    if out:
        figure(runs, controller).savefig(out, dpi=110)
    return rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controller", default="lin_lc", help="controller kind")
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds")
    parser.add_argument("--out", help="write the figure (PNG, SVG by suffix)")
    arguments = parser.parse_args()
    main(arguments.controller, arguments.duration, arguments.out)
