"""The realism study file: the settings every run shares, and the effects.

::

    study:               # a Monte-Carlo study without draws (analysis.uncertainty.study)
      seed: 2013
      sampling: latin_hypercube
      scenario: ../scenarios/paper_nominal.yaml
      duration: 20.0
      controllers: [proposed, lin_lc, pid]
    paper_table: nominal # the paper's table the errors are compared with: nominal | payload
    stand_ins:           # a studied controller compared with the paper's measurement of
      proposed_alpha_3_25: proposed  # another (and ranked in its place, as a second line-up)
    effects:
      - name: electrical_lag
        label: armature L/R
        source: maxon RE-series data sheets ...
        samples: 8
        settings: []     # KEY=VALUE, as --set (e.g. the friction law's kind)
        draws:           # scenario keys and their literature range
          actuator.electrical_time_constant: !Uniform {min: 1.0e-4, max: 2.0e-3}
        parameters: {}   # or the true arm's physical parameters drawn (a study's
        posterior: null  # parameters: and posterior:; not in the combination)
    combined: [electrical_lag, ...]   # the effects drawn together in one more study
    combined_samples: 4

or ``extends: OTHER.yaml`` (relative to this file) and only the keys that differ: the
other file's settings with this file's keys in their place, key by key inside ``study``
(e.g. another scenario and ``paper_table: payload`` over the same effects). The other
file's ``study.scenario`` stays relative to its own folder.

Each effect becomes the shared study with its ``settings`` appended and its ``draws``
(``realism_studies``); the combined study takes every listed effect's settings and draws,
in the listed order (a later effect's setting of the same key wins, and a drawn key
overrides a setting). The ideal arm is the shared study itself, one sample.
"""

import re
from dataclasses import dataclass, field, replace
from pathlib import Path

from posfb.analysis.common.tables import PAPER_TABLES
from posfb.analysis.uncertainty.study import (
    Distribution,
    ParameterDistributions,
    Posterior,
    Study,
    complete_study,
)
from posfb.diagrams.yaml_schema import load_typed, read_text

#: The name of the study of the ideal arm (no effect) and of all effects together.
IDEAL, COMBINED = "ideal", "combined"

#: An effect's name: a file name of its store.
NAME = re.compile(r"[a-z][a-z0-9_]*\Z")


@dataclass
class Effect:
    """One non-ideality: its ``name`` (lower-case, digits, ``_``), the ``label`` the
    report shows, the ``source`` of its range, the ``samples`` of its study, the
    ``settings`` that switch it on and the ``draws`` of its literature range; a model
    error draws the true arm itself, as a study's ``parameters`` and ``posterior``
    (``analysis.uncertainty.study``)."""

    name: str = ""
    label: str = ""
    source: str = ""
    samples: int = 8
    settings: list[str] = field(default_factory=list)
    draws: dict[str, Distribution] = field(default_factory=dict)
    parameters: ParameterDistributions = field(default_factory=ParameterDistributions)
    posterior: Posterior | None = None

    def draws_plant(self) -> bool:
        """Whether the effect draws the true arm's physical parameters."""
        return Study(parameters=self.parameters, posterior=self.posterior).draws_anything()


@dataclass
class RealismSpec:
    """The study file (module docstring)."""

    extends: str = ""
    study: Study = field(default_factory=Study)
    paper_table: str = "nominal"
    stand_ins: dict[str, str] = field(default_factory=dict)
    effects: list[Effect] = field(default_factory=list)
    combined: list[str] = field(default_factory=list)
    combined_samples: int = 4


@dataclass(frozen=True)
class RealismStudies:
    """The Monte-Carlo studies of a spec by name, in run order: ``ideal``, each effect,
    then ``combined`` (when the spec combines any), with the spec they came from."""

    spec: RealismSpec
    studies: dict[str, Study]

    def label(self, name: str) -> str:
        """What the report calls the study ``name``."""
        if name == IDEAL:
            return "none (ideal arm)"
        if name == COMBINED:
            return "combined: " + ", ".join(self.effect(n).label for n in self.spec.combined)
        return self.effect(name).label

    def effect(self, name: str) -> Effect:
        return next(e for e in self.spec.effects if e.name == name)


def _check(spec: RealismSpec, source: str) -> None:
    def require(condition: bool, message: str) -> None:
        if not condition:
            raise ValueError(f"{source}: {message}")

    require(
        spec.paper_table in PAPER_TABLES,
        f"paper_table = {spec.paper_table!r}; one of {sorted(PAPER_TABLES)} is required",
    )
    require(bool(spec.effects), "effects is empty; at least one effect is required")
    require(
        not spec.study.draws_anything(),
        "study draws something; the shared study draws nothing (each effect draws its own)",
    )
    controllers = spec.study.controllers
    papers = PAPER_TABLES.get(spec.paper_table, {})
    for stand_in, paper in spec.stand_ins.items():
        require(
            stand_in in controllers and stand_in not in papers,
            f"stand_ins: {stand_in!r} is not a studied controller outside the paper's "
            f"({[c for c in controllers if c not in papers]} are)",
        )
        require(
            paper in papers,
            f"stand_ins.{stand_in} = {paper!r}; one of the paper's {sorted(papers)} is required",
        )
    names = [effect.name for effect in spec.effects]
    for i, effect in enumerate(spec.effects):
        where = f"effects[{i}]"
        require(
            bool(NAME.match(effect.name)) and effect.name not in (IDEAL, COMBINED),
            f"{where}.name = {effect.name!r}; lower-case letters, digits and _ (not "
            f"{IDEAL!r} or {COMBINED!r}) are required",
        )
        require(names.count(effect.name) == 1, f"{where}.name = {effect.name!r} is repeated")
        require(bool(effect.label.strip()), f"{where}.label is empty; a label is required")
        require(
            bool(effect.source.strip()),
            f"{where}.source is empty; the source of the effect's range is required",
        )
        require(
            isinstance(effect.samples, int) and effect.samples >= 1,
            f"{where}.samples = {effect.samples!r}; an integer >= 1 is required",
        )
        require(
            bool(effect.settings or effect.draws or effect.draws_plant()),
            f"{where} ({effect.name}) has no settings and no draws; it changes nothing",
        )
    for name in spec.combined:
        require(name in names, f"combined names {name!r}; one of the effects {names} is required")
        require(
            name not in names or not spec.effects[names.index(name)].draws_plant(),
            f"combined names {name!r}, which draws the true arm (parameters or posterior); "
            "only effects of settings and draws combine",
        )
    require(
        isinstance(spec.combined_samples, int) and spec.combined_samples >= 1,
        f"combined_samples = {spec.combined_samples!r}; an integer >= 1 is required",
    )


def _study(
    spec: RealismSpec, settings: list[str], draws: dict, samples: int, plant: Effect | None = None
) -> Study:
    """The shared study with ``settings`` and ``draws`` (and the true arm drawn as
    ``plant`` draws it, where given)."""
    shared = spec.study
    study = replace(
        shared, samples=samples, settings=[*shared.settings, *settings], draws=dict(draws)
    )
    if plant is None or not plant.draws_plant():
        return study
    return replace(study, parameters=plant.parameters, posterior=plant.posterior)


def realism_studies(spec: RealismSpec, source: str, folder: Path) -> RealismStudies:
    """Every study of ``spec`` (checked; relative paths from ``folder``)."""
    _check(spec, source)
    studies = {IDEAL: complete_study(_study(spec, [], {}, 1), f"{source}: study", folder)}
    for i, effect in enumerate(spec.effects):
        study = _study(spec, effect.settings, effect.draws, effect.samples, effect)
        studies[effect.name] = complete_study(study, f"{source}: effects[{i}]", folder)
    if spec.combined:
        chosen = [next(e for e in spec.effects if e.name == n) for n in spec.combined]
        settings = [s for e in chosen for s in e.settings]
        draws = {key: d for e in chosen for key, d in e.draws.items()}
        study = _study(spec, settings, draws, spec.combined_samples)
        studies[COMBINED] = complete_study(study, f"{source}: combined", folder)
    return RealismStudies(spec, studies)


def _load_spec(path: Path, extended_by: tuple[Path, ...] = ()) -> RealismSpec:
    """The spec of ``path`` with what it ``extends`` folded in (module docstring)."""
    source = f"realism study {path}"
    what = "realism study" if not extended_by else f"{extended_by[-1]}: extends: realism study"
    text = read_text(path, what, missing=FileNotFoundError)
    spec = load_typed(RealismSpec, text, source)
    if not spec.extends:
        return spec
    other = path.parent / spec.extends
    if other.resolve() in {p.resolve() for p in (*extended_by, path)}:
        raise ValueError(f"{source}: extends: {spec.extends!r} extends this file again (a cycle)")
    base = _load_spec(other, (*extended_by, path))
    scenario = base.study.scenario
    if scenario and not Path(scenario).is_absolute():  # relative to its own file
        base = replace(base, study=replace(base.study, scenario=str(other.parent / scenario)))
    return replace(load_typed(RealismSpec, text, source, defaults=base), extends="")


def load_realism(path: str | Path) -> RealismStudies:
    """The studies of the realism file ``path``; every problem is one ``ValueError``
    line naming the file and the key."""
    path = Path(path)
    return realism_studies(_load_spec(path), f"realism study {path}", path.parent)
