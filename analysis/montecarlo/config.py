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
      link_mass: [!Uniform {low: -0.2, high: 0.2, relative: true}]
      payload_mass: !Uniform {low: 0.0, high: 0.5}

Distributions (YAML tags; an untagged map is a ``Uniform``):

* ``!Uniform {low, high, relative}``: uniform on ``[low, high]``;
* ``!Normal {mean, std, relative, low, high}``: normal, truncated to
  ``[low, high]`` when either is given (drawn by rejection);
* ``!Fixed {value}``: always ``value``, or the URDF's value when omitted.

``relative: true`` reads the numbers as fractions of the URDF's value ``v0``
(the draw ``x`` gives ``v0 (1 + x)``: ``low: -0.2, high: 0.2`` is +-20 %);
``relative: false`` (the default) reads them as the value itself in SI units.
The per-joint parameters take a list of one distribution (used for both joints,
each joint drawing its own value) or two (joint 1, joint 2).

``overrides`` pins parameters of chosen samples to absolute values after the
draw (the other draws are unchanged): to reproduce one plant of a study or to
see how a pathological plant is recorded (the divergence test uses it).

Drake's ``yaml_load_typed`` refuses unknown keys and wrongly typed values; it
assigns fields one at a time, so these schema classes cannot be frozen: treat a
loaded ``Study`` as read-only. ``validate_study`` then checks every value,
naming the key.
"""

import hashlib
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import scipy.stats
from pydrake.common.yaml import yaml_dump_typed

from posfb.diagrams.closed_loop import DIVERGENCE_BOUND, ClosedLoopConfig
from posfb.diagrams.encoder import DEFAULT_ENCODER_COUNTS
from posfb.diagrams.yaml_schema import load_typed
from posfb.models.controllers import CONTROLLER_KINDS
from posfb.models.design import ControllerConfig

#: Per-joint physical parameters of ``ArmParameters`` (two values each), in draw order.
JOINT_PARAMETERS = (
    "link_mass",
    "link_com",
    "link_inertia",
    "rotor_inertia",
    "damping",
    "coulomb",
    "motor_constant",
)

#: Parameters that must be > 0 (the others must be >= 0), as ``ArmParameters`` requires.
POSITIVE_PARAMETERS = ("link_mass", "motor_constant")

#: Smallest probability a truncated normal may keep (rejection sampling stays cheap).
MIN_TRUNCATED_MASS = 1e-3


@dataclass
class Uniform:
    """Uniform on ``[low, high]`` (fractions of the URDF value when ``relative``)."""

    low: float = 0.0
    high: float = 0.0
    relative: bool = False


@dataclass
class Normal:
    """Normal ``N(mean, std^2)``, truncated to ``[low, high]`` where given."""

    mean: float = 0.0
    std: float = 0.0
    relative: bool = False
    low: float | None = None
    high: float | None = None


@dataclass
class Fixed:
    """Always ``value`` (absolute), or the URDF's value when ``value`` is omitted."""

    value: float | None = None


Distribution = Uniform | Normal | Fixed


def _nominal() -> list[Distribution]:
    return [Fixed()]


@dataclass
class ParameterDistributions:
    """One entry per physical parameter of ``ArmParameters``; each per-joint list holds
    one distribution (both joints) or two (joint 1, joint 2). Omitted: the URDF value."""

    link_mass: list[Distribution] = field(default_factory=_nominal)
    link_com: list[Distribution] = field(default_factory=_nominal)
    link_inertia: list[Distribution] = field(default_factory=_nominal)
    rotor_inertia: list[Distribution] = field(default_factory=_nominal)
    damping: list[Distribution] = field(default_factory=_nominal)
    coulomb: list[Distribution] = field(default_factory=_nominal)
    motor_constant: list[Distribution] = field(default_factory=_nominal)
    payload_mass: Distribution = field(default_factory=Fixed)

    def for_joint(self, name: str, joint: int) -> Distribution:
        """The distribution of ``name`` at ``joint`` (0 or 1)."""
        entries = getattr(self, name)
        return entries[joint] if len(entries) == 2 else entries[0]


@dataclass
class SampleOverride:
    """Absolute values for sample ``sample``: keys are ``ArmParameters`` fields (two
    values for a per-joint field, one for ``payload_mass``) or ``encoder_counts``."""

    sample: int = 0
    values: dict[str, list[float]] = field(default_factory=dict)


@dataclass
class Study:
    """A Monte-Carlo study (module docstring). ``duration`` (s) is a whole number of
    control periods (0.01 s); ``divergence_bound`` (rad) on ``|q~|`` ends a run as
    diverged (``diagrams.closed_loop``); ``encoder_counts`` lists the resolutions a
    sample draws from (uniformly; one entry fixes it; 0 is an ideal sensor);
    ``alpha_star`` overrides the paper's alpha* = 4 for a labelled study."""

    seed: int = 0
    samples: int = 100
    duration: float = 20.0
    divergence_bound: float = DIVERGENCE_BOUND
    controllers: list[str] = field(default_factory=lambda: list(CONTROLLER_KINDS))
    encoder_counts: list[int] = field(default_factory=lambda: [DEFAULT_ENCODER_COUNTS])
    parameters: ParameterDistributions = field(default_factory=ParameterDistributions)
    overrides: list[SampleOverride] = field(default_factory=list)
    alpha_star: float | None = None

    def controller_config(self) -> ControllerConfig:
        """The controllers' design: the paper's, with ``alpha_star`` (the proposed
        controller's steady-state gain, Eq. 21) when the study sets it."""
        config = ControllerConfig()
        return config if self.alpha_star is None else config.with_alpha_star(self.alpha_star)


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
    if isinstance(distribution, Uniform):
        _finite(f"{key}.low", distribution.low)
        _finite(f"{key}.high", distribution.high)
        _require(
            distribution.low <= distribution.high,
            f"{key}: low = {distribution.low!r} > high = {distribution.high!r}; "
            "low <= high is required",
        )
        return distribution.low, distribution.high
    if isinstance(distribution, Normal):
        _finite(f"{key}.mean", distribution.mean)
        _finite(f"{key}.std", distribution.std)
        _require(distribution.std >= 0.0, f"{key}.std = {distribution.std!r}; std >= 0 is required")
        low = -math.inf if distribution.low is None else distribution.low
        high = math.inf if distribution.high is None else distribution.high
        for name in ("low", "high"):
            if getattr(distribution, name) is not None:
                _finite(f"{key}.{name}", getattr(distribution, name))
        _require(low <= high, f"{key}: low = {low!r} > high = {high!r}; low <= high is required")
        if distribution.std == 0.0:
            _require(
                low <= distribution.mean <= high,
                f"{key}: mean = {distribution.mean!r} lies outside [low, high] with std = 0",
            )
        else:
            norm = scipy.stats.norm(distribution.mean, distribution.std)
            kept = norm.cdf(high) - norm.cdf(low)
            _require(
                kept >= MIN_TRUNCATED_MASS,
                f"{key}: [low, high] keeps {kept:.2g} of the normal's probability; "
                f"at least {MIN_TRUNCATED_MASS:g} is required",
            )
        return low, high
    _finite(f"{key}.value", distribution.value)
    return distribution.value, distribution.value


def _check_physical(key: str, name: str, distribution: Distribution) -> None:
    """Refuse a distribution that can draw a value ``ArmParameters`` would refuse."""
    if isinstance(distribution, Fixed) and distribution.value is None:
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
    hint = "; truncate the normal with low:" if isinstance(distribution, Normal) else ""
    _require(
        ok,
        f"{key}: the range reaches {low!r}{' (relative)' if relative else ''}, "
        f"which gives a negative or zero {name}; every draw must be {bound}{hint}",
    )


def _check_parameters(parameters: ParameterDistributions) -> None:
    for name in JOINT_PARAMETERS:
        entries = getattr(parameters, name)
        _require(
            len(entries) in (1, 2),
            f"parameters.{name} has {len(entries)} entries; "
            "1 (both joints) or 2 (joint 1, joint 2) are required",
        )
        for j, distribution in enumerate(entries):
            _check_physical(f"parameters.{name}[{j}]", name, distribution)
    _check_physical("parameters.payload_mass", "payload_mass", parameters.payload_mass)


def _check_override(position: int, override: SampleOverride) -> None:
    key = f"overrides[{position}]"
    _require(override.sample >= 0, f"{key}.sample = {override.sample!r}; an index >= 0 is required")
    allowed = (*JOINT_PARAMETERS, "payload_mass", "encoder_counts")
    for name, values in override.values.items():
        _require(name in allowed, f"{key}.values has unknown key {name!r}; one of {allowed}")
        size = 2 if name in JOINT_PARAMETERS else 1
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


def validate_study(study: Study) -> Study:
    """Return ``study`` if every value is allowed; otherwise raise ``ValueError``
    naming the key, the value and what is allowed."""
    _require(
        isinstance(study.seed, int) and study.seed >= 0,
        f"seed = {study.seed!r}; an integer >= 0 is required",
    )
    _require(study.samples > 0, f"samples = {study.samples!r}; at least 1 sample is required")
    # The closed loop checks these itself (its messages name the key).
    ClosedLoopConfig(duration=study.duration, divergence_bound=study.divergence_bound)
    _require(len(study.controllers) > 0, "controllers is empty; name at least one controller")
    for name in study.controllers:
        _require(
            name in CONTROLLER_KINDS,
            f"controllers has {name!r}; each must be one of {CONTROLLER_KINDS}",
        )
    _require(
        len(set(study.controllers)) == len(study.controllers),
        f"controllers = {study.controllers!r} repeats a controller",
    )
    _require(len(study.encoder_counts) > 0, "encoder_counts is empty; give at least one")
    for counts in study.encoder_counts:
        _require(counts >= 0, f"encoder_counts has {counts!r}; integers >= 0 are required")
    if study.alpha_star is not None:
        _finite("alpha_star", study.alpha_star)
    study.controller_config()  # NonlinearTorqueConfig refuses alpha_star <= 0, naming it
    _check_parameters(study.parameters)
    for position, override in enumerate(study.overrides):
        _check_override(position, override)
    samples = [override.sample for override in study.overrides]
    _require(len(set(samples)) == len(samples), "overrides name a sample twice")
    return study


def load_study(path: str | Path) -> Study:
    """Load and validate a study file; every problem is one ``ValueError`` line."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"study {path} does not exist")
    return study_from_text(path.read_text(), source=f"study {path}")


def study_from_text(text: str, source: str = "study") -> Study:
    """Parse and validate a study from YAML text."""
    study = load_typed(Study, text, source)
    try:
        return validate_study(study)
    except ValueError as error:
        raise ValueError(f"{source}: {error}") from None


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
    draw depends only on the seed and its index)."""
    return hashlib.sha256(canonical_text(replace(study, samples=1)).encode()).hexdigest()
