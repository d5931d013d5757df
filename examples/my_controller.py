"""Your own controller
====================

A proportional law with gravity compensation, written against ``posfb.Controller``
only, named in a scenario as ``!Python {file, class, settings}`` and run by
``posfb.simulate`` and ``posfb.compare`` beside the built-in controllers.

Run it: ``.venv/bin/python examples/my_controller.py [--duration 5]``; or from the
command line, with a scenario that names this file::

    controller: !Python {file: my_controller.py, class: PGravity, settings: {Kp: [300, 200]}}
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import posfb


class PGravity(posfb.Controller):
    """``u = K_p (q_d - q) + G(q)`` (V): position only, the nominal model's gravity."""

    def __init__(self, setup: posfb.ControllerSetup, Kp: float | list[float] = 20.0) -> None:
        super().__init__(setup)
        self.Kp = np.broadcast_to(np.asarray(Kp, dtype=float), (setup.joints,))
        self.memory_size = 0
        self.internals = tuple(f"gravity_{j + 1}_V" for j in range(setup.joints))

    def start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        return np.zeros(0)

    def step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        gravity = self.setup.nominal.gravity(q)
        return self.Kp * (desired[: self.setup.joints] - q) + gravity, gravity


def scenario_text(duration: float) -> str:
    """A scenario that runs ``PGravity`` of this file (its path relative to the scenario)."""
    return (
        f"controller: !Python {{file: {Path(__file__).name}, class: PGravity, "
        "settings: {Kp: [300, 200]}}\n"
        f"timing: {{duration: {duration}}}\n"
    )


def main(duration: float = 5.0) -> posfb.Comparison:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "p_gravity.yaml"
        path.write_text(scenario_text(duration))
        (Path(folder) / Path(__file__).name).write_text(Path(__file__).read_text())
        comparison = posfb.compare(path, ["PGravity", "lin_lc"])
    print(comparison.markdown(), end="")
    return comparison


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds")
    main(parser.parse_args().duration)
