"""The Monte-Carlo study: a YAML file loaded into typed dataclasses and validated.

A study names the distribution of every physical parameter of the URDF plant
(``models.plant.ArmParameters``), the encoder resolutions, the controllers to
compare, the simulated duration, the number of samples and the seed::

    seed: 2013
    samples: 200
    duration: 20.0
    controllers: [proposed, lin_lc, pid]
    encoder_counts: [20000]
    parameters:
      link_mass: [!Uniform {min: -0.2, max: 0.2, relative: true}]
      payload_mass: !Uniform {min: 0.0, max: 0.5}

Distributions are written with Drake's names and keys
(``drake/common/schema/stochastic.h``; an untagged map is a ``Uniform``):

* ``!Uniform {min, max}``: uniform on ``[min, max]``;
* ``!Gaussian {mean, stddev}``: normal; posfb's ``min``/``max`` truncate it
  (drawn by rejection);
* ``!UniformDiscrete {values}``: one of the values, each equally likely;
* ``!Deterministic {value}``: always ``value``; posfb reads an omitted ``value`` as
  the base value (the URDF's).

posfb adds ``relative: true``, which reads the numbers as fractions of the URDF's
value ``v0`` (the draw ``x`` gives ``v0 (1 + x)``: ``min: -0.2, max: 0.2`` is +-20 %);
``relative: false`` (the default) reads them as the value itself in SI units.

The per-joint parameters take a list of one distribution (every joint drawing its
own value from it) or one per joint of the study's arm.

The closed loop each sample runs is a scenario (``diagrams.scenario``): ``base``,
built when the file is loaded from ``scenario`` (a scenario file, relative to the
study file; default: the paper's nominal scenario) and ``settings`` (``KEY=VALUE``
as for ``--set``). ``draws`` gives any other numeric scenario key a distribution::

    scenario: ../scenarios/paper_nominal.yaml
    settings: [controller.filter_a=200]
    draws:
      timing.sample_time: !UniformDiscrete {values: [0.005, 0.01]}
      sensor.encoder_counts: !UniformDiscrete {values: [4096, 20000]}
      sensor.noise_std[1]: !Uniform {min: 0.0, max: 1e-4}
      trajectory.joints[0].frequency: !Uniform {min: -0.1, max: 0.1, relative: true}

Integer keys need ``!UniformDiscrete`` or ``!Deterministic``; ``relative`` reads a
draw as a fraction of the base value; a per-joint key without ``[j]`` gives both
joints the same value. The physical plant stays under ``parameters`` (one place for
it). Every drawn value is recorded with the
sample (its ``parameters``, under the dotted key).

``overrides`` pins parameters of chosen samples to absolute values after the
draw (the other draws are unchanged): to reproduce one plant of a study or to
see how a pathological plant is recorded (the divergence test uses it).

Drake's ``yaml_load_typed`` refuses unknown keys and wrongly typed values; it
assigns fields one at a time, so these schema classes cannot be frozen: treat a
loaded ``Study`` as read-only. ``validate_study`` then checks every value,
naming the key.
"""

import copy
import dataclasses
import hashlib
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import ClassVar

import numpy as np
from pydrake.common.yaml import yaml_dump_typed

from posfb.diagrams.arm import ArmIdentity, arm_identity
from posfb.diagrams.resolve import (
    LoadedScenario,
    load_scenario,
    resolve,
    resolve_path,
    self_contained,
    with_arm_defaults,
)
from posfb.diagrams.scenario import (
    ControllerSection,
    Python,
    Scenario,
    apply_setting,
    controller_kind,
    get_setting,
    scenario_description,
    scenario_joints,
    with_controller,
)
from posfb.diagrams.yaml_schema import load_typed, read_text
from posfb.models.controllers import PAPER_CONTROLLERS, REGISTRY, require_design
from posfb.models.description import Description
from posfb.models.design import ControllerConfig
from posfb.models.plant import JOINT_PARAMETERS, PARAMETER_UNITS

#: Parameters that must be > 0 (the others must be >= 0), as ``ArmParameters`` requires.
POSITIVE_PARAMETERS = ("link_mass", "motor_constant")

#: The ``plant.`` keys ``draws:`` takes (the drive train's, ``models.friction`` and
#: ``models.gear``); the rest of the physical plant is drawn under ``parameters:``.
DRAWN_PLANT_KEYS = (
    "plant.friction.", "plant.gear_stiffness", "plant.gear_damping", "plant.backlash"
)  # fmt: skip

#: Smallest probability a truncated normal may keep (rejection sampling stays cheap).
MIN_TRUNCATED_MASS = 1e-3


@dataclass
class Uniform:
    """Uniform on ``[min, max]`` (Drake's ``!Uniform``); fractions of the base value
    when ``relative``."""

    min: float = 0.0
    max: float = 0.0
    relative: bool = False

    #: Keys of posfb's earlier spelling and the key that replaced each.
    RENAMED: ClassVar[dict[str, str]] = {"low": "min", "high": "max"}


@dataclass
class Gaussian:
    """Normal ``N(mean, stddev^2)`` (Drake's ``!Gaussian``), truncated to ``[min, max]``
    where given (posfb's keys, like ``relative``)."""

    mean: float = 0.0
    stddev: float = 0.0
    relative: bool = False
    min: float | None = None
    max: float | None = None

    RENAMED: ClassVar[dict[str, str]] = {"std": "stddev", "low": "min", "high": "max"}
    #: Tags of posfb's earlier spelling of this distribution.
    FORMERLY: ClassVar[tuple[str, ...]] = ("Normal",)


@dataclass
class Deterministic:
    """Always ``value`` (Drake's ``!Deterministic``, absolute); posfb reads an omitted
    ``value`` as the base value (the URDF's, or the scenario's)."""

    value: float | None = None

    FORMERLY: ClassVar[tuple[str, ...]] = ("Fixed",)


@dataclass
class UniformDiscrete:
    """One of ``values``, each equally likely (Drake's ``!UniformDiscrete``)."""

    values: list[float] = field(default_factory=list)


Distribution = Uniform | Gaussian | Deterministic | UniformDiscrete


def _nominal() -> list[Distribution]:
    return [Deterministic()]


def _for_joint(self: object, name: str, joint: int) -> Distribution:
    """The distribution of ``name`` at ``joint`` (0-based; one entry serves all)."""
    entries = getattr(self, name)
    return entries[joint] if len(entries) > 1 else entries[0]


#: One entry per physical parameter of ``ArmParameters`` (made from its field list,
#: ``JOINT_PARAMETERS``, so that the names are written once); each per-joint list holds
#: one distribution (every joint draws its own value from it) or one per joint.
#: Omitted: the URDF value.
ParameterDistributions = dataclasses.make_dataclass(
    "ParameterDistributions",
    [
        *((name, list[Distribution], field(default_factory=_nominal)) for name in JOINT_PARAMETERS),
        ("payload_mass", Distribution, field(default_factory=Deterministic)),
    ],  # fmt: skip
    namespace={
        "__module__": __name__,
        "__doc__": "A distribution per physical parameter of ArmParameters.",
        "for_joint": _for_joint,
    },
)


@dataclass
class Posterior:
    """Correlated draws of the physical plant: ``log(p / p_base) ~ N(mean, covariance)``
    over ``keys`` (``ArmParameters`` entries as ``link_mass[0]``, one per joint entry),
    with ``p_base`` the base scenario's true arm; the Laplace approximation of an
    identification's uncertainty (``posfb identify --study-out``). Drawn after
    ``parameters`` (the keys it names replace their draws), before ``overrides``; only
    with ``sampling: random``."""

    keys: list[str] = field(default_factory=list)
    mean: list[float] = field(default_factory=list)
    covariance: list[list[float]] = field(default_factory=list)

    def entries(self) -> list[tuple[str, int]]:
        """``keys`` as ``(field, joint)``."""
        out = []
        for key in self.keys:
            name, _, rest = key.partition("[")
            out.append((name, int(rest.rstrip("]")) if rest.rstrip("]").isdigit() else -1))
        return out


@dataclass
class SampleOverride:
    """Absolute values for sample ``sample``: keys are ``ArmParameters`` fields (one
    value per joint for a per-joint field, one for ``payload_mass``) or
    ``encoder_counts``."""

    sample: int = 0
    values: dict[str, list[float]] = field(default_factory=dict)


@dataclass
class Study:
    """A Monte-Carlo study (module docstring).

    The base scenario is ``scenario`` (a file, relative to the study file; empty: the
    paper's nominal scenario) with ``settings`` (``KEY=VALUE``) applied; loading folds
    both into ``base``, the complete scenario every sample starts from, so that the
    canonical study text is self-contained. ``duration`` (s, a whole number of
    periods), ``divergence_bound`` (rad) and ``alpha_star`` set ``timing.duration``,
    ``timing.divergence_bound`` and ``controller.alpha_star`` of the base where given;
    ``encoder_counts`` lists the resolutions a sample draws from (uniformly; one entry
    fixes it; 0 is an ideal sensor; empty: the scenario's). ``draws`` gives any other
    numeric scenario key a distribution (``relative: true`` reads it as a fraction of
    the base value; a per-joint key without ``[j]`` gives every joint the same draw).
    ``sampling`` is the design the draws follow (``SAMPLING_DESIGNS``,
    ``analysis.uncertainty.sampling``). ``controllers`` lists what every sample runs, by
    name: a registered kind (the base scenario's entry switched to it,
    ``diagrams.scenario.with_controller``) or a named entry of the base scenario's
    ``controllers``; ``entries`` adds named entries of its own (folded into the base's
    ``controllers`` when the study is loaded), e.g. the paper's controller twice::

        controllers: [proposed, proposed_275, pid]
        entries:
          proposed_275: !Proposed {alpha_star: 2.75}
    """

    seed: int = 0
    samples: int = 100
    sampling: str = "random"
    scenario: str = ""
    settings: list[str] = field(default_factory=list)
    base: Scenario = field(default_factory=Scenario)
    duration: float | None = None
    divergence_bound: float | None = None
    controllers: list[str] = field(default_factory=lambda: list(PAPER_CONTROLLERS))
    encoder_counts: list[int] = field(default_factory=list)
    parameters: ParameterDistributions = field(default_factory=ParameterDistributions)
    draws: dict[str, Distribution] = field(default_factory=dict)
    overrides: list[SampleOverride] = field(default_factory=list)
    posterior: Posterior | None = None
    alpha_star: float | None = None
    entries: dict[str, ControllerSection] = field(default_factory=dict)

    def draws_anything(self) -> bool:
        """Whether two samples can differ: some distribution is not a single value."""
        physical = [
            *(d for name in JOINT_PARAMETERS for d in getattr(self.parameters, name)),
            self.parameters.payload_mass,
        ]
        return (
            len(set(self.encoder_counts)) > 1
            or any(is_random(d) for d in physical)
            or any(is_random(d) for d in self.draws.values())
            or (self.posterior is not None and bool(self.posterior.keys))
        )

    def base_scenario(self) -> Scenario:
        """``base`` with the study's ``duration``, ``divergence_bound`` and ``alpha_star``."""
        scenario = self.base
        for key, value in (
            ("timing.duration", self.duration),
            ("timing.divergence_bound", self.divergence_bound),
            ("controller.alpha_star", self.alpha_star),
        ):
            if value is not None:
                scenario = apply_setting(scenario, f"{key}={value!r}")
        return scenario

    def controller_config(self) -> ControllerConfig:
        """The controllers' design in the base scenario (the paper's, with the study's
        ``alpha_star`` where it sets one)."""
        return resolve(LoadedScenario(self.base_scenario(), Path.cwd())).config.design


def is_random(distribution: Distribution) -> bool:
    """Whether ``distribution`` can draw more than one value."""
    if isinstance(distribution, Deterministic):
        return False
    if isinstance(distribution, UniformDiscrete):
        return len(set(distribution.values)) > 1
    if isinstance(distribution, Uniform):
        return distribution.min != distribution.max
    return distribution.stddev > 0.0 and distribution.min != distribution.max


def slots(joints: int) -> tuple[tuple[str, int], ...]:
    """The scalars of one sample of an arm of ``joints`` joints, in stream order:
    (name, joint). A slot's position seeds its stream, so this order is fixed (for
    two joints it is the order every earlier store was drawn in)."""
    return (
        *((name, joint) for name in JOINT_PARAMETERS for joint in range(joints)),
        ("payload_mass", 0),
        ("encoder_counts", 0),
    )


def study_joints(study: Study) -> int:
    """``n``: the joints of the study's plant URDF with what its scenario adds to it
    (welds; its paths are absolute), checked once per process (every sample asks)."""
    key = (study.base.plant.urdf, scenario_description(study.base, Path.cwd()))
    if key not in _STUDY_JOINTS:
        _STUDY_JOINTS[key] = scenario_joints(study.base, Path.cwd())
    return _STUDY_JOINTS[key]


#: ``study_joints``' answers by (plant URDF, description).
_STUDY_JOINTS: dict[tuple[str, Description], int] = {}


#: The sampling designs a study may name (``Study.sampling``).
SAMPLING_DESIGNS = ("random", "latin_hypercube", "sobol", "saltelli")

#: Designs built for a given number of rows: ``samples`` belongs to the study's identity.
SIZED_DESIGNS = ("latin_hypercube",)


@dataclass(frozen=True)
class VariedScalar:
    """One scalar that differs between samples: its ``slot``, the ``key`` it is recorded
    under in a sample's ``parameters`` (with ``joint`` for a per-joint parameter) and
    its column name with unit in exports."""

    slot: int
    key: str
    joint: int | None
    column: str


def varied_scalars(study: Study) -> tuple[VariedScalar, ...]:
    """The scalars whose distribution can draw more than one value, in slot order: the
    dimensions of a QMC design, the columns of an export, the inputs of a sensitivity
    analysis."""
    varied = []
    layout = slots(study_joints(study))
    for slot, (name, joint) in enumerate(layout):
        if name == "payload_mass":
            if is_random(study.parameters.payload_mass):
                varied.append(VariedScalar(slot, name, None, f"{name}_kg"))
        elif name == "encoder_counts":
            if len(set(study.encoder_counts)) > 1:
                varied.append(VariedScalar(slot, name, None, name))
        elif is_random(study.parameters.for_joint(name, joint)):
            column = f"{name}_{joint + 1}_{PARAMETER_UNITS[name]}"
            varied.append(VariedScalar(slot, name, joint, column))
    for position, (key, distribution) in enumerate(study.draws.items()):
        if is_random(distribution):
            varied.append(VariedScalar(len(layout) + position, key, None, key))
    return tuple(varied)


def saltelli_rows(dimensions: int) -> int:
    """Rows of a Saltelli design per base sample (first and total order): ``d + 2``."""
    return dimensions + 2


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise ValueError(message)


def _finite(key: str, value: float) -> None:
    _require(
        isinstance(value, int | float) and math.isfinite(value),
        f"{key} = {value!r}; a finite number is required",
    )


def _support(key: str, distribution: Distribution) -> tuple[float, float]:
    """The interval the draws ``x`` of ``distribution`` can take (validated)."""
    if isinstance(distribution, UniformDiscrete):
        _require(len(distribution.values) > 0, f"{key}.values is empty; give at least one")
        for i, value in enumerate(distribution.values):
            _finite(f"{key}.values[{i}]", value)
        return min(distribution.values), max(distribution.values)
    if isinstance(distribution, Uniform):
        _finite(f"{key}.min", distribution.min)
        _finite(f"{key}.max", distribution.max)
        _require(
            distribution.min <= distribution.max,
            f"{key}: min = {distribution.min!r} > max = {distribution.max!r}; "
            "min <= max is required",
        )
        return distribution.min, distribution.max
    if isinstance(distribution, Gaussian):
        _finite(f"{key}.mean", distribution.mean)
        _finite(f"{key}.stddev", distribution.stddev)
        _require(
            distribution.stddev >= 0.0,
            f"{key}.stddev = {distribution.stddev!r}; stddev >= 0 is required",
        )
        low = -math.inf if distribution.min is None else distribution.min
        high = math.inf if distribution.max is None else distribution.max
        for name in ("min", "max"):
            if getattr(distribution, name) is not None:
                _finite(f"{key}.{name}", getattr(distribution, name))
        _require(low <= high, f"{key}: min = {low!r} > max = {high!r}; min <= max is required")
        if distribution.stddev == 0.0:
            _require(
                low <= distribution.mean <= high,
                f"{key}: mean = {distribution.mean!r} lies outside [min, max] with stddev = 0",
            )
        else:
            import scipy.stats  # on use: a command that reads no study pays nothing for it

            norm = scipy.stats.norm(distribution.mean, distribution.stddev)
            kept = norm.cdf(high) - norm.cdf(low)
            _require(
                kept >= MIN_TRUNCATED_MASS,
                f"{key}: [min, max] keeps {kept:.2g} of the normal's probability; "
                f"at least {MIN_TRUNCATED_MASS:g} is required",
            )
        return low, high
    _finite(f"{key}.value", distribution.value)
    return distribution.value, distribution.value


def _check_physical(key: str, name: str, distribution: Distribution) -> None:
    """Refuse a distribution that can draw a value ``ArmParameters`` would refuse."""
    if isinstance(distribution, Deterministic) and distribution.value is None:
        return  # the URDF value, valid by construction
    low, _ = _support(key, distribution)
    relative = getattr(distribution, "relative", False)
    positive = name in POSITIVE_PARAMETERS
    if relative:
        _require(
            name != "payload_mass",
            f"{key}: relative to the URDF payload of 0 kg is always 0; use relative: false (kg)",
        )
        ok = low > -1.0 if positive else low >= -1.0
        bound = "> -1 (a value > 0)" if positive else ">= -1 (a value >= 0)"
    else:
        ok = low > 0.0 if positive else low >= 0.0
        bound = "> 0" if positive else ">= 0"
    hint = "; truncate the normal with min:" if isinstance(distribution, Gaussian) else ""
    _require(
        ok,
        f"{key}: the range reaches {low!r}{' (relative)' if relative else ''}, "
        f"which gives a negative or zero {name}; every draw must be {bound}{hint}",
    )


def _check_parameters(parameters: ParameterDistributions, joints: int) -> None:
    for name in JOINT_PARAMETERS:
        entries = getattr(parameters, name)
        _require(
            len(entries) in (1, joints),
            f"parameters.{name} has {len(entries)} entries; "
            f"1 (all joints) or {joints} (one per joint) are required",
        )
        for j, distribution in enumerate(entries):
            _check_physical(f"parameters.{name}[{j}]", name, distribution)
    _check_physical("parameters.payload_mass", "payload_mass", parameters.payload_mass)


def _check_override(position: int, override: SampleOverride, joints: int) -> None:
    key = f"overrides[{position}]"
    _require(override.sample >= 0, f"{key}.sample = {override.sample!r}; an index >= 0 is required")
    allowed = (*JOINT_PARAMETERS, "payload_mass", "encoder_counts")
    for name, values in override.values.items():
        _require(name in allowed, f"{key}.values has unknown key {name!r}; one of {allowed}")
        size = joints if name in JOINT_PARAMETERS else 1
        _require(
            len(values) == size,
            f"{key}.values.{name} has {len(values)} entries; {size} required",
        )
        for j, value in enumerate(values):
            _finite(f"{key}.values.{name}[{j}]", value)
            if name == "encoder_counts":
                _require(
                    value >= 0 and float(value).is_integer(),
                    f"{key}.values.encoder_counts = {value!r}; an integer >= 0 is required",
                )
            elif name in POSITIVE_PARAMETERS:
                _require(value > 0, f"{key}.values.{name}[{j}] = {value!r}; > 0 is required")
            else:
                _require(value >= 0, f"{key}.values.{name}[{j}] = {value!r}; >= 0 is required")


def _extremes(distribution: Distribution, base: float) -> list[float]:
    """The values at the ends of what ``distribution`` can draw around ``base``."""
    if isinstance(distribution, UniformDiscrete):
        return [float(v) for v in distribution.values]
    if isinstance(distribution, Deterministic):
        return [base if distribution.value is None else float(distribution.value)]
    low, high = _support("", distribution)
    ends = [v for v in (low, high) if math.isfinite(v)] or [distribution.mean]
    return [base * (1.0 + v) if distribution.relative else v for v in ends]


def _check_draws(study: Study, base: Scenario) -> None:
    """Every key of ``draws`` names a numeric scenario key, and the extremes of its
    distribution give a valid scenario."""
    for key, distribution in study.draws.items():
        where = f"draws.{key}"
        _require(
            not key.startswith("plant.") or key.startswith(DRAWN_PLANT_KEYS),
            f"{where}: the physical plant is drawn under parameters: (payload_mass and the "
            "ArmParameters names); draws: takes the other scenario keys (and the drive "
            "train's: "
            + ", ".join(f"{k}NAME" if k.endswith(".") else k for k in DRAWN_PLANT_KEYS)
            + ")",
        )
        current = get_setting(base, key)
        values = current if isinstance(current, list) else [current]
        numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
        _require(
            bool(values) and numeric,
            f"{where}: {key} = {current!r} is not a number; draws need a numeric key",
        )
        integer = all(isinstance(v, int) for v in values)
        _support(where, distribution)
        if integer:
            _require(
                isinstance(distribution, UniformDiscrete | Deterministic),
                f"{where}: {key} is an integer; use !UniformDiscrete {{values: [...]}} or "
                "!Deterministic",
            )
        for value in _extremes(distribution, float(values[0])):
            if integer:
                _require(float(value).is_integer(), f"{where}: {value!r} is not an integer")
                value = int(value)
            try:
                scenario = apply_setting(base, f"{key}={value!r}")
                _check_controllers(study, scenario)
            except ValueError as error:
                raise ValueError(f"{where} can draw {value!r}: {error}") from None


def _check_controllers(study: Study, scenario: Scenario) -> None:
    """``scenario`` is valid and every controller of the study accepts its design: each
    is resolved on it (a plug-in is built once, so a bad setting is refused)."""
    for controller in study.controllers:
        config = resolve(LoadedScenario(with_controller(scenario, controller), Path.cwd())).config
        require_design(config.controller, config.design)


#: The most samples a study of a design built whole in memory (``WHOLE_DESIGNS``) may
#: ask for, refused before any work: a Latin-hypercube, Sobol' or Saltelli design takes
#: samples x varied scalars x 8 bytes (10^12 samples of 3 scalars would take 21.8 TiB),
#: and at about a second a sample a million samples is already days of one core; the
#: statistics of a study need far fewer (the standard error of a probability at 10^6
#: samples is below 5e-4). ``random`` sampling draws each sample from its index on use,
#: so its memory stays flat at any count and it has no ceiling.
MAX_SAMPLES = 1_000_000

#: The sampling designs built whole in memory (every design but ``random``).
WHOLE_DESIGNS = tuple(design for design in SAMPLING_DESIGNS if design != "random")


def validate_study(study: Study) -> Study:
    """Return ``study`` if every value is allowed; otherwise raise ``ValueError``
    naming the key, the value and what is allowed."""
    _require(
        isinstance(study.seed, int) and study.seed >= 0,
        f"seed = {study.seed!r}; an integer >= 0 is required",
    )
    _require(study.samples > 0, f"samples = {study.samples!r}; at least 1 sample is required")
    _require(
        study.samples <= MAX_SAMPLES or study.sampling not in WHOLE_DESIGNS,
        f"samples = {study.samples!r} with sampling: {study.sampling}; at most "
        f"{MAX_SAMPLES:,} samples are allowed for a design built whole in memory "
        "(sampling: random draws each sample on use, at any count)",
    )
    _require(
        study.sampling in SAMPLING_DESIGNS,
        f"sampling = {study.sampling!r}; one of {', '.join(SAMPLING_DESIGNS)} is required",
    )
    _require(
        not study.scenario and not study.settings,
        "scenario/settings are folded into base when a study file is loaded",
    )
    base = study.base_scenario()  # the scenario checks its own keys, naming them
    _require(len(study.controllers) > 0, "controllers is empty; name at least one controller")
    own = [controller_kind(base.controller)] if isinstance(base.controller, Python) else []
    allowed = [*REGISTRY, *own, *base.controllers]
    for name in study.controllers:
        _require(
            name in allowed,
            f"controllers has {name!r}; each must be one of {', '.join(allowed)}",
        )
    _require(
        len(set(study.controllers)) == len(study.controllers),
        f"controllers = {study.controllers!r} repeats a controller",
    )
    for counts in study.encoder_counts:
        _require(counts >= 0, f"encoder_counts has {counts!r}; integers >= 0 are required")
    _check_controllers(study, base)
    _check_parameters(study.parameters, study_joints(study))
    _check_draws(study, base)
    for position, override in enumerate(study.overrides):
        _check_override(position, override, study_joints(study))
    samples = [override.sample for override in study.overrides]
    _require(len(set(samples)) == len(samples), "overrides name a sample twice")
    if study.posterior is not None:
        _check_posterior(study.posterior, study_joints(study), study.sampling)
    if study.sampling == "saltelli":
        _check_saltelli(study)
    return study


def _check_posterior(posterior: Posterior, joints: int, sampling: str) -> None:
    """Keys of per-joint physical parameters, once each; a mean per key; a symmetric
    positive semi-definite covariance of that size; random sampling."""
    size = len(posterior.keys)
    _require(size > 0, "posterior.keys is empty; name at least one parameter")
    _require(
        sampling == "random",
        f"posterior with sampling = {sampling!r}; sampling: random is required (a "
        "correlated draw has no unit-cube design)",
    )
    for key, (name, joint) in zip(posterior.keys, posterior.entries(), strict=True):
        _require(
            name in JOINT_PARAMETERS and 0 <= joint < joints,
            f"posterior.keys has {key!r}; a per-joint parameter with its joint, e.g. "
            f"link_mass[0] ({', '.join(JOINT_PARAMETERS)}; joints 0..{joints - 1}), is required",
        )
    _require(len(set(posterior.keys)) == size, "posterior.keys names a parameter twice")
    _require(
        len(posterior.mean) == size and all(math.isfinite(m) for m in posterior.mean),
        f"posterior.mean has {len(posterior.mean)} entries; {size} finite values (one per "
        "key) are required",
    )
    matrix = np.asarray(posterior.covariance, dtype=float)
    _require(
        matrix.shape == (size, size) and bool(np.all(np.isfinite(matrix))),
        f"posterior.covariance must be {size} x {size} (one row per key), finite",
    )
    scale = max(1.0, float(np.abs(matrix).max()))
    _require(
        np.allclose(matrix, matrix.T, rtol=1e-9, atol=1e-15)
        and float(np.linalg.eigvalsh(matrix).min()) >= -1e-12 * scale,
        "posterior.covariance must be symmetric positive semi-definite",
    )


def _check_saltelli(study: Study) -> None:
    """A Saltelli design has ``N (d + 2)`` rows for ``N`` a power of 2 (Sobol' balance)."""
    dimensions = len(varied_scalars(study))
    _require(dimensions > 0, "sampling = 'saltelli' needs at least one varied parameter")
    rows = saltelli_rows(dimensions)
    base, extra = divmod(study.samples, rows)
    _require(
        extra == 0 and base > 0 and base & (base - 1) == 0,
        f"samples = {study.samples!r} with sampling = 'saltelli' over {dimensions} varied "
        f"parameters; N x {rows} with N a power of 2 is required (e.g. {16 * rows} = 16 x {rows})",
    )


def load_study(path: str | Path, arm: ArmIdentity | None = None) -> Study:
    """Load and validate a study file; every problem is one ``ValueError`` line. Its
    ``scenario`` (relative to the study's folder) and ``settings`` are folded into
    ``base``, with the scenario's own relative paths made absolute. With ``arm``, a
    study of another arm is refused before the study is validated
    (``require_study_arm``)."""
    path = Path(path)
    text = read_text(path, "study", missing=FileNotFoundError)
    return study_from_text(text, source=f"study {path}", folder=path.parent, arm=arm)


def study_from_text(
    text: str, source: str = "study", folder: Path | None = None, arm: ArmIdentity | None = None
) -> Study:
    """Parse and validate a study from YAML text (relative scenario paths are read from
    ``folder``, default the working directory; ``arm`` as for ``load_study``)."""
    return complete_study(load_typed(Study, text, source), source, folder, arm)


def complete_study(
    study: Study,
    source: str = "study",
    folder: Path | None = None,
    arm: ArmIdentity | None = None,
) -> Study:
    """A study as written (``scenario`` relative to ``folder``, default the working
    directory, and ``settings`` not yet applied) folded into its ``base`` and validated;
    every problem is one ``ValueError`` line starting with ``source``. With ``arm``, a
    study of another arm is refused right after the fold, before the validation's
    designs (``require_study_arm``)."""
    try:
        study = _fold_scenario(study, Path.cwd() if folder is None else folder)
        if arm is not None:
            require_study_arm(study, arm)
        return validate_study(study)
    except ValueError as error:
        raise ValueError(f"{source}: {error}") from None


def study_arm(study: Study) -> ArmIdentity:
    """The arm the study describes: its base scenario's plant (``diagrams.arm``)."""
    return arm_identity(study.base, Path.cwd())  # the base's paths are absolute


def require_study_arm(study: Study, arm: ArmIdentity) -> None:
    """Refuse (``ValueError``, one line naming both arms) a study whose base scenario's
    arm is not ``arm``."""
    own = study_arm(study)
    _require(
        own == arm,
        f"the study describes {own} and the scenario {arm}; a study of the scenario's arm "
        "is required",
    )


def _fold_scenario(study: Study, folder: Path) -> Study:
    """``study`` with its ``scenario`` file and ``settings`` folded into ``base``, made
    self-contained (absolute paths, a ``!Python`` controller's source stored)."""
    if study.scenario:
        _require(
            study.base == Scenario(),
            "scenario and base both given; name a scenario file or write base, not both",
        )
        try:
            loaded = load_scenario(resolve_path(study.scenario, folder), study.settings)
        except ValueError as error:
            raise ValueError(f"scenario: {error}") from None
    else:
        loaded = LoadedScenario(study.base, folder)
        for setting in study.settings:
            loaded.scenario = apply_setting(loaded.scenario, setting)
    loaded.scenario = copy.deepcopy(loaded.scenario)
    loaded.scenario.controllers = {**loaded.scenario.controllers, **study.entries}
    if study.entries:  # the study's own entries take what they leave out from the arm
        loaded.scenario = with_arm_defaults(loaded.scenario, resolve(loaded).context)
    return replace(study, scenario="", settings=[], base=self_contained(loaded), entries={})


def with_overrides(study: Study, samples: int | None = None, seed: int | None = None) -> Study:
    """``study`` with the command line's ``--samples`` / ``--seed`` applied (validated)."""
    changes = {k: v for k, v in (("samples", samples), ("seed", seed)) if v is not None}
    return validate_study(replace(study, **changes))


def canonical_text(study: Study) -> str:
    """The study as canonical YAML (every field, fixed order): what the store keeps and
    what the workers reload."""
    return yaml_dump_typed(study)


def identity(study: Study) -> str:
    """SHA-256 of the canonical study without ``samples``: results belong together iff
    the identities match (a resume may ask for more or fewer samples, since a sample's
    draw depends only on the seed and its index). A design built for its number of rows
    (``SIZED_DESIGNS``) keeps ``samples``: another count gives other plants."""
    sized = study.sampling in SIZED_DESIGNS
    text = canonical_text(study if sized else replace(study, samples=1))
    return hashlib.sha256(text.encode()).hexdigest()
