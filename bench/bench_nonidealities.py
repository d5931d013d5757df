"""The cost of each non-ideality per run (issue 21): one 20 s run of the paper's nominal
experiment per controller and effect, with the integrator's steps and derivative
evaluations (exact counts) and the wall time (best of ``--repeat``).

    .venv/bin/python bench/bench_nonidealities.py [--repeat 2] [--duration 20]
        [--controllers pid,proposed] [--effects NAME,...]

Each effect is one scenario setting on top of the shipped paper scenario; ``off`` is the
default run. The effects and their settings are ``EFFECTS``.
"""

from __future__ import annotations

import argparse

from posfb.analysis.common.metrics import run_metrics
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.diagrams.runner import ClosedLoopRunner

#: Effect label -> scenario settings (``--set`` form).
EFFECTS = {
    "off": [],
    "L/R = 1 ms": ["actuator.electrical_time_constant=0.001"],
    "L/R = 0.27 ms": ["actuator.electrical_time_constant=0.00027"],
    "DAC 12 bit": ["actuator.dac_bits=12"],
    "delay T_s/2": ["actuator.compute_delay=0.005"],
    "delay T_s": ["actuator.compute_delay=0.01"],
    "Stribeck": ["plant.friction=!Stribeck {}"],
    "LuGre": ["plant.friction=!LuGre {}"],
    "LuGre at accuracy 1e-6": ["plant.friction=!LuGre {}", "timing.simulator.accuracy=1e-6"],
    "gear k = 5e3": ["plant.gear_stiffness=5000"],
    "gear k = 5e3 + backlash 0.5 mrad + motor encoder": [
        "plant.gear_stiffness=5000", "plant.backlash=0.0005", "sensor.location=motor"],
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2, help="runs per row (best kept)")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--controllers", default="pid,proposed", help="comma-separated kinds")
    parser.add_argument("--effects", default=",".join(EFFECTS), help="comma-separated labels")
    args = parser.parse_args()
    print("| controller | effect | wall s (best) | steps | derivative evaluations | "
          "RMS(q~1) rad | RMS(q~2) rad |")  # fmt: skip
    print("|---|---|---:|---:|---:|---:|---:|")
    for controller in args.controllers.split(","):
        for label in args.effects.split(","):
            settings = [f"controller.kind={controller}", f"timing.duration={args.duration}",
                        *EFFECTS[label]]  # fmt: skip
            runner = ClosedLoopRunner(resolve(load_scenario(None, settings)).config)
            best = min((runner.run() for _ in range(args.repeat)), key=lambda r: r.wall_time_s)
            metrics = run_metrics(best)
            print(f"| {controller} | {label} | {best.wall_time_s:.2f} | {best.integrator_steps} | "
                  f"{best.derivative_evaluations} | {metrics.rms_q[0]:.3g} | "
                  f"{metrics.rms_q[1]:.3g} |", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
