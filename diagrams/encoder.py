"""The joint encoders: a stateless quantiser of the true joint positions.

    q_measured = Delta * round(q / Delta),   Delta = 2 pi / N   (N counts per joint revolution)

It has no state and no sample period of its own: the ``encoder_hold``
(``ZeroOrderHold(T_s)``, ``diagrams.wiring``) samples it at ``t_k``, and the
controller's direct feedthrough uses that sample with no extra delay
(``docs/drake-notes.md``, "Timing of discrete systems").

Round to nearest, not floor: an incremental encoder zeroed at a count boundary
reports ``floor``, whose error lies in ``[0, Delta)`` with mean ``Delta/2``; the
controller would then hold the *true* position ``Delta/2`` off the desired one on
average, a bias that is an artefact of where the zero was set. Rounding keeps the
error in ``[-Delta/2, Delta/2]`` with zero mean (Drake's ``RotaryEncoders`` floors,
which is why it is not used here; it also fixes the resolution at construction).

``N`` (one per joint) is a numeric parameter of the Context, so the resolution
changes per run without rebuilding; ``N = 0`` means an ideal (unquantised)
sensor. So are a zero offset per joint (the encoder reads ``q + offset``) and,
when the encoder is built ``noisy``, the standard deviation of additive Gaussian
noise per joint; a sensor delay is a ``DiscreteTimeDelay`` after it
(``diagrams.wiring``).

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
from collections.abc import Sequence

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from posfb.models.validation import per_joint

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


def quantise(q: np.ndarray, counts: int | np.ndarray) -> np.ndarray:
    """``Delta round(q / Delta)``, ``Delta = 2 pi / counts`` (one count for all entries or
    one per entry); an entry with ``counts == 0`` is passed through unquantised."""
    q = np.asarray(q, dtype=float)
    counts = np.asarray(counts, dtype=float)
    ideal = np.broadcast_to(counts == 0, q.shape)
    step = 2.0 * math.pi / np.where(counts == 0, 1.0, counts)
    return np.where(ideal, q, step * np.round(q / step))


def _quantise_joints(q: Sequence[float], counts: Sequence[float]) -> list[float]:
    """``quantise`` for one sample, joint by joint with Python floats: the same IEEE
    operations (``round`` and ``numpy.round`` both round half to even), so the same
    bits, without the cost of small-array numpy calls (it runs once per sample)."""
    measured = []
    for value, count in zip(q, counts, strict=True):
        if count > 0.0:
            step = 2.0 * math.pi / count
            measured.append(step * round(value / step))
        else:
            measured.append(value)
    return measured


def per_joint_counts(name: str, counts: int | Sequence[int], size: int) -> tuple[int, ...]:
    """``counts`` for each of ``size`` joints: one integer for all, or one per joint."""
    values = per_joint(name, counts, size, kind="integer")
    return tuple(require_counts(name, value) for value in values)


class Encoder(LeafSystem):
    """Input ``q`` (true joint positions), output ``q_measured``, both size ``n``::

        q_measured = quantise(q + zero_offset, counts) + noise_std * w

    Numeric parameters (per Context, ``set_counts`` etc.): the counts per revolution
    and the zero offset (rad) per joint and, with ``noisy``, the noise standard
    deviation (rad) per joint; ``w`` is then the input ``unit_noise`` (a standard
    normal sample held over each period, ``diagrams.wiring``)."""

    def __init__(
        self, size: int = 2, counts: int | Sequence[int] = DEFAULT_ENCODER_COUNTS,
        noisy: bool = False,
    ) -> None:  # fmt: skip
        super().__init__()
        self.set_name("encoder")
        self._counts_index = self.DeclareNumericParameter(
            BasicVector([float(c) for c in per_joint_counts("encoder_counts", counts, size)])
        )
        self._offset_index = self.DeclareNumericParameter(BasicVector(np.zeros(size)))
        self._q = self.DeclareVectorInputPort("q", size)
        self._noise = None
        if noisy:
            self._noise_index = self.DeclareNumericParameter(BasicVector(np.zeros(size)))
            self._noise = self.DeclareVectorInputPort("unit_noise", size)
        self.DeclareVectorOutputPort("q_measured", size, self._calc_measured)

    def counts(self, context: Context) -> tuple[int, ...]:
        """Counts per revolution of each joint in this system's ``context``."""
        values = context.get_numeric_parameter(self._counts_index).CopyToVector()
        return tuple(int(value) for value in values)

    def set_counts(self, context: Context, counts: int | Sequence[int]) -> None:
        """Change the resolution in this system's ``context`` (0: ideal sensor)."""
        size = self._q.size()
        values = per_joint_counts("encoder_counts", counts, size)
        context.get_mutable_numeric_parameter(self._counts_index).SetFromVector(
            np.array(values, dtype=float)
        )

    def set_zero_offset(self, context: Context, offset: Sequence[float]) -> None:
        """The encoder zero offset per joint (rad) in this system's ``context``."""
        context.get_mutable_numeric_parameter(self._offset_index).SetFromVector(offset)

    def set_noise_std(self, context: Context, std: Sequence[float]) -> None:
        """The additive noise's standard deviation per joint (rad); needs ``noisy``."""
        if self._noise is None:
            raise ValueError("this encoder was built without noise (noisy = False)")
        context.get_mutable_numeric_parameter(self._noise_index).SetFromVector(std)

    def _calc_measured(self, context: Context, output: BasicVector) -> None:
        q = self._q.Eval(context) + context.get_numeric_parameter(self._offset_index).value()
        counts = context.get_numeric_parameter(self._counts_index).value()
        measured = np.array(_quantise_joints(q.tolist(), counts.tolist()))
        if self._noise is not None:
            std = context.get_numeric_parameter(self._noise_index).value()
            measured += std * self._noise.Eval(context)
        output.SetFromVector(measured)
