"""The experiments of Sec. 4: cases (nominal arm, 0.288 kg payload), studies (sets
of runs that share a setting) and the incremental ``results.json`` store.

* ``nominal`` (Sec. 4.2, Table 3, Figs. 4-5): the URDF arm as identified from Table 1.
* ``payload`` (Sec. 4.3, Table 4, Figs. 6-7): 0.288 kg at the link-2 tip; the
  controllers keep the nominal model (Table 1).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

from posfb.diagrams.closed_loop import ClosedLoopConfig, ClosedLoopResult, ClosedLoopRunner
from posfb.models.controllers import CONTROLLER_KINDS, ControllerConfig
from posfb.models.lumped import TABLE1, LumpedParameters
from posfb.models.plant import Arm, ArmParameters

#: The payload of the robustness test (Sec. 4.3), kg at the link-2 tip.
PAYLOAD_MASS = 0.288

#: The two experiments of Sec. 4.
CASES = ("nominal", "payload")

#: Human-readable names (figure legends, tables).
CONTROLLER_LABELS = {
    "pid": "computed torque + PID",
    "lin_lc": "Lin + LC",
    "proposed": "Lin + LC + NC (paper)",
}
CASE_TITLES = {
    "nominal": "nominal arm (Sec. 4.2)",
    "payload": f"{PAYLOAD_MASS} kg payload at the link-2 tip (Sec. 4.3)",
}


def require_case(case: str) -> str:
    if case not in CASES:
        raise ValueError(f"case = {case!r}; one of {', '.join(CASES)} is required")
    return case


def case_parameters(arm: Arm, case: str, coulomb_off: bool = False) -> ArmParameters:
    """The true plant of ``case``: the URDF arm, with the payload for ``"payload"``;
    ``coulomb_off`` removes the plant's Coulomb friction (evidence studies)."""
    payload = PAYLOAD_MASS if require_case(case) == "payload" else 0.0
    parameters = arm.default_parameters.with_payload(payload)
    return replace(parameters, coulomb=(0.0, 0.0)) if coulomb_off else parameters


@dataclass(frozen=True)
class Study:
    """A set of runs that share one setting; ``key`` names it in ``results.json``.

    ``controller_config`` overrides the controllers' design (default: the paper's),
    ``nominal`` is the model they use, ``coulomb_off`` removes the plant's Coulomb
    friction, ``encoder_counts`` / ``integrator_accuracy`` override the defaults."""

    key: str
    title: str
    description: str
    controllers: tuple[str, ...] = CONTROLLER_KINDS
    cases: tuple[str, ...] = CASES
    controller_config: ControllerConfig | None = None
    nominal: LumpedParameters = TABLE1
    coulomb_off: bool = False
    encoder_counts: int | None = None
    integrator_accuracy: float | None = None

    def closed_loop_config(self, kind: str, base: ClosedLoopConfig) -> ClosedLoopConfig:
        changes: dict[str, object] = {"controller": kind}
        if self.encoder_counts is not None:
            changes["encoder_counts"] = self.encoder_counts
        if self.integrator_accuracy is not None:
            changes["integrator_accuracy"] = self.integrator_accuracy
        return replace(base, **changes)

    def runs(
        self, base: ClosedLoopConfig
    ) -> Iterator[tuple[str, str, Callable[[], ClosedLoopResult]]]:
        """``(case, controller, run)`` for every run of the study, controllers outermost
        (one diagram per controller)."""
        for kind in self.controllers:
            runner = ClosedLoopRunner(
                self.closed_loop_config(kind, base),
                self.nominal,
                controller_config=self.controller_config,
            )
            for case in self.cases:
                parameters = case_parameters(runner.arm, case, self.coulomb_off)
                yield case, kind, lambda p=parameters, r=runner: r.run(p)


#: The paper's settings as printed (Sec. 4.2-4.3).
PAPER_STUDY = Study(
    key="paper",
    title="Paper settings",
    description="Sec. 4.2 gains and weights, T_s = 0.01 s, +-24 V, Table 1 model.",
)


def run_case(
    kind: str,
    case: str,
    config: ClosedLoopConfig,
    controller_config: ControllerConfig | None = None,
) -> ClosedLoopResult:
    """One run of controller ``kind`` on ``case`` (``posfb simulate``)."""
    runner = ClosedLoopRunner(replace(config, controller=kind), controller_config=controller_config)
    return runner.run(case_parameters(runner.arm, case))


def _json_number(value: object) -> object:
    """NaN (a run that diverged before its second sample) becomes ``None`` (JSON null)."""
    if isinstance(value, list):
        return [_json_number(v) for v in value]
    return None if isinstance(value, float) and not math.isfinite(value) else value


def result_entry(result: ClosedLoopResult) -> dict[str, object]:
    """The ``results.json`` entry of a run: metrics, status and message."""
    metrics = {key: _json_number(value) for key, value in result.metrics.as_dict().items()}
    return {**metrics, "status": result.status, "message": result.message}


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
        partial = self.path.with_name(self.path.name + ".partial")
        partial.write_text(json.dumps(self.data, indent=2, allow_nan=False) + "\n")
        os.replace(partial, self.path)
