"""Gear compliance and backlash between each motor and its link: Spong's flexible-joint
model (M. W. Spong, "Modeling and control of elastic joint robots", J. Dyn. Sys. Meas.
Control 109(4), 1987) with a dead zone for the backlash, as one C++
``SymbolicVectorSystem`` whose parameters are per Context.

Everything is written at the link side (motor angles divided by the gear ratio ``r``),
so the motor's inertia is the URDF's reflected rotor inertia ``J_m = I_rotor r^2``
(``ArmParameters.rotor_inertia``). Per joint ``j``, with ``d = theta_m - q``::

    theta_m' = omega_m
    J_m omega_m' = tau_m - tau_g                        tau_m = kappa u (the motor block)
    tau_g = k dz(d) + c (omega_m - q')                  -> the link's joint (actuation port)
    dz(d) = d - b (d > b),  d + b (d < -b),  0 otherwise

``k`` = ``plant.gear_stiffness`` (N m/rad), ``c`` = ``plant.gear_damping`` (N m s/rad),
``b`` = ``plant.backlash`` (rad, the dead band's half-width; ``b = 0`` is plain
elasticity). The damping term acts at every ``d``, inside the dead band too (the model
as the issue states it; with ``b > 0`` and ``c > 0`` the teeth that are not in contact
still pass ``c (omega_m - q')``). The dead zone is Drake's symbolic ``if_then_else``,
evaluated in C++: no Python in the integrator's inner loop.

Where it applies: with every ``k = 0`` (the default) the gear is rigid, no block is
added and the MultibodyPlant keeps ``J_m`` on its actuator (today's model, every number
unchanged). With ``k > 0`` at any joint the block is added over every joint and each
joint is compliant or rigid by its own ``k`` in the Context:

- a compliant joint (``k_j > 0``) follows the equations above; its actuator's rotor
  inertia in the MultibodyPlant is 0 and ``J_m`` is the block's parameter;
- a rigid joint (``k_j = 0``) passes the motor torque through (``tau_g = tau_m``), its
  motor angle and speed are the link's (``theta_m = q``, ``omega_m = q'``: outputs, so
  a motor encoder reads ``q`` there), its two motor states are idle (derivative 0) and
  the MultibodyPlant keeps ``J_m`` on its actuator, as on the rigid arm.

Each joint's branch is an ``if_then_else`` on ``k_j > 0``, so a compliant joint computes
the same expressions whether its neighbours are rigid or not. Whether the block exists is
part of the diagram; ``k`` (hence which joints are compliant), ``c``, ``b`` and ``J_m``
are per-Context parameters (a Monte-Carlo study draws them without rebuilding: they
travel like the friction law's values, ``ClosedLoopRunner.run(..., gear=)``, and ``J_m``
with ``ArmParameters.rotor_inertia``; ``models.plant.set_gear`` moves each joint's
``J_m`` between the block and the MultibodyPlant).

Friction stays on the link side (the plant's applied generalized force, reading ``q'``):
the Coulomb levels of ``<posfb:coulomb_friction>`` (and the paper's ``f_c``) were
identified at the joint as one lumped friction of motor, gear and bearing, with no way
to split them; so the scenario's friction acts where it acts today and ``J_m`` is
frictionless. The URDF's viscous joint damping stays on the link too.

A backlash needs a stiffness (a rigid gear with a dead band has no torque law here):
``b > 0`` with ``k = 0`` is refused, as is ``c > 0`` with ``k = 0`` (it would do
nothing). Typical values: harmonic drives of small arms have ``k ~ 1e3-1e4`` N m/rad at
the link (Harmonic Drive AG's CSF/CSG catalogue: K3 of 1.3e3 N m/rad for size 14 up to
5.4e4 for size 32; Tuttle & Seering, "A nonlinear model of a harmonic drive gear
transmission", IEEE Trans. Robotics Automat. 12(3), 1996, measure a few 1e3), and
backlash of well under 1 arcmin (harmonic drives) to 5-20 arcmin (spur gears).

The block's state is ``[theta_m (n), omega_m (n), W]``: ``W`` integrates the motor's
work ``sum_j tau_mj omega_mj`` (J), which replaces the motor block's ``tau_m q'`` in the
energy accounts. Output ``[tau_g (n), theta_m (n), omega_m (n)]``: the encoder reads
``theta_m`` with ``sensor.location: motor``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.symbolic import Variable, if_then_else
from pydrake.systems.framework import Context, DiagramBuilder, InputPort, OutputPort
from pydrake.systems.primitives import Demultiplexer, Multiplexer, SymbolicVectorSystem

from posfb.models.friction.common import total
from posfb.models.validation import per_joint, require_nonnegative, shown


@dataclass(frozen=True)
class GearConfig:
    """The gear's settings (module docstring), per joint: one value = every joint.
    The defaults (every ``k = 0``) are today's rigid gear. ``prefix`` in the checks is
    what the error messages put before each key (``plant.`` from a scenario)."""

    gear_stiffness: tuple[float, ...] = (0.0,)
    gear_damping: tuple[float, ...] = (0.0,)
    backlash: tuple[float, ...] = (0.0,)

    def __post_init__(self) -> None:
        for name in ("gear_stiffness", "gear_damping", "backlash"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
            for j, value in enumerate(getattr(self, name)):
                require_nonnegative(f"{name}[{j}]", value)

    @property
    def compliant(self) -> bool:
        """Whether the diagram gets the gear block (any stiffness > 0)."""
        return any(float(k) > 0.0 for k in self.gear_stiffness)

    def values(self, joints: int, prefix: str = "") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(k, c, b)``, ``joints`` values each, checked: all ``>= 0``; ``b > 0`` and
        ``c > 0`` need ``k > 0`` at their joint."""
        arrays = []
        for name in ("gear_stiffness", "gear_damping", "backlash"):
            key = f"{prefix}{name}"
            entries = per_joint(key, list(getattr(self, name)), joints)
            arrays.append(
                np.array([require_nonnegative(f"{key}[{j}]", v) for j, v in enumerate(entries)])
            )
        k, c, b = arrays
        for name, values in (("backlash", b), ("gear_damping", c)):
            for j in range(joints):
                if values[j] > 0.0 and k[j] == 0.0:
                    raise ValueError(
                        f"{prefix}{name}[{j}] = {shown(float(values[j]))} with "
                        f"{prefix}gear_stiffness[{j}] = 0 (a rigid gear); "
                        f"{prefix}gear_stiffness[{j}] > 0 is required"
                    )
        return k, c, b


class GearBlock:
    """The gear's ``SymbolicVectorSystem`` in a diagram (module docstring), its input
    multiplexer ``[tau_m, q, q']`` and output demultiplexer ``[tau_g, theta_m, omega_m]``,
    with per-Context setters. Parameters ``[k (n), c (n), b (n), J_m (n)]``, NaN by
    default (a Context that never got them fails loudly)."""

    def __init__(
        self,
        builder: DiagramBuilder,
        joints: int,
        plant_state: OutputPort,
        actuation: InputPort,
    ) -> None:
        n = self.joints = joints
        self.system = builder.AddSystem(_gear_system(n))
        self._input = builder.AddSystem(Multiplexer([n, 2 * n]))
        self._input.set_name("gear_input")
        self._output = builder.AddSystem(Demultiplexer([n, n, n]))
        self._output.set_name("gear_output")
        builder.Connect(plant_state, self._input.get_input_port(1))
        builder.Connect(self._input.get_output_port(0), self.system.get_input_port(0))
        builder.Connect(self.system.get_output_port(0), self._output.get_input_port(0))
        builder.Connect(self._output.get_output_port(0), actuation)

    def motor_torque_input_port(self) -> InputPort:
        """``tau_m`` (N m), size n: the motor block's output."""
        return self._input.get_input_port(0)

    def motor_position_output_port(self) -> OutputPort:
        """``theta_m`` (rad, at the link side), size n."""
        return self._output.get_output_port(1)

    def gear_torque_output_port(self) -> OutputPort:
        """``tau_g`` (N m), size n: the torque the gear applies to each link."""
        return self._output.get_output_port(0)

    def _parameters(self, root_context: Context) -> np.ndarray:
        return self.system.GetMyContextFromRoot(root_context).get_numeric_parameter(0).value()

    def _write(self, root_context: Context, start: int, values: np.ndarray) -> None:
        vector = self._parameters(root_context).copy()
        vector[start : start + len(values)] = values
        context = self.system.GetMyMutableContextFromRoot(root_context)
        context.get_mutable_numeric_parameter(0).SetFromVector(vector)

    def set_gear(self, root_context: Context, settings: GearConfig) -> None:
        """Set ``k``, ``c``, ``b`` from ``settings`` (checked; a joint with ``k = 0`` is
        rigid, ``models.plant.set_gear`` moves its ``J_m`` back to the MultibodyPlant)."""
        k, c, b = settings.values(self.joints)
        require_motor_inertia(k, self._parameters(root_context)[3 * self.joints :])
        self._write(root_context, 0, np.concatenate([k, c, b]))

    def set_inertia(self, root_context: Context, inertia: tuple[float, ...]) -> None:
        """Set ``J_m`` (kg m^2 at the link side, one per joint; > 0 where the joint is
        compliant)."""
        inertia = np.asarray(inertia, dtype=float)
        require_motor_inertia(self.gear(root_context)[0], inertia)
        self._write(root_context, 3 * self.joints, inertia)

    def gear(self, root_context: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(k, c, b)`` in ``root_context``."""
        p, n = self._parameters(root_context), self.joints
        return p[:n].copy(), p[n : 2 * n].copy(), p[2 * n : 3 * n].copy()

    def inertia(self, root_context: Context) -> tuple[float, ...]:
        """``J_m`` in ``root_context``."""
        return tuple(float(v) for v in self._parameters(root_context)[3 * self.joints :])

    def set_state(self, root_context: Context, theta_m: np.ndarray, omega_m: np.ndarray) -> None:
        """Set the motor state (rad, rad/s at the link side) and zero the work account."""
        context = self.system.GetMyMutableContextFromRoot(root_context)
        context.SetContinuousState(np.concatenate([theta_m, omega_m, [0.0]]))

    def state(self, root_context: Context) -> tuple[np.ndarray, np.ndarray]:
        """``(theta_m, omega_m)`` in ``root_context``, as the block outputs them: a
        compliant joint's motor state, a rigid joint's link ``q``, ``q'``."""
        context = self.system.GetMyContextFromRoot(root_context)
        x, n = context.get_continuous_state_vector().CopyToVector(), self.joints
        link = self._input.get_input_port(1).Eval(self._input.GetMyContextFromRoot(root_context))
        rigid = ~(self.gear(root_context)[0] > 0.0)
        theta, omega = x[:n], x[n : 2 * n]
        return np.where(rigid, link[:n], theta), np.where(rigid, link[n:], omega)

    def motor_work(self, root_context: Context) -> float:
        """``int sum_j tau_mj omega_mj dt`` (J) so far."""
        x = self.system.GetMyContextFromRoot(root_context).get_continuous_state_vector()
        return float(x[x.size() - 1])


def require_motor_inertia(stiffness: np.ndarray, inertia: np.ndarray) -> None:
    """A compliant joint (``k > 0``) needs its own motor inertia ``J_m > 0``."""
    for j, (k, value) in enumerate(zip(stiffness, inertia, strict=True)):
        if k > 0.0 and not value > 0.0:
            raise ValueError(
                f"plant.parameters.rotor_inertia[{j}] (or the URDF's) = {shown(float(value))} "
                f"with plant.gear_stiffness[{j}] = {shown(float(k))} (a compliant joint); > 0 "
                "is required (the motor's own inertia J_m)"
            )


def dead_zone(d, b):
    """``dz(d)`` of half-width ``b`` (module docstring), symbolic."""
    return if_then_else(d > b, d - b, if_then_else(d < -b, d + b, 0.0))


def _gear_system(joints: int) -> SymbolicVectorSystem:
    """The gear and motor inertia of ``joints`` joints (module docstring)."""
    idx = range(1, joints + 1)
    theta = [Variable(f"theta_m{j}") for j in idx]
    omega = [Variable(f"omega_m{j}") for j in idx]
    work = Variable("motor_work")
    tau_m = [Variable(f"tau_m{j}") for j in idx]
    q = [Variable(f"q{j}") for j in idx]
    v = [Variable(f"v{j}") for j in idx]
    k = [Variable(f"k{j}") for j in idx]
    c = [Variable(f"c{j}") for j in idx]
    b = [Variable(f"b{j}") for j in idx]
    inertia = [Variable(f"J_m{j}") for j in idx]
    n = range(joints)
    compliant = [k[j] > 0.0 for j in n]
    spring = [k[j] * dead_zone(theta[j] - q[j], b[j]) + c[j] * (omega[j] - v[j]) for j in n]
    tau_g = [if_then_else(compliant[j], spring[j], tau_m[j]) for j in n]
    motor_speed = [if_then_else(compliant[j], omega[j], v[j]) for j in n]
    system = SymbolicVectorSystem(
        state=[*theta, *omega, work],
        input=[*tau_m, *q, *v],
        parameter=[*k, *c, *b, *inertia],
        dynamics=[
            *[if_then_else(compliant[j], omega[j], 0.0) for j in n],
            *[if_then_else(compliant[j], (tau_m[j] - spring[j]) / inertia[j], 0.0) for j in n],
            total([tau_m[j] * motor_speed[j] for j in n]),
        ],
        output=[*tau_g, *[if_then_else(compliant[j], theta[j], q[j]) for j in n], *motor_speed],
    )
    system.set_name("gear")
    return system


def add_gear(
    builder: DiagramBuilder, joints: int, plant_state: OutputPort, actuation: InputPort
) -> GearBlock:
    """Add the gear between the motor and the plant's ``actuation`` port (which then
    receives ``tau_g``); the motor block drives ``motor_torque_input_port()``."""
    return GearBlock(builder, joints, plant_state, actuation)
