"""Monte-Carlo studies built on scenarios: a base scenario file with settings, and
distributions on any numeric scenario key (``draws``)."""

from __future__ import annotations

import pytest

from posfb.analysis.common.metrics import run_metrics
from posfb.analysis.montecarlo.worker import ClosedLoopEvaluator
from posfb.analysis.uncertainty.study import canonical_text, load_study, study_from_text
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.diagrams.runner import ClosedLoopRunner
from posfb.models.plant import ArmParameters

TIMING_AND_SENSOR = """
seed: 3
samples: 6
duration: 0.5
controllers: [lin_lc, pid]
draws:
  timing.sample_time: !UniformDiscrete {values: [0.005, 0.01]}
  sensor.encoder_counts: !UniformDiscrete {values: [1024, 20000]}
"""


@pytest.mark.slow
def test_a_study_varying_sample_time_and_encoder_counts_matches_direct_runs():
    study = study_from_text(TIMING_AND_SENSOR)
    evaluator = ClosedLoopEvaluator(study)
    seen = set()
    for index in range(study.samples):
        sample = evaluator(index)
        sample_time = sample.parameters["timing.sample_time"]
        counts = sample.parameters["sensor.encoder_counts"]
        seen.add((sample_time, counts))
        assert sample.encoder_counts == counts
        arm = {k: tuple(v) if isinstance(v, list) else v for k, v in sample.parameters.items()}
        true_arm = ArmParameters(**{k: v for k, v in arm.items() if "." not in k})
        for run in sample.runs:
            loaded = load_scenario(
                None,
                [
                    "timing.duration=0.5",
                    f"timing.sample_time={sample_time!r}",
                    f"sensor.encoder_counts={counts}",
                    f"controller.kind={run.controller}",
                ],
            )
            direct = run_metrics(ClosedLoopRunner(resolve(loaded).config).run(true_arm))
            assert run.status == "ok"
            assert run.metrics["rms_q2"] == direct.rms_q[1]
            assert run.metrics["rms_u1"] == direct.rms_u[0]
    assert len({t for t, _ in seen}) == 2 and len({c for _, c in seen}) == 2


def test_a_study_names_a_base_scenario_file_and_settings(tmp_path):
    (tmp_path / "base.yaml").write_text(
        "plant: {payload_mass: 0.2}\ncontroller: {alpha_star: 3, filter_a: 200}\n"
    )
    (tmp_path / "study.yaml").write_text(
        "seed: 1\nsamples: 2\nduration: 0.5\ncontrollers: [proposed]\nscenario: base.yaml\n"
        "settings: ['timing.sample_time=0.005']\n"
        "draws:\n  trajectory.joints[1].frequency:\n"
        "    !Uniform {min: -0.1, max: 0.1, relative: true}\n"
    )
    study = load_study(tmp_path / "study.yaml")
    assert study.scenario == "" and study.base.plant.payload_mass == 0.2
    assert study.base.timing.sample_time == 0.005
    assert study_from_text(canonical_text(study)).base.controller.alpha_star == 3.0
    sample = ClosedLoopEvaluator(study)(1)
    assert sample.parameters["payload_mass"] == 0.2
    assert 2.7 <= sample.parameters["trajectory.joints[1].frequency"] <= 3.3


@pytest.mark.parametrize(
    ("draws", "needle"),
    [
        ("timing.sample_time: !Uniform {min: 0.0, max: 0.01}", "timing.sample_time"),
        ("sensor.encoder_counts: !Uniform {min: 100, max: 200}", "UniformDiscrete"),
        ("plant.payload_mass: !Uniform {min: 0, max: 1}", "parameters"),
        ("timing.sampel_time: !Deterministic {value: 0.01}", "sampel_time"),
        ("controller.kind: !Deterministic {value: 1}", "not a number"),
        ("timing.sample_time: !UniformDiscrete {values: [0.003]}", "whole number"),
        ("timing.sample_time: !UniformDiscrete {values: [0.005]}", "filter_a"),
    ],
)
def test_bad_draws_are_refused_naming_the_key(draws, needle):
    with pytest.raises(ValueError, match=needle):
        study_from_text(f"seed: 1\nsamples: 1\nduration: 1.0\ndraws:\n  {draws}\n")
