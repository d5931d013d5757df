"""The true plant's motor stage and friction (Sec. 4.1), as Drake C++ blocks
between the voltage, the joint velocities and the MultibodyPlant::

    voltage u (V)  --> tau_j = kappa_j u_j           --> plant actuation (N m)
    velocities v   --> f_j = friction law (v)        --> plant applied generalized force

The friction law is ``PlantConfig.friction`` (``models.friction``: the default
``-f_cj tanh(v_j / v_s)``, ``models.plant`` explains ``v_s``; Stribeck; LuGre).
``kappa``, ``f_c``, ``v_s`` and every parameter of the law are per-Context parameters,
so one diagram serves every Monte-Carlo sample. Two implementations, picked by
``PlantConfig.motor_friction_blocks``:

* ``"symbolic"`` (the default, every law): two ``SymbolicVectorSystem``s whose
  parameters default to NaN, so a Context that never got its parameters fails loudly
  ("Detected NaN in applied generalized force input port"). Each carries one state
  that integrates energy: the work the motors deliver, ``sum_j tau_j v_j``, and the
  work the joints do against friction, ``-sum_j f_j v_j`` (J). Those states are part
  of the integrator's error control, so they take part in choosing its steps.
* ``"perceptron"`` (the default law only): two ``MultilayerPerceptron``s, ``kappa``
  as a one-layer identity network and the friction as a tanh layer (weights
  ``I / v_s``) followed by a linear one (``-diag(f_c)``). About 12-24 % faster per run
  (user guide, ``docs/guide/performance.md``), with no energy states (``energy`` refuses) and
  round-off differences: it computes ``v (1 / v_s)`` where the symbolic block computes
  ``v / v_s``, and without the energy states the integrator's steps can differ. Its
  parameters default to 0 (Drake's), so a Context that never got them runs with no
  motor and no friction: ``models.plant.apply_parameters`` is required, as everywhere
  in posfb.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from pydrake.symbolic import Variable
from pydrake.systems.framework import Context, DiagramBuilder, InputPort, OutputPort
from pydrake.systems.primitives import (
    MultilayerPerceptron,
    Multiplexer,
    PerceptronActivationType,
    SymbolicVectorSystem,
)

from posfb.models.friction import DEFAULT_LAW, tag
from posfb.models.friction.block import SymbolicFriction
from posfb.models.friction.common import total

#: The implementations of the motor and friction blocks (module docstring).
MOTOR_FRICTION_BLOCKS = ("symbolic", "perceptron")


def require_blocks(value: object) -> str:
    """Return ``value`` if it names one of ``MOTOR_FRICTION_BLOCKS``."""
    if value not in MOTOR_FRICTION_BLOCKS:
        raise ValueError(
            f"motor_friction_blocks = {value!r}; one of {', '.join(MOTOR_FRICTION_BLOCKS)} "
            "is required"
        )
    return str(value)


def require_blocks_for(blocks: str, friction: object) -> None:
    """The perceptron blocks carry the default law only."""
    if blocks == "perceptron" and type(friction) is not DEFAULT_LAW:
        raise ValueError(
            f"motor_friction_blocks = 'perceptron' with friction = {tag(friction)}; "
            f"motor_friction_blocks = 'symbolic' (or friction = {tag(DEFAULT_LAW())}) "
            "is required"
        )


class MotorFriction(Protocol):
    """What ``models.plant`` needs of either implementation."""

    def voltage_input_port(self) -> InputPort:
        """Motor voltages ``u`` (V), size n."""

    def set_motor_constants(self, root_context: Context, kappa: tuple[float, ...]) -> None:
        """Set ``kappa`` (N m / V, one per joint) in ``root_context``."""

    def set_coulomb(self, root_context: Context, levels: tuple[float, ...], v_s: float) -> None:
        """Set the Coulomb levels (N m, one per joint) and the smoothing velocity (rad/s)."""

    def set_friction_law(self, root_context: Context, settings: object) -> None:
        """Set the friction law's own parameters (``models.friction``) from its settings,
        of the kind the blocks were built for."""

    def motor_constants(self, root_context: Context) -> tuple[float, ...]:
        """The motor constants in ``root_context``."""

    def coulomb_levels(self, root_context: Context) -> tuple[float, ...]:
        """The Coulomb levels in ``root_context``."""

    def energy(self, root_context: Context) -> tuple[float, float]:
        """(work delivered by the motors, work the joints did against friction), J."""


def add_motor_friction(
    builder: DiagramBuilder,
    blocks: str,
    velocities: OutputPort,
    actuation: InputPort,
    applied_force: InputPort,
    friction: object | None = None,
) -> MotorFriction:
    """Add the ``blocks`` implementation with the ``friction`` law's kind (its settings;
    default ``!TanhCoulomb``), reading the joint ``velocities`` (size n) and driving the
    plant's ``actuation`` (actuator order = joint order, checked by ``models.plant``)
    and ``applied_force`` ports."""
    friction = DEFAULT_LAW() if friction is None else friction
    require_blocks_for(require_blocks(blocks), friction)
    if blocks == "perceptron":
        return PerceptronMotorFriction(builder, velocities, actuation, applied_force)
    return SymbolicMotorFriction(builder, velocities, actuation, applied_force, friction)


class SymbolicMotorFriction:
    """``SymbolicVectorSystem``s with NaN-default parameters and energy states."""

    def __init__(
        self,
        builder: DiagramBuilder,
        velocities: OutputPort,
        actuation: InputPort,
        applied_force: InputPort,
        friction: object,
    ) -> None:
        n = velocities.size()
        self._motor = builder.AddSystem(_symbolic_motor(n))
        self._motor_input = builder.AddSystem(Multiplexer([n, n]))
        self._motor_input.set_name("motor_input")
        builder.Connect(self._motor_input.get_output_port(0), self._motor.get_input_port(0))
        builder.Connect(velocities, self._motor_input.get_input_port(1))
        builder.Connect(self._motor.get_output_port(0), actuation)
        self.friction = SymbolicFriction(builder, friction, velocities, applied_force)

    def voltage_input_port(self) -> InputPort:
        return self._motor_input.get_input_port(0)

    def set_motor_constants(self, root_context: Context, kappa: tuple[float, ...]) -> None:
        context = self._motor.GetMyMutableContextFromRoot(root_context)
        context.get_mutable_numeric_parameter(0).SetFromVector(np.asarray(kappa, dtype=float))

    def set_coulomb(self, root_context: Context, levels: tuple[float, ...], v_s: float) -> None:
        self.friction.set_coulomb(root_context, levels, v_s)

    def set_friction_law(self, root_context: Context, settings: object) -> None:
        self.friction.set_law(root_context, settings)

    def motor_constants(self, root_context: Context) -> tuple[float, ...]:
        context = self._motor.GetMyContextFromRoot(root_context)
        return tuple(float(k) for k in context.get_numeric_parameter(0).value())

    def coulomb_levels(self, root_context: Context) -> tuple[float, ...]:
        return self.friction.coulomb_levels(root_context)

    def energy(self, root_context: Context) -> tuple[float, float]:
        motor = self._motor.GetMyContextFromRoot(root_context).get_continuous_state_vector()
        return float(motor[0]), self.friction.loss(root_context)


def _symbolic_motor(joints: int) -> SymbolicVectorSystem:
    """``tau_j = kappa_j u_j`` with the motor constants as numeric parameters.

    Input ``[u_1..u_n, v_1..v_n]``; its state integrates the mechanical work the
    motors deliver, ``W = sum_j tau_j v_j`` (J), for energy bookkeeping. (A
    stateless SymbolicVectorSystem cannot sit in a continuous diagram in
    Drake 1.51: its DoCalcTimeDerivatives asserts.)"""
    u = [Variable(f"u{j + 1}") for j in range(joints)]
    v = [Variable(f"v{j + 1}") for j in range(joints)]
    kappa = [Variable(f"kappa{j + 1}") for j in range(joints)]
    work = Variable("motor_work")
    torque = [kappa[j] * u[j] for j in range(joints)]
    system = SymbolicVectorSystem(
        state=[work],
        input=[*u, *v],
        parameter=kappa,
        dynamics=[total([torque[j] * v[j] for j in range(joints)])],
        output=torque,
    )
    system.set_name("motor")
    return system


class PerceptronMotorFriction:
    """``MultilayerPerceptron``s: no Python, no symbolic evaluation, no energy states."""

    def __init__(
        self,
        builder: DiagramBuilder,
        velocities: OutputPort,
        actuation: InputPort,
        applied_force: InputPort,
    ) -> None:
        n = velocities.size()
        identity, tanh_layer = PerceptronActivationType.kIdentity, PerceptronActivationType.kTanh
        self._joints = n
        self._motor = builder.AddSystem(MultilayerPerceptron([n, n], identity))
        self._motor.set_name("motor")
        self._coulomb = builder.AddSystem(MultilayerPerceptron([n, n, n], [tanh_layer, identity]))
        self._coulomb.set_name("coulomb_friction")
        builder.Connect(self._motor.get_output_port(), actuation)
        builder.Connect(velocities, self._coulomb.get_input_port())
        builder.Connect(self._coulomb.get_output_port(), applied_force)

    def voltage_input_port(self) -> InputPort:
        return self._motor.get_input_port()

    def set_motor_constants(self, root_context: Context, kappa: tuple[float, ...]) -> None:
        context = self._motor.GetMyMutableContextFromRoot(root_context)
        self._motor.SetWeights(context, 0, np.diag(np.asarray(kappa, dtype=float)))
        self._motor.SetBiases(context, 0, np.zeros(self._joints))

    def set_coulomb(self, root_context: Context, levels: tuple[float, ...], v_s: float) -> None:
        n = self._joints
        context = self._coulomb.GetMyMutableContextFromRoot(root_context)
        self._coulomb.SetWeights(context, 0, np.eye(n) / v_s)
        self._coulomb.SetBiases(context, 0, np.zeros(n))
        self._coulomb.SetWeights(context, 1, -np.diag(np.asarray(levels, dtype=float)))
        self._coulomb.SetBiases(context, 1, np.zeros(n))

    def set_friction_law(self, root_context: Context, settings: object) -> None:
        require_blocks_for("perceptron", settings)  # the default law has no parameters

    def motor_constants(self, root_context: Context) -> tuple[float, ...]:
        context = self._motor.GetMyContextFromRoot(root_context)
        return tuple(float(k) for k in np.diag(self._motor.GetWeights(context, 0)))

    def coulomb_levels(self, root_context: Context) -> tuple[float, ...]:
        context = self._coulomb.GetMyContextFromRoot(root_context)
        return tuple(float(-f) for f in np.diag(self._coulomb.GetWeights(context, 1)))

    def energy(self, root_context: Context) -> tuple[float, float]:
        raise ValueError(
            "motor_friction_blocks = 'perceptron' keeps no energy states; 'symbolic' is "
            "required for energy accounts"
        )
