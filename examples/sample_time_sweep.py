"""A sample-time sweep
====================

One controller at several ``T_s``, the paper's RMS metrics in a pandas table and a plot
of RMS(q~) against ``T_s``.

Each point is ``posfb.simulate`` with ``timing.sample_time`` set; a run that diverges
stays in the table with its status. Run it:
``.venv/bin/python examples/sample_time_sweep.py [--duration 5] [--out sweep.png]``.
"""

from __future__ import annotations

import argparse

import pandas as pd
from matplotlib.figure import Figure

import posfb

#: Sample times (s) of the sweep: the paper's 10 ms and slower.
SAMPLE_TIMES = (0.005, 0.01, 0.02, 0.04)


def sweep(
    controller: str = "lin_lc", sample_times=SAMPLE_TIMES, duration: float = 5.0
) -> pd.DataFrame:
    """One row per sample time: status, RMS(q~) and RMS(u) per joint."""
    rows = []
    for sample_time in sample_times:
        scenario = posfb.load_scenario(
            set={"timing.sample_time": sample_time, "timing.duration": duration}
        )
        run = posfb.simulate(scenario, controller)
        rows.append(
            {
                "sample_time_s": sample_time,
                "status": run.status,
                **{f"rms_q{j + 1}_rad": v for j, v in enumerate(run.rms_q)},
                **{f"rms_u{j + 1}_V": v for j, v in enumerate(run.rms_u)},
            }
        )
    return pd.DataFrame(rows)


def plot(table: pd.DataFrame, title: str) -> Figure:
    """RMS(q~) per joint against the sample time, log-log."""
    figure = Figure(figsize=(6, 4), layout="constrained")
    axis = figure.subplots()
    for column in [c for c in table.columns if c.startswith("rms_q")]:
        axis.loglog(table["sample_time_s"], table[column], marker="o", label=column)
    axis.set_xlabel("sample time T_s (s)")
    axis.set_ylabel("RMS(q~) (rad)")
    axis.set_title(title)
    axis.legend()
    return figure


def main(duration: float = 5.0, out: str | None = None) -> pd.DataFrame:
    table = sweep(duration=duration)
    print(table.to_string(index=False))
    if out:
        plot(table, f"Lin + LC, {duration:g} s runs").savefig(out)
    return table


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds per run")
    parser.add_argument("--out", help="write the plot to this file (PNG, SVG, PDF)")
    arguments = parser.parse_args()
    main(arguments.duration, arguments.out)
