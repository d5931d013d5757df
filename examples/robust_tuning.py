"""Robust tuning from a script
============================

``posfb.tune`` designs the paper's controller and Lin+LC for the scenario's arm on
sampled plants, verifies the design on fresh plants (the guarantee it states), and
returns the tuned scenario; ``posfb.simulate`` then runs the paper's settings and the
tuned ones on the nominal arm and on one with a payload the nominal model lacks
(Sec. 4.3).

Run it: ``.venv/bin/python examples/robust_tuning.py [--plants 50] [--out tuned.yaml]``
(the defaults take about a minute; the test suite runs it with fewer plants).
"""

from __future__ import annotations

import argparse

import pandas as pd

import posfb

#: The payload of the paper's Sec. 4.3 (kg at the link-2 tip).
PAYLOAD = 0.288


def compare_designs(
    result: posfb.TuneResult, scenario: posfb.LoadedScenario, duration: float = 5.0
) -> pd.DataFrame:
    """RMS(q~) of the paper's controller and Lin+LC, before and after tuning, on the
    nominal arm and with ``PAYLOAD``: one row per run."""
    rows = []
    for design, source in (("paper's settings", scenario), ("tuned", result.tuned)):
        for payload in (0.0, PAYLOAD):
            arm = posfb.load_scenario(
                source, set={"timing.duration": duration, "plant.payload_mass": payload}
            )
            for controller in ("proposed", "lin_lc"):
                run = posfb.simulate(arm, controller)
                rows.append({"design": design, "payload_kg": payload, "controller": controller,
                             "status": run.status, "rms_q_rad": max(run.rms_q)})  # fmt: skip
    return pd.DataFrame(rows)


def main(plants: int = 50, generations: int = 30, out: str | None = None) -> pd.DataFrame:
    scenario = posfb.load_scenario()  # the paper's nominal experiment
    settings = posfb.TuneSettings(plants=plants, generations=generations)
    result = posfb.tune(scenario, settings=settings)
    for name, entry in result.controllers.items():
        print(f"{name}: {entry.guarantee.sentence('rho >= 1')}")
    if out:
        result.save(out)
    table = compare_designs(result, scenario)
    print(table.to_string(index=False))
    return table


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plants", type=int, default=50, help="design plants")
    parser.add_argument("--out", help="write the tuned scenario here")
    arguments = parser.parse_args()
    main(arguments.plants, out=arguments.out)
