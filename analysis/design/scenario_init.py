"""``posfb scenario init``: a complete, commented scenario for any serial arm posfb
accepts, its settings derived from the arm by the rules of ``models.design.initial``.

The steps: check the URDF (``models.urdf_check.check_serial_urdf``); read its joint
limits and find the posture the trajectory starts from (``start_posture``); shrink the
trajectory until the nominal model's inverse dynamics need at most
``VOLTAGE_HEADROOM`` of the voltage limit at every sample instant (``fit_trajectory``);
derive the LQR weights, ``G(s)``, ``H(s)`` and PID gains from ``M0*`` and ``T_s``;
choose ``alpha*`` from the nominal sampled-data spectral radius; write the scenario
with one comment per choice, stating the rule and its numbers; load it back with
posfb's loader before it replaces ``--out``.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from posfb.analysis.common.errors import UsageError
from posfb.analysis.common.outputs import atomic_file, output_file
from posfb.models.description import DRIVE_FIELDS, Description, Drives
from posfb.models.drive_rules import DerivedDrives

#: Step (s) of the time grid on which the trajectory's scale is searched; the chosen
#: trajectory is then checked at every sample instant, as ``scenario check`` does.
SEARCH_STEP = 0.01

#: Offset (rad) from the start of the potential-energy descent, so that a URDF whose
#: zero posture is an unstable equilibrium (upright) does not stay there.
DESCENT_NUDGE = 1e-2


@dataclass(frozen=True)
class InitOptions:
    """What ``posfb scenario init`` was asked for (``None``: the section's default)."""

    urdf: Path | str
    out: Path
    sample_time: float | None = None
    encoder_counts: int | None = None
    voltage_limit: float | None = None
    duration: float | None = None
    force: bool = False
    package_paths: tuple[Path, ...] = ()
    welds: tuple[str, ...] = ()
    drives: Path | None = None


@dataclass(frozen=True)
class Settings:
    """The validated options with every default filled in from its section; ``description``
    is what the scenario adds to the URDF (package folders, welds, the derived drives,
    ``models.drive_rules``)."""

    urdf: Path
    out: Path
    sample_time: float
    encoder_counts: int
    voltage_limit: float
    duration: float
    description: Description
    derived: DerivedDrives


def _welds(options: InitOptions) -> tuple[tuple[str, float | None], ...]:
    """``--weld NAME[=POSITION]`` values as (name, position)."""
    welds = []
    for text in options.welds:
        name, _, position = text.partition("=")
        try:
            value = float(position) if position else None
        except ValueError:
            value = math.nan
        if not name or (value is not None and not math.isfinite(value)):
            raise UsageError(
                f"--weld {text!r}; NAME or NAME=POSITION (a joint of the URDF, a finite "
                "position in rad or m) is required"
            )
        welds.append((name, value))
    return tuple(welds)


def _given_drives(path: Path | None) -> Drives:
    """The user's ``--drives`` file: ``plant.drives``' keys (``DriveSettings``)."""
    if path is None:
        return Drives(label="--drives")
    from posfb.diagrams.scenario import DriveSettings
    from posfb.diagrams.yaml_schema import load_typed, read_text

    try:
        settings = load_typed(DriveSettings, read_text(path, "--drives"), f"--drives {path}")
        return Drives(
            **{
                name: None if getattr(settings, name) is None else tuple(getattr(settings, name))
                for name in DRIVE_FIELDS
            },
            label="--drives",
        )
    except (ValueError, OSError) as error:
        raise UsageError(str(error)) from None


def settings_of(options: InitOptions) -> Settings:
    """Validate ``options`` where they enter; defaults from ``diagrams.sections``."""
    from posfb.diagrams.sections import (
        MIN_ENCODER_COUNTS,
        Actuator,
        Sensor,
        TimingSection,
        require_run_samples,
    )

    timing, sensor, actuator = TimingSection(), Sensor(), Actuator()
    sample_time = _pick(options.sample_time, timing.sample_time)
    duration = _pick(options.duration, timing.duration)
    counts = int(_pick(options.encoder_counts, sensor.encoder_counts[0]))
    voltage = _pick(options.voltage_limit, actuator.voltage_limit[0])
    if not (math.isfinite(sample_time) and sample_time > 0):
        raise UsageError(f"--sample-time {sample_time!r}; a time > 0 (s) is required")
    if counts < MIN_ENCODER_COUNTS:
        raise UsageError(
            f"--encoder-counts {counts}; at least {MIN_ENCODER_COUNTS} counts per revolution "
            "are required (one count must be at most a quarter turn)"
        )
    if not (math.isfinite(voltage) and voltage > 0):
        raise UsageError(f"--voltage-limit {voltage!r}; a voltage > 0 (V) is required")
    periods = duration / sample_time
    if not (math.isfinite(duration) and duration > 0) or abs(periods - round(periods)) > 1e-9 * max(
        1.0, periods
    ):
        raise UsageError(
            f"--duration {duration!r}; a time > 0 that is a whole number of periods of "
            f"T_s = {sample_time:g} s is required"
        )
    try:
        require_run_samples(periods, "--duration / --sample-time")
    except ValueError as error:
        raise UsageError(str(error)) from None
    out = options.out
    if out.is_dir():
        raise UsageError(f"--out {out} is a directory; a scenario file name is required")
    if out.exists() and not options.force:
        raise UsageError(f"--out {out} exists; give --force to overwrite it")
    if not out.parent.is_dir():
        raise UsageError(f"--out {out}: folder {out.parent} does not exist")
    output_file("--out", str(out), force=True)  # writable: refused before the work, not after
    from posfb.models.drive_rules import derive_drives
    from posfb.models.urdf_check import check_serial_urdf

    urdf = urdf_file(options.urdf)
    given = _given_drives(options.drives)
    try:
        located = Description(tuple(str(p) for p in options.package_paths), _welds(options))
    except ValueError as error:
        raise UsageError(f"--{error}".replace("--package_paths", "--package-path")) from None
    try:
        derived = derive_drives(urdf, located, voltage, given)
        description = Description(located.package_paths, located.welds, derived.written)
        check_serial_urdf(urdf, description)
    except (ValueError, FileNotFoundError) as error:
        raise UsageError(f"--urdf: {error}") from None
    return Settings(urdf, out, sample_time, counts, voltage, duration, description, derived)


def urdf_file(urdf: Path | str) -> Path:
    """The file ``--urdf`` names: a shipped arm as a scenario names it
    (``package://posfb/NAME``, also once a ``Path`` has folded it to ``package:/posfb/``)
    or a path."""
    from posfb.diagrams.scenario import SHIPPED_PREFIX, resolve_path

    text, folded = str(urdf), SHIPPED_PREFIX.replace("://", ":/")
    if text.startswith(folded):
        text = SHIPPED_PREFIX + text.removeprefix(folded)
    return resolve_path(text, Path.cwd()) if text.startswith(SHIPPED_PREFIX) else Path(urdf)


def _pick(value: float | None, default: float) -> float:
    return float(default if value is None else value)


# --- the arm -----------------------------------------------------------------------


@dataclass(frozen=True)
class ArmFacts:
    """What the rules read from the arm: joint names, limits (rad, infinite for a
    continuous joint), the start posture and the nominal ``M0*``, ``B*`` (V s^2/rad,
    V s/rad) and Coulomb levels (V)."""

    joints: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    offsets: np.ndarray
    free: np.ndarray
    M0: np.ndarray
    B: np.ndarray
    coulomb: np.ndarray


def limited(lower: float, upper: float) -> bool:
    """Whether a joint's range is narrower than a full turn (so it is centred, not
    hung)."""
    return math.isfinite(lower) and math.isfinite(upper) and upper - lower < 2 * math.pi


def start_posture(urdf: Path, description: Description) -> tuple[
    tuple[str, ...], np.ndarray, np.ndarray, np.ndarray, np.ndarray
]:
    """Joint names, limits and the trajectory's offsets: a joint whose range is less than
    a full turn sits at the centre of its limits; the other joints take the posture of
    least potential energy (the arm hanging), found by L-BFGS-B from the centres (0 for
    a continuous joint, nudged by ``DESCENT_NUDGE``) within their limits with the limited
    joints held. Returns ``(joints, lower, upper, offsets, free)``, ``free`` marking the
    hung joints."""
    import scipy.optimize

    from posfb.models.plant import PlantConfig, build_arm_diagram
    from posfb.models.urdf_check import check_serial_urdf

    chain = check_serial_urdf(urdf, description)
    _, arm, _ = build_arm_diagram(PlantConfig(urdf=str(urdf), description=description))
    plant = arm.plant
    context = plant.CreateDefaultContext()
    handles = [plant.GetJointByName(name) for name in chain.joints]
    lower = np.array([float(j.position_lower_limits()[0]) for j in handles])
    upper = np.array([float(j.position_upper_limits()[0]) for j in handles])
    free = np.array([not limited(lo, hi) for lo, hi in zip(lower, upper, strict=True)])
    start = np.where(np.isfinite(lower) & np.isfinite(upper), 0.5 * (lower + upper), 0.0)
    start = np.where(np.abs(start) < 1e9, start, 0.0)
    index = [j.position_start() for j in handles]
    positions = plant.GetPositions(context).copy()

    def energy(x: np.ndarray) -> float:
        q = start.copy()
        q[free] = x
        positions[index] = q
        plant.SetPositions(context, positions)
        return float(plant.EvalPotentialEnergy(context))

    if np.any(free):
        bounds = [
            (lo if math.isfinite(lo) else None, hi if math.isfinite(hi) else None)
            for lo, hi in zip(lower[free], upper[free], strict=True)
        ]
        x0 = np.clip(start[free] + DESCENT_NUDGE, lower[free], upper[free])
        result = scipy.optimize.minimize(energy, x0, method="L-BFGS-B", bounds=bounds,
                                         options={"ftol": 1e-14, "gtol": 1e-10})  # fmt: skip
        start[free] = result.x
    return chain.joints, lower, upper, start, free


def arm_facts(urdf: Path, description: Description) -> ArmFacts:
    """``ArmFacts`` of the URDF at ``urdf`` (checked) with what ``description`` adds."""
    from posfb.models.nominal import UrdfNominal, nominal_model

    joints, lower, upper, offsets, free = start_posture(urdf, description)
    model = nominal_model(UrdfNominal(str(urdf), description))
    return ArmFacts(joints, lower, upper, offsets, free, model.M0(), model.B(),
                    model.coulomb_levels())  # fmt: skip


# --- the trajectory ----------------------------------------------------------------


@dataclass(frozen=True)
class FittedTrajectory:
    """The waves, their amplitude ``scale`` (1: the rule's full motion), the nominal peak
    voltage per joint at the sample instants and when it occurs (s)."""

    waves: tuple
    scale: float
    peak: np.ndarray
    peak_time: np.ndarray


def peak_voltages(
    settings: Settings, waves: tuple, times: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, the largest ``|u|`` of the nominal inverse dynamics (Eq. 2, gravity and
    friction included) along ``waves`` at ``times``, and when."""
    from posfb.models.nominal import UrdfNominal, nominal_model, trajectory_voltages
    from posfb.models.trajectory import WaveTrajectory

    model = nominal_model(UrdfNominal(str(settings.urdf), settings.description))
    trajectory = WaveTrajectory(waves)
    voltages = trajectory_voltages(model, trajectory, times)
    where = np.argmax(np.abs(voltages), axis=0)
    return np.abs(voltages).max(axis=0), times[where]


def fit_trajectory(settings: Settings, facts: ArmFacts) -> FittedTrajectory:
    """The largest amplitude scale whose nominal peak voltage is at most
    ``VOLTAGE_HEADROOM`` of the limit (``models.design.initial.largest_scale``), searched
    on a ``SEARCH_STEP`` grid and confirmed at every sample instant. Refuses, naming
    ``--voltage-limit``, an arm that cannot hold its start posture within it."""
    from posfb.models.design.initial import VOLTAGE_HEADROOM, initial_waves, largest_scale

    allowed = VOLTAGE_HEADROOM * settings.voltage_limit
    step = max(SEARCH_STEP, settings.sample_time)
    grid = np.arange(0.0, settings.duration + 0.5 * step, step)
    samples = np.arange(round(settings.duration / settings.sample_time) + 1) * settings.sample_time

    def waves_at(scale: float) -> tuple:
        return initial_waves(facts.offsets, facts.lower, facts.upper, scale)

    def peak(scale: float, times: np.ndarray = grid) -> float:
        return float(peak_voltages(settings, waves_at(scale), times)[0].max())

    scale = largest_scale(peak, allowed)
    if scale is None:
        hold = peak_voltages(settings, waves_at(1e-3), grid)[0]
        j = int(np.argmax(hold))
        raise UsageError(
            f"--voltage-limit {settings.voltage_limit:g} V is too low for this arm: holding "
            f"joint {j + 1} near its start posture against gravity and Coulomb friction needs "
            f"{hold[j]:.3g} V (nominal model); with the trajectory kept within "
            f"{VOLTAGE_HEADROOM:.0%} of the limit, --voltage-limit "
            f"{math.ceil(100 * hold.max() / VOLTAGE_HEADROOM) / 100:g} or more is needed"
        )
    while True:  # confirm at the sample instants, where scenario check looks
        peaks, times = peak_voltages(settings, waves_at(scale), samples)
        if peaks.max() <= allowed:
            return FittedTrajectory(waves_at(scale), scale, peaks, times)
        scale *= 0.98 * allowed / peaks.max()


# --- the controllers ---------------------------------------------------------------


@dataclass(frozen=True)
class DesignedControllers:
    """The derived settings and the numbers they came from."""

    weights: object  # models.design.initial.InitialWeights
    filter_a: float
    gamma: float
    alpha: object  # models.design.initial.AlphaChoice
    pid: object  # models.design.initial.InitialPid
    radius_lin_lc: float
    radius_at_cap: float
    eigenvalue_range: tuple[float, float]

    def reason(self) -> str:
        """Why no setting of the rules passes over the path's configurations (empty when
        one does): one line, for the log and the file."""
        if self.alpha.met and self.radius_lin_lc < 1.0:
            return ""
        low, high = self.eigenvalue_range
        return (
            f"M*(q) varies {high / low:.3g}x along the path (eigenvalues of M0*^-1 M*(q) "
            f"{low:.3g} to {high:.3g}): no alpha* reaches radius {self.alpha.target:.4g} at "
            "every configuration" + ("" if self.radius_lin_lc < 1.0 else
                                     f" and Lin+LC's worst radius is {self.radius_lin_lc:.4f}")
            + f" at bandwidth scale {self.weights.scale:.4g}; give the drives' rotor inertia "
            "and gear, or a shorter T_s"
        )  # fmt: skip


def design_controllers(
    settings: Settings, facts: ArmFacts, fitted: FittedTrajectory
) -> DesignedControllers:
    """LQR weights, ``G(s)``, ``H(s)``, PID gains by their rules: the bandwidth by the
    largest scale whose Lin+LC loop passes over ``M0*`` and the configurations of the
    fitted path (``models.design.configurations``) with a gain margin where ``M*(q)`` is
    lightest, ``alpha*`` by the largest sampled-data spectral radius ``<= alpha_target``
    over the same configurations (``models.design.initial``; one design per bandwidth
    scale tried; only ``alpha*`` changes between the radii)."""
    from posfb.models.design import (
        ControllerConfig,
        NonlinearTorqueConfig,
        PidGains,
        cached_design,
    )
    from posfb.models.design.configurations import CONFIGURATION_SPACING, path_configurations
    from posfb.models.design.initial import (
        BANDWIDTH_SCALES,
        CONFIGURATION_GAIN_MARGIN,
        alpha_target,
        filter_pole,
        h_gamma,
        largest_alpha_star,
        largest_bandwidth_scale,
        lqr_weights,
        pid_gains,
    )
    from posfb.models.design.loop_context import LoopContext
    from posfb.models.design.synthesis import plant_spectral_radii
    from posfb.models.nominal import UrdfNominal, nominal_model
    from posfb.models.trajectory import WaveTrajectory

    n = len(facts.joints)
    pid = pid_gains(settings.sample_time, facts.M0, settings.encoder_counts,
                    settings.voltage_limit)  # fmt: skip
    filter_a = filter_pole(settings.sample_time)
    gamma = h_gamma([w.frequency for w in fitted.waves])
    nominal = UrdfNominal(str(settings.urdf), settings.description)
    context = LoopContext(nominal, settings.sample_time)  # the rules' design inputs
    model = nominal_model(nominal)
    configurations = path_configurations(
        model, WaveTrajectory(fitted.waves), settings.duration, CONFIGURATION_SPACING
    )
    masses = configurations.masses  # M*(q) at each configuration, computed once
    lightest = next(M for c, M in zip(configurations.configurations, configurations.masses,
                                      strict=True) if c.role == "lightest")  # fmt: skip

    def config_at(scale: float) -> ControllerConfig:
        return ControllerConfig(
            context=context,
            lqr=lqr_weights(facts.M0, settings.sample_time, scale).lqr(),
            nonlinear=NonlinearTorqueConfig(
                A_zeta=-gamma * np.eye(n), B_zeta=gamma * np.eye(n), C_zeta=np.eye(n),
                filter_a=filter_a,
            ),
            pid=PidGains(Kp=pid.Kp, Kv=pid.Kv, KI=pid.KI),
        )  # fmt: skip

    def lin_lc_passes(scale: float) -> bool:
        radii = plant_spectral_radii(
            cached_design(config_at(scale)),
            model,
            masses=(*masses, lightest / CONFIGURATION_GAIN_MARGIN),
        )
        return radii["sampled_data_lin_lc"] < 1.0

    scale = largest_bandwidth_scale(lin_lc_passes) or BANDWIDTH_SCALES[-1]
    weights = lqr_weights(facts.M0, settings.sample_time, scale)
    config = config_at(scale)
    design = cached_design(config)

    def radius(alpha_star: float) -> float:
        changed = replace(design, config=config.with_alpha_star(alpha_star))
        return plant_spectral_radii(changed, model, masses=masses)["sampled_data"]

    radius_lin_lc = plant_spectral_radii(design, model, masses=masses)["sampled_data_lin_lc"]
    cap = config.nonlinear.alpha_star
    return DesignedControllers(
        weights=weights,
        filter_a=filter_a,
        gamma=gamma,
        alpha=largest_alpha_star(radius, cap, alpha_target(radius_lin_lc)),
        pid=pid,
        radius_lin_lc=radius_lin_lc,
        radius_at_cap=radius(cap),
        eigenvalue_range=configurations.eigenvalue_range(),
    )


# --- the file ----------------------------------------------------------------------


def scenario_path(urdf: Path, out: Path) -> str:
    """How the scenario names ``urdf``: ``package://posfb/NAME`` for a shipped arm, a
    path relative to the scenario's folder when the URDF lies inside it (the two travel
    together), the absolute path otherwise (diagrams.resolve reads relative paths from
    the scenario file's folder)."""
    from posfb.diagrams.scenario import SHIPPED_PREFIX
    from posfb.models.plant import DEFAULT_URDF

    target, folder = urdf.resolve(), out.resolve().parent
    if target.parent == DEFAULT_URDF.parent.resolve():
        return f"{SHIPPED_PREFIX}{target.name}"
    if target.is_relative_to(folder):
        return os.path.relpath(target, folder)
    return str(target)


def welded(settings: Settings) -> tuple:
    """The joints the description welds (``models.description.Weld``), the automatic ones
    included, so that the scenario states every position."""
    from posfb.models.description import prepare_urdf

    return prepare_urdf(settings.urdf, settings.description).welds


def _numbers(values: object, digits: int = 4) -> str:
    return ", ".join(f"{float(v):.{digits}g}" for v in np.ravel(values))


def build_scenario(settings: Settings, facts: ArmFacts, fitted: FittedTrajectory,
                   designed: DesignedControllers):  # fmt: skip
    """The ``diagrams.scenario.Scenario`` of the derived settings."""
    from posfb.diagrams.scenario import (
        DriveSettings,
        PlantSettings,
        Scenario,
        UrdfModel,
        Wave,
        WaveJoint,
    )
    from posfb.diagrams.sections import Actuator, Sensor, TimingSection
    from posfb.models.controllers import kind_of
    from posfb.models.design.settings import DiagonalH, LinLc, Pid, Proposed

    n = len(facts.joints)
    path = scenario_path(settings.urdf, settings.out)
    w = designed.weights
    matrices = w.lqr()
    lqr = {
        "Q1": [list(row) for row in matrices.Q1],
        "Q2": [list(row) for row in matrices.Q2],
        "R": [list(row) for row in matrices.R],
        "lambdas": list(w.lambdas),
    }
    sensor = Sensor()
    return Scenario(
        plant=PlantSettings(
            urdf=path,
            package_paths=[
                scenario_path(Path(folder), settings.out)
                for folder in settings.description.package_paths
            ],
            weld={w.joint: w.position for w in welded(settings)},
            drives=DriveSettings(
                **{
                    name: None if values is None else list(values)
                    for name in DRIVE_FIELDS
                    if (values := getattr(settings.description.drives, name)) is not None
                }
            ),
        ),
        nominal_model=UrdfModel(urdf=path),
        trajectory=Wave(
            joints=[
                WaveJoint(w.offset, w.amplitude, w.wave_amplitude, w.frequency)
                for w in fitted.waves
            ]
        ),  # fmt: skip
        timing=TimingSection(sample_time=settings.sample_time, duration=settings.duration),
        sensor=replace(
            sensor,
            encoder_counts=[settings.encoder_counts] * n,
            zero_offset=sensor.zero_offset * n
            if len(sensor.zero_offset) == 1
            else sensor.zero_offset,
            noise_std=sensor.noise_std * n if len(sensor.noise_std) == 1 else sensor.noise_std,
        ),  # fmt: skip
        actuator=Actuator(voltage_limit=[settings.voltage_limit] * n),
        controller=Proposed(
            **lqr,
            alpha_star=designed.alpha.alpha_star,
            H=DiagonalH(gamma=[designed.gamma] * n),
            filter_a=designed.filter_a,
        ),
        controllers={
            kind_of(LinLc): LinLc(**lqr),
            kind_of(Pid): Pid(
                Kp=list(designed.pid.Kp), Kv=list(designed.pid.Kv), KI=list(designed.pid.KI)
            ),  # fmt: skip
        },
    )


def _written_kinds() -> tuple[str, str, str]:
    """The kinds of the entries the file holds, as the scenario names them: PID and Lin+LC
    (named entries) and the paper's controller (``controller:``)."""
    from posfb.models.controllers import kind_of
    from posfb.models.design.settings import LinLc, Pid, Proposed

    return kind_of(Pid), kind_of(LinLc), kind_of(Proposed)


def comments(settings: Settings, facts: ArmFacts, fitted: FittedTrajectory,
             designed: DesignedControllers) -> dict[str, list[str]]:  # fmt: skip
    """Comment lines to write above each dotted key of the scenario: the rule of each
    derived setting and the numbers it came from."""
    from posfb.models.design.initial import (
        filter_pole_rule,
        h_gamma_rule,
        trajectory_rule,
    )

    pid, lin_lc, _ = _written_kinds()

    return {
        "plant": [
            f"The arm {settings.urdf.name} ({len(facts.joints)} joints: "
            f"{', '.join(facts.joints)}), its path relative to this file's folder,",
            "absolute, or package://posfb/ for a shipped arm.",
        ],
        "plant.package_paths": [
            "Folders that resolve the file's package:// meshes (--package-path; also",
            "ROS_PACKAGE_PATH and the file's own ancestor folders).",
        ],
        "plant.weld": [
            "Joints that are not the arm's, welded at these positions (rad or m): "
            + ", ".join(f"{w.joint} ({w.reason})" for w in welded(settings))
            + "."
        ],
        "plant.drives": [
            "Each arm joint's drive, where the file has no posfb/Drake element for it",
            "(models/drive_rules.py); replace a derived value with the datasheet's.",
        ],
        **{f"plant.drives.{name}": settings.derived.rules(name) for name in DRIVE_FIELDS},
        "nominal_model": ["What the controllers believe: the same URDF, computed by Drake."],
        "trajectory": trajectory_rule(
            facts.lower,
            facts.upper,
            facts.free,
            fitted.scale,
            fitted.peak,
            settings.voltage_limit,
        ),  # fmt: skip
        "timing": [
            f"T_s = {settings.sample_time:g} s and duration {settings.duration:g} s "
            "(--sample-time, --duration; their defaults are the paper's)."
        ],  # fmt: skip
        "sensor": [f"--encoder-counts {settings.encoder_counts} on every joint."],
        "actuator": [f"--voltage-limit {settings.voltage_limit:g} V on every joint."],
        "controller": [
            "The paper's controller (Eq. 3), its settings derived from this arm's nominal",
            f"M0* diagonal ({_numbers(np.diag(facts.M0))} V s^2/rad) and T_s; B* diagonal "
            f"({_numbers(np.diag(facts.B))} V s/rad)",
            "does not enter the rules (the LQR accounts for it). models/design/initial.py "
            "states every rule.",
        ],
        "controller.Q1": designed.weights.rule(),
        "controller.alpha_star": designed.alpha.rule(designed.radius_at_cap, designed.radius_lin_lc)
        + ([f"NOT MET: {designed.reason()}"] if designed.reason() else []),
        "controller.H": h_gamma_rule(designed.gamma),
        "controller.filter_a": filter_pole_rule(settings.sample_time),
        "controller.bounds": ["Assumption 1: the default, half of each nominal norm."],
        "controllers": [
            f"Named entries: --controller {lin_lc} and --controller {pid}, and posfb compare."
        ],
        f"controllers.{lin_lc}": ["Lin+LC (Eq. 4 + 13) with the same LQR weights."],
        f"controllers.{pid}": designed.pid.rule(),
    }


#: A ``key:`` line of a dumped scenario (``diagrams.scenario.dump_scenario``'s form).
_KEY = re.compile(r"^( *)([A-Za-z_][A-Za-z0-9_]*):")


def annotate(text: str, notes: dict[str, list[str]]) -> str:
    """``text`` (a dumped scenario) with the comment lines of ``notes`` above the line of
    each dotted key, indented as that line."""
    lines, keys = [], []
    for line in text.splitlines():
        match = _KEY.match(line)
        if match:
            depth = len(match.group(1)) // 2
            keys[depth:] = [match.group(2)]
            for note in notes.get(".".join(keys), []):
                lines.append(f"{match.group(1)}# {note}")
        lines.append(line)
    return "\n".join(lines) + "\n"


def header(settings: Settings) -> str:
    """The file's first comment: what wrote it and how to use it."""
    return (
        f"# A scenario for {settings.urdf.name}, written by posfb scenario init with\n"
        f"#   --sample-time {settings.sample_time:g} --encoder-counts {settings.encoder_counts} "
        f"--voltage-limit {settings.voltage_limit:g} --duration {settings.duration:g}\n"
        "# Every derived setting carries its rule and numbers; a starting point, not a tuned\n"
        "# design. Check and run it:\n"
        f"#   posfb scenario check {settings.out.name}\n"
        f"#   posfb compare --scenario {settings.out.name} --controllers "
        f"{','.join(_written_kinds())}\n"
    )


@dataclass(frozen=True)
class InitResult:
    """What was written, with the numbers a user wants to see at once."""

    path: Path
    joints: int
    peak_fraction: float
    scale: float
    alpha_star: float
    radius: float
    radius_lin_lc: float
    bandwidth_scale: float = 1.0
    reason: str = ""


def write_scenario(options: InitOptions, log: Callable[[str], None] = lambda _: None
                   ) -> InitResult:  # fmt: skip
    """Derive, write and reload the scenario of ``options`` (module docstring)."""
    from posfb.diagrams.resolve import load_scenario
    from posfb.diagrams.scenario import dump_scenario

    settings = settings_of(options)
    facts = arm_facts(settings.urdf, settings.description)
    fitted = fit_trajectory(settings, facts)
    designed = design_controllers(settings, facts, fitted)
    scenario = build_scenario(settings, facts, fitted, designed)
    text = header(settings) + annotate(
        dump_scenario(scenario), comments(settings, facts, fitted, designed)
    )
    with atomic_file(settings.out) as staging:  # nothing is left behind on a failure
        staging.write_text(text)
        load_scenario(staging)  # posfb's loader accepts what it will read
    return InitResult(
        path=settings.out,
        joints=len(facts.joints),
        peak_fraction=float(np.max(fitted.peak) / settings.voltage_limit),
        scale=fitted.scale,
        alpha_star=designed.alpha.alpha_star,
        radius=designed.alpha.radius,
        radius_lin_lc=designed.radius_lin_lc,
        bandwidth_scale=designed.weights.scale,
        reason=designed.reason(),
    )
