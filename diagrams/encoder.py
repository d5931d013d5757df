"""The joint encoders: a stateless quantiser of the true joint positions.

    q_measured = Delta * round(q / Delta),   Delta = 2 pi / N   (N counts per joint revolution)

It has no state and no sample period of its own: the controller's periodic
update (period ``T_s``, offset 0) reads it at ``t_k``, which *is* the sampling.
A ``ZeroOrderHold(T_s)`` in front of the controller would add one extra sample
of delay (``../shared/DRAKE-NOTES.md``, "Timing of discrete systems").

Round to nearest, not floor: an incremental encoder zeroed at a count boundary
reports ``floor``, whose error lies in ``[0, Delta)`` with mean ``Delta/2``; the
controller would then hold the *true* position ``Delta/2`` off the desired one on
average, a bias that is an artefact of where the zero was set. Rounding keeps the
error in ``[-Delta/2, Delta/2]`` with zero mean (Drake's ``RotaryEncoders`` floors,
which is why it is not used here; it also fixes the resolution at construction).

``N`` is a numeric parameter of the Context, so the resolution changes per run
without rebuilding; ``N = 0`` means an ideal (unquantised) sensor.

Default ``N = 20000`` counts per joint revolution (``Delta = 3.14e-4 rad``): a
500-line optical encoder read in quadrature (2000 counts per motor revolution,
the paper's "optical encoder mounted on the shaft", Sec. 4.1) behind joint 2's
1:10 gear (``urdf/README.md``); joint 1's 1:100 gear would give 10x finer counts,
and using the coarser figure for both joints is the conservative choice. ``Delta``
is 1/7 of the smallest RMS error of Tables 3-4 (0.0021 rad), so quantisation is
visible but does not dominate; the backward-difference velocity of the PID
baseline then moves in steps of ``Delta / T_s = 0.031 rad/s``.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

#: Default counts per joint revolution (see the module docstring).
DEFAULT_ENCODER_COUNTS = 20000


def require_counts(name: str, counts: int) -> int:
    """Return ``counts`` if it is an integer >= 0 (0: ideal sensor)."""
    if isinstance(counts, bool) or not isinstance(counts, int | np.integer) or counts < 0:
        raise ValueError(
            f"{name} = {counts!r}; an integer number of counts per revolution >= 0 is required "
            "(0: no quantisation)"
        )
    return int(counts)


def quantise(q: np.ndarray, counts: int) -> np.ndarray:
    """``Delta round(q / Delta)``, ``Delta = 2 pi / counts``; ``q`` itself if ``counts == 0``."""
    if counts == 0:
        return np.asarray(q, dtype=float).copy()
    step = 2.0 * math.pi / counts
    return step * np.round(np.asarray(q, dtype=float) / step)


class Encoder(LeafSystem):
    """Input ``q`` (true joint positions), output ``q_measured`` (quantised), both size ``n``.

    The counts per revolution are numeric parameter 0 (``set_counts``)."""

    def __init__(self, size: int = 2, counts: int = DEFAULT_ENCODER_COUNTS) -> None:
        super().__init__()
        self.set_name("encoder")
        self._counts_index = self.DeclareNumericParameter(
            BasicVector([float(require_counts("encoder_counts", counts))])
        )
        self._q = self.DeclareVectorInputPort("q", size)
        self.DeclareVectorOutputPort("q_measured", size, self._calc_measured)

    def counts(self, context: Context) -> int:
        """Counts per revolution in this system's ``context``."""
        return int(context.get_numeric_parameter(self._counts_index).GetAtIndex(0))

    def set_counts(self, context: Context, counts: int) -> None:
        """Change the resolution in this system's ``context`` (0: ideal sensor)."""
        context.get_mutable_numeric_parameter(self._counts_index).SetAtIndex(
            0, float(require_counts("encoder_counts", counts))
        )

    def _calc_measured(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(quantise(self._q.Eval(context), self.counts(context)))
