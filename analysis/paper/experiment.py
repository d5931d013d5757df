"""The experiments of Sec. 4: cases (shipped scenario files, ``analysis.common.cases``), studies
(sets of runs that share a setting) and the incremental ``results.json`` store.

* ``nominal`` (Sec. 4.2, Table 3, Figs. 4-5): ``scenarios/paper_nominal.yaml``,
  the URDF arm as identified from Table 1.
* ``payload`` (Sec. 4.3, Table 4, Figs. 6-7): ``scenarios/paper_payload.yaml``,
  a payload at the link-2 tip; the controllers keep the nominal Table 1 model.

A study is a list of ``KEY=VALUE`` scenario settings applied on top of each case
(``diagrams.scenario.apply_setting``), so every run it makes is one scenario.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cache, partial
from pathlib import Path

from posfb.analysis.common.cases import CASE_FILES, CASES
from posfb.analysis.common.metrics import run_metrics, run_verdict
from posfb.analysis.common.outputs import atomic_file
from posfb.diagrams.resolve import LoadedScenario, load_scenario, resolve, run_scenario
from posfb.diagrams.runner import ClosedLoopResult
from posfb.models.controllers import PAPER_CONTROLLERS
from posfb.models.plant import Arm, ArmParameters


def require_case(case: str) -> str:
    if case not in CASES:
        raise ValueError(f"case = {case!r}; one of {', '.join(CASES)} is required")
    return case


def case_scenario(case: str, settings: tuple[str, ...] = ()) -> LoadedScenario:
    """The shipped scenario of ``case`` with ``KEY=VALUE`` ``settings`` applied."""
    return load_scenario(CASE_FILES[require_case(case)], settings)


@cache
def payload_mass(case: str) -> float:
    """The tip payload (kg) of ``case``'s scenario file."""
    return float(case_scenario(case).scenario.plant.payload_mass)


def case_title(case: str) -> str:
    """A title for tables and figures, with the payload read from the scenario file."""
    if require_case(case) == "nominal":
        return "nominal arm (Sec. 4.2)"
    return f"{payload_mass(case):g} kg payload at the link-2 tip (Sec. 4.3)"


def case_parameters(arm: Arm, case: str) -> ArmParameters:
    """The true plant of ``case``: ``arm``'s URDF values with the scenario's payload
    and overrides."""
    return resolve(case_scenario(case)).true_parameters(arm.default_parameters)


@dataclass(frozen=True)
class Study:
    """A set of runs that share one setting; ``key`` names it in ``results.json``.

    ``settings`` are scenario ``KEY=VALUE`` changes applied to every case (default:
    none, the paper's settings)."""

    key: str
    title: str
    description: str
    controllers: tuple[str, ...] = PAPER_CONTROLLERS
    cases: tuple[str, ...] = CASES
    settings: tuple[str, ...] = ()

    def runs(self, duration: float) -> Iterator[tuple[str, str, Callable[..., ClosedLoopResult]]]:
        """``(case, controller, run)`` for every run of the study; ``run(progress=None)``
        takes an optional progress callback (``ClosedLoopRunner.run``)."""
        for kind in self.controllers:
            for case in self.cases:
                loaded = case_scenario(
                    case, (*self.settings, f"controller.kind={kind}", f"timing.duration={duration}")
                )
                yield case, kind, partial(run_scenario, loaded)


#: The paper's settings as printed (Sec. 4.2-4.3).
PAPER_STUDY = Study(
    key="paper",
    title="Paper settings",
    description="Sec. 4.2 gains and weights, T_s = 0.01 s, +-24 V, Table 1 model.",
)


def _json_number(value: object) -> object:
    """NaN (a run that diverged before its second sample) becomes ``None`` (JSON null)."""
    if isinstance(value, list):
        return [_json_number(v) for v in value]
    return None if isinstance(value, float) and not math.isfinite(value) else value


def result_entry(result: ClosedLoopResult) -> dict[str, object]:
    """The ``results.json`` entry of a run: metrics, its verdict's status and message
    (``analysis.common.metrics.run_verdict``)."""
    metrics = {key: _json_number(value) for key, value in run_metrics(result).as_dict().items()}
    verdict = run_verdict(result)
    return {**metrics, "status": verdict.status, "message": verdict.message}


class ResultsFile:
    """``results.json``, rewritten atomically after every run so that finished runs
    are never lost. ``set(("payload", "pid"), entry)`` stores a nested entry."""

    def __init__(self, path: Path, header: dict[str, object]) -> None:
        self.path = path
        self.data: dict[str, object] = dict(header)
        self._write()

    def set(self, keys: tuple[str, ...], value: object) -> None:
        node = self.data
        for key in keys[:-1]:
            node = node.setdefault(key, {})
        node[keys[-1]] = value
        self._write()

    def _write(self) -> None:
        with atomic_file(self.path) as partial:
            partial.write_text(json.dumps(self.data, indent=2, allow_nan=False) + "\n")
