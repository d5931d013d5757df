"""The shape shared by the three controllers (the interface the closed-loop
diagrams wire).

Inputs: ``q_measured`` (2, the quantised joint positions) and ``desired`` (6,
``[q_d, qdot_d, qddot_d]`` of ``models.trajectory``); no velocity input. Outputs:
``voltage`` (2, volts before saturation) and ``internals`` (named by the
subclass's ``INTERNALS`` tuple). Both outputs come from discrete state written by
one periodic update (period ``T_s``, offset 0, so the first sample is at
``t = 0``): the voltage computed at ``t_k`` from ``q_measured(t_k)`` is applied on
``[t_k, t_k + T_s)`` with no extra sample of delay.

The first update (``started = 0``) initialises the subclass's memory from the
first measurement (``_start``), then computes the first sample as any other.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import Context, DiscreteValues, LeafSystem

from posfb.models.design.config import JOINTS
from posfb.models.trajectory import DESIRED_SIZE
from posfb.models.validation import require_positive


class SampledController(LeafSystem):
    """Ports, state and the periodic update; subclasses implement ``_start`` and ``_step``."""

    def __init__(self, sample_time: float, internals: tuple[str, ...], memory_size: int) -> None:
        super().__init__()
        self.sample_time = require_positive("sample_time", sample_time)
        self.internals_names = internals
        self._q_port = self.DeclareVectorInputPort("q_measured", JOINTS)
        self._desired_port = self.DeclareVectorInputPort("desired", DESIRED_SIZE)
        self._voltage = self.DeclareDiscreteState(JOINTS)
        self._internals = self.DeclareDiscreteState(len(internals))
        self._memory = self.DeclareDiscreteState(memory_size)
        self._started = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("voltage", self._voltage)
        self.DeclareStateOutputPort("internals", self._internals)
        self.DeclarePeriodicDiscreteUpdateEvent(sample_time, 0.0, self._update)

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        q = self._q_port.Eval(context)
        desired = self._desired_port.Eval(context)
        if context.get_discrete_state(self._started).GetAtIndex(0) == 0.0:
            memory = self._start(q, desired)
            discrete_state.get_mutable_vector(self._started).SetAtIndex(0, 1.0)
        else:
            memory = context.get_discrete_state(self._memory).CopyToVector()
        voltage, internals = self._step(q, desired, memory)
        discrete_state.get_mutable_vector(self._voltage).SetFromVector(voltage)
        discrete_state.get_mutable_vector(self._internals).SetFromVector(internals)
        discrete_state.get_mutable_vector(self._memory).SetFromVector(memory)

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The memory before the first sample, from the first measurement."""
        raise NotImplementedError

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(voltage, internals)`` at this sample; advances ``memory`` in place."""
        raise NotImplementedError
