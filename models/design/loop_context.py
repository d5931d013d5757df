"""The loop context: what every piece of one closed loop shares, held once.

A scenario is resolved once (``diagrams.resolve``) into one frozen ``LoopContext``: the
``nominal`` model the controllers use (its joint count ``n`` and ``M0*``), the sample
time ``T_s`` (s) of the controller, the encoder's zero-order hold and the voltage
command (the paper's 0.01 s by default, Sec. 4.2: the one place that default is
written), the desired trajectory's wave ``frequencies`` (rad/s; empty for a trajectory
that is not a wave), and per joint the ``encoder_counts`` per revolution (0: ideal) and
the ``voltage_limit`` (V) (empty: ideal encoders and no limit known, as for a design
made outside a scenario). The design inputs (``ControllerConfig.context``), an entry's
left-out per-joint settings (``models.design.settings``), a plug-in's setup
(``ControllerSetup``) and the closed loop (``ClosedLoopConfig``) hold this value; none
keeps its own copy of the sample time or the nominal model, so no two places can
disagree on them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from posfb.models.lumped import TABLE1
from posfb.models.nominal import NominalModel, is_nominal_model, joint_count, nominal_model
from posfb.models.validation import require_positive

#: The joint count of the paper's arm (Table 1): an arm with this many joints gets the
#: paper's Sec. 4.2 lists as its defaults (``models.design.settings``).
PAPER_JOINTS = joint_count(TABLE1)


@dataclass(frozen=True)
class LoopContext:
    """What one closed loop's pieces share (module docstring)."""

    nominal: NominalModel = TABLE1
    sample_time: float = 0.01
    frequencies: tuple[float, ...] = ()
    encoder_counts: tuple[int, ...] = ()
    voltage_limit: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        require_positive("sample_time", self.sample_time)
        if not is_nominal_model(self.nominal):
            raise ValueError(
                f"nominal = {self.nominal!r} is not a nominal model "
                "(LumpedParameters or UrdfNominal)"
            )
        n = self.joints
        for name in ("encoder_counts", "voltage_limit"):
            values = getattr(self, name)
            if values and len(values) != n:
                raise ValueError(
                    f"{name} has {len(values)} entries; the nominal model has {n} joints: "
                    "one per joint (or none) is required"
                )

    @property
    def joints(self) -> int:
        """``n``: the nominal model's joint count."""
        return joint_count(self.nominal)

    @property
    def paper_arm(self) -> bool:
        """Whether the arm has the paper's two joints (its defaults are the paper's)."""
        return self.joints == PAPER_JOINTS

    def M0(self) -> np.ndarray:
        """The nominal ``M0*`` (n x n, V s^2/rad)."""
        return np.asarray(nominal_model(self.nominal).M0(), dtype=float)


class InLoopContext:
    """A part of the loop (a design, a plug-in's setup, the closed loop): its sample time
    and joint count are its loop context's (``self.context``), read here, the one place
    each is forwarded."""

    @property
    def sample_time(self) -> float:
        """``T_s`` (s): the loop context's, which the controller, the loggers and the
        sensor share."""
        return self.context.sample_time

    @property
    def joints(self) -> int:
        """``n``: the nominal model's joint count (the loop context's)."""
        return self.context.joints
