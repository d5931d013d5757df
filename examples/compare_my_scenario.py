"""Compare controllers on your own scenario
==========================================

A point-to-point move of the paper's arm with a payload, written as a scenario file,
run by ``posfb.compare`` (the same as
``posfb compare --scenario my_move.yaml --controllers pid,lin_lc --out DIR``).

Run it: ``.venv/bin/python examples/compare_my_scenario.py [--duration 4] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import posfb

#: A scenario file gives only what differs from the paper's settings.
MY_MOVE = """\
# The paper's arm carrying 0.2 kg moves from hanging down to a raised pose and back.
plant:
  payload_mass: 0.2
trajectory: !Waypoints
  times: [0.0, 1.5, 3.0, 4.0]
  positions: [[-1.5708, 0.0], [-0.5, 1.0], [-0.5, 1.0], [-1.5708, 0.0]]
timing:
  duration: 4.0
"""


def main(duration: float = 4.0, out: str | None = None) -> posfb.Comparison:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "my_move.yaml"
        path.write_text(MY_MOVE)
        scenario = posfb.load_scenario(path, set={"timing.duration": duration})
        comparison = posfb.compare(scenario, ["pid", "lin_lc"])
    print(comparison.markdown(), end="")
    if out:
        comparison.save(out)
    return comparison


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=4.0, help="simulated seconds")
    parser.add_argument("--out", help="write the table, summaries and figures into this folder")
    arguments = parser.parse_args()
    main(arguments.duration, arguments.out)
