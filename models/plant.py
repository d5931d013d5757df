"""The true plant: a serial URDF arm (the paper's two-link arm by default) in a
MultibodyPlant, its motor stage and its friction.

Signal path (all C++ systems, no Python in the integrator's inner loop)::

    voltage u (V) --> [motor: tau = kappa * u] --> plant actuation (N m)
    plant velocity v --> [friction law, default -f_c tanh(v / v_s)] --> plant applied
                                                                     generalized force

The friction law is ``PlantConfig.friction`` (``models.friction``: ``!TanhCoulomb``,
the default, ``!Stribeck``, ``!LuGre``); the Coulomb levels ``f_c`` enter every law from
``ArmParameters.coulomb``, ``v_s`` from ``friction_velocity``, the law's own
parameters from its settings (``set_friction_law``), all per Context.

The motor and friction blocks are ``models.drive``'s: ``SymbolicVectorSystem``s by
default, each with one state that integrates energy (work delivered by the motors,
energy dissipated by friction, which the energy-balance tests read), or, with
``PlantConfig.motor_friction_blocks = "perceptron"``, faster ``MultilayerPerceptron``s
without energy states.

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

The arm's ``n`` joints come from the URDF (``models.urdf_check.check_serial_urdf``:
one chain of revolute joints from the base, each with its motor stage); every
per-joint vector is in that base-to-tip order. A link named ``payload`` welded to
the last link carries the tip payload (an arm without one takes no payload).

Motor constants and Coulomb levels are numeric parameters of those systems,
so they, like the MultibodyPlant's masses, centres of mass, inertias, damping
and rotor inertias, can change per Context without rebuilding
(``apply_parameters``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np
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
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.systems.primitives import Demultiplexer

from posfb.models.description import Description, PreparedUrdf, prepare_urdf
from posfb.models.drive import (
    MotorFriction,
    add_motor_friction,
    require_blocks,
    require_blocks_for,
)
from posfb.models.friction import DEFAULT_LAW, check_law
from posfb.models.gear import GearBlock, GearConfig, add_gear
from posfb.models.package_data import package_path
from posfb.models.serial_model import SerialArmModel
from posfb.models.urdf_check import SerialChain, add_urdf_models, check_serial_urdf, weld_base
from posfb.models.validation import require_finite, require_nonnegative, require_positive

#: The arm shipped with posfb (the paper's two-link arm).
DEFAULT_URDF = package_path("posfb.urdf", "two_link_arm.urdf")

#: The link that carries the tip payload, where an arm has one.
PAYLOAD_BODY = "payload"


@dataclass(frozen=True)
class PlantConfig:
    """How the true plant is built.

    ``time_step = 0`` gives a continuous plant (the default: Coulomb friction
    is then evaluated at every integrator stage); ``time_step > 0`` gives a
    discrete one (keep it <= 1 ms where friction matters, docs/drake-notes.md).
    ``motor_friction_blocks`` picks the C++ blocks of the motor stage and the Coulomb
    friction (``models.drive``): ``"symbolic"`` (the default; energy states, NaN
    parameter defaults) or ``"perceptron"`` (12-24 % faster runs, no energy states,
    results that differ by round-off and its growth; the default friction law only).
    ``friction`` is the friction law's settings (``models.friction``; default
    ``!TanhCoulomb``): its kind is part of the diagram, its parameters are set per
    Context (``set_friction_law``), these by default. ``gear`` is the gear's compliance
    and backlash (``models.gear``; default rigid: no block): whether the block exists
    (any joint compliant) is part of the diagram, its values (which joints are
    compliant included) are set per Context (``set_gear``), these by default.
    """

    urdf: str = str(DEFAULT_URDF)
    time_step: float = 0.0
    friction_velocity: float = 1e-2
    motor_friction_blocks: str = "symbolic"
    friction: object = dataclasses.field(default_factory=DEFAULT_LAW, hash=False)
    gear: GearConfig = dataclasses.field(default_factory=GearConfig)
    description: Description = dataclasses.field(default_factory=Description)

    def __post_init__(self) -> None:
        require_nonnegative("time_step", self.time_step)
        require_positive("friction_velocity", self.friction_velocity)
        require_blocks(self.motor_friction_blocks)
        check_law(self.friction)
        require_blocks_for(self.motor_friction_blocks, self.friction)
        if not isinstance(self.gear, GearConfig):
            raise ValueError(f"gear = {self.gear!r} is not a GearConfig")
        if not isinstance(self.description, Description):
            raise ValueError(f"description = {self.description!r} is not a Description")


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
    """The physical parameters that can change per Context (SI units), one entry per
    joint in base-to-tip order (``n`` from the URDF).

    ``link_*`` describe the link each joint moves (the joint's child link):
    ``link_com`` is the distance of its centre of mass from the joint frame along
    the URDF's direction to it, ``link_inertia`` its central moment of inertia about
    the joint axis (the URDF's central inertia is scaled to it, keeping its shape;
    a planar arm's out-of-plane moments do not enter its dynamics, so the paper's
    runs are unchanged by them). ``rotor_inertia`` is the reflected
    value (rotor inertia x gear ratio^2) seen at the joint. ``payload_mass`` is a
    point mass at the ``payload`` link, at most ``MAX_PAYLOAD_MASS``.
    """

    link_mass: tuple[float, ...]
    link_com: tuple[float, ...]
    link_inertia: tuple[float, ...]
    rotor_inertia: tuple[float, ...]
    damping: tuple[float, ...]
    coulomb: tuple[float, ...]
    motor_constant: tuple[float, ...]
    payload_mass: float = 0.0

    def __post_init__(self) -> None:
        joints = len(self.link_mass)
        for field in fields(self):
            value = getattr(self, field.name)
            if field.name == "payload_mass":
                require_payload_mass(value)
                continue
            if len(value) != joints or joints == 0:
                raise ValueError(
                    f"{field.name} = {value!r}; {max(joints, 1)} values (one per joint, as "
                    "link_mass) required"
                )
            for j, entry in enumerate(value):
                name = f"{field.name}[{j}]"
                if field.name in ("link_mass", "motor_constant"):
                    require_positive(name, entry)
                else:
                    require_nonnegative(name, entry)

    @property
    def joints(self) -> int:
        return len(self.link_mass)

    def with_payload(self, mass: float) -> ArmParameters:
        return replace(self, payload_mass=mass)


#: The per-joint fields of ``ArmParameters`` (one value per joint), in declaration
#: order: what a scenario overrides and a Monte-Carlo study draws (its stream order).
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
class LinkShape:
    """How ``ArmParameters``' ``link_com`` and ``link_inertia`` map to a link's spatial
    inertia: the unit direction to its centre of mass and its central inertia divided
    by the moment about the joint axis (both in the link frame, from the URDF)."""

    com_direction: np.ndarray
    inertia_shape: np.ndarray
    axis: np.ndarray


@dataclass(frozen=True)
class ArmLayout:
    """What the URDF names: the ``joints`` (base to tip), the link each moves, their
    actuators, the payload body (``None`` where the arm has none), each link's
    ``LinkShape``, the distances between successive joints (``link_lengths``,
    ``n - 1``) and from the last joint to the payload (``tip_length``, 0 without one)."""

    joints: tuple[str, ...]
    links: tuple[str, ...]
    actuators: tuple[str, ...]
    payload: str | None
    shapes: tuple[LinkShape, ...]
    link_lengths: tuple[float, ...]
    tip_length: float

    @property
    def size(self) -> int:
        """``n``: the number of joints."""
        return len(self.joints)


@dataclass(frozen=True)
class Arm:
    """Handles to the systems that make up the true plant inside a diagram, its
    ``layout`` and the URDF's parameters."""

    plant: MultibodyPlant
    motor_friction: MotorFriction
    state_split: Demultiplexer
    config: PlantConfig
    layout: ArmLayout
    default_parameters: ArmParameters
    gear: GearBlock | None = None

    @property
    def size(self) -> int:
        """``n``: the number of joints."""
        return self.layout.size

    def voltage_input_port(self):
        """Motor voltages ``u`` (V), size n."""
        return self.motor_friction.voltage_input_port()

    def position_output_port(self, location: str = "link"):
        """True joint positions ``q`` (rad), size n; with ``location = "motor"`` the
        motor angles ``theta_m`` (rad, at the link side) of a compliant gear
        (``models.gear``)."""
        if location == "link":
            return self.state_split.get_output_port(0)
        if location == "motor" and self.gear is not None:
            return self.gear.motor_position_output_port()
        raise ValueError(
            f"location = {location!r}; 'link' (or 'motor' with a compliant gear) is required"
        )

    def velocity_output_port(self):
        """True joint velocities (rad/s), size n: for loggers and energy checks
        only, never for a controller."""
        return self.state_split.get_output_port(1)


def _load_urdf(plant: MultibodyPlant, prepared: PreparedUrdf, chain: SerialChain) -> None:
    try:
        add_urdf_models(Parser(plant), prepared)
    except RuntimeError as error:
        first_line = str(error).strip().splitlines()[0]
        raise ValueError(f"URDF {prepared.path} could not be parsed: {first_line}") from None
    weld_base(plant, chain.base)
    for index in plant.GetJointActuatorIndices():
        # Voltage saturation is modelled upstream; no extra clamp on the torque.
        plant.get_joint_actuator(index).set_effort_limit(np.inf)


def _actuators(plant: MultibodyPlant, joints: tuple[str, ...]) -> tuple[str, ...]:
    """The actuator of each joint, in joint order; the plant's actuation input is in
    actuator-index order, which must be the same (checked)."""
    by_joint = {}
    for index in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(index)
        by_joint[actuator.joint().name()] = (int(index), actuator.name())
    order = [by_joint[j][0] for j in joints]
    if order != sorted(order) or len(by_joint) != len(joints):
        raise ValueError(
            f"the URDF's transmissions are declared in the order {list(by_joint)}; one per "
            f"arm joint, in the chain's order {list(joints)}, is required"
        )
    return tuple(by_joint[j][1] for j in joints)


def _check_state_order(plant: MultibodyPlant, joints: tuple[str, ...]) -> None:
    """The plant's state must be ``[q_1..q_n, v_1..v_n]`` in chain order (true for a
    serial chain of revolute joints; checked, since the encoder and friction read it)."""
    for j, name in enumerate(joints):
        joint = plant.GetJointByName(name)
        if joint.position_start() != j or joint.velocity_start() != j:
            raise ValueError(
                f"joint {name!r} is state entry {joint.position_start()} of the plant; "
                f"the chain's order ({j}) is required"
            )
    if plant.num_positions() != len(joints):
        raise ValueError(
            f"the plant has {plant.num_positions()} positions; one per arm joint "
            f"({len(joints)}) is required"
        )


def _payload(plant: MultibodyPlant, last_link: str) -> str | None:
    """The payload body, if the URDF has one; it must be welded to the last link (directly
    or through bodies welded to it)."""
    if not plant.HasBodyNamed(PAYLOAD_BODY):
        return None
    body = plant.GetBodyByName(PAYLOAD_BODY)
    carrier = body
    while carrier.index() != plant.world_body().index():
        joint = next(
            plant.get_joint(index)
            for index in plant.GetJointIndices()
            if plant.get_joint(index).child_body().index() == carrier.index()
        )
        if joint.num_velocities() != 0:
            break
        carrier = joint.parent_body()
        if carrier.name() == last_link:
            return PAYLOAD_BODY
    raise ValueError(
        f"link {PAYLOAD_BODY!r} moves with {carrier.name()!r}; a link welded to the last "
        f"link {last_link!r} is required"
    )


def add_arm(builder: DiagramBuilder, config: PlantConfig | None = None) -> Arm:
    """Add the URDF arm, its motor stage and Coulomb friction to ``builder``.

    The MultibodyPlant's defaults come from the URDF, but the motor constants
    and Coulomb levels are parameters of ``models.drive``'s blocks whose defaults
    are not the URDF's (NaN for the symbolic blocks, 0 for the perceptrons): every
    Context of the built diagram must get
    ``apply_parameters(arm, context, arm.default_parameters)`` (or sampled
    parameters) before it is simulated, as ``build_arm_diagram`` and
    ``diagrams.runner.ClosedLoopRunner`` do. With the symbolic blocks,
    forgetting it fails loudly ("Detected NaN in applied generalized force input
    port")."""
    config = config or PlantConfig()
    urdf = Path(config.urdf)
    chain = check_serial_urdf(urdf, config.description)
    n = len(chain.joints)
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=config.time_step), builder)
    plant.set_name("arm")
    _load_urdf(plant, prepare_urdf(urdf, config.description), chain)
    plant.Finalize()
    _check_state_order(plant, chain.joints)
    actuators = _actuators(plant, chain.joints)
    links = tuple(plant.GetJointByName(j).child_body().name() for j in chain.joints)
    payload = _payload(plant, links[-1])

    split = builder.AddSystem(Demultiplexer([n, n]))
    split.set_name("state_split")
    builder.Connect(plant.get_state_output_port(), split.get_input_port(0))
    gear = None
    actuation = plant.get_actuation_input_port()
    if config.gear.compliant:
        config.gear.values(n)
        gear = add_gear(builder, n, plant.get_state_output_port(), actuation)
        actuation = gear.motor_torque_input_port()
    motor_friction = add_motor_friction(
        builder,
        config.motor_friction_blocks,
        split.get_output_port(1),
        actuation,
        plant.get_applied_generalized_force_input_port(),
        config.friction,
    )

    context = plant.CreateDefaultContext()
    joints = [plant.GetJointByName(j) for j in chain.joints]
    lengths = tuple(
        float(np.linalg.norm(joint.frame_on_parent().CalcPoseInBodyFrame(context).translation()))
        for joint in joints[1:]
    )
    tip = 0.0
    if payload is not None:
        pose = plant.GetFrameByName(payload).CalcPose(context, plant.GetFrameByName(links[-1]))
        tip = float(np.linalg.norm(pose.translation()))
    layout = ArmLayout(
        joints=chain.joints,
        links=links,
        actuators=actuators,
        payload=payload,
        shapes=tuple(_link_shape(plant, context, joint) for joint in joints),
        link_lengths=lengths,
        tip_length=tip,
    )
    return Arm(
        plant=plant,
        motor_friction=motor_friction,
        state_split=split,
        config=config,
        layout=layout,
        default_parameters=_read(plant, layout, context, chain.coulomb, chain.motor_constant),
        gear=gear,
    )


def _central_inertia(body: RigidBody, context: Context) -> np.ndarray:
    """The body's rotational inertia about its centre of mass, in its frame."""
    spatial = body.CalcSpatialInertiaInBodyFrame(context)
    return spatial.Shift(spatial.get_com()).CalcRotationalInertia().CopyToFullMatrix3()


def _joint_axis(joint: RevoluteJoint) -> np.ndarray:
    """The joint's axis in its child body's frame."""
    pose = joint.frame_on_child().GetFixedPoseInBodyFrame()
    return pose.rotation().matrix() @ joint.revolute_axis()


def _link_shape(plant: MultibodyPlant, context: Context, joint: RevoluteJoint) -> LinkShape:
    body = joint.child_body()
    com = body.CalcCenterOfMassInBodyFrame(context)
    distance = float(np.linalg.norm(com))
    axis = _joint_axis(joint)
    inertia = _central_inertia(body, context)
    moment = float(axis @ inertia @ axis)
    return LinkShape(
        com_direction=com / distance if distance > 0.0 else np.zeros(3),
        inertia_shape=inertia / moment if moment > 0.0 else np.zeros((3, 3)),
        axis=axis,
    )


def _read(
    plant: MultibodyPlant,
    layout: ArmLayout,
    context: Context,
    coulomb: tuple[float, ...],
    motor: tuple[float, ...],
) -> ArmParameters:
    """The parameters in the plant ``context``, with the given Coulomb levels and motor
    constants (they live in the symbolic systems)."""
    bodies = [plant.GetBodyByName(name) for name in layout.links]
    actuators = [plant.GetJointActuatorByName(name) for name in layout.actuators]
    payload = layout.payload
    return ArmParameters(
        link_mass=tuple(float(b.get_mass(context)) for b in bodies),
        link_com=tuple(
            float(b.CalcCenterOfMassInBodyFrame(context) @ shape.com_direction)
            for b, shape in zip(bodies, layout.shapes, strict=True)
        ),
        link_inertia=tuple(
            float(shape.axis @ _central_inertia(b, context) @ shape.axis)
            for b, shape in zip(bodies, layout.shapes, strict=True)
        ),
        rotor_inertia=tuple(
            float(a.rotor_inertia(context) * a.gear_ratio(context) ** 2) for a in actuators
        ),
        damping=tuple(float(plant.GetJointByName(j).GetDamping(context)) for j in layout.joints),
        coulomb=tuple(float(c) for c in coulomb),
        motor_constant=tuple(float(k) for k in motor),
        payload_mass=0.0
        if payload is None
        else float(plant.GetBodyByName(payload).get_mass(context)),
    )


def _require_size(arm: Arm, parameters: ArmParameters) -> None:
    if parameters.joints != arm.size:
        raise ValueError(
            f"the parameters have {parameters.joints} joints and the arm "
            f"{arm.config.urdf} {arm.size}; one value per arm joint is required"
        )


def _link_inertia(arm: Arm, j: int, parameters: ArmParameters) -> SpatialInertia:
    """Link ``j``'s spatial inertia for ``parameters`` (``ArmParameters``' docstring)."""
    shape = arm.layout.shapes[j]
    com, moment = parameters.link_com[j], parameters.link_inertia[j]
    for name, value, direction in (
        ("link_com", com, shape.com_direction),
        ("link_inertia", moment, shape.inertia_shape),
    ):
        if value != 0.0 and not np.any(direction):
            raise ValueError(
                f"{name}[{j}] = {value!r}, but link {arm.layout.links[j]!r} has it 0 in the URDF "
                "(no direction to scale); 0 is required"
            )
    inertia = shape.inertia_shape * moment
    return SpatialInertia.MakeFromCentralInertia(
        parameters.link_mass[j],
        shape.com_direction * com,
        RotationalInertia(
            inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]
        ),
    )


def apply_parameters(arm: Arm, root_context: Context, parameters: ArmParameters) -> None:
    """Set every physical parameter of the true plant in ``root_context``
    (a Context of the diagram that holds ``arm``), without rebuilding."""
    _require_size(arm, parameters)
    layout = arm.layout
    if layout.payload is None and parameters.payload_mass != 0.0:
        raise ValueError(
            f"payload_mass = {parameters.payload_mass!r} kg, but {arm.config.urdf} has no "
            f"link named {PAYLOAD_BODY!r} to carry it; 0 is required"
        )
    plant = arm.plant
    plant_context = plant.GetMyMutableContextFromRoot(root_context)
    for j in range(arm.size):
        body: RigidBody = plant.GetBodyByName(layout.links[j])
        body.SetSpatialInertiaInBodyFrame(plant_context, _link_inertia(arm, j, parameters))
        joint: RevoluteJoint = plant.GetJointByName(layout.joints[j])
        joint.SetDamping(plant_context, parameters.damping[j])
        actuator: JointActuator = plant.GetJointActuatorByName(layout.actuators[j])
        if arm.gear is not None:  # set_gear places J_m per joint (models.gear)
            continue
        actuator.SetRotorInertia(
            plant_context, parameters.rotor_inertia[j] / actuator.default_gear_ratio() ** 2
        )
    if layout.payload is not None:
        payload: RigidBody = plant.GetBodyByName(layout.payload)
        payload.SetSpatialInertiaInBodyFrame(
            plant_context,
            SpatialInertia(parameters.payload_mass, np.zeros(3), UnitInertia(0.0, 0.0, 0.0)),
        )
    arm.motor_friction.set_motor_constants(root_context, parameters.motor_constant)
    set_coulomb(arm, root_context, parameters.coulomb)
    set_friction_law(arm, root_context, arm.config.friction)
    if arm.gear is not None:
        arm.gear.set_inertia(root_context, parameters.rotor_inertia)
        set_gear(arm, root_context, arm.config.gear)


def set_gear(arm: Arm, root_context: Context, settings: GearConfig) -> None:
    """Set the gear's stiffness, damping and backlash (``models.gear``) from
    ``settings`` (a Monte-Carlo sample's drawn values) and place each joint's motor
    inertia ``J_m``: in the gear block where the joint is compliant (the actuator's rotor
    inertia in the MultibodyPlant is then 0), on the actuator where it is rigid. A rigid
    arm (built without the gear block) takes only a rigid ``settings``."""
    if arm.gear is None:
        if settings.compliant:
            raise ValueError(
                f"gear_stiffness = {list(settings.gear_stiffness)}, but the diagram was built "
                "with a rigid gear; a new diagram is required for a compliant one"
            )
        settings.values(arm.size)
        return
    arm.gear.set_gear(root_context, settings)
    stiffness = arm.gear.gear(root_context)[0]
    plant_context = arm.plant.GetMyMutableContextFromRoot(root_context)
    for j, (name, inertia) in enumerate(
        zip(arm.layout.actuators, arm.gear.inertia(root_context), strict=True)
    ):
        actuator = arm.plant.GetJointActuatorByName(name)
        rotor = 0.0 if stiffness[j] > 0.0 else inertia / actuator.default_gear_ratio() ** 2
        actuator.SetRotorInertia(plant_context, rotor)


def set_motor_state(arm: Arm, root_context: Context) -> None:
    """With a compliant gear, start each motor where its link is (``theta_m = q``,
    ``omega_m = q'``: no deflection; an arm under gravity would start with the gear
    unloaded and settle). Nothing to do for a rigid gear."""
    if arm.gear is None:
        return
    plant = arm.plant
    plant_context = plant.GetMyContextFromRoot(root_context)
    arm.gear.set_state(
        root_context, plant.GetPositions(plant_context), plant.GetVelocities(plant_context)
    )


def set_friction_law(arm: Arm, root_context: Context, settings: object) -> None:
    """Set the friction law's own parameters (``models.friction``) from its ``settings``
    (the law the arm was built with; a Monte-Carlo sample's drawn values)."""
    arm.motor_friction.set_friction_law(root_context, settings)


def set_coulomb(
    arm: Arm,
    root_context: Context,
    levels: tuple[float, ...],
    friction_velocity: float | None = None,
) -> None:
    """Set the Coulomb levels (N m, one per joint) and, optionally, the smoothing
    velocity."""
    if len(levels) != arm.size:
        raise ValueError(f"coulomb = {levels!r}; {arm.size} levels (one per joint) required")
    for j, level in enumerate(levels):
        require_nonnegative(f"coulomb[{j}]", level)
    v_s = arm.config.friction_velocity if friction_velocity is None else friction_velocity
    require_positive("friction_velocity", v_s)
    arm.motor_friction.set_coulomb(root_context, levels, v_s)


def read_parameters(arm: Arm, root_context: Context) -> ArmParameters:
    """The physical parameters currently in ``root_context``."""
    blocks = arm.motor_friction
    parameters = _read(
        arm.plant,
        arm.layout,
        arm.plant.GetMyContextFromRoot(root_context),
        blocks.coulomb_levels(root_context),
        blocks.motor_constants(root_context),
    )
    if arm.gear is not None:
        parameters = replace(parameters, rotor_inertia=arm.gear.inertia(root_context))
    return parameters


def arm_model(arm: Arm, root_context: Context) -> SerialArmModel:
    """The Eq. 2 model (``models.serial_model``) of the arm with the parameters in
    ``root_context``: a sampled plant as the design's terms see it."""
    parameters = read_parameters(arm, root_context)
    plant_context = arm.plant.CreateDefaultContext()
    plant_context.SetTimeStateAndParametersFrom(arm.plant.GetMyContextFromRoot(root_context))
    if arm.gear is not None:  # the rigid-gear equivalent: J_m back on the joint
        for name, inertia in zip(arm.layout.actuators, parameters.rotor_inertia, strict=True):
            actuator = arm.plant.GetJointActuatorByName(name)
            actuator.SetRotorInertia(plant_context, inertia / actuator.default_gear_ratio() ** 2)
    return SerialArmModel.of_plant(
        arm.plant, plant_context, arm.layout.joints, parameters.motor_constant, parameters.coulomb
    )


def energy_accounts(arm: Arm, root_context: Context) -> tuple[float, float]:
    """(work delivered by the motors, work the joints did against friction), J. The
    second is the energy friction dissipated; for LuGre it includes the energy still
    stored in the bristles (``models.friction.lugre``). With a compliant gear the
    motors' work is ``sum tau_m omega_m`` (``models.gear``)."""
    work, loss = arm.motor_friction.energy(root_context)
    if arm.gear is not None:
        work = arm.gear.motor_work(root_context)
    return work, loss


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
