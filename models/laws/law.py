"""One controller's law as two CasADi functions, and their numeric evaluation.

``Law.start``: ``(q[n], desired[3n]) -> memory[m]``; ``Law.step``: ``(memory[m], q[n],
desired[3n]) -> (voltage[n], internals[k], memory_next[m])``, both ``SX`` expression
graphs (the nominal model's terms too, on the theta model or any URDF arm:
``models.laws.nominal``), which ``posfb codegen`` prints as C.

``Stepper`` evaluates both through CasADi's function buffers (no copies; about a
microsecond a call for an ``SX`` law), for the simulated controller.

``Law.held`` names the memory entries that adapt a gain or record a bound (the paper's
controller's ``y = |alpha~1|`` and running maxima): the linear feedback that margins and
tuning use (``models.controllers.linearise``) holds them at the stated values instead
of treating them as states.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import casadi as ca
import numpy as np


@dataclass(frozen=True, eq=False)
class Law:
    """A controller's ``start`` and ``step`` (module docstring) for ``joints`` joints;
    ``held``: ``(memory index, value)`` pairs held in the linear feedback."""

    name: str
    joints: int
    start: ca.Function
    step: ca.Function
    held: tuple[tuple[int, float], ...] = ()

    @property
    def memory(self) -> int:
        return int(self.start.size1_out(0))

    @property
    def internals(self) -> int:
        return int(self.step.size1_out(1))


#: ``(q, q_d) -> memory_0``: a law's memory before the first sample.
Start = Callable[[ca.SX, ca.SX], ca.SX]
#: ``(memory, q, q_d, qd_dot, qd_ddot) -> (voltage, internals, memory_next)``: one sample.
Step = Callable[[ca.SX, ca.SX, ca.SX, ca.SX, ca.SX], tuple[ca.SX, ca.SX, ca.SX]]


def law(
    name: str,
    joints: int,
    memory: int,
    start: Start,
    step: Step,
    held: Mapping[int, float] | None = None,
) -> Law:
    """A ``Law`` of ``joints`` joints and ``memory`` numbers kept between samples, from
    ``start`` and ``step`` written on CasADi ``SX`` symbols (which this function makes:
    the position, the desired signals split in ``[q_d, qd_dot, qd_ddot]``, the memory);
    ``held``: memory entries held at a value in the linear feedback (module docstring).
    Equal subexpressions of the step's outputs are computed once (``casadi.cse``): a URDF
    arm's kinematics, which Eq. 4 and Eq. 18's mass matrix both build from ``q``."""
    q, desired, state = (ca.SX.sym(label, size) for label, size in
                         (("q", joints), ("desired", 3 * joints), ("memory", memory)))  # fmt: skip
    q_d, qd_dot, qd_ddot = (desired[k * joints : (k + 1) * joints] for k in range(3))
    voltage, internals, following = ca.cse(list(step(state, q, q_d, qd_dot, qd_ddot)))
    return Law(
        name,
        joints,
        ca.Function(f"{name}_start", [q, desired], [start(q, q_d)], ["q", "desired"], ["memory"]),
        ca.Function(
            f"{name}_step",
            [state, q, desired],
            [voltage, internals, following],
            ["memory", "q", "desired"],
            ["voltage", "internals", "memory_next"],
        ),  # fmt: skip
        _held(name, memory, held or {}),
    )


def _held(name: str, memory: int, held: Mapping[int, float]) -> tuple[tuple[int, float], ...]:
    """``held`` as sorted pairs; ``ValueError`` for an index outside the memory or a
    non-finite value."""
    for index, value in held.items():
        if not (isinstance(index, int) and 0 <= index < memory):
            raise ValueError(f"law {name!r}: held index {index!r}; 0 <= index < {memory} "
                             "(the memory's size) is required")  # fmt: skip
        if not math.isfinite(value):
            raise ValueError(f"law {name!r}: held[{index}] = {value!r}; a finite value is "
                             "required")  # fmt: skip
    return tuple(sorted((index, float(value)) for index, value in held.items()))


class Evaluator:
    """A CasADi function evaluated through its buffers: its inputs and outputs are bound
    once to arrays; each call copies the arguments in and returns copies of the results
    (about a microsecond a call)."""

    def __init__(self, function: ca.Function) -> None:
        self._inputs = [np.zeros(function.nnz_in(i)) for i in range(function.n_in())]
        self._outputs = [np.zeros(function.nnz_out(i)) for i in range(function.n_out())]
        self._buffer, self._call = function.buffer()
        for i, array in enumerate(self._inputs):
            self._buffer.set_arg(i, memoryview(array))
        for i, array in enumerate(self._outputs):
            self._buffer.set_res(i, memoryview(array))

    def __call__(self, *arguments: np.ndarray) -> tuple[np.ndarray, ...]:
        for array, value in zip(self._inputs, arguments, strict=True):
            array[:] = value
        self._call()
        return tuple(array.copy() for array in self._outputs)


class Stepper:
    """Numeric ``start`` and ``step`` of a ``Law`` (``Evaluator``), for the simulated
    controller."""

    def __init__(self, law: Law) -> None:
        self.law = law
        self._start = Evaluator(law.start)
        self._step = Evaluator(law.step)

    def start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The memory before the first sample."""
        return self._start(q, desired)[0]

    def step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(voltage, internals)`` at this sample; advances ``memory`` in place."""
        voltage, internals, memory[:] = self._step(memory, q, desired)
        return voltage, internals
