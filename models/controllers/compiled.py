"""A controller whose step is generated C (``models.laws.c_code``) compiled into a shared
library and called through ``ctypes``: the diagram's controller of a software-in-the-loop
run (``posfb simulate --sil``). It has the ports, state and timing of every
``SampledController``; its memory is the C state struct's array.
"""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np

from posfb.models.controllers.base import SampledController


class CompiledController(SampledController):
    """The controller of the library ``library`` (symbols ``NAME_start`` and
    ``NAME_step_internals``) with the ``precision`` it was generated in; ``internals``
    and ``internals_columns`` are the simulated controller's, so the logs keep their
    columns."""

    def __init__(
        self,
        library: Path,
        name: str,
        precision: str,
        sample_time: float,
        joints: int,
        memory: int,
        internals: tuple[str, ...],
        internals_columns: tuple[str, ...],
    ) -> None:
        super().__init__(sample_time, joints, internals, memory)
        self.set_name(f"{name}_compiled_controller")
        self._columns = internals_columns
        self._real = np.float32 if precision == "float" else np.float64
        pointer = np.ctypeslib.ndpointer(dtype=self._real, flags="C_CONTIGUOUS")
        self._library = ctypes.CDLL(str(library))
        self._start_c = getattr(self._library, f"{name}_start")
        self._start_c.argtypes = [pointer, pointer, pointer]
        self._start_c.restype = None
        self._step_c = getattr(self._library, f"{name}_step_internals")
        self._step_c.argtypes = [pointer] * 5
        self._step_c.restype = None
        self._voltage = np.zeros(joints, dtype=self._real)
        self._internals = np.zeros(len(internals), dtype=self._real)

    @property
    def internals_columns(self) -> tuple[str, ...]:
        return self._columns

    def _start(self, q: np.ndarray, desired: np.ndarray) -> np.ndarray:
        memory = np.zeros(self.memory_size, dtype=self._real)
        self._start_c(memory, np.ascontiguousarray(q, self._real),
                      np.ascontiguousarray(desired, self._real))  # fmt: skip
        return memory.astype(float)

    def _step(
        self, q: np.ndarray, desired: np.ndarray, memory: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        state = np.ascontiguousarray(memory, self._real)
        q, desired = (np.ascontiguousarray(x, self._real) for x in (q, desired))
        self._step_c(state, q, desired, self._voltage, self._internals)
        memory[:] = state
        return self._voltage.astype(float), self._internals.astype(float)
