"""The scenario: one typed settings tree for everything a closed-loop run depends on.

A scenario file is YAML loaded with Drake's ``yaml_load_typed`` into the
dataclasses below (the way RussTedrake/manipulation's ``Scenario`` wraps
``SimulatorConfig``). A file gives only what differs from the paper: every key
it omits keeps the paper's value, and each default is read from the one place
the code defines it (``ControllerConfig``, ``PlantConfig``, ``diagrams.sections``,
``models.design.settings``, ``LumpedParameters``, ``models.trajectory.PAPER_TRAJECTORY``)::

    plant:          URDF, tip payload, friction smoothing, motor/friction blocks,
                    physical parameter overrides (Monte-Carlo names), friction law:
                    !TanhCoulomb {}, !Stribeck, !LuGre (``models.friction``), gear
                    compliance and backlash (``models.gear``)
    nominal_model:  what the controllers believe: !Table1 {}, !IdentifiedFromUrdf, !Theta,
                    !UrdfModel (any serial arm, computed by Drake), !Identified (from a log)
    trajectory:     !Wave {joints: [...]}, !Waypoints {times, positions}, !CsvFile {path}
    timing:         sample_time, duration, divergence_bound, simulator (SimulatorConfig)
    sensor:         encoder_counts, zero_offset, noise_std, noise_seed, delay_samples,
                    location (link | motor)
    actuator:       voltage_limit, electrical_time_constant, dac_bits, compute_delay
                    (these three: ``diagrams.sections``)
    controller:     one tagged entry with only the chosen controller's settings:
                    !Proposed, !LinLc, !Pid (``models.design.settings``), !PdGravity,
                    !Adrc (their modules), !Python {file | module, class, settings}
    controllers:    named entries that --controller NAME, compare and studies pick

The number of joints ``n`` is the plant URDF's; per-joint lists take one value
(all joints) or ``n``. A controller entry's per-joint settings that it leaves out
(the LQR weights, ``H``, the PID gains) come from the arm: the paper's on two joints,
``scenario init``'s rules on any other (``models.design.settings``; the loaded
scenario holds the values taken, ``diagrams.resolve.with_arm_defaults``); the paper's
two-joint trajectory must be given for any other arm. This module holds the tree
and its text forms (``dump_scenario``, ``apply_setting`` for ``--set``,
``get_setting``); ``diagrams.resolve`` loads a file, validates a scenario into
the frozen ``ClosedLoopConfig`` the runner builds from, and runs it.
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

import copy
import dataclasses
import math
import re
import typing
from dataclasses import dataclass, field, fields
from pathlib import Path

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.sections import Actuator, Sensor, TimingSection
from posfb.diagrams.yaml_schema import check_shape, parse, prepare
from posfb.models.controllers import REGISTRY
from posfb.models.controllers.registry import settings_kind
from posfb.models.description import DRIVE_FIELDS, Description, Drives
from posfb.models.design.loop_context import LoopContext
from posfb.models.design.settings import default_of
from posfb.models.friction import DEFAULT_LAW, LAW_SETTINGS
from posfb.models.gear import GearConfig
from posfb.models.lumped import TABLE1
from posfb.models.plant import (
    DEFAULT_URDF,
    JOINT_PARAMETERS,
    ArmParameters,
    PlantConfig,
)
from posfb.models.trajectory import PAPER_TRAJECTORY
from posfb.models.urdf_check import SerialChain, check_serial_urdf

#: How a scenario names the arms shipped with posfb (``urdf/``): this prefix and the
#: file name.
SHIPPED_PREFIX = "package://posfb/"

#: The paper's arm, as a scenario names it.
SHIPPED_URDF = f"{SHIPPED_PREFIX}{DEFAULT_URDF.name}"


def resolve_path(text: str, base_dir: Path) -> Path:
    """A scenario path: a shipped arm (``package://posfb/NAME``), absolute, or relative
    to ``base_dir``."""
    if text.startswith(SHIPPED_PREFIX):
        return DEFAULT_URDF.parent / text.removeprefix(SHIPPED_PREFIX)
    path = Path(text).expanduser()
    return path if path.is_absolute() else base_dir / path


def _rows(matrix: tuple[tuple[float, ...], ...]) -> list[list[float]]:
    return [list(row) for row in matrix]


# --- plant -------------------------------------------------------------------------


#: Absolute values (SI units, one per joint or one for every joint) that replace the
#: URDF's; omitted parameters keep the URDF's values. One field per per-joint field of
#: ``models.plant.ArmParameters``, made from its list (``JOINT_PARAMETERS``), so that
#: the names are written once.
ParameterOverrides = dataclasses.make_dataclass(
    "ParameterOverrides",
    [(name, list[float] | None, field(default=None)) for name in JOINT_PARAMETERS],
    namespace={
        "__module__": __name__,  # pickled by name (a tuning's processes)
        "__doc__": "Absolute per-joint values that replace the URDF's (SI units).",
    },
)


#: Widest gear backlash (half-width, rad) a scenario may set: 1/64 of a turn (0.098 rad,
#: 5.6 deg). Gear backlash is arc-minutes (1 arcmin = 0.29 mrad; the realism study draws
#: up to 1 mrad), so this is a hundred times any working gear's; a wider dead band leaves
#: the link free over a large part of its motion (``scenario init``'s largest wave
#: amplitude, 2/9 of a quarter turn, is 0.35 rad) and the arm is unactuated there.
MAX_BACKLASH = 2.0 * math.pi / 64.0


def require_backlash(values: object) -> None:
    """Refuse a per-joint ``plant.backlash`` wider than ``MAX_BACKLASH``."""
    for j, value in enumerate(values):
        if value > MAX_BACKLASH:
            raise ValueError(
                f"plant.backlash[{j}] = {value:g} rad; at most {MAX_BACKLASH:.3g} rad (1/64 of "
                "a turn, 100x a working gear's) is allowed: a wider dead band leaves the link "
                "unactuated over its motion"
            )


#: The scenario's friction law: one tagged entry of a registered law
#: (``models.friction``), the default's first.
FrictionSection = typing.Union[LAW_SETTINGS]  # noqa: UP007 - built from the registry


@dataclass
class DriveSettings:
    """Each arm joint's drive, replacing the URDF's ``posfb:`` and Drake elements where
    given (``models.description.Drives``; per-joint lists, one value = every joint):
    ``motor_constant`` (N m/V), ``gear_ratio``, ``rotor_inertia`` (kg m^2 at the motor),
    ``damping`` (N m s/rad), ``coulomb`` (N m). Unlike ``parameters`` (the true arm's
    departures from its description), the drives are the description: the plant and a
    ``!UrdfModel`` of the same file both take them. The voltage limit is
    ``actuator.voltage_limit``."""

    motor_constant: list[float] | None = None
    gear_ratio: list[float] | None = None
    rotor_inertia: list[float] | None = None
    damping: list[float] | None = None
    coulomb: list[float] | None = None


@dataclass
class PlantSettings:
    """The true arm: its URDF, a point payload (kg) at the link-2 tip, the Coulomb
    smoothing velocity (rad/s, ``models.plant``), the implementation of the motor and
    friction blocks (``symbolic`` or ``perceptron``, ``models.drive``), parameter
    overrides and the friction law (``!TanhCoulomb {}``, ``!Stribeck``, ``!LuGre``;
    per-joint lists, one value = every joint; ``models.friction``), and the gear between
    each motor and its link: ``gear_stiffness`` (N m/rad), ``gear_damping`` (N m s/rad),
    ``backlash`` (rad, half-width), at the link side; a joint with stiffness 0 is rigid,
    every stiffness 0 (the default) is today's rigid arm (``models.gear``). What the
    scenario adds to a published URDF (``models.description``): ``package_paths``
    (folders that resolve its ``package://`` meshes, relative to the scenario's folder),
    ``weld`` (joint name: position, rad or m, for joints that are not the arm's: a
    gripper) and ``drives`` (``DriveSettings``)."""

    urdf: str = SHIPPED_URDF
    payload_mass: float = field(default_factory=default_of(ArmParameters, "payload_mass"))
    friction_velocity: float = field(default_factory=default_of(PlantConfig, "friction_velocity"))
    motor_friction_blocks: str = field(
        default_factory=default_of(PlantConfig, "motor_friction_blocks")
    )
    parameters: ParameterOverrides = field(default_factory=ParameterOverrides)
    friction: FrictionSection = field(default_factory=DEFAULT_LAW)
    gear_stiffness: list[float] = field(default_factory=default_of(GearConfig, "gear_stiffness"))
    gear_damping: list[float] = field(default_factory=default_of(GearConfig, "gear_damping"))
    backlash: list[float] = field(default_factory=default_of(GearConfig, "backlash"))
    package_paths: list[str] = field(default_factory=list)
    weld: dict[str, float] = field(default_factory=dict)
    drives: DriveSettings = field(default_factory=DriveSettings)


# --- nominal model -----------------------------------------------------------------


@dataclass
class Table1:
    """The paper's identified model (Table 1) with the shipped arm's ``l1``."""


@dataclass
class IdentifiedFromUrdf:
    """theta identified exactly from a URDF arm with ``payload_mass`` kg at its tip."""

    urdf: str = SHIPPED_URDF
    payload_mass: float = 0.0


@dataclass
class Theta:
    """Explicit theta_1..theta_11 of Sec. 4.1 (SI units per volt) and ``l1`` (m)."""

    theta1: float = TABLE1.theta1
    theta2: float = TABLE1.theta2
    theta3: float = TABLE1.theta3
    theta4: float = TABLE1.theta4
    theta5: float = TABLE1.theta5
    theta6: float = TABLE1.theta6
    theta7: float = TABLE1.theta7
    theta8: float = TABLE1.theta8
    theta9: float = TABLE1.theta9
    theta10: float = TABLE1.theta10
    theta11: float = TABLE1.theta11
    l1: float = TABLE1.l1


@dataclass
class Identified:
    """A model identified from an encoder log (``posfb identify --log ... --out FILE``):
    ``file`` (relative to the scenario's folder) holds theta_1..theta_11 of Sec. 4.1 and
    ``l1`` with their uncertainty (``models.identification.model_file``)."""

    file: str = ""


@dataclass
class UrdfModel:
    """``M*, C*, G*, B*, F*`` computed by Drake from a nominal URDF (any serial arm,
    ``models.serial_model``); ``M0*`` is the mean of ``M*(q)`` over the joint angles."""

    urdf: str = SHIPPED_URDF


NominalModel = Table1 | IdentifiedFromUrdf | Theta | UrdfModel | Identified


# --- trajectory --------------------------------------------------------------------


@dataclass
class WaveJoint:
    """``offset + s(t) (amplitude + wave_amplitude sin(frequency t))`` (rad, rad/s)."""

    offset: float = 0.0
    amplitude: float = 0.0
    wave_amplitude: float = 0.0
    frequency: float = 0.0


def _paper_waves() -> list[WaveJoint]:
    return [WaveJoint(**dataclasses.asdict(wave)) for wave in PAPER_TRAJECTORY]


@dataclass
class Wave:
    """The Sec. 4.2 form, one entry per joint (default: the paper's trajectory)."""

    joints: list[WaveJoint] = field(default_factory=_paper_waves)


@dataclass
class Waypoints:
    """A clamped cubic through ``positions[i]`` (rad, one list per waypoint) at
    ``times[i]`` (s), at rest at both ends."""

    times: list[float] = field(default_factory=list)
    positions: list[list[float]] = field(default_factory=list)


@dataclass
class CsvFile:
    """Sampled positions: a CSV file whose header row names its columns, time ``time``
    or ``time_s`` (s) and ``q1 .. qn`` or ``q1_rad .. qn_rad`` (rad), in any order
    (``diagrams.resolve.read_csv_trajectory``); a not-a-knot cubic spline interpolates
    them. A file that starts after t = 0 is refused unless ``hold_before_start`` says to
    hold its first position at rest until then, and one that ends before
    ``timing.duration`` unless ``hold_after_end`` says to hold its last position at rest
    from its end on."""

    path: str = ""
    hold_before_start: bool = False
    hold_after_end: bool = False


TrajectorySettings = Wave | Waypoints | CsvFile


# --- timing, sensor, actuator -------------------------------------------------------


# --- controller ---------------------------------------------------------------------


@dataclass
class Python:
    """Your own controller (``models.controllers.plugin``, ``posfb.Controller``): the class
    ``class`` (``class_name``) defined in ``file`` (relative to the scenario's folder) or
    in the importable ``module``, built with ``settings`` (a map of numbers, lists and
    strings, passed as keyword arguments); ``label`` names it in legends and tables
    (default: the class name, which is also its kind; an entry of ``controllers``: its
    name there, so that two entries of one class stay apart). ``source`` is the file's text, which
    a Monte-Carlo study stores when it is loaded (``diagrams.resolve.self_contained``), so
    that its workers need no shared folder; when set, it is run instead of the file."""

    #: YAML spellings of fields whose name is a Python keyword.
    ALIASES: typing.ClassVar[dict[str, str]] = {"class": "class_name"}
    #: Keys whose map is kept as JSON text for the plug-in (``yaml_schema.prepare``).
    FREEFORM: typing.ClassVar[tuple[str, ...]] = ("settings",)

    file: str = ""
    module: str = ""
    class_name: str = ""
    settings: str = "{}"
    label: str = ""
    source: str = ""


#: The default controller kind (the paper's, ``ClosedLoopConfig.controller``): its entry
#: is the union's first member, read from an untagged map.
DEFAULT_KIND = default_of(ClosedLoopConfig, "controller")()

#: The scenario's controller: one tagged entry of a registered kind (``!Proposed``,
#: ``!LinLc``, ``!Pid``, ``!PdGravity``, ``!Adrc``; ``models.controllers.registry``) or your
#: own controller (``!Python {file, class}``).
ControllerSection = typing.Union[  # noqa: UP007 - built from the registry
    (
        REGISTRY[DEFAULT_KIND].settings,
        *(s.settings for k, s in REGISTRY.items() if k != DEFAULT_KIND),
        Python,
    )
]


@dataclass
class Scenario:
    """Everything one closed-loop run depends on (module docstring)."""

    plant: PlantSettings = field(default_factory=PlantSettings)
    nominal_model: NominalModel = field(default_factory=Table1)
    trajectory: TrajectorySettings = field(default_factory=Wave)
    timing: TimingSection = field(default_factory=TimingSection)
    sensor: Sensor = field(default_factory=Sensor)
    actuator: Actuator = field(default_factory=Actuator)
    controller: ControllerSection = field(default_factory=REGISTRY[DEFAULT_KIND].settings)
    controllers: dict[str, ControllerSection] = field(default_factory=dict)

    #: What the controller entries' left-out per-joint settings were taken from, set on
    #: a loaded scenario (``diagrams.resolve.with_arm_defaults``; not a key of the file):
    #: ``with_controller`` gives a new entry the same.
    arm_defaults: typing.ClassVar[LoopContext | None] = None


def controller_kind(section: object) -> str:
    """The kind of a scenario's ``controller`` entry (a ``!Python`` entry's: its class)."""
    if isinstance(section, Python):
        return section.class_name
    return settings_kind(section)


def with_controller(scenario: Scenario, kind: str) -> Scenario:
    """A copy of ``scenario`` whose controller is ``kind``: the entry of that name in
    ``controllers`` (a ``!Python`` one without a ``label`` is labelled by that name); the
    scenario's own entry if it is one of that kind; otherwise the
    kind's default entry with every setting the two entries share carried over (Lin+LC
    keeps the paper's controller's LQR weights, ``lambdas`` and ``discretisation``; the
    baselines their ``bandwidth``), the rest from the loaded scenario's arm
    (``Scenario.arm_defaults``)."""
    section = scenario.controller
    result = copy.deepcopy(scenario)
    if kind in scenario.controllers:
        entry = copy.deepcopy(scenario.controllers[kind])
        if isinstance(entry, Python) and not entry.label:
            entry.label = kind  # two entries of one class: each its own name in tables
        result.controller = entry
        return result
    if kind == controller_kind(section):
        return result
    if kind not in REGISTRY:
        own = [controller_kind(section)] if isinstance(section, Python) else []
        names = list(dict.fromkeys([*REGISTRY, *own, *scenario.controllers]))
        classes = {
            name: entry.class_name
            for name, entry in scenario.controllers.items()
            if isinstance(entry, Python) and entry.class_name == kind
        }
        hint = (
            f"; {kind} is the class of the named entr{'y' if len(classes) == 1 else 'ies'} "
            f"{', '.join(classes)}: choose one by its name"
            if classes
            else " (or a !Python {file, class} entry for your own controller)"
        )
        raise ValueError(f"controller.kind = {kind!r}; one of {', '.join(names)} is required{hint}")
    entry = REGISTRY[kind].settings()
    shared = {f.name for f in fields(entry)} & {f.name for f in fields(section)}
    for name in shared:
        setattr(entry, name, copy.deepcopy(getattr(section, name)))
    fill = getattr(entry, "with_arm_defaults", None)
    if scenario.arm_defaults is not None and fill is not None:
        entry = fill(scenario.arm_defaults)
    result.controller = entry
    return result


# --- dump, --set ------------------------------------------------------------------


def _untagged_unions(value: object, path: str = "") -> set[str]:
    """Dotted paths of the union-typed fields whose value is the union's first member
    (Drake writes those without their tag)."""
    found: set[str] = set()
    if not dataclasses.is_dataclass(value):
        return found
    hints = typing.get_type_hints(type(value))
    for entry in fields(value):
        key, member = f"{path}{entry.name}", getattr(value, entry.name)
        options = [a for a in typing.get_args(hints[entry.name]) if dataclasses.is_dataclass(a)]
        if options and type(member) is options[0]:
            found.add(key)
        found |= _untagged_unions(member, f"{key}.")
    return found


def dump_scenario(scenario: Scenario) -> str:
    """The complete scenario as YAML, every default written out. Drake writes the first
    member of a union without its tag; it is added back so that the file names the
    form it holds (``nominal_model: !Table1 {}``, ``trajectory: !Wave``)."""
    tagged = {
        path: f"!{type(get_setting(scenario, path)).__name__}"
        for path in _untagged_unions(scenario)
    }
    lines, keys = [], []
    for line in yaml_dump_typed(scenario).splitlines():
        match = re.match(r"^( *)([A-Za-z_][A-Za-z0-9_]*):", line)
        if match:
            depth = len(match.group(1)) // 2
            keys[depth:] = [match.group(2)]
            tag = tagged.get(".".join(keys))
            if tag:
                line = f"{match.group(0)} {tag}{line[match.end() :]}"
        lines.append(line)
    return "\n".join(lines) + "\n"


def _field_types(schema: type) -> dict[str, object]:
    """Field names and types of a dataclass (not its class variables) or a Drake config."""
    if dataclasses.is_dataclass(schema):
        hints = typing.get_type_hints(schema)
        return {f.name: hints[f.name] for f in fields(schema)}
    return {f.name: f.type for f in schema.__fields__}


def _is_list(kind: object) -> bool:
    """Whether ``kind`` is ``list[...]`` or ``list[...] | None``."""
    if typing.get_origin(kind) is list:
        return True
    return any(typing.get_origin(option) is list for option in typing.get_args(kind))


def _is_section(value: object) -> bool:
    """A dataclass or a Drake config (``SimulatorConfig``): something with sub-keys."""
    return dataclasses.is_dataclass(value) or hasattr(type(value), "__fields__")


#: One part of a dotted key: a name, optionally indexed (``joints[0]``).
_PART = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?$")


def _walk(scenario: Scenario, key: str) -> tuple[object, str, int | None]:
    """The object holding the last part of dotted ``key``, that part's name and index
    (a part after a map of named entries names an entry: ``controllers.pid.Kp``)."""
    parts = key.split(".")
    parent: object = scenario
    depth = 0
    tagged = False  # whether parent is one kind of a tagged union's entries
    while True:
        part = parts[depth]
        where = ".".join(parts[: depth + 1])
        match = _PART.match(part)
        if not match:
            raise ValueError(f"--set {where}: not a key; names and [index] are allowed")
        name, index = match.group(1), match.group(2)
        known = list(_field_types(type(parent)))
        if name not in known:
            entry = (
                f" of {'.'.join(parts[:depth])} (a !{type(parent).__name__} entry: another "
                "kind may have it; set the entry first)"
                if tagged
                else ""
            )
            raise ValueError(
                f"--set {where}: unknown key{entry}; known keys: {', '.join(known) or 'none'}"
            )
        index = None if index is None else int(index)
        value = getattr(parent, name)
        if index is not None and (not isinstance(value, list) or index >= max(len(value), 2)):
            size = len(value) if isinstance(value, list) else 0
            raise ValueError(f"--set {where}: index {index} out of range (a list of {size})")
        if depth == len(parts) - 1:
            return parent, name, index
        tagged = len(typing.get_args(_field_types(type(parent))[name])) > 1
        parent = value if index is None else value[index]
        if isinstance(parent, dict) and depth + 2 < len(parts):
            depth += 1
            if parts[depth] not in parent:
                raise ValueError(
                    f"--set {where}.{parts[depth]}: no such entry; entries: "
                    f"{', '.join(parent) or 'none'} (a new entry is written in the file)"
                )
            parent = parent[parts[depth]]
        if not _is_section(parent):
            raise ValueError(f"--set {key}: {where} has no sub-keys")
        depth += 1


def get_setting(scenario: Scenario, key: str) -> object:
    """The value of dotted ``key`` (``sensor.encoder_counts[1]``: a per-joint list of one
    value reads that value for every joint)."""
    if key == "controller.kind":
        return controller_kind(scenario.controller)
    parent, name, index = _walk(scenario, key)
    value = getattr(parent, name)
    if index is None:
        return value
    return value[index] if index < len(value) else value[0]


def scenario_description(scenario: Scenario, base_dir: Path) -> Description:
    """What the scenario's ``plant`` section adds to the URDFs it names (package folders
    relative to ``base_dir``); a bad value is refused naming its key."""
    plant = scenario.plant
    drives = plant.drives
    try:
        return Description(
            package_paths=tuple(
                str(resolve_path(folder, base_dir)) for folder in plant.package_paths
            ),
            welds=tuple(plant.weld.items()),
            drives=Drives(
                **{
                    name: None if getattr(drives, name) is None else tuple(getattr(drives, name))
                    for name in DRIVE_FIELDS
                },
                label="plant.drives",
            ),
        )
    except ValueError as error:
        message = str(error)
        if message.startswith(("package_paths", "weld")):
            message = f"plant.{message}"
        raise ValueError(message) from None


def scenario_chain(scenario: Scenario, base_dir: Path) -> SerialChain:
    """The scenario's plant URDF, checked (relative paths from ``base_dir``) with what the
    scenario adds to it; a bad file is refused naming ``plant.urdf``."""
    urdf = resolve_path(scenario.plant.urdf, base_dir)
    description = scenario_description(scenario, base_dir)
    try:
        return check_serial_urdf(urdf, description)
    except (ValueError, FileNotFoundError) as error:
        raise ValueError(f"plant.urdf = {scenario.plant.urdf!r}: {error}") from None


def scenario_joints(scenario: Scenario, base_dir: Path) -> int:
    """``n``: the number of joints of the scenario's plant URDF."""
    return len(scenario_chain(scenario, base_dir).joints)


def yaml_value(value: object, key: str = "value") -> str:
    """``value`` as the YAML text of a ``KEY=VALUE`` setting: a string is taken as it is
    (``lin_lc``, ``!Theta {theta6: 0}``); numbers, booleans and (nested) sequences,
    numpy's included, are written as YAML flow text. Anything else is a ``TypeError``
    naming ``key``."""
    if isinstance(value, str):
        return value
    plain = value.tolist() if hasattr(value, "tolist") else value  # a numpy array or scalar
    if isinstance(plain, tuple):
        plain = list(plain)
    try:
        text = yaml.safe_dump(plain, default_flow_style=True, width=math.inf)
    except yaml.representer.RepresenterError:
        raise TypeError(
            f"{key} = {value!r}; a number, a boolean, a string or a (nested) list of them "
            "is required"
        ) from None
    return text.removesuffix("\n").removesuffix("\n...").strip()


def apply_setting(scenario: Scenario, setting: str, base_dir: Path | None = None) -> Scenario:
    """A copy of ``scenario`` with ``KEY=VALUE`` applied: ``KEY`` is a dotted path
    (``timing.sample_time``, ``sensor.encoder_counts[1]``, ``trajectory.joints[0].frequency``),
    ``VALUE`` YAML (``0.005``, ``[4096, 2048]``, ``lin_lc``, or a whole section such as
    ``!Theta {theta6: 0}`` for ``nominal_model``). A single number given to a per-joint
    list applies to all joints; indexing a one-value list first repeats it once per
    joint of the plant URDF (relative paths from ``base_dir``, default the working
    folder)."""
    key, equals, text = setting.partition("=")
    key, text = key.strip(), text.strip()
    if not equals or not key:
        raise ValueError(f"--set {setting!r}; KEY=VALUE is required (e.g. timing.duration=5)")
    if key == "controller.kind":
        kind = parse(text, f"--set {key}")
        if not isinstance(kind, str):
            raise ValueError(f"--set controller.kind={text}; a controller kind is required")
        return with_controller(scenario, kind)
    result = copy.deepcopy(scenario)
    parent, name, index = _walk(result, key)
    schema = type(parent)
    if index is not None:
        items = list(getattr(parent, name))
        if len(items) == 1:
            items = items * scenario_joints(result, Path.cwd() if base_dir is None else base_dir)
        rendered = [yaml.safe_dump(item, default_flow_style=True).strip() for item in items]
        rendered = [r.removesuffix("\n...").strip() for r in rendered]
        rendered[index] = text
        text = f"[{', '.join(rendered)}]"
    elif _is_list(_field_types(schema)[name]) and not isinstance(parse(text, f"--set {key}"), list):
        text = f"[{text}]"
    document = prepare(f"{name}: {text}", schema)
    prefix = key.rpartition(".")[0]
    check_shape(parse(document, f"--set {key}"), schema, prefix)
    try:
        updated = yaml_load_typed(schema=schema, data=document, defaults=parent)
    except Exception as error:
        first = str(error).strip().splitlines()[0]
        raise ValueError(f"--set {key}: {first}") from None
    setattr(parent, name, getattr(updated, name))
    return result
