"""The true plant: the URDF two-link arm in a MultibodyPlant, its motor stage
and its Coulomb friction.

Signal path (all C++ systems, no Python in the integrator's inner loop)::

    voltage u (V) --> [motor: tau = kappa * u] --> plant actuation (N m)
    plant velocity v --> [coulomb: -f_c tanh(v / v_s)] --> plant applied generalized force

The motor and friction blocks each carry one state that integrates energy
(work delivered by the motors, energy dissipated by friction), which the
energy-balance tests and reports read.

Coulomb friction ``f_c sgn(v)`` is regularised as ``f_c tanh(v / v_s)`` with
the smoothing velocity ``v_s`` (``PlantConfig.friction_velocity``, default
0.01 rad/s = 0.57 deg/s: 1 % of the trajectory's typical joint speed, so the
friction torque reaches 76 % of ``f_c`` at 0.01 rad/s and 99.9 % at 0.04
rad/s). Smaller values make the friction law stiffer: a 20 s open-loop run
with Drake's default RK3 (accuracy 1e-2) takes 8 k steps at 0.01 rad/s but
20 k at 1e-3 rad/s (3.5x the wall time) for a final-state difference below
1e-3 rad. A discrete plant evaluates the friction explicitly once per step,
which is stable only for ``time_step < 2 M_jj v_s / f_c`` (~3e-4 s for
joint 2 at the default); use the continuous plant where friction matters.

Motor constants and Coulomb levels are numeric parameters of those systems,
so they, like the MultibodyPlant's masses, centres of mass, inertias, damping
and rotor inertias, can change per Context without rebuilding
(``apply_parameters``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import (
    JointActuator,
    RevoluteJoint,
    RigidBody,
    RotationalInertia,
    SpatialInertia,
    UnitInertia,
)
from pydrake.symbolic import Variable, tanh
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.systems.primitives import Demultiplexer, Multiplexer, SymbolicVectorSystem

from posfb.models.urdf_check import POSFB_NS, check_arm_urdf
from posfb.models.validation import require_finite, require_nonnegative, require_positive

#: The arm shipped with posfb.
DEFAULT_URDF = Path(__file__).resolve().parent.parent / "urdf" / "two_link_arm.urdf"

JOINTS = ("joint1", "joint2")
LINKS = ("link1", "link2")
PAYLOAD_BODY = "payload"
ACTUATORS = ("motor1", "motor2")


@dataclass(frozen=True)
class PlantConfig:
    """How the true plant is built.

    ``time_step = 0`` gives a continuous plant (the default: Coulomb friction
    is then evaluated at every integrator stage); ``time_step > 0`` gives a
    discrete one (keep it <= 1 ms where friction matters, docs/drake-notes.md).
    """

    urdf: str = str(DEFAULT_URDF)
    time_step: float = 0.0
    friction_velocity: float = 1e-2

    def __post_init__(self) -> None:
        require_nonnegative("time_step", self.time_step)
        require_positive("friction_velocity", self.friction_velocity)


#: The heaviest tip payload accepted (kg). An absolute cap, not a multiple of
#: the link masses, so that every place a payload enters (``posfb identify
#: --payload``, a scenario, a Monte-Carlo study) can check it before an arm is
#: built and whatever link masses a sample draws. 100 kg is 15 times the
#: shipped arm's moving mass (6.41 kg) and 350 times the paper's 0.288 kg
#: payload: anything heavier is a unit slip or an overflow, not a payload
#: change the two-link model of Sec. 4.1 is meant for.
MAX_PAYLOAD_MASS = 100.0


def require_payload_mass(value: float) -> float:
    """Return ``value`` if it is an accepted tip payload: 0..``MAX_PAYLOAD_MASS`` kg."""
    mass = require_finite("payload_mass", value)
    if not 0.0 <= mass <= MAX_PAYLOAD_MASS:
        raise ValueError(
            f"payload_mass = {value!r} kg; 0 <= payload_mass <= {MAX_PAYLOAD_MASS:g} kg "
            "is allowed (a tip payload)"
        )
    return mass


@dataclass(frozen=True)
class ArmParameters:
    """The physical parameters that can change per Context (SI units).

    Link inertias are about the centre of mass and the joint axis; centres of
    mass lie on the link's x axis at ``com`` from the joint. ``rotor_inertia``
    is the reflected value (rotor inertia x gear ratio^2) seen at the joint.
    ``payload_mass`` is a point mass at the link-2 tip, at most
    ``MAX_PAYLOAD_MASS``.
    """

    link_mass: tuple[float, float]
    link_com: tuple[float, float]
    link_inertia: tuple[float, float]
    rotor_inertia: tuple[float, float]
    damping: tuple[float, float]
    coulomb: tuple[float, float]
    motor_constant: tuple[float, float]
    payload_mass: float = 0.0

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            if field.name == "payload_mass":
                require_payload_mass(value)
                continue
            if len(value) != 2:
                raise ValueError(f"{field.name} = {value!r}; two values (one per joint) required")
            for j, entry in enumerate(value):
                name = f"{field.name}[{j}]"
                if field.name in ("link_mass", "motor_constant"):
                    require_positive(name, entry)
                else:
                    require_nonnegative(name, entry)

    def with_payload(self, mass: float) -> ArmParameters:
        return replace(self, payload_mass=mass)


#: The per-joint fields of ``ArmParameters`` (two values each), in declaration order:
#: what a scenario overrides and a Monte-Carlo study draws (its stream order).
JOINT_PARAMETERS = tuple(f.name for f in fields(ArmParameters) if f.name != "payload_mass")

#: The SI unit of each ``ArmParameters`` field, as a column-name suffix (exports).
PARAMETER_UNITS = {
    "link_mass": "kg",
    "link_com": "m",
    "link_inertia": "kg_m2",
    "rotor_inertia": "kg_m2",
    "damping": "N_m_s_per_rad",
    "coulomb": "N_m",
    "motor_constant": "N_m_per_V",
    "payload_mass": "kg",
}


@dataclass(frozen=True)
class Arm:
    """Handles to the systems that make up the true plant inside a diagram."""

    plant: MultibodyPlant
    motor: SymbolicVectorSystem
    motor_input: Multiplexer
    coulomb: SymbolicVectorSystem
    state_split: Demultiplexer
    config: PlantConfig
    link1_length: float
    link2_length: float
    default_parameters: ArmParameters

    def voltage_input_port(self):
        """Motor voltages ``u`` (V), size 2."""
        return self.motor_input.get_input_port(0)

    def position_output_port(self):
        """True joint positions ``q`` (rad), size 2."""
        return self.state_split.get_output_port(0)

    def velocity_output_port(self):
        """True joint velocities (rad/s), size 2: for loggers and energy checks
        only, never for a controller."""
        return self.state_split.get_output_port(1)


def _read_posfb_extras(urdf: Path) -> tuple[tuple[float, float], tuple[float, float]]:
    """Coulomb levels and motor constants from posfb's own URDF elements."""
    root = ET.parse(urdf).getroot()
    coulomb = {}
    for joint in root.iter("joint"):
        element = joint.find(f"{{{POSFB_NS}}}coulomb_friction")
        if element is not None:
            coulomb[joint.get("name")] = float(element.get("value"))
    motor = {}
    for actuator in root.iter("actuator"):
        element = actuator.find(f"{{{POSFB_NS}}}motor_constant")
        if element is not None:
            motor[actuator.get("name")] = float(element.get("value"))
    missing = [f"posfb:coulomb_friction in joint {j}" for j in JOINTS if j not in coulomb]
    missing += [f"posfb:motor_constant in actuator {a}" for a in ACTUATORS if a not in motor]
    if missing:
        raise ValueError(f"URDF {urdf} lacks {', '.join(missing)}")
    return (coulomb[JOINTS[0]], coulomb[JOINTS[1]]), (motor[ACTUATORS[0]], motor[ACTUATORS[1]])


def _load_urdf(plant: MultibodyPlant, urdf: Path) -> None:
    try:
        Parser(plant).AddModels(str(urdf))
    except RuntimeError as error:
        first_line = str(error).strip().splitlines()[0]
        raise ValueError(f"URDF {urdf} could not be parsed: {first_line}") from None
    for name in (*LINKS, PAYLOAD_BODY, "base"):
        if not plant.HasBodyNamed(name):
            raise ValueError(f"URDF {urdf} has no link named {name!r}")
    for name in JOINTS:
        if not plant.HasJointNamed(name):
            raise ValueError(f"URDF {urdf} has no joint named {name!r}")
    for name in ACTUATORS:
        if not plant.HasJointActuatorNamed(name):
            raise ValueError(f"URDF {urdf} has no actuator named {name!r}")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base"), RigidTransform())
    for index in plant.GetJointActuatorIndices():
        # Voltage saturation is modelled upstream; no extra clamp on the torque.
        plant.get_joint_actuator(index).set_effort_limit(np.inf)


def _make_motor() -> SymbolicVectorSystem:
    """``tau_j = kappa_j u_j`` with the motor constants as numeric parameters.

    Input ``[u1, u2, v1, v2]``; its state integrates the mechanical work the
    motors deliver, ``W = sum_j tau_j v_j`` (J), for energy bookkeeping. (A
    stateless SymbolicVectorSystem cannot sit in a continuous diagram in
    Drake 1.51: its DoCalcTimeDerivatives asserts.)"""
    u = [Variable(f"u{j + 1}") for j in range(2)]
    v = [Variable(f"v{j + 1}") for j in range(2)]
    kappa = [Variable(f"kappa{j + 1}") for j in range(2)]
    work = Variable("motor_work")
    torque = [kappa[j] * u[j] for j in range(2)]
    system = SymbolicVectorSystem(
        state=[work],
        input=[*u, *v],
        parameter=kappa,
        dynamics=[torque[0] * v[0] + torque[1] * v[1]],
        output=torque,
    )
    system.set_name("motor")
    return system


def _make_coulomb() -> SymbolicVectorSystem:
    """``-f_c tanh(v / v_s)`` per joint; parameters ``[f_c1, f_c2, v_s]``.

    Input: joint velocities. Its state integrates the energy friction
    dissipates (J, never decreasing)."""
    v = [Variable(f"v{j + 1}") for j in range(2)]
    levels = [Variable(f"fc{j + 1}") for j in range(2)]
    v_s = Variable("v_s")
    loss = Variable("friction_loss")
    force = [-levels[j] * tanh(v[j] / v_s) for j in range(2)]
    system = SymbolicVectorSystem(
        state=[loss],
        input=v,
        parameter=[*levels, v_s],
        dynamics=[-(force[0] * v[0] + force[1] * v[1])],
        output=force,
    )
    system.set_name("coulomb_friction")
    return system


def add_arm(builder: DiagramBuilder, config: PlantConfig | None = None) -> Arm:
    """Add the URDF arm, its motor stage and Coulomb friction to ``builder``.

    The MultibodyPlant's defaults come from the URDF, but the motor constants
    and Coulomb levels are numeric parameters of symbolic systems whose
    defaults are NaN: every Context of the built diagram must get
    ``apply_parameters(arm, context, arm.default_parameters)`` (or sampled
    parameters) before it is simulated, as ``build_arm_diagram`` and
    ``diagrams.closed_loop.ClosedLoopRunner`` do. Forgetting it fails loudly
    ("Detected NaN in applied generalized force input port")."""
    config = config or PlantConfig()
    urdf = Path(config.urdf)
    check_arm_urdf(urdf, payload_link=PAYLOAD_BODY)
    coulomb_levels, motor_constant = _read_posfb_extras(urdf)
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=config.time_step), builder)
    plant.set_name("arm")
    _load_urdf(plant, urdf)
    plant.Finalize()

    motor = builder.AddSystem(_make_motor())
    motor_input = builder.AddSystem(Multiplexer([2, 2]))
    motor_input.set_name("motor_input")
    coulomb = builder.AddSystem(_make_coulomb())
    split = builder.AddSystem(Demultiplexer([2, 2]))
    split.set_name("state_split")
    builder.Connect(plant.get_state_output_port(), split.get_input_port(0))
    builder.Connect(motor_input.get_output_port(0), motor.get_input_port(0))
    builder.Connect(split.get_output_port(1), motor_input.get_input_port(1))
    builder.Connect(motor.get_output_port(0), plant.get_actuation_input_port())
    builder.Connect(split.get_output_port(1), coulomb.get_input_port(0))
    builder.Connect(coulomb.get_output_port(0), plant.get_applied_generalized_force_input_port())

    context = plant.CreateDefaultContext()
    elbow = plant.GetJointByName(JOINTS[1]).frame_on_parent().CalcPoseInBodyFrame(context)
    tip = plant.GetFrameByName(PAYLOAD_BODY).CalcPose(context, plant.GetFrameByName(LINKS[1]))
    return Arm(
        plant=plant,
        motor=motor,
        motor_input=motor_input,
        coulomb=coulomb,
        state_split=split,
        config=config,
        link1_length=float(np.linalg.norm(elbow.translation())),
        link2_length=float(np.linalg.norm(tip.translation())),
        default_parameters=_read_plant_defaults(plant, context, coulomb_levels, motor_constant),
    )


def _central_inertia_about_axis(body: RigidBody, context: Context) -> float:
    """Moment of inertia about the centre of mass and the joint (y) axis."""
    spatial = body.CalcSpatialInertiaInBodyFrame(context)
    return float(spatial.Shift(spatial.get_com()).CalcRotationalInertia()[1, 1])


def _read_plant_defaults(
    plant: MultibodyPlant,
    context: Context,
    coulomb: tuple[float, float],
    motor: tuple[float, float],
) -> ArmParameters:
    bodies = [plant.GetBodyByName(name) for name in LINKS]
    actuators = [plant.GetJointActuatorByName(name) for name in ACTUATORS]
    return ArmParameters(
        link_mass=tuple(float(b.get_mass(context)) for b in bodies),
        link_com=tuple(float(b.CalcCenterOfMassInBodyFrame(context)[0]) for b in bodies),
        link_inertia=tuple(_central_inertia_about_axis(b, context) for b in bodies),
        rotor_inertia=tuple(
            float(a.default_rotor_inertia() * a.default_gear_ratio() ** 2) for a in actuators
        ),
        damping=tuple(float(plant.GetJointByName(j).default_damping()) for j in JOINTS),
        coulomb=coulomb,
        motor_constant=motor,
        payload_mass=float(plant.GetBodyByName(PAYLOAD_BODY).get_mass(context)),
    )


def apply_parameters(arm: Arm, root_context: Context, parameters: ArmParameters) -> None:
    """Set every physical parameter of the true plant in ``root_context``
    (a Context of the diagram that holds ``arm``), without rebuilding.

    Link inertias are rebuilt as a rod along the link's x axis
    (``I_yy = I_zz = link_inertia``, ``I_xx = 0``); the out-of-plane moment does
    not enter the planar dynamics."""
    plant = arm.plant
    plant_context = plant.GetMyMutableContextFromRoot(root_context)
    for j in range(2):
        body: RigidBody = plant.GetBodyByName(LINKS[j])
        inertia = parameters.link_inertia[j]
        body.SetSpatialInertiaInBodyFrame(
            plant_context,
            SpatialInertia.MakeFromCentralInertia(
                parameters.link_mass[j],
                [parameters.link_com[j], 0.0, 0.0],
                RotationalInertia(0.0, inertia, inertia),
            ),
        )
        joint: RevoluteJoint = plant.GetJointByName(JOINTS[j])
        joint.SetDamping(plant_context, parameters.damping[j])
        actuator: JointActuator = plant.GetJointActuatorByName(ACTUATORS[j])
        actuator.SetRotorInertia(
            plant_context, parameters.rotor_inertia[j] / actuator.default_gear_ratio() ** 2
        )
    payload: RigidBody = plant.GetBodyByName(PAYLOAD_BODY)
    payload.SetSpatialInertiaInBodyFrame(
        plant_context,
        SpatialInertia(parameters.payload_mass, np.zeros(3), UnitInertia(0.0, 0.0, 0.0)),
    )
    arm.motor.GetMyMutableContextFromRoot(root_context).get_mutable_numeric_parameter(
        0
    ).SetFromVector(np.asarray(parameters.motor_constant, dtype=float))
    set_coulomb(arm, root_context, parameters.coulomb)


def set_coulomb(
    arm: Arm,
    root_context: Context,
    levels: tuple[float, float],
    friction_velocity: float | None = None,
) -> None:
    """Set the Coulomb levels (N m) and, optionally, the smoothing velocity."""
    for j, level in enumerate(levels):
        require_nonnegative(f"coulomb[{j}]", level)
    v_s = arm.config.friction_velocity if friction_velocity is None else friction_velocity
    require_positive("friction_velocity", v_s)
    arm.coulomb.GetMyMutableContextFromRoot(root_context).get_mutable_numeric_parameter(
        0
    ).SetFromVector(np.array([levels[0], levels[1], v_s], dtype=float))


def read_parameters(arm: Arm, root_context: Context) -> ArmParameters:
    """The physical parameters currently in ``root_context``."""
    plant = arm.plant
    plant_context = plant.GetMyContextFromRoot(root_context)
    bodies = [plant.GetBodyByName(name) for name in LINKS]
    actuators = [plant.GetJointActuatorByName(name) for name in ACTUATORS]
    kappa = arm.motor.GetMyContextFromRoot(root_context).get_numeric_parameter(0).value()
    coulomb = arm.coulomb.GetMyContextFromRoot(root_context).get_numeric_parameter(0).value()
    return ArmParameters(
        link_mass=tuple(float(b.get_mass(plant_context)) for b in bodies),
        link_com=tuple(float(b.CalcCenterOfMassInBodyFrame(plant_context)[0]) for b in bodies),
        link_inertia=tuple(_central_inertia_about_axis(b, plant_context) for b in bodies),
        rotor_inertia=tuple(
            float(a.rotor_inertia(plant_context) * a.gear_ratio(plant_context) ** 2)
            for a in actuators
        ),
        damping=tuple(float(plant.GetJointByName(j).GetDamping(plant_context)) for j in JOINTS),
        coulomb=(float(coulomb[0]), float(coulomb[1])),
        motor_constant=(float(kappa[0]), float(kappa[1])),
        payload_mass=float(plant.GetBodyByName(PAYLOAD_BODY).get_mass(plant_context)),
    )


def energy_accounts(arm: Arm, root_context: Context) -> tuple[float, float]:
    """(work delivered by the motors, energy dissipated by Coulomb friction), J."""
    motor = arm.motor.GetMyContextFromRoot(root_context).get_continuous_state_vector()
    friction = arm.coulomb.GetMyContextFromRoot(root_context).get_continuous_state_vector()
    return float(motor[0]), float(friction[0])


def build_arm_diagram(
    config: PlantConfig | None = None, parameters: ArmParameters | None = None
) -> tuple[Diagram, Arm, Context]:
    """The arm alone (voltage input exported as ``voltage``), with a Context
    holding ``parameters`` (default: the URDF's)."""
    builder = DiagramBuilder()
    arm = add_arm(builder, config)
    builder.ExportInput(arm.voltage_input_port(), "voltage")
    builder.ExportOutput(arm.plant.get_state_output_port(), "state")
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    apply_parameters(arm, context, parameters or arm.default_parameters)
    return diagram, arm, context
