"""From a scenario (``diagrams.scenario``) to a run: load a file with ``--set``
settings, validate it into the frozen ``ClosedLoopConfig`` the runner builds from
(every error names the dotted scenario key), and run it on its true arm.

Relative paths (``plant.urdf``, ``nominal_model.urdf``, ``nominal_model.file``,
``trajectory.path``) are read from the scenario file's folder (the working directory
when there is no file); ``package://posfb/two_link_arm.urdf`` is the shipped arm.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import yaml

from posfb.diagrams.encoder import per_joint_counts
from posfb.diagrams.loop_config import ClosedLoopConfig, TruePlant
from posfb.diagrams.runner import ClosedLoopResult, ClosedLoopRunner
from posfb.diagrams.scenario import (
    SHIPPED_PREFIX,
    CsvFile,
    Identified,
    IdentifiedFromUrdf,
    NominalModel,
    ParameterOverrides,
    Python,
    Scenario,
    Table1,
    Theta,
    TrajectorySettings,
    UrdfModel,
    Wave,
    Waypoints,
    apply_setting,
    controller_kind,
    dump_scenario,
    get_setting,
    require_backlash,
    resolve_path,
    scenario_chain,
    scenario_description,
)
from posfb.diagrams.sections import require_dac_resolution, require_encoder_resolution
from posfb.diagrams.yaml_schema import load_typed, read_text
from posfb.models.controllers import PluginError, UserPlugin, entry_build, make_controller
from posfb.models.controllers.plugin import load_plugin, module_plugin
from posfb.models.description import Description
from posfb.models.design import ControllerConfig
from posfb.models.design.loop_context import LoopContext
from posfb.models.friction import law_spec, law_values, tag
from posfb.models.gear import GearConfig, require_motor_inertia
from posfb.models.identification.model_file import load_model
from posfb.models.lumped import TABLE1, LumpedParameters
from posfb.models.nominal import NominalModel as NominalForm
from posfb.models.nominal import UrdfNominal, joint_count
from posfb.models.plant import (
    JOINT_PARAMETERS,
    PAYLOAD_BODY,
    ArmParameters,
    PlantConfig,
    require_payload_mass,
)
from posfb.models.theta_of_plant import identify_urdf
from posfb.models.trajectory import (
    JointWave,
    SplineTrajectory,
    Trajectory,
    WaveTrajectory,
)
from posfb.models.validation import per_joint, require_positive, require_regular_file


@dataclass
class LoadedScenario:
    """A scenario, the folder its relative paths are read from, and where it came from
    (``source``: the file, or a word for a scenario that has none).

    ``resolve`` keeps its answer here with a copy of the scenario it validated
    (``_resolution``): resolving again a scenario that still equals that copy returns it
    without a second validation, so a scenario loaded once and passed on is validated
    once; an edit (``loaded.scenario.timing.duration = 5``) makes the next ``resolve``
    validate again."""

    scenario: Scenario
    base_dir: Path
    source: str = "defaults"
    _resolution: tuple[Scenario, Path, ResolvedScenario] | None = field(
        default=None, repr=False, compare=False
    )

    def with_settings(self, settings: Iterable[str]) -> LoadedScenario:
        """A copy with the ``KEY=VALUE`` ``settings`` applied in order, validated once
        (``resolve``; the copy keeps the answer)."""
        settings = list(settings)
        if not settings and self._resolved() is not None:
            return LoadedScenario(self.scenario, self.base_dir, self.source, self._resolution)
        loaded = LoadedScenario(self.scenario, self.base_dir, self.source)
        for setting in settings:
            if _indexes_left_out_list(loaded.scenario, setting):
                loaded.scenario = with_arm_defaults(loaded.scenario, resolve(loaded).context)
            loaded.scenario = apply_setting(loaded.scenario, setting, loaded.base_dir)
        resolved = resolve(loaded)
        loaded.scenario = with_arm_defaults(loaded.scenario, resolved.context)
        loaded.keep(resolved)
        return loaded

    def keep(self, resolved: ResolvedScenario) -> None:
        """Keep ``resolved`` as the validation of the scenario as it is now."""
        self._resolution = (copy.deepcopy(self.scenario), self.base_dir, resolved)

    def _resolved(self) -> ResolvedScenario | None:
        """The kept validation, if the scenario and its folder are still the ones it
        validated."""
        if self._resolution is None:
            return None
        scenario, base_dir, resolved = self._resolution
        try:
            same = base_dir == self.base_dir and scenario == self.scenario
        except ValueError:  # a value without a plain equality (an array): validate again
            same = False
        return resolved if same else None

    def get(self, key: str) -> object:
        """The value of dotted ``key`` (``timing.duration``, ``sensor.encoder_counts[1]``)."""
        if not isinstance(key, str):
            raise TypeError(
                f"key = {key!r}; a dotted key string such as 'timing.duration' is required"
            )
        return get_setting(self.scenario, key)

    def dump(self) -> str:
        """The complete scenario as YAML, every default written out."""
        return dump_scenario(self.scenario)


def _indexes_left_out_list(scenario: Scenario, setting: str) -> bool:
    """Whether ``setting`` sets one joint (``controller.lambdas[1]=20``) of a per-joint
    list that its entry left out: the arm's list is then taken first, and the setting
    changes that joint of it."""
    key = setting.partition("=")[0].strip()
    if not key.endswith("]"):
        return False
    try:
        return get_setting(scenario, key.rpartition("[")[0]) is None
    except ValueError:
        return False


def scenario_from_file(path: str | Path, settings: Iterable[str] = ()) -> LoadedScenario:
    """The scenario of YAML file ``path`` with the ``KEY=VALUE`` ``settings`` applied in
    order, validated by ``resolve``."""
    file = Path(path)
    text = read_text(file, "scenario")
    scenario = load_typed(Scenario, text, f"scenario {file}", empty_ok=True)
    return LoadedScenario(scenario, file.resolve().parent, str(path)).with_settings(settings)


def scenario_from_mapping(
    mapping: Mapping[str, object], settings: Iterable[str] = ()
) -> LoadedScenario:
    """A scenario from a mapping with a scenario file's keys (relative paths from the
    working folder), with ``settings`` applied, validated."""
    text = yaml.safe_dump(dict(mapping), default_flow_style=False, sort_keys=False)
    scenario = load_typed(Scenario, text, "scenario mapping", empty_ok=True)
    return LoadedScenario(scenario, Path.cwd(), "mapping").with_settings(settings)


def load_scenario(path: str | Path | None = None, settings: Iterable[str] = ()) -> LoadedScenario:
    """The scenario of file ``path`` (the paper's defaults without one), with the
    ``KEY=VALUE`` ``settings`` applied in order, validated by ``resolve``."""
    if path is None:
        return LoadedScenario(Scenario(), Path.cwd()).with_settings(settings)
    return scenario_from_file(path, settings)


def in_section(section: str, error: ValueError) -> ValueError:
    """``error`` of a value of scenario section ``section`` (whose validator names its
    fields bare, as ``PlantConfig``'s and ``ArmParameters``' do) with the section's key."""
    return ValueError(f"{section}.{error}")


def with_absolute_paths(loaded: LoadedScenario) -> Scenario:
    """A copy of the scenario whose file paths no longer depend on its folder."""
    scenario = copy.deepcopy(loaded.scenario)

    def absolute(text: str) -> str:
        if not text or text.startswith(SHIPPED_PREFIX):
            return text
        return str(resolve_path(text, loaded.base_dir))

    scenario.plant.urdf = absolute(scenario.plant.urdf)
    scenario.plant.package_paths = [absolute(folder) for folder in scenario.plant.package_paths]
    if isinstance(scenario.nominal_model, IdentifiedFromUrdf | UrdfModel):
        scenario.nominal_model.urdf = absolute(scenario.nominal_model.urdf)
    if isinstance(scenario.nominal_model, Identified):
        scenario.nominal_model.file = absolute(scenario.nominal_model.file)
    if isinstance(scenario.trajectory, CsvFile):
        scenario.trajectory.path = absolute(scenario.trajectory.path)
    for entry in python_entries(scenario):
        entry.file = absolute(entry.file) if entry.file else entry.file
    return scenario


def self_contained(loaded: LoadedScenario) -> Scenario:
    """``with_absolute_paths``, and a ``!Python`` controller file's text stored in its
    ``source`` (a Monte-Carlo study's scenario: its workers need no shared folder)."""
    scenario = with_absolute_paths(loaded)
    for section in python_entries(scenario):
        if section.file and not section.source:
            try:
                section.source = Path(section.file).read_text()
            except (OSError, UnicodeDecodeError) as error:
                message = f"controller.file = {section.file!r} cannot be read: {error}"
                raise ValueError(message) from None
    return scenario


def python_entries(scenario: Scenario) -> list[Python]:
    """The ``!Python`` entries of a scenario: its controller and its named entries."""
    entries = [scenario.controller, *scenario.controllers.values()]
    return [entry for entry in entries if isinstance(entry, Python)]


def plugin_file_changed(scenario: Scenario) -> str:
    """A note when the ``!Python`` file of a stored scenario no longer holds its stored
    ``source`` ("" when it does, or when there is none)."""
    for section in python_entries(scenario):
        if not (section.source and section.file):
            continue
        path = Path(section.file)
        current = path.read_text() if path.is_file() else None
        if current != section.source:
            state = "is gone" if current is None else "has changed"
            return (f"the controller file {path} {state} since the study ran; the study's "
                    "stored copy of it runs")  # fmt: skip
    return ""


#: The names a CSV trajectory's time column (s) may have.
CSV_TIME_COLUMNS = ("time", "time_s")

#: A CSV trajectory's position column of joint ``j`` (rad): ``qj`` or ``qj_rad``.
_CSV_JOINT_COLUMN = re.compile(r"q([1-9][0-9]*)(_rad)?")


def csv_columns_required(joints: int) -> str:
    """The header a CSV trajectory of a ``joints``-joint arm needs (for messages)."""
    names = ", ".join(f"q{j + 1}" for j in range(joints))
    return (
        f"a header row naming the columns time (or time_s), {names} (or q1_rad .. "
        f"q{joints}_rad), in any order, is required"
    )


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _csv_column_order(header: list[str], joints: int, source: str) -> list[int]:
    """The indices of the time column and of joints ``1..joints``' columns in ``header``,
    by name; any other name, a name given twice or a joint count that is not the arm's
    is refused naming the columns required."""
    required = csv_columns_required(joints)
    if all(_is_number(name) for name in header):
        raise ValueError(f"{source} has no header row (its first row is numbers); {required}")
    times, by_joint = [], {}
    for index, name in enumerate(header):
        match = _CSV_JOINT_COLUMN.fullmatch(name)
        if name in CSV_TIME_COLUMNS:
            times.append(index)
        elif match:
            by_joint.setdefault(int(match[1]), []).append(index)
        else:
            raise ValueError(f"{source}: column {name!r} is not a trajectory column; {required}")
    if len(times) != 1:
        listed = ", ".join(header[k] for k in times) or "none"
        raise ValueError(f"{source} has {len(times)} time columns ({listed}); {required}")
    for joint, indices in sorted(by_joint.items()):
        if len(indices) > 1:
            named = ", ".join(header[k] for k in indices)
            raise ValueError(f"{source} names joint {joint} twice ({named}); {required}")
    if sorted(by_joint) != list(range(1, joints + 1)):
        count = len(by_joint)
        named = ", ".join(header[by_joint[j][0]] for j in sorted(by_joint))
        columns = "column" if count == 1 else "columns"
        arm = "joint" if joints == 1 else "joints"
        raise ValueError(
            f"{source} has {count} joint {columns} ({named}); the arm has {joints} {arm}: "
            f"{required}"
        )
    return [times[0], *(by_joint[j][0] for j in range(1, joints + 1))]


def read_csv_trajectory(path: Path, joints: int) -> SplineTrajectory:
    """The desired path of a ``joints``-joint arm in a CSV file, its columns read by the
    names in its header row: time ``time`` or ``time_s`` (s), joint ``j``'s position
    ``qj`` or ``qj_rad`` (rad), in any order; a not-a-knot cubic through the samples."""
    source = f"trajectory.path {path}"
    require_regular_file("trajectory.path", path)  # a FIFO would block the read
    import pandas as pd  # on use: the CLI's start-up does not pay for it

    try:
        table = pd.read_csv(
            path, header=None, dtype=str, skip_blank_lines=True, keep_default_na=False
        )
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError) as err:
        raise ValueError(f"{source} cannot be read as CSV: {str(err).splitlines()[0]}") from None
    header = [name.strip() for name in table.iloc[0]]
    order = _csv_column_order(header, joints, source)
    numbers = table.iloc[1:, order].apply(pd.to_numeric, errors="coerce")
    if numbers.isna().to_numpy().any():
        row = int(np.argmax(numbers.isna().to_numpy().any(axis=1)))
        raise ValueError(f"{source}: data row {row + 1} has a non-numeric entry")
    data = numbers.to_numpy(dtype=float)
    return SplineTrajectory.from_samples(data[:, 0], data[:, 1:], source)


def make_trajectory(settings: TrajectorySettings, base_dir: Path, joints: int) -> Trajectory:
    """The desired trajectory of a scenario for a ``joints``-joint arm."""
    if isinstance(settings, Wave):
        try:
            waves = tuple(JointWave(**dataclasses.asdict(joint)) for joint in settings.joints)
            return WaveTrajectory(waves)
        except ValueError as error:
            raise ValueError(f"trajectory.joints: {error}") from None
    if isinstance(settings, Waypoints):
        return SplineTrajectory.from_waypoints(settings.times, settings.positions)
    if not settings.path:
        raise ValueError("trajectory.path is empty; the CSV file's path is required")
    return read_csv_trajectory(resolve_path(settings.path, base_dir), joints)


def _check_csv(settings: TrajectorySettings, trajectory: Trajectory, duration: float) -> None:
    """A CSV trajectory covers the run, ``[0, timing.duration]``, unless it says to hold
    its first position before its start or its last one after its end."""
    if not isinstance(settings, CsvFile):
        return
    if trajectory.start_time > 0.0 and not settings.hold_before_start:
        raise ValueError(
            f"trajectory.path {settings.path} starts at t = {trajectory.start_time:g} s, after "
            "the run starts (t = 0); samples from t = 0 are required (or "
            "trajectory.hold_before_start: true, to hold its first position at rest until then)"
        )
    if trajectory.end_time < duration and not settings.hold_after_end:
        raise ValueError(
            f"trajectory.path {settings.path} ends at t = {trajectory.end_time:g} s, before "
            f"timing.duration = {duration:g} s; samples up to {duration:g} s are required (or "
            "trajectory.hold_after_end: true, to hold its last position at rest)"
        )


def make_nominal(
    settings: NominalModel, base_dir: Path, description: Description | None = None
) -> NominalForm:
    """The model the controllers are designed from; a URDF model takes what the scenario
    adds to its file (``description``: package folders, welds, drives)."""
    if isinstance(settings, Table1):
        return TABLE1
    if isinstance(settings, UrdfModel):
        return UrdfNominal(str(resolve_path(settings.urdf, base_dir)), description or Description())
    if isinstance(settings, Theta):
        return LumpedParameters(**dataclasses.asdict(settings))
    if isinstance(settings, Identified):
        if not settings.file:
            raise ValueError("!Identified needs file: the model posfb identify --out wrote")
        path = resolve_path(settings.file, base_dir)
        model = load_model(path)
        if model.kind == "urdf":  # written with the scenario's description in it
            return UrdfNominal(str(path.parent / model.urdf))
        return LumpedParameters.from_theta(np.asarray(model.values), l1=model.l1, g=model.g)
    return identify_urdf(str(resolve_path(settings.urdf, base_dir)), settings.payload_mass)


def load_python_controller(section: Python, base_dir: Path) -> UserPlugin:
    """The user's controller class of a ``!Python`` entry (file relative to ``base_dir``,
    or module), with its settings; every problem is one line naming the key (a
    ``PluginError``: ``resolve`` adds no prefix to it)."""
    if bool(section.file) == bool(section.module):
        raise PluginError(
            f"controller: !Python has file = {section.file!r} and module = {section.module!r};"
            " exactly one of them is required"
        )
    if not section.class_name:
        raise PluginError("controller.class is empty; the name of a posfb.Controller subclass "
                         "is required")  # fmt: skip
    try:
        settings = json.loads(section.settings)
    except json.JSONDecodeError:
        settings = None
    if not isinstance(settings, dict):
        raise PluginError(f"controller.settings = {section.settings!r}; a map of names to values "
                         "is required")  # fmt: skip
    label = section.label or section.class_name
    if section.source:  # stored by a study: the file need not exist here
        path = resolve_path(section.file, base_dir) if section.file else Path(section.module)
        return load_plugin(section.source, str(path), section.class_name, settings, label)
    if section.file:
        path = resolve_path(section.file, base_dir)
        if path.is_dir():
            raise PluginError(
                f"controller.file = {section.file!r}: {path} is a directory; a Python file "
                "defining the class is required"
            )
        if not path.is_file():
            raise PluginError(f"controller.file = {section.file!r}: {path} does not exist")
        try:
            text = path.read_text()
        except (OSError, UnicodeDecodeError) as error:
            message = f"controller.file = {section.file!r} cannot be read: {error}"
            raise PluginError(message) from None
        return load_plugin(text, str(path), section.class_name, settings, label)
    return module_plugin(section.module, section.class_name, settings, label)


def controller_inputs(
    section: object, context: LoopContext, base_dir: Path
) -> tuple[str, ControllerConfig, object | None]:
    """``(kind, design inputs, settings)`` of the scenario's controller entry: the paper's
    three give their ``ControllerConfig`` (``models.design.settings``) and no settings; a
    plug-in gives its settings with ``ControllerConfig.without_design``. A plug-in is
    built once here, so a bad setting is refused now."""
    if isinstance(section, Python):
        design = ControllerConfig.without_design(context)
        settings: object = load_python_controller(section, base_dir)
        kind = settings.kind
    else:
        build = entry_build(copy.deepcopy(section), context)
        design, settings, kind = build.design, build.settings, controller_kind(section)
        if settings is None:
            return kind, design, None
    make_controller(kind, design, settings=settings)
    return kind, design, settings


def loop_context(scenario: Scenario, nominal: NominalForm) -> LoopContext:
    """The scenario's loop context (``models.design.loop_context``), built once: the
    nominal model, ``timing.sample_time``, the wave trajectory's frequencies,
    ``sensor.encoder_counts`` and ``actuator.voltage_limit`` (checked, per joint). The
    design, the controller and the closed loop hold it; the controller entries derive the
    per-joint settings they leave out from it (``models.design.settings``)."""
    n = joint_count(nominal)
    trajectory = scenario.trajectory
    waves = trajectory.joints if isinstance(trajectory, Wave) else []
    limits = per_joint("actuator.voltage_limit", scenario.actuator.voltage_limit, n)
    for j, limit in enumerate(limits):
        require_positive(f"actuator.voltage_limit[{j}]", limit)
    return LoopContext(
        nominal=nominal,
        sample_time=float(scenario.timing.sample_time),
        frequencies=tuple(float(wave.frequency) for wave in waves),
        encoder_counts=per_joint_counts("sensor.encoder_counts", scenario.sensor.encoder_counts, n),
        voltage_limit=tuple(float(v) for v in limits),
    )


def _entry_with_arm_defaults(entry: object, arm: LoopContext) -> object:
    """``entry`` with its left-out per-joint settings from ``arm`` (a plug-in's as it is)."""
    fill = getattr(entry, "with_arm_defaults", None)
    return entry if fill is None else fill(arm)


def with_arm_defaults(scenario: Scenario, arm: LoopContext) -> Scenario:
    """A copy of ``scenario`` whose controller entries (``controller`` and every named one)
    hold the per-joint settings they left out, from ``arm`` (``models.design.settings``):
    what ``scenario dump`` shows and tuning starts from; ``arm`` is kept as its
    ``arm_defaults``, for the entries ``with_controller`` makes."""
    filled = replace(
        scenario,
        controller=_entry_with_arm_defaults(scenario.controller, arm),
        controllers={
            name: _entry_with_arm_defaults(entry, arm)
            for name, entry in scenario.controllers.items()
        },
    )
    filled.arm_defaults = arm
    return filled


@dataclass(frozen=True, eq=False)
class ResolvedScenario:
    """A validated scenario: the closed-loop config, which carries the true plant's
    payload and overrides (``ClosedLoopConfig.true_plant``) and the loop context
    (``context``: what the controller entries' left-out settings came from too)."""

    config: ClosedLoopConfig

    @property
    def context(self) -> LoopContext:
        """The scenario's loop context, resolved once (``loop_context``)."""
        return self.config.context

    @property
    def payload_mass(self) -> float:
        return self.config.true_plant.payload_mass

    @property
    def overrides(self) -> dict[str, tuple[float, ...]]:
        return dict(self.config.true_plant.overrides)

    def true_parameters(self, defaults: ArmParameters) -> ArmParameters:
        """The true arm: the URDF's ``defaults`` with the scenario's overrides."""
        try:
            return self.config.true_plant.parameters(defaults)
        except ValueError as error:
            raise in_section("plant.parameters", error) from None


def _overrides(settings: ParameterOverrides, joints: int) -> dict[str, tuple[float, ...]]:
    overrides = {}
    for name in JOINT_PARAMETERS:
        values = getattr(settings, name)
        if values is None:
            continue
        values = per_joint(name, values, joints)
        overrides[name] = tuple(float(v) for v in values)
    return overrides


def _check_law_coulomb(plant: PlantConfig, levels: tuple[float, ...]) -> None:
    """A law that divides by the Coulomb level (LuGre) needs it > 0 at every joint."""
    if not law_spec(plant.friction).positive_coulomb:
        return
    for j, level in enumerate(levels):
        if not level > 0.0:
            raise ValueError(
                f"plant.parameters.coulomb[{j}] = {level!r} (or the URDF's "
                f"posfb:coulomb_friction) with plant.friction = {tag(plant.friction)}; > 0 is "
                "required (the law divides by g(v) >= f_c)"
            )


def nominal_mismatch(scenario: Scenario, nominal_joints: int, joints: int) -> str:
    """The one line that refuses a nominal model of another joint count than the plant's,
    saying how to describe the plant's own arm."""
    form = type(scenario.nominal_model).__name__
    urdf = scenario.plant.urdf
    return (
        f"nominal_model has {nominal_joints} joints (!{form}) and plant.urdf = {urdf!r} has "
        f"{joints}; the same number is required: write nominal_model: !UrdfModel "
        f"{{urdf: {urdf}}} (the plant's URDF, computed by Drake), or start from posfb "
        f"scenario init --urdf {urdf}"
    )


def resolve(loaded: LoadedScenario) -> ResolvedScenario:
    """Validate ``loaded`` into a ``ResolvedScenario``; errors name the dotted key. A
    scenario already validated as it is returns that answer (``LoadedScenario``)."""
    kept = loaded._resolved()
    if kept is not None:
        return kept
    resolved = _validated(loaded)
    loaded.keep(resolved)
    return resolved


def _validated(loaded: LoadedScenario) -> ResolvedScenario:
    """``resolve``'s validation itself."""
    scenario, base = loaded.scenario, loaded.base_dir
    section = scenario.controller
    # The design takes the sample time; it is the timing section's.
    require_positive("timing.sample_time", scenario.timing.sample_time)  # named by its key
    chain = scenario_chain(scenario, base)
    joints = len(chain.joints)
    try:
        nominal = make_nominal(scenario.nominal_model, base, scenario_description(scenario, base))
    except (ValueError, FileNotFoundError) as error:
        raise ValueError(f"nominal_model: {error}") from None
    if joint_count(nominal) != joints:
        raise ValueError(nominal_mismatch(scenario, joint_count(nominal), joints))
    context = loop_context(scenario, nominal)
    require_encoder_resolution(context.encoder_counts)
    require_dac_resolution(scenario.actuator.dac_bits)
    try:
        kind, design, controller_settings = controller_inputs(
            _entry_with_arm_defaults(section, context), context, base
        )
    except PluginError:
        raise  # a plug-in's own message names its key and class
    except ValueError as error:
        raise in_section("controller", error) from None
    trajectory = make_trajectory(scenario.trajectory, base, joints)
    _check_csv(scenario.trajectory, trajectory, scenario.timing.duration)
    plant = scenario.plant
    gear = _gear(plant, joints)
    try:
        require_payload_mass(plant.payload_mass)
        plant_config = PlantConfig(
            urdf=str(resolve_path(plant.urdf, base)),
            friction_velocity=plant.friction_velocity,
            motor_friction_blocks=plant.motor_friction_blocks,
            friction=copy.deepcopy(plant.friction),
            gear=gear,
            description=scenario_description(scenario, base),
        )
        law_values(plant_config.friction, joints)
    except ValueError as error:
        raise in_section("plant", error) from None
    if plant.payload_mass != 0.0 and PAYLOAD_BODY not in chain.links:
        raise ValueError(
            f"plant.payload_mass = {plant.payload_mass!r} kg, but plant.urdf = {plant.urdf!r} "
            f"has no link named {PAYLOAD_BODY!r} to carry it; 0 is required"
        )
    try:  # the overrides are checked against ArmParameters' own rules
        overrides = _overrides(plant.parameters, joints)
        probe = ArmParameters(**{name: (1.0,) * joints for name in JOINT_PARAMETERS})
        replace(probe, **overrides)
    except ValueError as error:
        raise in_section("plant.parameters", error) from None
    _check_law_coulomb(plant_config, overrides.get("coulomb", chain.coulomb))
    if "rotor_inertia" in overrides:  # the URDF's values are checked on the built arm
        stiffness = gear.values(joints)[0]
        require_motor_inertia(stiffness, np.array(overrides["rotor_inertia"]))
    config = ClosedLoopConfig(
        controller=kind,
        design=design,
        controller_settings=controller_settings,
        trajectory=trajectory,
        timing=scenario.timing.loop_timing(),
        sensor=scenario.sensor,
        actuator=scenario.actuator,
        plant=plant_config,
        true_plant=TruePlant(float(plant.payload_mass), tuple(overrides.items())),
    )
    return ResolvedScenario(config)


def _gear(plant: object, joints: int) -> GearConfig:
    """``plant.gear_stiffness``, ``gear_damping`` and ``backlash`` as a ``GearConfig``,
    checked for ``joints`` joints (errors name the keys)."""
    names = ("gear_stiffness", "gear_damping", "backlash")
    try:
        gear = GearConfig(**{name: tuple(getattr(plant, name)) for name in names})
    except ValueError as error:
        raise in_section("plant", error) from None
    require_backlash(gear.values(joints, prefix="plant.")[2])
    return gear


def run_scenario(
    loaded: LoadedScenario, progress: Callable[[float], None] | None = None
) -> ClosedLoopResult:
    """Build the scenario's closed loop and run it on its true arm (``progress``: see
    ``ClosedLoopRunner.run``)."""
    return run_resolved(resolve(loaded), progress)


def run_resolved(
    resolved: ResolvedScenario, progress: Callable[[float], None] | None = None
) -> ClosedLoopResult:
    """``run_scenario`` for a scenario already resolved (no second validation)."""
    return ClosedLoopRunner(resolved.config).run(progress=progress)
