"""The study file: typed loading, validation with the key named, CLI refusals."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from helpers.montecarlo_helpers import TINY_STUDY, write_study
from helpers.paths import REPO
from posfb.analysis.cli import main
from posfb.analysis.uncertainty.study import (
    Deterministic,
    Gaussian,
    Uniform,
    UniformDiscrete,
    canonical_text,
    identity,
    load_study,
    study_from_text,
    with_overrides,
)

SHIPPED = REPO / "analysis" / "studies" / "paper_uncertainty.yaml"


def test_shipped_study_loads_with_the_documented_choices():
    study = load_study(SHIPPED)
    assert study.samples == 200 and study.duration == 20.0
    assert set(study.controllers) == {"proposed", "lin_lc", "pid", "pd_gravity", "adrc"}
    assert study.parameters.link_mass == [Uniform(min=-0.2, max=0.2, relative=True)]
    assert study.parameters.payload_mass == Uniform(min=0.0, max=0.5, relative=False)
    assert isinstance(study.parameters.motor_constant[0], Gaussian)


def test_tags_select_the_distribution_and_omitted_parameters_stay_nominal():
    study = study_from_text(TINY_STUDY)
    assert study.parameters.coulomb == [Uniform(-0.2, 0.2, True), Deterministic()]
    assert study.parameters.for_joint("coulomb", 1) == Deterministic()
    assert study.parameters.for_joint("link_mass", 1) == Uniform(-0.2, 0.2, True)
    assert study.parameters.link_inertia == [Deterministic()]


def test_canonical_text_round_trips_and_identity_ignores_the_sample_count():
    study = study_from_text(TINY_STUDY)
    text = canonical_text(study)
    assert canonical_text(study_from_text(text)) == text
    assert identity(with_overrides(study, samples=50)) == identity(study)
    assert identity(with_overrides(study, seed=8)) != identity(study)


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        ("samples: 0", "samples"),
        ("samples: -3", "samples"),
        ("seed: -1", "seed"),
        ("duration: 0.015", "duration"),
        ("controllers: [proposed, lqr]", "lqr"),
        ("controllers: []", "controllers"),
        ("encoder_counts: [-5]", "encoder_counts"),
        ("bogus_key: 1", "bogus_key"),
        ("parameters: {link_mass: [!Uniform {min: 0.3, max: 0.1, relative: true}]}", "min"),
        ("parameters: {link_mass: [!Uniform {lo: 0.1, max: 0.3}]}", "lo"),
        ("parameters: {damping: [!Uniform {min: -2.0, max: 1.0}]}", "parameters.damping[0]"),
        ("parameters: {link_mass: [!Uniform {min: -1.0, max: 0.1, relative: true}]}", "link_mass"),
        ("parameters: {coulomb: [!Gaussian {mean: 0.0, stddev: -1.0, relative: true}]}", "stddev"),
        ("parameters: {coulomb: [!Gaussian {mean: 0.0, stddev: 0.1, relative: true}]}", "coulomb"),
        ("parameters: {payload_mass: !Uniform {min: 0.0, max: 0.2, relative: true}}", "payload"),
        ("parameters: {damping: [!Deterministic {}, !Deterministic {}, !Deterministic {}]}",
         "3 entries"),  # fmt: skip
        ("overrides: [{sample: 1, values: {mass: [1.0, 1.0]}}]", "mass"),
        ("overrides: [{sample: 1, values: {link_mass: [1.0]}}]", "link_mass"),
        ("parameters: {link_mass: !Uniform {min: 0.1, max: 0.2}}", "parameters.link_mass"),
        ("parameters: {link_mass: [3]}", "parameters.link_mass[0]"),
        ("parameters: {link_mass: [!Gamma {k: 2}]}", "!Gamma"),
        ("parameters: {payload_mass: !Gaussian {mean: 0.1, sd: 0.1}}", "payload_mass.sd"),
        ("encoder_counts: [1.5]", "encoder_counts[0]"),
        ("samples: [", "line"),
        ("alpha_star: 0.0", "alpha_star"),
        ("alpha_star: -2.0", "alpha_star"),
        ("alpha_star: .nan", "alpha_star"),
    ],
)
def test_bad_study_is_refused_with_the_key_named(edit, needle):
    text = "seed: 1\nsamples: 3\nduration: 1.0\n" + edit + "\n"
    with pytest.raises(ValueError, match="study") as caught:
        study_from_text(text)
    assert needle in str(caught.value)
    assert "\n" not in str(caught.value)


def test_alpha_star_changes_only_the_proposed_design_and_the_identity():
    paper = study_from_text("seed: 1\nsamples: 3\nduration: 1.0\n")
    labelled = study_from_text("seed: 1\nsamples: 3\nduration: 1.0\nalpha_star: 2.75\n")
    assert paper.controller_config().nonlinear.alpha_star == 4.0
    assert labelled.controller_config().nonlinear.alpha_star == 2.75
    assert labelled.controller_config().lqr == paper.controller_config().lqr
    assert identity(labelled) != identity(paper)
    assert study_from_text(canonical_text(labelled)) == labelled


def test_a_truncated_normal_fits_the_physical_range():
    text = "parameters: {coulomb: [!Gaussian {mean: 0.0, stddev: 0.5, relative: true, min: -0.9}]}"
    assert study_from_text(text).parameters.coulomb[0].min == -0.9


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        ("bogus_key: 1", "bogus_key"),
        ("parameters: {link_mass: [!Uniform {min: -0.5, max: -0.1}]}", "link_mass"),
        ("parameters: {link_com: [!Uniform {min: 0.3, max: 0.1}]}", "min"),
        ("samples: 0", "samples"),
    ],
)
def test_cli_refuses_bad_config_with_one_line(tmp_path, capsys, edit, needle):
    study = write_study(tmp_path, "duration: 1.0\n" + edit + "\n")
    code = main(["montecarlo", "run", str(study), "--db", str(tmp_path / "r.sqlite")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and needle in err[0], err
    assert not (tmp_path / "r.sqlite").exists()


@pytest.mark.parametrize(
    "args",
    [
        ["--samples", "0"],
        ["--workers", "0"],
        ["--seed", "-2"],
        ["--workers", "two"],
    ],
)
def test_cli_refuses_bad_arguments_with_one_line(tmp_path, capsys, args):
    study = write_study(tmp_path)
    with pytest.raises(SystemExit) as caught:
        main(["montecarlo", "run", str(study), "--db", str(tmp_path / "r.sqlite"), *args])
    assert caught.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_entry_point_reports_a_missing_study_as_one_line(tmp_path):
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "posfb.analysis.cli",
            "montecarlo",
            "run",
            str(tmp_path / "none.yaml"),
            "--db",
            str(tmp_path / "r.sqlite"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "none.yaml" in lines[0], result.stderr


def test_yaml_12_numbers_are_numbers():
    study = study_from_text(
        "seed: 1\nsamples: 2\nduration: 2e1\ncontrollers: [lin_lc]\nalpha_star: .5\n"
        "parameters:\n  payload_mass: !Uniform {min: 0, max: 1e-1}\n"
    )
    assert study.duration == 20.0 and study.alpha_star == 0.5
    assert study.parameters.payload_mass.max == 0.1


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("parameters: {payload_mass: !Uniform {low: 0.0, high: 0.5}}", "'low' is now spelled"),
        ("parameters: {coulomb: [!Normal {mean: 0.0, std: 0.1}]}", "!Normal is now !Gaussian"),
        ("parameters: {coulomb: [!Gaussian {mean: 0.0, std: 0.1}]}", "'std' is now spelled"),
        ("parameters: {damping: [!Fixed {}]}", "!Fixed is now !Deterministic"),
    ],
)
def test_the_former_spellings_are_refused_with_drakes_names(text, needle):
    with pytest.raises(ValueError, match=re.escape(needle)) as error:
        study_from_text(text)
    assert len(str(error.value).splitlines()) == 1


def test_drake_named_distributions_load_in_pydrakes_own_schema():
    """The distributions a study writes mean what Drake's schema types mean: the same YAML
    loads into pydrake.common.schema (posfb's extra keys ignored by Drake) with equal
    numbers, and Drake's own sampler draws inside the same range."""
    from pydrake.common import RandomGenerator, schema
    from pydrake.common.yaml import yaml_load_typed

    drake_union = schema.Deterministic | schema.Gaussian | schema.Uniform | schema.UniformDiscrete
    ours_union = Deterministic | Gaussian | Uniform | UniformDiscrete
    texts = [
        "!Uniform {min: -0.2, max: 0.3}",
        "!Gaussian {mean: 1.5, stddev: 0.25}",
        "!UniformDiscrete {values: [1.0, 2.0, 4.0]}",
        "!Deterministic {value: 7.0}",
        "!Gaussian {mean: 0.0, stddev: 0.05, relative: true, min: -0.15, max: 0.15}",
    ]
    for text in texts:
        drake = yaml_load_typed(
            schema=_holder(drake_union), data=f"x: {text}", allow_yaml_with_no_schema=True
        ).x
        posfb = yaml_load_typed(schema=_holder(ours_union), data=f"x: {text}").x
        assert type(drake).__name__ == type(posfb).__name__, text
        for name in (f.name for f in type(drake).__fields__):
            assert getattr(drake, name) == getattr(posfb, name), (text, name)
    uniform = yaml_load_typed(schema=_holder(drake_union), data=f"x: {texts[0]}").x
    generator = RandomGenerator(1)
    draws = [uniform.Sample(generator) for _ in range(200)]
    assert min(draws) >= -0.2 and max(draws) <= 0.3


def _holder(kind: object) -> type:
    """A one-field schema ``x: kind`` for loading a single distribution."""
    import dataclasses

    first = kind.__args__[0]
    return dataclasses.make_dataclass(
        "Holder", [("x", kind, dataclasses.field(default_factory=first))]
    )


@pytest.mark.parametrize(
    "path", sorted((SHIPPED.parent).glob("*.yaml")), ids=lambda path: path.name
)
def test_every_shipped_study_loads(path):
    study = load_study(path)
    assert study.samples > 0 and study.controllers
