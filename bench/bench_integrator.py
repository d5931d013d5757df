"""The integrator's accuracy-cost curve against a tight reference, and the numerical
spread it must be compared with (issue 11, item 5).

    .venv/bin/python bench/bench_integrator.py [--duration 20] [--perturbations 6]

For each controller on the paper's nominal scenario (``analysis/scenarios/
paper_nominal.yaml``; add ``--case payload`` for the payload arm):

* **reference**: RK5 with error control at accuracy 1e-9 (steps capped at T_s, as
  every run);
* **candidates**: RK3 at 1e-2, 3e-3 (posfb's default), 1e-3, 1e-4, 1e-5; RK5 at
  1e-4; implicit Radau3 at 1e-3; fixed-step RK2 at 0.25 ms (explicit RK2 is stable on
  joint 2's tanh friction, stiffness about 7200 1/s, below about 0.35 ms);
* **spread**: the default integrator on runs whose initial joint-1 velocity is
  ``k * 1e-9`` rad/s (k = 1..P) instead of 0: physically the same experiment, a
  perturbation of the size of the integrator's own local errors. Smaller
  perturbations (1e-12 relative in a damping) leave the runs identical to 1e-9,
  because the encoder quantiser absorbs them; errors of this size move a
  measurement across a count boundary now and then, and each such flip changes
  the control by a whole count. ``spread`` is (max - min) / median of the RMS
  over those runs; a candidate whose difference from the reference is within the
  spread is as good as the reference can be told apart from round-off.

Printed per candidate: RMS(q~1), RMS(q~2), their relative difference from the
reference, wall time, derivative evaluations and steps.
"""

from __future__ import annotations

import argparse
import statistics

import numpy as np
from pydrake.systems.framework import Context

from posfb.analysis.common.metrics import run_metrics
from posfb.analysis.paper.experiment import case_scenario
from posfb.diagrams.resolve import resolve
from posfb.diagrams.runner import ClosedLoopResult, ClosedLoopRunner
from posfb.models.controllers import PAPER_CONTROLLERS

REFERENCE = ("RK5, 1e-9 (reference)", "runge_kutta5", 1e-9, True)

#: (label, scheme, accuracy or fixed step, error control)
CANDIDATES = [
    ("RK3, 1e-2", "runge_kutta3", 1e-2, True),
    ("RK3, 3e-3 (default)", "runge_kutta3", 3e-3, True),
    ("RK3, 1e-3", "runge_kutta3", 1e-3, True),
    ("RK3, 1e-4", "runge_kutta3", 1e-4, True),
    ("RK3, 1e-5", "runge_kutta3", 1e-5, True),
    ("RK5, 1e-4", "runge_kutta5", 1e-4, True),
    ("Radau3, 1e-3", "radau3", 1e-3, True),
    ("RK2 fixed 0.25 ms", "runge_kutta2", 2.5e-4, False),
]


def _settings(scheme: str, value: float, error_control: bool) -> tuple[str, ...]:
    size = "max_step_size" if not error_control else "accuracy"
    return (
        f"timing.simulator.integration_scheme={scheme}",
        f"timing.simulator.{size}={value!r}",
        f"timing.simulator.use_error_control={'true' if error_control else 'false'}",
    )


def _run(case: str, settings: tuple[str, ...], initial_velocity: float = 0.0) -> ClosedLoopResult:
    """One run; ``initial_velocity`` (rad/s) is added to joint 1's initial velocity."""
    resolved = resolve(case_scenario(case, settings))
    runner = ClosedLoopRunner(resolved.config)
    fresh = runner.new_context

    def perturbed(*args: object) -> Context:
        context = fresh(*args)
        plant = runner.arm.plant
        plant_context = plant.GetMyMutableContextFromRoot(context)
        plant.SetVelocities(
            plant_context, plant.GetVelocities(plant_context) + [initial_velocity, 0.0]
        )
        return context

    runner.new_context = perturbed
    return runner.run(resolved.true_parameters(runner.arm.default_parameters))


def _rms(result: ClosedLoopResult) -> np.ndarray:
    return np.array(run_metrics(result).rms_q)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--perturbations", type=int, default=6)
    parser.add_argument("--case", choices=("nominal", "payload"), default="nominal")
    parser.add_argument("--controllers", nargs="+", default=list(PAPER_CONTROLLERS))
    args = parser.parse_args()
    print(f"{args.case} arm, {args.duration:g} s runs")
    for controller in args.controllers:
        base = (f"controller.kind={controller}", f"timing.duration={args.duration!r}")
        reference = _rms(_run(args.case, (*base, *_settings(*REFERENCE[1:]))))
        spread_runs = [
            _rms(_run(args.case, base, initial_velocity=k * 1e-9))
            for k in range(1, args.perturbations + 1)
        ]
        spread = (np.max(spread_runs, axis=0) - np.min(spread_runs, axis=0)) / np.median(
            spread_runs, axis=0
        )
        print(
            f"\n### {controller}: reference RMS = ({reference[0]:.6g}, {reference[1]:.6g}) rad; "
            f"round-off spread of the default = ({100 * spread[0]:.2g} %, "
            f"{100 * spread[1]:.2g} %) over {args.perturbations} runs\n"
        )
        print("| integrator | RMS q~1 | RMS q~2 | vs reference j1 | j2 | wall s | evals | steps |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        for label, scheme, value, error_control in CANDIDATES:
            walls, result = [], None
            for _ in range(2):
                result = _run(args.case, (*base, *_settings(scheme, value, error_control)))
                walls.append(result.wall_time_s)
            rms = _rms(result)
            difference = (rms - reference) / reference
            within = ["" if abs(d) <= s else " *" for d, s in zip(difference, spread, strict=True)]
            print(
                f"| {label} | {rms[0]:.5g} | {rms[1]:.5g} | {100 * difference[0]:+.2f} %"
                f"{within[0]} | {100 * difference[1]:+.2f} %{within[1]} | "
                f"{statistics.median(walls):.3f} | {result.derivative_evaluations} | "
                f"{result.integrator_steps} |",
                flush=True,
            )
    print("\n`*`: the difference from the reference exceeds the round-off spread.")


if __name__ == "__main__":
    main()
