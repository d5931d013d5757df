"""The shape shared by the three controllers (the interface the closed-loop
diagrams wire): discrete systems with direct feedthrough behind a zero-order hold.

Inputs: ``q_measured`` (n, the held quantised joint positions) and ``desired`` (3n,
the held ``[q_d, qdot_d, qddot_d]`` of ``models.trajectory``); no velocity input.
Outputs: ``voltage`` (n, volts before saturation) and ``internals`` (named by the
subclass's ``internals`` names).

With both inputs held by ``ZeroOrderHold(T_s)`` blocks (``diagrams.wiring``)
the controller realises, with no extra sample of delay::

    u_k = g(x_k, y_k),   x_{k+1} = f(x_k, y_k)

``g`` is the output, computed from the discrete state and the held inputs (direct
feedthrough); ``f`` is the periodic update (period ``T_s``, offset 0: the same event
times as the holds', ``k T_s``). At ``t_k`` every discrete update reads the values
from before ``t_k``: the hold takes ``y_k`` while the update writes
``f(x_{k-1}, y_{k-1}) = x_k``, so after ``t_k`` the output is ``g(x_k, y_k)``,
applied on ``[t_k, t_k + T_s)``. One cache entry computes ``(u, internals,
x_next)`` once per sample for the output ports and the update.

``phase`` counts the start: 0 before ``t_0``; the update at ``t_0`` only sets it to
1 (there is no earlier sample to step from), and while it is 1 the state is the
subclass's memory initialised from the held first measurement (``_start``); the
update at ``t_1`` steps from there and sets it to 2.
"""

from __future__ import annotations

import typing
from collections.abc import Mapping

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    LeafSystem,
    ValueProducer,
)

from posfb.models.validation import require_positive

if typing.TYPE_CHECKING:
    from posfb.models.laws.law import Law


def unit_of(name: str, units: Mapping[str, str]) -> str:
    """The unit of internal ``name`` in ``units`` (``name``, or for ``stem_j`` the
    stem's); ``KeyError`` for a name without one."""
    stem, _, joint = name.rpartition("_")
    if name in units:
        return units[name]
    if joint.isdigit() and stem in units:
        return units[stem]
    raise KeyError(f"controller internal {name!r} has no unit in internal_units")


def unit_columns(names: tuple[str, ...], units: Mapping[str, str]) -> tuple[str, ...]:
    """``names`` with their unit suffixes (``unit_of``): ``tau_lin_1`` -> ``tau_lin_1_V``."""
    return tuple(f"{name}_{unit_of(name, units)}" for name in names)


def joint_names(prefix: str, joints: int) -> tuple[str, ...]:
    """``(prefix_1, ..., prefix_n)``: one internals column per joint."""
    return tuple(f"{prefix}_{j + 1}" for j in range(joints))


class SampledController(LeafSystem):
    """Ports, state, the cached step and the periodic update; subclasses implement
    ``_start`` and ``_step`` and name their export columns (``internals_columns``);
    ``joints`` is ``n``."""

    def __init__(
        self, sample_time: float, joints: int, internals: tuple[str, ...], memory_size: int
    ) -> None:
        super().__init__()
        require_positive("sample_time", sample_time)
        self.joints = joints
        self.internals_names = internals
        self.memory_size = memory_size
        self._q_port = self.DeclareVectorInputPort("q_measured", joints)
        self._desired_port = self.DeclareVectorInputPort("desired", 3 * joints)
        # One state group, [memory, phase]: one read and one write per sample.
        self._state = self.DeclareDiscreteState(memory_size + 1)
        self._voltage_end = joints
        self._internals_end = joints + len(internals)
        self._step_cache = self.DeclareCacheEntry(
            description="controller step (u, internals, next memory)",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(np.zeros(self._internals_end + memory_size)).Clone,
                calc=self._calc_step,
            ),
            prerequisites_of_calc={self.xd_ticket(), self.all_input_ports_ticket()},
        )
        ticket = {self._step_cache.ticket()}
        self.DeclareVectorOutputPort("voltage", joints, self._calc_voltage, ticket)
        self.DeclareVectorOutputPort("internals", len(internals), self._calc_internals, ticket)
        self.DeclarePeriodicDiscreteUpdateEvent(sample_time, 0.0, self._update)

    @property
    def sample_time(self) -> float:
        """``T_s`` (s): the period of the update event this system declared (Drake holds
        it; the loop context gave it)."""
        return self.GetUniquePeriodicDiscreteUpdateAttribute().period_sec()

    def _calc_step(self, context: Context, value: AbstractValue) -> None:
        q = self._q_port.Eval(context)
        desired = self._desired_port.Eval(context)
        state = context.get_discrete_state(self._state).value()
        memory = self._start(q, desired) if state[-1] < 2.0 else state[:-1].copy()
        voltage, internals = self._step(q, desired, memory)
        step = value.get_mutable_value()
        step[: self._voltage_end] = voltage
        step[self._voltage_end : self._internals_end] = internals
        step[self._internals_end :] = memory

    def _calc_voltage(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._step_cache.Eval(context)[: self._voltage_end])

    def _calc_internals(self, context: Context, output: BasicVector) -> None:
        step = self._step_cache.Eval(context)
        output.SetFromVector(step[self._voltage_end : self._internals_end])

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        state = discrete_state.get_mutable_vector(self._state).get_mutable_value()
        if state[-1] == 0.0:  # t_0: the holds take the first sample now; nothing to step
            state[-1] = 1.0
            return
        state[:-1] = self._step_cache.Eval(context)[self._internals_end :]
        state[-1] = 2.0

    @property
    def internals_columns(self) -> tuple[str, ...]:
        """The internals' export names, each with its unit suffix."""
        raise NotImplementedError

    def split_desired(self, desired: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q_d, qdot_d, qddot_d)`` of the stacked desired input."""
        n = self.joints
        return desired[:n], desired[n : 2 * n], desired[2 * n :]

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The memory before the first sample, from the first measurement."""
        raise NotImplementedError

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(voltage, internals)`` at this sample; advances ``memory`` in place."""
        raise NotImplementedError


class LawController(SampledController):
    """The discrete system of every controller written as a ``models.laws`` law: its
    ``_start`` and ``_step`` evaluate ``law.start`` and ``law.step`` (``Stepper``), the
    one description that ``posfb codegen`` also prints and that the linear feedback is
    derived from. ``internals_columns`` are ``internals``' export names (with their units);
    by default the names themselves."""

    def __init__(
        self,
        law: Law,
        sample_time: float,
        internals: tuple[str, ...],
        internals_columns: tuple[str, ...] | None = None,
    ) -> None:
        from posfb.models.laws.law import Stepper

        if len(internals) != law.internals:
            given = ", ".join(internals)
            raise ValueError(f"law {law.name!r} has {law.internals} internals; "
                             f"{len(internals)} names were given ({given})")  # fmt: skip
        super().__init__(sample_time, law.joints, internals, law.memory)
        self.law = law
        self._columns = internals if internals_columns is None else internals_columns
        self.set_name(f"{law.name}_controller")
        self._stepper = Stepper(law)

    @property
    def internals_columns(self) -> tuple[str, ...]:
        return self._columns

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        return self._stepper.start(q, desired)

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        return self._stepper.step(q, desired, memory)
