"""Property-based: whatever YAML a user writes, a scenario or study loader either
accepts it (and the result validates) or refuses it with ``ValueError`` (the CLI's
one-line error), never with another exception."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from posfb.analysis.uncertainty.study import study_from_text
from posfb.diagrams.resolve import load_scenario
from posfb.diagrams.scenario import Scenario, apply_setting, dump_scenario

#: Dotted keys a user might set (valid ones, and near misses).
KEYS = [
    "timing.sample_time", "timing.duration", "timing.divergence_bound",
    "timing.simulator.accuracy", "timing.simulator.integration_scheme",
    "timing.simulator.max_step_size", "sensor.encoder_counts", "sensor.encoder_counts[1]",
    "sensor.zero_offset", "sensor.noise_std", "sensor.noise_seed", "sensor.delay_samples",
    "actuator.voltage_limit", "plant.payload_mass", "plant.friction_velocity",
    "plant.parameters.link_mass", "plant.parameters.damping", "controller.kind",
    "controller.alpha_star", "controller.K_alpha", "controller.alpha0", "controller.filter_a",
    "controller.Q2", "controller.R", "controller.lambdas", "controller.Kp", "controller.KI",
    "controller.discretisation", "controller.H.gamma", "controller.bounds.relative",
    "trajectory.joints[0].frequency", "trajectory.joints[1].amplitude", "nominal_model",
    "trajectory", "timing", "sensor.bogus", "timing.sample_time[0]",
]  # fmt: skip

SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**12), max_value=10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["", "abc", "proposed", "lin_lc", "foh", "!Theta {}", "[1, 2]", "1e-3"]),
)
VALUES = st.recursive(
    SCALARS,
    lambda children: st.one_of(
        st.lists(children, max_size=4),
        st.dictionaries(st.sampled_from(["a", "theta1", "gamma", "times", "positions"]),
                        children, max_size=3),
    ),
    max_leaves=8,
)  # fmt: skip


def _yaml_value(value: object) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return ".nan" if math.isnan(value) else (".inf" if value > 0 else "-.inf")
    if isinstance(value, str):
        return value
    return yaml.safe_dump(value, default_flow_style=True).strip().removesuffix("...").strip()


def _loads_or_refuses(text: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scenario.yaml"
        path.write_text(text)
        try:
            loaded = load_scenario(path)
        except ValueError:
            return
        dump_scenario(loaded.scenario)  # an accepted scenario can be written back


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(max_size=200))
def test_any_text_is_loaded_or_refused_in_one_line(text):
    _loads_or_refuses(text)


SECTIONS = st.dictionaries(
    st.sampled_from(["plant", "timing", "sensor", "actuator", "controller", "trajectory",
                     "nominal_model", "bogus"]),
    st.dictionaries(st.sampled_from(["sample_time", "duration", "encoder_counts",
                                     "voltage_limit", "payload_mass", "kind", "alpha_star",
                                     "noise_std", "joints", "simulator", "x"]),
                    VALUES, max_size=3),
    max_size=4,
)  # fmt: skip


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(SECTIONS)
def test_any_structured_document_is_loaded_or_refused(document):
    _loads_or_refuses(yaml.safe_dump(document))


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(KEYS), VALUES)
def test_any_setting_is_applied_or_refused(key, value):
    try:
        scenario = apply_setting(Scenario(), f"{key}={_yaml_value(value)}")
    except ValueError:
        return
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scenario.yaml"
        path.write_text(dump_scenario(scenario))
        try:
            load_scenario(path)
        except ValueError:
            return


STUDY_KEYS = st.sampled_from(
    ["seed", "samples", "duration", "controllers", "encoder_counts", "alpha_star",
     "divergence_bound", "settings", "draws", "parameters", "overrides", "bogus"]
)  # fmt: skip


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(STUDY_KEYS, VALUES, max_size=4))
def test_any_study_is_loaded_or_refused(document):
    try:
        study_from_text(yaml.safe_dump(document))
    except ValueError:
        return
