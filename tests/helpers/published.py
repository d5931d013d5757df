"""Published arm descriptions from the registry's ``example-robot-data`` package (PyPI,
installed with posfb's dev extra), with the drive data a user gives for them: the files
carry no gear, no rotor inertia and no motor constants, only each joint's ``<limit
effort>``.

``published_urdf`` finds a file of the package; ``with_drive_data`` writes the copy a user
hands to posfb today (issue 41 takes these edits over): the geometry dropped (its
``world`` link kept: posfb welds the arm where the file does), and per joint a motor
constant that gives the rated effort at the voltage limit, a Coulomb level and a viscous
damping as small shares of the effort (``DRIVE_SHARES``; typical of a harmonic drive's
no-load losses, a user's estimate, not the arm's data).
"""

from __future__ import annotations

import re
from importlib import metadata
from pathlib import Path

#: Where the package's robot descriptions are installed (a cmeel prefix).
ROBOTS = "cmeel.prefix/share/example-robot-data/robots"

#: The drive data a user writes for a joint of rated effort ``tau`` (N m): Coulomb level
#: ``coulomb * tau`` (N m) and viscous damping ``damping * tau`` (N m s/rad).
DRIVE_SHARES = {"coulomb": 0.02, "damping": 0.01}

#: The voltage the motor constants are written for (V): ``kappa = effort / VOLTS``.
VOLTS = 24.0

UR5 = "ur_description/urdf/ur5_joint_limited_robot.urdf"


def published_urdf(relative: str) -> Path:
    """The package's file ``relative`` (under its ``robots`` folder)."""
    path = Path(str(metadata.distribution("example-robot-data").locate_file(ROBOTS))) / relative
    if not path.is_file():
        raise FileNotFoundError(f"{relative} is not in example-robot-data ({path})")
    return path


def with_drive_data(source: Path, target: Path) -> Path:
    """Write ``source`` with the user's edits (module docstring) to ``target``."""
    text = source.read_text()
    for tag in ("visual", "collision", "gazebo"):
        text = re.sub(rf"<{tag}\b.*?</{tag}>", "", text, flags=re.S)
    text = text.replace("<robot ", '<robot xmlns:posfb="urn:posfb:urdf" ', 1)
    efforts: dict[str, float] = {}

    def joint(match: re.Match) -> str:
        block = match.group(0)
        name = re.search(r'name="([^"]+)"', block).group(1)
        effort = float(re.search(r'effort="([^"]+)"', block).group(1))
        efforts[name] = effort
        block = re.sub(r"<dynamics[^>]*/>", "", block)
        damping, coulomb = (DRIVE_SHARES[k] * effort for k in ("damping", "coulomb"))
        drive = (f'<dynamics damping="{damping:g}"/>'
                 f'<posfb:coulomb_friction value="{coulomb:g}"/>')  # fmt: skip
        return block.replace("</joint>", drive + "</joint>")

    text = re.sub(r'<joint name="[^"]+" type="revolute">.*?</joint>', joint, text, flags=re.S)

    def transmission(match: re.Match) -> str:
        block = match.group(0)
        name = re.search(r'<joint name="([^"]+)"', block).group(1)
        constant = f'<posfb:motor_constant value="{efforts[name] / VOLTS:g}"/>'
        return block.replace("</actuator>", constant + "</actuator>")

    text = re.sub(r"<transmission\b.*?</transmission>", transmission, text, flags=re.S)
    target.write_text(text)
    return target
