"""From a scenario (``diagrams.scenario``) to a run: load a file with ``--set``
settings, validate it into the frozen ``ClosedLoopConfig`` the runner builds from
(every error names the dotted scenario key), and run it on its true arm.

Relative paths (``plant.urdf``, ``nominal_model.urdf``, ``trajectory.path``) are
read from the scenario file's folder (the working directory when there is no
file); ``package://posfb/two_link_arm.urdf`` is the shipped arm.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from posfb.diagrams.closed_loop import ClosedLoopConfig, ClosedLoopResult, ClosedLoopRunner
from posfb.diagrams.scenario import (
    SHIPPED_PREFIX,
    ControllerSettings,
    CsvFile,
    FilterH,
    IdentifiedFromUrdf,
    NominalModel,
    ParameterOverrides,
    Scenario,
    StateSpaceH,
    Table1,
    Theta,
    TrajectorySettings,
    UrdfModel,
    Wave,
    Waypoints,
    apply_setting,
    resolve_path,
    scenario_chain,
)
from posfb.diagrams.yaml_schema import load_typed, read_text
from posfb.models.controllers import CONTROLLER_KINDS
from posfb.models.design import ControllerConfig
from posfb.models.design.config import (
    LqrWeights,
    NonlinearTorqueConfig,
    PidGains,
    UncertaintyBounds,
)
from posfb.models.identify import identify_urdf
from posfb.models.lumped import TABLE1, LumpedParameters
from posfb.models.nominal import NominalModel as NominalForm
from posfb.models.nominal import UrdfNominal, joint_count
from posfb.models.plant import (
    JOINT_PARAMETERS,
    PAYLOAD_BODY,
    ArmParameters,
    PlantConfig,
)
from posfb.models.trajectory import (
    JointWave,
    SplineTrajectory,
    Trajectory,
    WaveTrajectory,
)
from posfb.models.validation import per_joint


@dataclass
class LoadedScenario:
    """A scenario and the folder its relative paths are read from."""

    scenario: Scenario
    base_dir: Path


def load_scenario(path: str | Path | None = None, settings: Iterable[str] = ()) -> LoadedScenario:
    """The scenario of file ``path`` (the paper's defaults without one), with the
    ``KEY=VALUE`` ``settings`` applied in order, validated by ``resolve``."""
    if path is None:
        loaded = LoadedScenario(Scenario(), Path.cwd())
    else:
        file = Path(path)
        text = read_text(file, "scenario")
        scenario = load_typed(Scenario, text, f"scenario {file}", empty_ok=True)
        loaded = LoadedScenario(scenario, file.resolve().parent)
    for setting in settings:
        loaded.scenario = apply_setting(loaded.scenario, setting, loaded.base_dir)
    resolve(loaded)
    return loaded



def h_matrices(settings: FilterH, joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A_zeta, B_zeta, C_zeta)`` of either form of ``H(s)`` (one ``gamma`` broadcasts
    to the ``joints`` joints)."""
    if isinstance(settings, StateSpaceH):
        return tuple(np.asarray(m, dtype=float) for m in (settings.A_zeta, settings.B_zeta,
                                                          settings.C_zeta))  # fmt: skip
    gamma = np.asarray(per_joint("H.gamma", settings.gamma, joints), dtype=float)
    if not np.all(np.isfinite(gamma)) or np.any(gamma <= 0.0):
        raise ValueError(f"H.gamma = {settings.gamma!r}; finite values > 0 are required")
    return -np.diag(gamma), np.diag(gamma), np.eye(gamma.size)



#: Which scenario section owns a name that a frozen config's error message starts with.
_SECTIONS = {
    "sample_time": "timing",
    "duration": "timing",
    "divergence_bound": "timing",
    "accuracy": "timing.simulator",
    "integration_scheme": "timing.simulator",
    "max_step_size": "timing.simulator",
    "target_realtime_rate": "timing.simulator",
    "start_time": "timing.simulator",
    "encoder_counts": "sensor",
    "zero_offset": "sensor",
    "noise_std": "sensor",
    "noise_seed": "sensor",
    "delay_samples": "sensor",
    "voltage_limit": "actuator",
    "trajectory": "trajectory",
    "controller": "controller.kind",
    "payload_mass": "plant",
    "friction_velocity": "plant",
    "motor_friction_blocks": "plant",
}


def _with_key(error: ValueError, default: str) -> ValueError:
    """``error`` with the scenario section of the name its message starts with."""
    message = str(error)
    head = message.split(" ", 1)[0].split("[", 1)[0].split("=", 1)[0]
    section = _SECTIONS.get(head, default)
    if section.endswith(f".{head}") or section == head:
        return ValueError(f"{section}{message[len(head) :]}")
    return ValueError(f"{section}.{message}")


def with_absolute_paths(loaded: LoadedScenario) -> Scenario:
    """A copy of the scenario whose file paths no longer depend on its folder."""
    scenario = copy.deepcopy(loaded.scenario)

    def absolute(text: str) -> str:
        if not text or text.startswith(SHIPPED_PREFIX):
            return text
        return str(resolve_path(text, loaded.base_dir))

    scenario.plant.urdf = absolute(scenario.plant.urdf)
    if isinstance(scenario.nominal_model, IdentifiedFromUrdf | UrdfModel):
        scenario.nominal_model.urdf = absolute(scenario.nominal_model.urdf)
    if isinstance(scenario.trajectory, CsvFile):
        scenario.trajectory.path = absolute(scenario.trajectory.path)
    return scenario


def read_csv_trajectory(path: Path) -> SplineTrajectory:
    """Columns time (s), q1 .. qn (rad) of a CSV file, header row optional."""
    source = f"trajectory.path {path}"
    if path.is_dir():
        raise ValueError(f"{source} is a directory; a CSV file is required")
    if not path.is_file():
        raise ValueError(f"{source} does not exist")
    try:
        table = pd.read_csv(path, header=None, dtype=str, skip_blank_lines=True)
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError) as err:
        raise ValueError(f"{source} cannot be read as CSV: {str(err).splitlines()[0]}") from None
    numbers = table.apply(pd.to_numeric, errors="coerce")
    if len(numbers) and numbers.iloc[0].isna().all():
        numbers = numbers.iloc[1:]  # a header row
    if numbers.shape[1] < 2:
        raise ValueError(
            f"{source} has {numbers.shape[1]} columns; time and one column per joint "
            "(time, q1, .., qn) are required"
        )
    if numbers.isna().to_numpy().any():
        row = int(np.argmax(numbers.isna().to_numpy().any(axis=1)))
        raise ValueError(f"{source}: data row {row + 1} has a non-numeric entry")
    data = numbers.to_numpy(dtype=float)
    return SplineTrajectory.from_samples(data[:, 0], data[:, 1:], source)


def make_trajectory(settings: TrajectorySettings, base_dir: Path) -> Trajectory:
    """The desired trajectory of a scenario."""
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
    return read_csv_trajectory(resolve_path(settings.path, base_dir))


def make_nominal(settings: NominalModel, base_dir: Path) -> NominalForm:
    """The model the controllers are designed from."""
    if isinstance(settings, Table1):
        return TABLE1
    if isinstance(settings, UrdfModel):
        return UrdfNominal(str(resolve_path(settings.urdf, base_dir)))
    if isinstance(settings, Theta):
        return LumpedParameters(**dataclasses.asdict(settings))
    return identify_urdf(str(resolve_path(settings.urdf, base_dir)), settings.payload_mass)


def make_design(
    settings: ControllerSettings, nominal: NominalForm, sample_time: float
) -> ControllerConfig:
    """The frozen ``ControllerConfig`` of the controller settings; the per-joint lists
    (``lambdas``, ``H.gamma``, ``Kp``, ``Kv``, ``KI``) take one value for every joint of
    ``nominal`` or one per joint."""
    joints = joint_count(nominal)

    def vector(name: str) -> tuple[float, ...]:
        return tuple(per_joint(name, getattr(settings, name), joints))

    bounds = dataclasses.asdict(settings.bounds)
    A_zeta, B_zeta, C_zeta = h_matrices(settings.H, joints)
    return ControllerConfig(
        nominal=nominal,
        sample_time=sample_time,
        lqr=LqrWeights(Q1=settings.Q1, Q2=settings.Q2, R=settings.R, lambdas=vector("lambdas")),
        nonlinear=NonlinearTorqueConfig(
            alpha_star=settings.alpha_star,
            K_alpha=settings.K_alpha,
            alpha0=settings.alpha0,
            A_zeta=A_zeta,
            B_zeta=B_zeta,
            C_zeta=C_zeta,
            filter_a=settings.filter_a,
        ),
        bounds=UncertaintyBounds(**bounds),
        pid=PidGains(Kp=vector("Kp"), Kv=vector("Kv"), KI=vector("KI")),
        discretisation=settings.discretisation,
    )


@dataclass(frozen=True, eq=False)
class ResolvedScenario:
    """A validated scenario: the closed-loop config and the true plant's overrides."""

    config: ClosedLoopConfig
    payload_mass: float
    overrides: dict[str, tuple[float, ...]]

    def true_parameters(self, defaults: ArmParameters) -> ArmParameters:
        """The true arm: the URDF's ``defaults`` with the scenario's overrides."""
        try:
            return replace(defaults, **self.overrides, payload_mass=self.payload_mass)
        except ValueError as error:
            raise _with_key(error, "plant.parameters") from None


def _overrides(settings: ParameterOverrides, joints: int) -> dict[str, tuple[float, ...]]:
    overrides = {}
    for name in JOINT_PARAMETERS:
        values = getattr(settings, name)
        if values is None:
            continue
        values = per_joint(f"plant.parameters.{name}", values, joints)
        overrides[name] = tuple(float(v) for v in values)
    return overrides


def resolve(loaded: LoadedScenario) -> ResolvedScenario:
    """Validate ``loaded`` into a ``ResolvedScenario``; errors name the dotted key."""
    scenario, base = loaded.scenario, loaded.base_dir
    settings = scenario.controller
    if settings.kind not in CONTROLLER_KINDS:
        raise ValueError(
            f"controller.kind = {settings.kind!r}; one of {', '.join(CONTROLLER_KINDS)} is required"
        )
    chain = scenario_chain(scenario, base)
    joints = len(chain.joints)
    try:
        nominal = make_nominal(scenario.nominal_model, base)
    except (ValueError, FileNotFoundError) as error:
        raise ValueError(f"nominal_model: {error}") from None
    if joint_count(nominal) != joints:
        raise ValueError(
            f"nominal_model has {joint_count(nominal)} joints and plant.urdf = "
            f"{scenario.plant.urdf!r} has {joints}; the same number is required"
        )
    try:
        design = make_design(settings, nominal, scenario.timing.sample_time)
    except ValueError as error:
        raise _with_key(error, "controller") from None
    trajectory = make_trajectory(scenario.trajectory, base)
    plant = scenario.plant
    urdf = resolve_path(plant.urdf, base)
    try:
        plant_config = PlantConfig(
            urdf=str(urdf),
            friction_velocity=plant.friction_velocity,
            motor_friction_blocks=plant.motor_friction_blocks,
        )
        config = ClosedLoopConfig(
            controller=settings.kind,
            design=design,
            duration=scenario.timing.duration,
            trajectory=trajectory,
            encoder_counts=tuple(scenario.sensor.encoder_counts),
            zero_offset=tuple(scenario.sensor.zero_offset),
            noise_std=tuple(scenario.sensor.noise_std),
            noise_seed=scenario.sensor.noise_seed,
            delay_samples=scenario.sensor.delay_samples,
            voltage_limit=tuple(scenario.actuator.voltage_limit),
            plant=plant_config,
            divergence_bound=scenario.timing.divergence_bound,
            simulator=scenario.timing.simulator,
        )
        # The payload and overrides are checked against ArmParameters' own rules.
        if plant.payload_mass != 0.0 and PAYLOAD_BODY not in chain.links:
            raise ValueError(
                f"payload_mass = {plant.payload_mass!r} kg, but plant.urdf = {plant.urdf!r} "
                f"has no link named {PAYLOAD_BODY!r} to carry it; 0 is required"
            )
        overrides = _overrides(plant.parameters, joints)
        probe = ArmParameters(**{name: (1.0,) * joints for name in JOINT_PARAMETERS})
        replace(probe, **overrides, payload_mass=plant.payload_mass)
    except ValueError as error:
        raise _with_key(error, "plant.parameters") from None
    return ResolvedScenario(config, float(plant.payload_mass), overrides)


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
    runner = ClosedLoopRunner(resolved.config)
    parameters = resolved.true_parameters(runner.arm.default_parameters)
    return runner.run(parameters, progress=progress)
