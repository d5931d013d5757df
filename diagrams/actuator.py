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
  ``tau v_m' = v - v_m``, ``v_m(0) = 0`` (the motor
  at rest, no current). This equals the armature-current lag where the back-EMF
  ``k_e w`` changes little over ``tau`` (the mechanical time constants are 10-100x
  longer); it does not lag the back-EMF term itself. DC servo motors have
  ``L/R`` of 0.1-5 ms (e.g. Maxon RE 40: 0.082 mH / 0.299 Ohm = 0.27 ms; larger
  brushed motors a few ms). A joint with ``tau = 0`` passes its voltage through
  unfiltered (exactly, not a tiny time constant).
  An explicit integrator must take steps of about ``tau`` or shorter on a lagged run,
  so a short ``tau`` costs integrator steps (user guide, ``docs/guide/nonidealities.md``).

Per Context or per diagram: the lag's ``tau`` (per joint) and the DAC's ``b`` are
parameters of their blocks' Contexts (``ActuatorState``, ``ActuatorBlocks.set_state``), so
one diagram serves every Monte-Carlo sample that draws them. Whether a block exists is the
diagram's: a lag block where any joint has ``tau > 0`` (one C++ ``SymbolicVectorSystem``
over every joint, ``v_m' = (v - v_m) / tau`` as Drake's ``FirstOrderLowPassFilter``
computes it, so a run is the same to the bit; a joint with ``tau = 0`` passes ``v``
through by an ``if_then_else``), a DAC where ``b > 0`` (``b = 0`` in its Context passes
the voltage through). The compute delay stays the diagram's: ``d`` is an event time,
and Drake fixes a system's periodic event times when the system is declared (pydrake has
no per-Context ``DoCalcNextUpdateTime``; a witness function would evaluate Python at
every integrator step), so each distinct ``d`` is its own diagram (a study caches one
per value).

The DAC is the one Python block: its output is declared to depend on its input and its
bits only, so Drake's cache recomputes it only when its input changes, i.e. once per
period (at ``t_k``, or at ``t_k + d`` behind a compute delay), never per integrator step
(``tests/diagrams/test_actuator_effects.py`` counts the calls).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.symbolic import Variable, if_then_else
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiagramBuilder,
    LeafSystem,
    NumericParameterIndex,
    OutputPort,
)
from pydrake.systems.primitives import Saturation, SymbolicVectorSystem, ZeroOrderHold

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
    """Input ``u`` (V), output ``u_dac`` (V), both size ``n``: ``dac_quantise(u)`` with the
    Context's ``bits`` (a parameter; 0 passes ``u`` through).

    Stateless, but its output depends on its input and its bits alone (declared), so it
    is computed only when the input changes: the controller's output and a hold's output
    change only at sample instants."""

    def __init__(self, limits: Sequence[float], bits: int = 0) -> None:
        super().__init__()
        self.set_name("dac")
        self._limits = [float(limit) for limit in limits]
        default = BasicVector([float(require_dac_bits("bits", bits))])
        self._bits = self.DeclareNumericParameter(default)
        self._u = self.DeclareVectorInputPort("u", len(self._limits))
        self.DeclareVectorOutputPort(
            "u_dac",
            len(self._limits),
            self._calc_output,
            prerequisites_of_calc={
                self._u.ticket(),
                self.numeric_parameter_ticket(NumericParameterIndex(self._bits)),
            },
        )
        #: How often the output was computed (once per period in a run; a diagnostic).
        self.evaluations = 0

    def bits(self, context: Context) -> int:
        """The resolution in ``context`` (its own Context)."""
        return int(context.get_numeric_parameter(self._bits)[0])

    def set_bits(self, context: Context, bits: int) -> None:
        """Set the resolution (0..32, 0: ideal) in ``context`` (its own Context)."""
        bits = require_dac_bits("actuator.dac_bits", bits)
        context.get_mutable_numeric_parameter(self._bits).SetAtIndex(0, float(bits))

    def _calc_output(self, context: Context, output: BasicVector) -> None:
        self.evaluations += 1
        voltage = self._u.Eval(context).tolist()
        bits = self.bits(context)
        output.SetFromVector(dac_quantise(voltage, self._limits, bits) if bits else voltage)


def electrical_lag(joints: int) -> SymbolicVectorSystem:
    """The armature lag of ``joints`` joints (module docstring): input ``v``, state and
    (where ``tau > 0``) output ``v_m``, parameters ``tau`` (s; NaN until set: a Context
    that never got them fails loudly). A joint with ``tau = 0`` outputs ``v`` and its state
    stays idle."""
    idx = range(1, joints + 1)
    lagged = [Variable(f"v_m{j}") for j in idx]
    voltage = [Variable(f"v{j}") for j in idx]
    taus = [Variable(f"tau{j}") for j in idx]
    rows = list(zip(taus, lagged, voltage, strict=True))
    system = SymbolicVectorSystem(
        state=lagged,
        input=voltage,
        parameter=taus,
        dynamics=[if_then_else(tau == 0.0, 0.0, (v - x) / tau) for tau, x, v in rows],
        output=[if_then_else(tau == 0.0, v, x) for tau, x, v in rows],
    )
    system.set_name("electrical_lag")
    return system


def set_time_constants(
    lag: SymbolicVectorSystem, context: Context, time_constants: Sequence[float]
) -> None:
    """Set the lag's ``tau`` (s, one per joint, each finite and >= 0) in ``context`` (the
    lag's own Context)."""
    key = "actuator.electrical_time_constant"
    taus = [require_time_constant(f"{key}[{j}]", tau) for j, tau in enumerate(time_constants)]
    parameter = context.get_mutable_numeric_parameter(0)
    if len(taus) != parameter.size():
        raise ValueError(f"{key} = {taus!r}; {parameter.size()} values (one per joint) required")
    parameter.SetFromVector(taus)


def add_electrical_lag(
    builder: DiagramBuilder, voltage: OutputPort, time_constants: Sequence[float]
) -> tuple[OutputPort, SymbolicVectorSystem | None]:
    """``voltage`` through the armature lag (``electrical_lag``) when any of
    ``time_constants`` (s, one per joint) is > 0; the lagged port and the lag (``None``
    when every constant is 0: nothing is added). Its Contexts take their ``tau`` from
    ``set_time_constants``."""
    if not any(float(tau) > 0.0 for tau in time_constants):
        return voltage, None
    lag = builder.AddSystem(electrical_lag(voltage.size()))
    builder.Connect(voltage, lag.get_input_port(0))
    return lag.get_output_port(0), lag


@dataclass(frozen=True)
class ActuatorState:
    """The actuator settings one run's Context holds (``ActuatorBlocks.set_state``):
    ``electrical_time_constant`` (s, one per joint) and ``dac_bits``. Whether the lag and
    the DAC exist, and the compute delay, are part of the diagram."""

    electrical_time_constant: tuple[float, ...]
    dac_bits: int


@dataclass(frozen=True, eq=False)
class ActuatorBlocks:
    """The actuator section as built: the saturation (always), the optional blocks
    (``None`` where off), the port of the terminal voltage ``u_applied`` and the port
    that drives the motor block."""

    saturation: Saturation
    compute_delay: ZeroOrderHold | None
    dac: Dac | None
    electrical_lag: SymbolicVectorSystem | None
    applied: OutputPort
    motor_voltage: OutputPort

    def set_state(self, root_context: Context, state: ActuatorState) -> None:
        """Set the lag's time constants and the DAC's bits in ``root_context``; an effect
        the diagram was built without must be off in ``state``."""
        lagged = any(tau > 0.0 for tau in state.electrical_time_constant)
        for name, on, block in (
            ("electrical_time_constant", lagged, self.electrical_lag),
            ("dac_bits", state.dac_bits > 0, self.dac),
        ):
            if on and block is None:
                raise ValueError(
                    f"actuator.{name} = {getattr(state, name)!r} needs a diagram built with "
                    f"that effect (a config with actuator.{name} > 0)"
                )
        if self.electrical_lag is not None:
            context = self.electrical_lag.GetMyMutableContextFromRoot(root_context)
            set_time_constants(self.electrical_lag, context, state.electrical_time_constant)
        if self.dac is not None:
            self.dac.set_bits(self.dac.GetMyMutableContextFromRoot(root_context), state.dac_bits)


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
    (module docstring); a 0 setting adds no block. The lag's and the DAC's values are
    the Context's (``ActuatorBlocks.set_state``): here they decide which blocks exist."""
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
        dac = builder.AddSystem(Dac(limits))
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


#: Shortest armature lag (s) a run takes; 0 switches the lag off. The lag is a stiff
#: state for the explicit integrator, whose steps shrink to about ``tau``: a run's cost
#: grows as ``1 / tau`` (Lin+LC on the paper's arm, per simulated second: 0.08 s of wall
#: time at 1 ms, 0.27 s at 0.1 ms, 1.9 s at 10 us), so below 10 us a 20 s run takes
#: minutes, while such a lag delays the voltage by under 0.1 % of the paper's period.
MIN_ELECTRICAL_TIME_CONSTANT = 1e-5


def require_time_constant(name: str, value: float) -> float:
    """``value`` if it is 0 (no lag) or a finite time constant of at least
    ``MIN_ELECTRICAL_TIME_CONSTANT`` (s)."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float | np.integer | np.floating)
        or not math.isfinite(value)
        or value < 0.0
    ):
        raise ValueError(f"{name} = {value!r}; a finite time constant >= 0 s is required")
    if 0.0 < value < MIN_ELECTRICAL_TIME_CONSTANT:
        raise ValueError(
            f"{name} = {value!r}; 0 (no lag) or at least {MIN_ELECTRICAL_TIME_CONSTANT:g} s is "
            "required (a shorter lag makes the integrator's steps that short: minutes per run)"
        )
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
