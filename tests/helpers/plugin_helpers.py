"""Plug-in controllers for tests: a user's controller written against the public
contract only (``posfb.Controller``), and a scenario that names its file."""

from __future__ import annotations

import textwrap
from pathlib import Path

#: A user's controller, written against the public contract only.
P_GRAVITY = '''
import numpy as np
import posfb

class PGravity(posfb.Controller):
    memory_size = 1

    def __init__(self, setup, Kp=20.0):
        super().__init__(setup)
        self.Kp = np.broadcast_to(np.asarray(Kp, dtype=float), (setup.joints,))
        self.internals = tuple(f"gravity_{j + 1}_V" for j in range(setup.joints)) + ("k_count",)

    def start(self, q, desired):
        return np.zeros(1)

    def step(self, q, desired, memory):
        memory[0] += 1.0
        gravity = self.setup.nominal.gravity(q)
        return self.Kp * (desired[: self.setup.joints] - q) + gravity, [*gravity, memory[0]]
'''


def write_plugin(
    folder: Path, body: str = P_GRAVITY, name: str = "my_controller.py",
    class_name: str = "PGravity", settings: str = "{Kp: [300, 200]}",
) -> str:  # fmt: skip
    """A plug-in file and a scenario that names it; returns the scenario's path."""
    (folder / name).write_text(textwrap.dedent(body))
    scenario = folder / "scenario.yaml"
    scenario.write_text(
        f"controller: !Python\n  file: {name}\n  class: {class_name}\n  settings: {settings}\n"
        "timing: {duration: 1.0}\n"
    )
    return str(scenario)
