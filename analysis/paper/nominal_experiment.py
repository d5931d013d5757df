"""The nominal experiment of Sec. 4.2 (Table 3, Figs. 4-5) with the paper's settings.

Run it directly::

    python -m posfb.analysis.paper.nominal_experiment [--out results/nominal] [--duration 20]
    python analysis/paper/nominal_experiment.py

It simulates computed torque + PID, Lin+LC and the paper's controller on the
nominal arm for 20 s and writes Figs. 4-5 (PNG, SVG) and Table 3 beside the
paper's. ``posfb reproduce`` does this and everything else.
"""

from __future__ import annotations

import argparse

from posfb.analysis.common.errors import UsageError
from posfb.analysis.common.outputs import output_folder
from posfb.analysis.paper.reproduce import case_experiment


def main(case: str, description: str) -> None:
    """Parse ``--out``/``--duration`` and run ``case``
    (``analysis.paper.reproduce.case_experiment``)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--out", default=f"results/{case}", help="output folder")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    args = parser.parse_args()
    try:
        case_experiment(case, output_folder("--out", args.out), args.duration)
    except (ValueError, FileNotFoundError, UsageError) as error:
        parser.error(str(error).strip().splitlines()[0])


if __name__ == "__main__":
    main("nominal", __doc__.splitlines()[0])
