"""The actuator section of the closed loop: what happens to the controller's voltage on
its way to the motor block. Each effect is selectable (``diagrams.sections.Actuator``)
and, when off, adds no block::

    controller -> [compute_delay] -> [dac] -> voltage_saturation -> [electrical_lag] -> motor
      u_commanded                                        u_applied

Why this order: the DSP computes ``u_k`` from the sample of ``t_k`` and writes it to its
DAC when the computation ends (``compute_delay``), so the delay acts on the number the
controller produced; the DAC converts that number to one of its levels (``dac``); the
power amplifier then clips the analogue voltage to its supply (``voltage_saturation``,
the paper's +-24 V, Sec. 4.1); the armature's inductance finally lags the current, and
with it the torque, behind the terminal voltage (``electrical_lag``). ``u_applied``, the
logged and RMS'd voltage, is the terminal voltage (the saturation's output), before the
lag: the lag is a property of the motor, not of the voltage the drive applies.

Models (``T_s`` the sample time, ``V`` the voltage limit of a joint):

- ``compute_delay = d`` (s, ``0 <= d <= T_s``): a ``ZeroOrderHold(T_s, n, offset d)``
  samples the controller's output at ``t_k + d``. The controller's output on
  ``[t_k, t_{k+1})`` is ``u_k`` (``models.controllers.base``), so the applied voltage
  is ``u_{k-1}`` on ``[t_k, t_k + d)`` and ``u_k`` on ``[t_k + d, t_{k+1})``; at
  ``d = T_s`` the hold's update at ``t_{k+1}`` reads the controller's output from before
  the controller's own update at that instant (all discrete updates at one instant read
  the values from before it, ``docs/drake-notes.md``), i.e. ``u_k``, so ``u_k`` applies on
  ``[t_{k+1}, t_{k+2})``: one whole sample of delay. (At ``d = T_s`` the hold is built
  with offset 0, reading ``u_{k-1}`` at ``t_k``: an offset of ``T_s`` would put its
  events at ``T_s + k T_s``, which rounds differently from the controller's ``(k+1) T_s``
  and, where it lands just after, reads the new ``u_{k+1}``.) Before the first computed
  voltage arrives (``t < d``) the hold applies the controller's output from before its
  first update (its initial state with the first sample; ``ClosedLoopRunner.new_context``
  sets it), the same for every ``d``. ``d`` is meant to be a fraction of ``T_s``, not a
  rounding error: a ``d`` within rounding of 0 would coincide with ``t_k`` and act as
  ``T_s``. Typical DSP
  computation times are a fraction of the period (the paper's DSP board, Sec. 4.1,
  computes a 2-joint law in well under 1 ms of its 10 ms period).
- ``dac_bits = b`` (``1 <= b <= 32``): a two's-complement (mid-tread) DAC over
  ``[-V, +V]``: step ``Delta = 2 V / 2^b``, code ``c = clamp(round(u / Delta),
  -2^(b-1), 2^(b-1) - 1)`` (round half to even), output ``c Delta``. Its ``2^b`` levels
  are ``-V, -V + Delta, ..., V - Delta``; 0 V is a level (no dither at rest). For
  ``-V - Delta/2 <= u <= V - Delta/2`` the error is at most ``Delta/2``; above, the top
  code ``V - Delta`` is output. 12-bit DACs are the common choice on DSP control boards
  (TI's C2000 family, dSPACE DS1104's DAC channels: 16 bit); at 12 bits and 24 V,
  ``Delta = 11.7 mV``.
- ``electrical_time_constant = L/R`` (s, per joint): the armature circuit
  ``L di/dt = v - R i - k_e w`` lags the current behind the voltage with time constant
  ``tau = L/R``. The motor block of ``models.plant`` takes a voltage and is static
  (``i = (v - k_e w) / R``), so the lag is modelled on the voltage reaching it:
  ``tau v_m' = v - v_m`` (Drake's ``FirstOrderLowPassFilter``), ``v_m(0) = 0`` (the motor
  at rest, no current). This equals the armature-current lag where the back-EMF
  ``k_e w`` changes little over ``tau`` (the mechanical time constants are 10-100x
  longer); it does not lag the back-EMF term itself. DC servo motors have
  ``L/R`` of 0.1-5 ms (e.g. Maxon RE 40: 0.082 mH / 0.299 Ohm = 0.27 ms; larger
  brushed motors a few ms). A joint with ``tau = 0`` passes its voltage through
  unfiltered (exactly, not a tiny time constant): the filter then covers only the
  joints with ``tau > 0``, between a ``Demultiplexer`` and a ``Multiplexer``.
  An explicit integrator must take steps of about ``tau`` or shorter on a lagged run,
  so a short ``tau`` costs integrator steps (README, "Non-idealities").

The DAC is the one Python block: its output is declared to depend on its input only,
so Drake's cache recomputes it only when its input changes, i.e. once per period
(at ``t_k``, or at ``t_k + d`` behind a compute delay), never per integrator step
(``tests/test_actuator_effects.py`` counts the calls).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, LeafSystem, OutputPort
from pydrake.systems.primitives import (
    Demultiplexer,
    FirstOrderLowPassFilter,
    Multiplexer,
    Saturation,
    ZeroOrderHold,
)

#: Names of the actuator blocks that exist only where an effect is on.
EFFECT_BLOCKS = ("compute_delay", "dac", "electrical_lag")


def dac_step(voltage_limit: float, bits: int) -> float:
    """``Delta = 2 V / 2^bits`` (V): the DAC's step."""
    return 2.0 * voltage_limit / 2.0**bits


def dac_quantise(voltage: Sequence[float], limits: Sequence[float], bits: int) -> list[float]:
    """The DAC's output for the commanded ``voltage``, joint by joint (module docstring):
    ``clamp(round(u / Delta), -2^(bits-1), 2^(bits-1) - 1) Delta``."""
    low, high = -(2 ** (bits - 1)), 2 ** (bits - 1) - 1
    out = []
    for value, limit in zip(voltage, limits, strict=True):
        step = dac_step(limit, bits)
        out.append(min(max(round(value / step), low), high) * step)
    return out


class Dac(LeafSystem):
    """Input ``u`` (V), output ``u_dac`` (V), both size ``n``: ``dac_quantise(u)``.

    Stateless, but its output depends on its input alone (declared), so it is computed
    only when the input changes: the controller's output and a hold's output change
    only at sample instants."""

    def __init__(self, limits: Sequence[float], bits: int) -> None:
        super().__init__()
        self.set_name("dac")
        self._limits = [float(limit) for limit in limits]
        self._bits = int(bits)
        self._u = self.DeclareVectorInputPort("u", len(self._limits))
        self.DeclareVectorOutputPort(
            "u_dac",
            len(self._limits),
            self._calc_output,
            prerequisites_of_calc={self._u.ticket()},
        )
        #: How often the output was computed (once per period in a run; a diagnostic).
        self.evaluations = 0

    @property
    def bits(self) -> int:
        return self._bits

    def step(self) -> list[float]:
        """``Delta`` (V) of each joint."""
        return [dac_step(limit, self._bits) for limit in self._limits]

    def _calc_output(self, context: Context, output: BasicVector) -> None:
        self.evaluations += 1
        voltage = self._u.Eval(context).tolist()
        output.SetFromVector(dac_quantise(voltage, self._limits, self._bits))


def add_electrical_lag(
    builder: DiagramBuilder, voltage: OutputPort, time_constants: Sequence[float]
) -> tuple[OutputPort, FirstOrderLowPassFilter | None]:
    """``voltage`` through a first-order lag of ``time_constants[j]`` (s) per joint (0:
    passed through); the lagged port and the filter (``None`` when every constant is 0:
    nothing is added)."""
    taus = [float(tau) for tau in time_constants]
    lagged = [j for j, tau in enumerate(taus) if tau > 0.0]
    if not lagged:
        return voltage, None
    lag = builder.AddSystem(FirstOrderLowPassFilter(np.array([taus[j] for j in lagged])))
    lag.set_name("electrical_lag")
    n = len(taus)
    if len(lagged) == n:
        builder.Connect(voltage, lag.get_input_port())
        return lag.get_output_port(), lag
    split = builder.AddSystem(Demultiplexer(n, 1))
    split.set_name("electrical_lag_split")
    gather = builder.AddSystem(Multiplexer(len(lagged)))
    gather.set_name("electrical_lag_gather")
    scatter = builder.AddSystem(Demultiplexer(len(lagged), 1))
    scatter.set_name("electrical_lag_scatter")
    merge = builder.AddSystem(Multiplexer(n))
    merge.set_name("electrical_lag_merge")
    builder.Connect(voltage, split.get_input_port(0))
    builder.Connect(gather.get_output_port(0), lag.get_input_port())
    builder.Connect(lag.get_output_port(), scatter.get_input_port(0))
    for slot, j in enumerate(lagged):
        builder.Connect(split.get_output_port(j), gather.get_input_port(slot))
        builder.Connect(scatter.get_output_port(slot), merge.get_input_port(j))
    for j in (j for j in range(n) if j not in lagged):
        builder.Connect(split.get_output_port(j), merge.get_input_port(j))
    return merge.get_output_port(0), lag


@dataclass(frozen=True, eq=False)
class ActuatorBlocks:
    """The actuator section as built: the saturation (always), the optional blocks
    (``None`` where off), the port of the terminal voltage ``u_applied`` and the port
    that drives the motor block."""

    saturation: Saturation
    compute_delay: ZeroOrderHold | None
    dac: Dac | None
    electrical_lag: FirstOrderLowPassFilter | None
    applied: OutputPort
    motor_voltage: OutputPort


def add_actuator(
    builder: DiagramBuilder,
    command: OutputPort,
    *,
    limits: Sequence[float],
    sample_time: float,
    compute_delay: float = 0.0,
    dac_bits: int = 0,
    electrical_time_constant: Sequence[float] = (0.0,),
) -> ActuatorBlocks:
    """controller ``command`` -> [compute delay] -> [DAC] -> saturation -> [lag]
    (module docstring); a 0 setting adds no block."""
    n = len(limits)
    voltage = command
    delay = None
    if compute_delay > 0.0:
        # At d = T_s, offset 0: a hold's update at t_k reads u_(k-1), with no event time
        # one rounding error away from the controller's (0.01 + 5 x 0.01 != 0.06).
        offset = 0.0 if compute_delay >= sample_time else compute_delay
        delay = builder.AddSystem(ZeroOrderHold(sample_time, n, offset))
        delay.set_name("compute_delay")
        builder.Connect(voltage, delay.get_input_port())
        voltage = delay.get_output_port()
    dac = None
    if dac_bits > 0:
        dac = builder.AddSystem(Dac(limits, dac_bits))
        builder.Connect(voltage, dac.get_input_port())
        voltage = dac.get_output_port()
    limit = np.array(limits, dtype=float)
    saturation = builder.AddSystem(Saturation(-limit, limit))
    saturation.set_name("voltage_saturation")
    builder.Connect(voltage, saturation.get_input_port(0))
    applied = saturation.get_output_port(0)
    taus = list(electrical_time_constant)
    if len(taus) == 1:
        taus *= n
    motor_voltage, lag = add_electrical_lag(builder, applied, taus)
    return ActuatorBlocks(saturation, delay, dac, lag, applied, motor_voltage)


def require_time_constant(name: str, value: float) -> float:
    """``value`` if it is a finite number >= 0 (s)."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float | np.integer | np.floating)
        or not math.isfinite(value)
        or value < 0.0
    ):
        raise ValueError(f"{name} = {value!r}; a finite time constant >= 0 s is required")
    return float(value)


def require_dac_bits(name: str, value: object) -> int:
    """``value`` if it is an integer in 0..32 (0: ideal DAC)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 0 <= value <= 32:
        raise ValueError(f"{name} = {value!r}; an integer from 0 (ideal) to 32 is required")
    return int(value)


def require_compute_delay(name: str, value: object, sample_time: float) -> float:
    """``value`` if ``0 <= value <= sample_time`` (s)."""
    ok = (
        not isinstance(value, bool)
        and isinstance(value, int | float | np.integer | np.floating)
        and math.isfinite(value)
        and 0.0 <= value <= sample_time
    )
    if not ok:
        raise ValueError(
            f"{name} = {value!r}; 0 <= delay <= timing.sample_time = {sample_time!r} is required"
        )
    return float(value)
