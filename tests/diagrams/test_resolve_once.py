"""A scenario is validated once (``diagrams.resolve``): ``resolve`` keeps its answer on
the ``LoadedScenario`` with a copy of what it validated, so loading a scenario and
simulating it validates it once, an edit makes the next ``resolve`` validate again, and
the kept answer runs exactly as a fresh validation does."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import posfb
from helpers.paths import REPO
from posfb.diagrams import resolve as resolve_module
from posfb.diagrams.resolve import LoadedScenario, resolve, run_resolved

#: The shipped scenarios' folder.
SHIPPED = REPO / "analysis" / "scenarios"


@pytest.fixture
def validations(monkeypatch):
    """The scenarios ``resolve`` validated (not answered from what it kept), in order."""
    seen = []
    original = resolve_module._validated

    def counted(loaded: LoadedScenario):
        seen.append(loaded.source)
        return original(loaded)

    monkeypatch.setattr(resolve_module, "_validated", counted)
    return seen


def test_simulate_validates_a_loaded_scenario_once(validations):
    loaded = posfb.load_scenario(set={"timing.duration": 0.1, "controller.alpha_star": 3.25})
    assert len(validations) == 1
    run = posfb.simulate(loaded)
    assert run.status == "ok" and len(validations) == 1
    posfb.simulate(loaded, "lin_lc")  # another controller is another scenario: once more
    assert len(validations) == 2


def test_an_edit_is_validated_again(validations):
    loaded = posfb.load_scenario(set={"timing.duration": 0.1})
    loaded.scenario.timing.duration = 0.2
    assert resolve(loaded).config.timing.duration == 0.2 and len(validations) == 2
    loaded.scenario.timing.sample_time = -1.0
    with pytest.raises(ValueError, match="timing.sample_time"):
        resolve(loaded)


@pytest.mark.parametrize("name", ["paper_nominal", "three_link_nominal"])
def test_the_kept_answer_runs_as_a_fresh_validation(name):
    loaded = posfb.load_scenario(SHIPPED / f"{name}.yaml", set={"timing.duration": 0.3})
    fresh = LoadedScenario(copy.deepcopy(loaded.scenario), loaded.base_dir, loaded.source)
    kept, again = run_resolved(resolve(loaded)), run_resolved(resolve(fresh))
    for field in ("q_true", "q_measured", "u_applied", "internals"):
        np.testing.assert_array_equal(getattr(kept, field), getattr(again, field))
